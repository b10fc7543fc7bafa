"""The package's layout rules (docs/architecture.md), checked on the source tree.

- every module basename is unique across lgvtool (``__init__.py`` and ``__main__.py`` aside);
- the device side (codecs, sessions, device models, emulators) imports no estimator;
- the simulator sits above the device families, never the reverse: no module under
  ``lgvtool/devices`` imports ``lgvtool.sim``, and the emulators, simulator links and loopbacks
  live in ``lgvtool/sim``;
- a device family holds no command-line code: no module under ``lgvtool/devices`` imports click
  (or lgvtool's option and command modules, which do);
- nothing outside the command line imports ``lgvtool.commands``;
- nothing outside the command line and the jobs (``lgvtool/app``) imports ``lgvtool.app``;
- the configuration (``lgvtool/config.py``) imports neither the estimators nor the simulator: their
  tables' checks (``lgvtool/config_checks.py``) are registered into it, by ``lgvtool/__init__.py``;
- the log layer (``lgvtool.log``) imports none of the layers above it: the estimators, the
  evaluation, the jobs, the commands;
- importing the pure core opens no file;
- one module defines a trajectory class (t, x, y, heading arrays): ``lgvtool/trajectory.py``.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "lgvtool"

DEVICE_SIDE = ("devices", "wire", "sim/emulate")
"""Folders of lgvtool holding device code: codecs, host sessions, device models, emulators."""
ESTIMATOR_PACKAGES = ("lgvtool.localize",)

COMMAND_LINE = ("lgvtool/commands/", "lgvtool/cli.py")

PURE_CORE = ("lgvtool.angles", "lgvtool.timestamps", "lgvtool.quantiles", "lgvtool.values",
             "lgvtool.wire", "lgvtool.localize", "lgvtool.evaluate.metrics",
             "lgvtool.circle", "lgvtool.evaluate.laps", "lgvtool.audit.reflector_audit")
"""Modules and packages without I/O: importing them opens no file of their own."""


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _rel(path: Path, root: Path = ROOT) -> str:
    return path.relative_to(root).as_posix()


def _imported(path: Path, root: Path = ROOT) -> set[str]:
    """Every module ``path`` imports, at the top or inside functions (absolute names)."""
    own = _rel(path, root)[:-3].replace("/", ".")
    package = own if path.name == "__init__.py" else own.rpartition(".")[0]
    package = package.removesuffix(".__init__")
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                module = f"{base}.{node.module}" if node.module else base
            else:
                module = node.module or ""
            out.add(module)
            out.update(f"{module}.{a.name}" for a in node.names)  # from pkg import module
    return out


def _imports_any(path: Path, packages: tuple[str, ...], root: Path = ROOT) -> bool:
    return any(m == p or m.startswith(p + ".") for m in _imported(path, root) for p in packages)


def test_module_basenames_are_unique() -> None:
    where: defaultdict[str, list[str]] = defaultdict(list)
    for p in _modules():
        if p.name not in ("__init__.py", "__main__.py"):
            where[p.name].append(_rel(p))
    repeated = {name: paths for name, paths in where.items() if len(paths) > 1}
    assert not repeated, f"module names used twice (rename one to say what it holds): {repeated}"


def test_device_code_imports_no_estimator() -> None:
    device_modules = [p for p in _modules()
                      if any(_rel(p).startswith(f"lgvtool/{d}/") for d in DEVICE_SIDE)]
    assert device_modules
    bad = [_rel(p) for p in device_modules if _imports_any(p, ESTIMATOR_PACKAGES)]
    assert not bad, f"device modules importing an estimator package: {bad}"


LOG_LAYER_ABOVE = ("lgvtool.localize", "lgvtool.evaluate", "lgvtool.app", "lgvtool.commands")
"""What ``lgvtool/log`` (log I/O, messages, the view's channels) must not import."""


def test_the_log_layer_imports_no_layer_above_it() -> None:
    log_modules = [p for p in _modules() if _rel(p).startswith("lgvtool/log/")]
    assert log_modules
    bad = {_rel(p): sorted(m for m in _imported(p) if any(
        m == a or m.startswith(a + ".") for a in LOG_LAYER_ABOVE)) for p in log_modules}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, f"log modules importing a layer above them: {bad}"


def test_only_the_command_line_imports_the_commands() -> None:
    importers = {_rel(p) for p in _modules()
                 if not _rel(p).startswith(COMMAND_LINE) and _imports_any(p, ("lgvtool.commands",))}
    assert not importers, f"import lgvtool.commands from outside the command line: {sorted(importers)}"


APP_USERS = ("lgvtool/commands/", "lgvtool/app/", "lgvtool/cli.py")
"""The only modules that import ``lgvtool.app``: the command line and the jobs themselves."""


def test_only_the_command_line_and_the_jobs_import_the_app_layer() -> None:
    importers = {_rel(p) for p in _modules()
                 if not _rel(p).startswith(APP_USERS) and _imports_any(p, ("lgvtool.app",))}
    assert not importers, (f"import lgvtool.app from below it (move the core into its stage, "
                           f"e.g. lgvtool/evaluate): {sorted(importers)}")


CONFIG_BELOW = ("lgvtool.localize", "lgvtool.sim")
"""What ``lgvtool/config.py`` must not import: the layers whose tables it checks sit above it."""


def test_the_configuration_imports_neither_the_estimators_nor_the_simulator() -> None:
    bad = _offenders([PACKAGE / "config.py"], CONFIG_BELOW)
    assert not bad, f"lgvtool/config.py importing a layer above it (register a check): {bad}"


def test_a_configuration_is_checked_without_importing_the_estimators_first(
        tmp_path: Path) -> None:
    """The checks of ``[estimators.*]`` and ``[simulator]`` are there whatever was imported:
    a fresh interpreter that imports only ``lgvtool.config`` still refuses a bad table."""
    bad = tmp_path / "bad.toml"
    bad.write_text("[estimators.bogus]\nx = 1\n[simulator]\nfoo = 1\n")
    sim = tmp_path / "sim.toml"
    sim.write_text("[simulator]\nfoo = 1\n")
    probe = ("import sys\n"
             "from lgvtool.config import load_config\n"
             "from lgvtool.errors import ConfigError\n"
             "assert not [m for m in sys.modules if m.startswith(('lgvtool.localize', "
             "'lgvtool.sim'))], 'imported too early'\n"
             "for path in sys.argv[1:]:\n"
             "    try:\n"
             "        load_config(path)\n"
             "    except ConfigError as exc:\n"
             "        print(exc)\n")
    res = subprocess.run([sys.executable, "-c", probe, str(bad), str(sim)], capture_output=True,
                         text=True, cwd=ROOT, timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert len(lines) == 2, res.stdout
    assert "unknown estimator [estimators.bogus]" in lines[0]
    assert "foo" in lines[1]


def test_the_app_and_config_rules_see_imports_inside_functions(tmp_path: Path) -> None:
    src = tmp_path / "lgvtool" / "fleet" / "probe.py"
    src.parent.mkdir(parents=True)
    src.write_text("def f():\n    from ..app.evaluate_job import evaluate_log\n")
    cfg = tmp_path / "lgvtool" / "config.py"
    cfg.write_text("def g():\n    from lgvtool.sim.settings import flatten\n"
                   "    from .localize import registry\n")
    assert _imports_any(src, ("lgvtool.app",), tmp_path)
    assert _offenders([cfg], CONFIG_BELOW, tmp_path) == {"lgvtool/config.py": [
        "lgvtool.localize", "lgvtool.localize.registry", "lgvtool.sim.settings",
        "lgvtool.sim.settings.flatten"]}


DEVICES_BELOW = ("lgvtool.sim",)
"""What ``lgvtool/devices`` must not import: the simulator (and its emulators) sit above it."""
COMMAND_LINE_CODE = ("click", "lgvtool.options", "lgvtool.commands", "lgvtool.cli",
                     "lgvtool.lazy_group")
"""What ``lgvtool/devices`` must not import: click, and lgvtool's modules that are click code."""
SIMULATOR_PARTS = ("_emulator.py", "_emulation.py", "_simlink.py", "_loopback.py")
"""Module name endings of a family's emulator, emulation, simulator link and loopback."""


def _device_modules(root: Path = ROOT) -> list[Path]:
    return sorted(p for p in (root / "lgvtool" / "devices").rglob("*.py")
                  if "__pycache__" not in p.parts)


def _offenders(modules: list[Path], packages: tuple[str, ...], root: Path = ROOT
               ) -> dict[str, list[str]]:
    """Module -> the imports of ``packages`` it makes (the modules that make any)."""
    found = {_rel(p, root): sorted(m for m in _imported(p, root)
                                   if any(m == a or m.startswith(a + ".") for a in packages))
             for p in modules}
    return {k: v for k, v in found.items() if v}


def test_no_device_module_imports_the_simulator() -> None:
    modules = _device_modules()
    assert len(modules) > 20
    bad = _offenders(modules, DEVICES_BELOW)
    assert not bad, f"device modules importing the simulator (it sits above them): {bad}"


def test_no_device_module_imports_click() -> None:
    bad = _offenders(_device_modules(), COMMAND_LINE_CODE)
    assert not bad, f"device modules importing command-line code (declare the options): {bad}"


def test_the_emulators_simulator_links_and_loopbacks_live_in_sim() -> None:
    in_devices = [_rel(p) for p in _device_modules() if p.name.endswith(SIMULATOR_PARTS)]
    assert not in_devices, f"simulator parts under lgvtool/devices (move them to sim/): {in_devices}"
    in_sim = {p.name for p in (PACKAGE / "sim").rglob("*.py") if p.name.endswith(SIMULATOR_PARTS)}
    assert {"mcu_emulator.py", "nav200_emulator.py", "nav350_emulator.py", "mcu_simlink.py",
            "nav200_simlink.py", "nav350_simlink.py", "nav350_loopback.py"} <= in_sim


def test_the_device_rules_see_imports_inside_functions(tmp_path: Path) -> None:
    src = tmp_path / "lgvtool" / "devices" / "probe" / "probe_registration.py"
    src.parent.mkdir(parents=True)
    src.write_text("def f():\n    from ...sim.emulate import serve\n    import click.types\n")
    (tmp_path / "lgvtool" / "devices" / "clean.py").write_text("from lgvtool.log import topics\n")
    modules = _device_modules(tmp_path)
    assert len(modules) == 2
    assert _offenders(modules, DEVICES_BELOW, tmp_path) == {
        "lgvtool/devices/probe/probe_registration.py": ["lgvtool.sim.emulate",
                                                        "lgvtool.sim.emulate.serve"]}
    assert _offenders(modules, COMMAND_LINE_CODE, tmp_path) == {
        "lgvtool/devices/probe/probe_registration.py": ["click.types"]}


def test_the_rules_see_relative_imports_and_imports_inside_functions(tmp_path: Path) -> None:
    src = tmp_path / "lgvtool" / "wire" / "probe.py"
    src.parent.mkdir(parents=True)
    src.write_text("def f():\n    from ..localize import ekf\n    import lgvtool.commands.info\n")
    assert _imported(src, tmp_path) >= {"lgvtool.localize", "lgvtool.commands.info"}
    assert _imports_any(src, ESTIMATOR_PACKAGES, tmp_path)
    assert _imports_any(src, ("lgvtool.commands",), tmp_path)
    assert not _imports_any(src, ("lgvtool.log",), tmp_path)


_OPEN_PROBE = r"""
import importlib, os, sys, sysconfig
stdlib = os.path.realpath(sysconfig.get_paths()["stdlib"])
package = os.path.realpath(sys.argv[1])
code = (".py", ".pyc", ".so", ".pyd", ".pth", ".zip")
opened = []

def hook(event, args):
    if event != "open" or not isinstance(args[0], (str, bytes, os.PathLike)):
        return
    path = os.fsdecode(args[0])
    if path.endswith(code) or os.path.isdir(path):
        return
    f = sys._getframe(1)
    while f is not None:  # the first frame that is neither the import system nor stdlib
        name = f.f_code.co_filename
        if not name.startswith("<") and not os.path.realpath(name).startswith(stdlib):
            if os.path.realpath(name).startswith(package):
                opened.append(f"{path} (by {os.path.relpath(name, package)})")
            return
        f = f.f_back

sys.addaudithook(hook)
for name in sys.argv[2:]:
    importlib.import_module(name)
print("\n".join(opened))
"""


@pytest.mark.parametrize("module", PURE_CORE)
def test_importing_the_pure_core_opens_no_file(module: str) -> None:
    res = subprocess.run([sys.executable, "-c", _OPEN_PROBE, str(PACKAGE), module],
                         capture_output=True, text=True, cwd=ROOT, timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "", f"importing {module} opened: {res.stdout}"


def test_the_open_probe_sees_a_module_that_reads_a_file(tmp_path: Path) -> None:
    pkg = tmp_path / "probe_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "data.txt").write_text("x")
    (pkg / "reads.py").write_text(
        "from pathlib import Path\nTEXT = (Path(__file__).parent / 'data.txt').read_text()\n")
    res = subprocess.run([sys.executable, "-c", _OPEN_PROBE, str(pkg), "probe_pkg.reads"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    assert "data.txt" in res.stdout


TRAJECTORY_MODULE = "lgvtool/trajectory.py"
"""The one module that defines a trajectory class (:class:`lgvtool.trajectory.Trajectory`)."""
_POSE_FIELDS = {"t", "x", "y", "heading"}
_ARRAY_TYPES = ("Array", "ndarray", "list[", "Sequence[", "DataFrame", "Series")
"""An annotation naming one of these holds a column of values, not one value."""
TRAJECTORY_EXCEPTIONS: set[str] = set()
"""Known trajectory classes outside the one module, not folded into it yet (none)."""


def _trajectory_classes(path: Path) -> list[str]:
    """The classes of ``path`` holding t, x, y and heading as array fields: annotated class
    attributes, or ``__slots__`` and ``self.<name> =`` in ``__init__`` with the annotation of
    the ``__init__`` parameter of that name."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.ClassDef):
            continue
        fields: dict[str, str] = {}
        for item in node.body:
            if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                fields[item.target.id] = ast.unparse(item.annotation)
            elif isinstance(item, ast.FunctionDef) and item.name == "__init__":
                given = {a.arg: ast.unparse(a.annotation) for a in item.args.args
                         if a.annotation is not None}
                for sub in ast.walk(item):
                    if isinstance(sub, ast.Assign):
                        for t in sub.targets:
                            if (isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name)
                                    and t.value.id == "self"):
                                fields.setdefault(t.attr, given.get(t.attr, ""))
        arrays = {k for k, v in fields.items() if any(a in v for a in _ARRAY_TYPES)}
        if arrays >= _POSE_FIELDS:
            out.append(node.name)
    return out


def test_one_module_defines_a_trajectory_class() -> None:
    offenders = [f"{_rel(p)}: {name}" for p in _modules() if _rel(p) != TRAJECTORY_MODULE
                 for name in _trajectory_classes(p)]
    offenders = [o for o in offenders if o not in TRAJECTORY_EXCEPTIONS]
    assert offenders == [], ("classes with t, x, y, heading array fields outside "
                             f"{TRAJECTORY_MODULE} (use lgvtool.trajectory.Trajectory): "
                             f"{offenders}")
    assert _trajectory_classes(PACKAGE / "trajectory.py") == ["Trajectory"]


def test_the_trajectory_rule_sees_each_kind_of_field(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text(
        "from dataclasses import dataclass\n"
        "@dataclass\nclass A:\n    t: FloatArray\n    x: FloatArray\n    y: FloatArray\n"
        "    heading: NDArray[np.float64]\n"
        "class B:\n    __slots__ = ('t', 'x', 'y', 'heading')\n"
        "    def __init__(self, t: FloatArray, x: FloatArray, y: list[float],\n"
        "                 heading: np.ndarray) -> None:\n"
        "        self.t = t\n        self.x = x\n        self.y = y\n"
        "        self.heading = heading\n"
        "class OnePose:\n    t: float\n    x: float\n    y: float\n    heading: float\n"
        "class NoHeading:\n    t: FloatArray\n    x: FloatArray\n    y: FloatArray\n",
        encoding="utf-8")
    assert _trajectory_classes(src) == ["A", "B"]
