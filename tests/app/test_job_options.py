"""Every job a command runs (``lgvtool/app/<verb>_job.py``) takes one frozen, slotted options
dataclass of parsed values: no ``**kwargs``, no parameter annotated ``Any``, a docstring (with
units) under every field; the command parses the texts (``--set KEY=VALUE``, ``10%``,
``auto``, ``[HOST:]PORT``) through :mod:`lgvtool.app.option_values`. A bad value is still
refused through the CLI in the one line it always was (exit 2).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from inprocess import run_command

ROOT = Path(__file__).resolve().parents[2]
COMMANDS = ROOT / "lgvtool" / "commands"
SAMPLE = ROOT / "sample_logs" / "paper-circle.mcap"

WITHOUT_OPTIONS = {
    "lgvtool.app.info_job.describe_log": "one path: an options class would add nothing",
    "lgvtool.app.config_job.effective_config": "one path or None: an options class would add "
                                               "nothing",
    "lgvtool.app.simulate_job.describe_scenarios": "no argument",
    "lgvtool.app.evaluate_job.column_help": "no argument (evaluate --help's column list)",
    "lgvtool.app.config_job.parameters": "one flag (markdown): an options class would add "
                                         "nothing",
}
"""Functions a command calls that take no options class, and why."""

NO_BAD_VALUE = {"describe_scenarios", "column_help", "parameters"}
"""Functions a command calls that take no value which could be bad."""

JOBS = {
    "audit_job.audit_logs", "calibrate_job.calibrate_logs", "compare_job.compare_results",
    "decode_job.decode_file",
    "evaluate_job.evaluate_logs",
    "export_job.export_trajectories", "import_job.import_mrclam", "import_job.import_ros2",
    "layout_job.convert_layout", "layout_job.refine_layout", "record_job.record_devices",
    "recover_job.recover_log",
    "replay_job.replay_log", "simulate_job.simulate_log", "sweep_job.sweep_logs",
    "view_job.view_log",
}
"""The jobs with an options class (module in lgvtool.app, function)."""


def _called_jobs() -> list[str]:
    """``lgvtool.app.<verb>_job.<function>`` of every function that a command module imports
    from a job module and calls."""
    found: set[str] = set()
    for path in sorted(COMMANDS.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        imported: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module \
                    and re.fullmatch(r"lgvtool\.app\.\w+_job", node.module):
                for alias in node.names:
                    imported[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        called = {n.func.id for n in ast.walk(tree)
                  if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
        for name, qualified in imported.items():
            if name in called and inspect.isfunction(_resolve(qualified)):
                found.add(qualified)
    return sorted(found)


def _resolve(qualified: str) -> Any:
    module, _, name = qualified.rpartition(".")
    return getattr(importlib.import_module(module), name)


def _mentions_any(annotation: object) -> bool:
    text = annotation if isinstance(annotation, str) else repr(annotation)
    return re.search(r"\bAny\b", text) is not None


CALLED = _called_jobs()


def test_every_job_a_command_calls_is_checked() -> None:
    jobs = {f"lgvtool.app.{j}" for j in JOBS}
    assert jobs <= set(CALLED)
    assert set(CALLED) - jobs <= set(WITHOUT_OPTIONS)


@pytest.mark.parametrize("qualified", CALLED)
def test_a_job_takes_no_kwargs_and_nothing_typed_any(qualified: str) -> None:
    params = inspect.signature(_resolve(qualified)).parameters.values()
    assert not [p.name for p in params if p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL)]
    assert not [p.name for p in params if _mentions_any(p.annotation)]


@pytest.mark.parametrize("qualified", [q for q in CALLED if q not in WITHOUT_OPTIONS])
def test_a_job_takes_one_frozen_options_dataclass(qualified: str) -> None:
    fn = _resolve(qualified)
    first, *others = inspect.signature(fn).parameters.values()
    assert first.name == "options" and str(first.annotation).endswith("Options")
    # the rest are collaborators (warn, notify), never options: keyword-only, with a default
    assert all(p.kind is p.KEYWORD_ONLY and p.default is not p.empty for p in others), others
    cls = getattr(sys.modules[fn.__module__], str(first.annotation))
    _check_options_class(cls)


@pytest.mark.parametrize("qualified", [q for q in CALLED if q in WITHOUT_OPTIONS])
def test_a_job_left_without_options_takes_at_most_one_argument(qualified: str) -> None:
    assert len(inspect.signature(_resolve(qualified)).parameters) <= 1


def _check_options_class(cls: type) -> None:
    assert dataclasses.is_dataclass(cls), cls
    params = cls.__dataclass_params__  # type: ignore[attr-defined]
    assert params.frozen, f"{cls.__name__} is not frozen"
    assert "__slots__" in cls.__dict__, f"{cls.__name__} is not slotted"
    hints = {f.name: f.type for f in dataclasses.fields(cls)}
    assert not [n for n, t in hints.items() if _mentions_any(t)], cls
    # a docstring under every field (units, what None means)
    source = ast.parse(inspect.getsource(cls)).body[0]
    assert isinstance(source, ast.ClassDef)
    body = source.body
    undocumented = [node.target.id for i, node in enumerate(body)
                    if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and not (i + 1 < len(body) and isinstance(body[i + 1], ast.Expr)
                             and isinstance(getattr(body[i + 1], "value", None), ast.Constant))]
    assert undocumented == [], (cls.__name__, undocumented)


def test_the_per_log_options_of_evaluate_are_a_frozen_dataclass() -> None:
    """What travels with each log to a fleet worker is typed, not a dict of keywords."""
    from lgvtool.app import evaluate_job

    (field,) = [f for f in dataclasses.fields(evaluate_job._LogTask) if f.name == "options"]
    assert field.type == "LogEvaluationOptions"
    _check_options_class(evaluate_job.LogEvaluationOptions)


def test_an_options_object_cannot_be_changed() -> None:
    from lgvtool.app.replay_job import ReplayOptions

    options = ReplayOptions("in.mcap", "out.mcap")
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.seed = 1  # type: ignore[misc]


def test_a_device_option_no_family_takes_is_refused(tmp_path: Path) -> None:
    """record's device options are typed values by parameter name; one that no family
    declares is a TypeError, before any link is opened."""
    from lgvtool.app.record_job import RecordOptions, record_devices

    with pytest.raises(TypeError, match=r"no device family has the option\(s\) bogus"):
        record_devices(RecordOptions(str(tmp_path / "r.mcap"),
                                     device_options={"mcu_url": "tcp://127.0.0.1:1",
                                                     "bogus": 1}))


def _layout(tmp: Path) -> Path:
    path = tmp / "layout.toml"
    path.write_text("[[reflectors]]\nid = 1\nx = 0.0\ny = 0.0\nlayer = 0\n", encoding="utf-8")
    return path


def _bad_toml(tmp: Path) -> Path:
    path = tmp / "bad.toml"
    path.write_text("x = [", encoding="utf-8")
    return path


#: job -> (arguments, the one line on stderr); {log}: the sample log, {tmp}: the test's folder,
#: {layout}: a layout file with one reflector in layer 0, {bad}: malformed TOML
BAD_VALUES: dict[str, tuple[tuple[str, ...], str]] = {
    "audit_logs": (("audit", "{log}", "-o", "{tmp}/audit", "--set", "audit.weak_sigmas"),
                   "--set expects key=value, got 'audit.weak_sigmas'"),
    "calibrate_logs": (("calibrate", "{log}", "-o", "{log}", "--no-progress"),
                       "output {log} is the input {log}; choose another output"),
    "compare_results": (("compare", "{log}", "{log}"),
                        "{log} is a log; compare reads results: run 'lgvtool audit LOG -o DIR' "
                        "or 'lgvtool evaluate LOG -o DIR' on each log first, then compare the "
                        "DIRs"),
    "decode_file": (("decode", "{log}", "-o", "{log}"),
                    "output {log} is the input {log}; choose another output"),
    "evaluate_logs": (("evaluate", "{log}", "--tolerance", "abc", "--baseline", "{tmp}/b.json"),
                      "--tolerance expects a percentage such as 10%, got 'abc'"),
    "evaluate_logs/max": (("evaluate", "{log}", "--max", "pf.rmse"),
                          "--max expects KEY=VALUE (e.g. pf.circle.rmse_mm=25), got 'pf.rmse'"),
    "export_trajectories": (("export", "{log}", "-o", "{tmp}/exp", "--set", "novalue"),
                            "--set expects key=value, got 'novalue'"),
    "import_mrclam": (("import", "mrclam", "{tmp}/dataset", "-r", "1", "-o", "{tmp}/o.mcap",
                       "--odometry-delay", "soon"),
                      "--odometry-delay expects seconds or auto, got 'soon'"),
    "import_ros2": (("import", "ros2", "{tmp}/bag", "-o", "{tmp}/r.mcap", "--topic",
                     "bogus=/x"),
                    "--topic: no role 'bogus' (roles: odom, gyro, nav, reflectors, truth, tf)"),
    "convert_layout": (("layout", "convert", "{layout}", "-o", "{tmp}/l.imk", "--layer", "7"),
                       "layout convert: {layout} has no reflector in layer 7"),
    "refine_layout": (("layout", "refine", "{log}", "-o", "{tmp}/r.toml", "--set", "novalue"),
                      "--set expects key=value, got 'novalue'"),
    "record_devices": (("record", "--mcu", "tcp://127.0.0.1:1", "-o", "{tmp}/rec.mcap",
                        "--live", "nope"),
                       "--live: 'nope' is not [HOST:]PORT (the port must be a number)"),
    "recover_log": (("recover", "{log}", "-o", "{log}"),
                    "output {log} is the input {log}; choose another output"),
    "replay_log": (("replay", "{log}", "-o", "{tmp}/r.mcap", "--set", "pf.particles"),
                   "--set expects key=value, got 'pf.particles'"),
    "simulate_log": (("simulate", "-s", "paper-circle", "-o", "{tmp}/s.mcap", "--set",
                      "novalue"),
                     "--set expects key=value, got 'novalue'"),
    "sweep_logs": (("sweep", "{log}", "-o", "{tmp}/sweep", "--grid", "pf.particles="),
                   "--grid pf.particles: empty value in ''"),
    "view_log": (("view", "{log}", "--live", "nope"),
                 "--live: 'nope' is not [HOST:]PORT (the port must be a number)"),
    "describe_log": (("info", "{layout}"), "{layout}: not an MCAP file"),
    "effective_config": (("config", "{bad}"),
                         "{bad}: malformed TOML: Invalid value (at end of document)"),
}


def test_every_job_has_a_bad_value_case() -> None:
    assert {q.rpartition(".")[2] for q in CALLED} - NO_BAD_VALUE \
        == {k.partition("/")[0] for k in BAD_VALUES}


@pytest.mark.parametrize("case", list(BAD_VALUES))
def test_a_bad_value_is_refused_in_one_line(case: str, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    args, line = BAD_VALUES[case]
    where: dict[str, Callable[[Path], Path]] = {"layout": _layout, "bad": _bad_toml}
    values = {"log": str(SAMPLE), "tmp": str(tmp_path),
              **{k: str(make(tmp_path)) for k, make in where.items()}}
    code, out, err = run_command(capsys, *(a.format(**values) for a in args))
    assert (code, out) == (2, "")
    assert err == f"lgvtool: error: {line.format(**values)}\n"
