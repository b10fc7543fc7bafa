"""``lgvtool replay``: a complete output log that validates against the schemas, identical
output for the same seed, and one-line exit-2 errors for bad input."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).parent / "localize"))

from localize_synth import circle_log, write_log

from lgvtool.localize.paper_pf import PaperPfParams
from lgvtool.log import LogReader, topics

SCHEMAS = Path(__file__).resolve().parent.parent / "schemas"


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("replay")
    data, _, cfg = circle_log(8.0, ids=True)
    out = {}
    for name, kw in {"full": {}, "nomotion": {"mcu": False},
                     "noobs": {"nav": False, "scans": False}}.items():
        out[name] = d / f"{name}.mcap"
        write_log(out[name], data, cfg, **kw)
    return out


def _validator(schema: str):
    import jsonschema

    doc = json.loads((SCHEMAS / f"{schema}.json").read_text())
    return jsonschema.Draft202012Validator(doc)


def test_replay_output_is_complete_and_valid(logs: dict[str, Path], tmp_path: Path,
                                             run_cli) -> None:
    out = tmp_path / "out.mcap"
    res = run_cli("replay", logs["full"], "-o", out, "--seed", "3", "--json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert set(summary["estimators"]) == {"laser", "deadreckoning", "ekf", "pf-paper", "pf"}
    src, dst = LogReader(logs["full"]), LogReader(out)
    assert dst.complete
    src_topics, dst_topics = src.topics(), dst.topics()
    for t, info in src_topics.items():
        assert dst_topics[t].count == info.count, t
    validators: dict[str, Any] = {}
    seen = set()
    for m in dst.messages():
        if not m.topic.startswith(topics.ESTIMATE_PREFIX):
            continue
        schema = topics.schema_for_topic(m.topic)
        assert schema is not None
        v = validators.setdefault(schema, _validator(schema))
        v.validate(m.data)
        seen.add(m.topic)
    for name in summary["estimators"]:
        assert topics.estimate_pose(name) in seen and topics.estimate_state(name) in seen
    assert topics.estimate_particles("pf") in seen
    meta = dst.metadata["replay"]
    assert meta["seed"] == 3 and set(meta["settings"]) == set(summary["estimators"])
    assert meta["settings"]["pf-paper"]["particles"] == 150


def test_same_seed_gives_identical_output(logs: dict[str, Path], tmp_path: Path,
                                          run_cli) -> None:
    outs = []
    # the second run on one thread: the same output as the estimators side by side
    for i, (seed, threads) in enumerate((("5", "2"), ("5", "1"), ("6", "2"))):
        out = tmp_path / f"o{i}.mcap"
        res = run_cli("replay", logs["full"], "-o", out, "-e", "pf", "-e", "pf-paper",
                      "--seed", seed, "--particles", "80", "--threads", threads)
        assert res.returncode == 0, res.stderr
        outs.append([(m.topic, m.log_time_ns, m.data) for m in LogReader(out).raw_messages()
                     if m.topic.startswith(topics.ESTIMATE_PREFIX)])
    assert outs[0] == outs[1]
    assert outs[0] != outs[2]
    states = [json.loads(d) for t, _, d in outs[0] if t == topics.estimate_state("pf-paper")]
    counts = [s["particles"] for s in states]
    start = PaperPfParams().start_particles  # the uniform start's large set, then 80
    assert counts and counts[-1] == 80 and set(counts) <= {start, 80}
    assert counts == sorted(counts, reverse=True)


@pytest.mark.parametrize(("args", "message"), [
    (["-e", "kalman"], "unknown estimator 'kalman'"),
    (["--set", "pf.nope=1"], "unknown parameter 'pf.nope'"),
    (["--set", "pf.particles=many"], "pf.particles must be an integer"),
    (["--set", "spread=1"], "<estimator>.<param>"),
    (["--set", "bogus.x=1"], "unknown estimator 'bogus'"),
    (["-e", "laser", "--particles", "10"], "--particles applies to the particle filters"),
    (["-e", "laser", "--set", "pf.particles=10"], "'pf' is not run"),
    (["--threads", "0"], "--threads"),
])
def test_bad_options_exit_2_with_one_line(logs: dict[str, Path], tmp_path: Path, run_cli,
                                          args: list[str], message: str) -> None:
    res = run_cli("replay", logs["full"], "-o", tmp_path / "x.mcap", *args)
    assert res.returncode == 2
    assert message in res.stderr and res.stderr.count("\n") == 1, res.stderr


@pytest.mark.parametrize(("log", "message"), [
    ("nomotion", "no motion data"),
    ("noobs", "no observations"),
])
def test_missing_data_exits_2(logs: dict[str, Path], tmp_path: Path, run_cli, log: str,
                              message: str) -> None:
    res = run_cli("replay", logs[log], "-o", tmp_path / "x.mcap")
    assert res.returncode == 2
    assert message in res.stderr and res.stderr.count("\n") == 1, res.stderr


def test_bad_paths_exit_2(logs: dict[str, Path], tmp_path: Path, run_cli) -> None:
    res = run_cli("replay", logs["full"], "-o", logs["full"])
    assert res.returncode == 2 and "is the input" in res.stderr
    res = run_cli("replay", tmp_path / "absent.mcap", "-o", tmp_path / "x.mcap")
    assert res.returncode == 2 and res.stderr.count("\n") == 1
