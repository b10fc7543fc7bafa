"""The layering of the command line (docs/contracts.md, "Thin commands"):

* nothing outside ``lgvtool/commands/`` and ``lgvtool/cli.py`` (nor a benchmark) imports
  ``lgvtool.commands``: the operations live in ``lgvtool.app``;
* a command module imports only the standard library, click, the shared option code and the
  application layer (:data:`COMMAND_IMPORTS`), so it cannot reach into a stage;
* a command's click callback holds at most :data:`MAX_CALLBACK_STATEMENTS` statements;
* an ``lgvtool.app`` module never imports ``lgvtool.commands`` or click.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "lgvtool"
COMMANDS = PACKAGE / "commands"

COMMAND_IMPORTS = ("lgvtool.app.", "lgvtool.options", "lgvtool.values", "lgvtool.errors",
                   "lgvtool.outputs", "lgvtool.lazy_group", "lgvtool.cli")
"""The lgvtool modules a command module may import (and the device registry
``lgvtool.devices.device_registry`` and its ``lgvtool.devices.<family>.<family>_registration``
modules, which contribute every device family's options to ``record``)."""

MAX_CALLBACK_STATEMENTS = 25
"""Most statements (nested ones counted) in a command's callback: parse, call, print."""

EXEMPT: set[str] = set()
"""Command modules whose operation is not in lgvtool.app yet (remove when it is)."""


def _imports(tree: ast.AST) -> Iterator[tuple[int, str]]:
    """(line, module) of every import in ``tree``, relative imports resolved to ``lgvtool``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            yield node.lineno, ("lgvtool." + module if node.level else module)
            if module == "lgvtool" or (node.level and not module):
                for alias in node.names:
                    yield node.lineno, f"lgvtool.{alias.name}"


def _sources(*folders: Path) -> list[Path]:
    return sorted(p for folder in folders for p in folder.rglob("*.py"))


def _is_command(module: str) -> bool:
    return module == "lgvtool.commands" or module.startswith("lgvtool.commands.")


def test_only_the_cli_imports_the_commands() -> None:
    offenders = []
    for path in _sources(PACKAGE, ROOT / "benchmarks"):
        if path == PACKAGE / "cli.py" or COMMANDS in path.parents:
            continue
        for line, module in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            if _is_command(module):
                offenders.append(f"{path.relative_to(ROOT)}:{line}: {module}")
    assert offenders == []


def test_the_application_layer_knows_no_command_line() -> None:
    offenders = []
    for path in _sources(PACKAGE / "app"):
        for line, module in _imports(ast.parse(path.read_text(encoding="utf-8"))):
            if _is_command(module) or module.split(".")[0] == "click":
                offenders.append(f"{path.relative_to(ROOT)}:{line}: {module}")
    assert offenders == []


def _allowed(module: str) -> bool:
    top = module.split(".")[0]
    if top != "lgvtool":
        return top in sys.stdlib_module_names or top == "click"
    if module == "lgvtool.devices.device_registry" or (
            module.startswith("lgvtool.devices.") and module.endswith("_registration")):
        return True
    return module in COMMAND_IMPORTS or module.startswith(COMMAND_IMPORTS[0])


def _callbacks(tree: ast.Module) -> Iterator[ast.FunctionDef]:
    """Functions decorated as click commands or groups (``@click.command()``,
    ``@group.command(...)``)."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and any(
                isinstance(d, ast.Call) and isinstance(d.func, ast.Attribute)
                and d.func.attr in ("command", "group") for d in node.decorator_list):
            yield node


COMMAND_MODULES = sorted(p.name for p in COMMANDS.glob("*.py") if p.name != "__init__.py")


@pytest.mark.parametrize("name", [n for n in COMMAND_MODULES if n not in EXEMPT])
def test_a_command_only_parses_calls_and_prints(name: str) -> None:
    tree = ast.parse((COMMANDS / name).read_text(encoding="utf-8"))
    bad = [f"{name}:{line}: {module}" for line, module in _imports(tree)
           if module != "__future__" and not _allowed(module)]
    assert bad == []
    callbacks = list(_callbacks(tree))
    assert callbacks, f"{name} defines no click command"
    for fn in callbacks:
        statements = sum(isinstance(n, ast.stmt) for n in ast.walk(fn)) - 1
        assert statements <= MAX_CALLBACK_STATEMENTS, (fn.name, statements)


def test_the_rule_catches_a_command_that_reaches_into_a_stage() -> None:
    source = ("import click\n\n@click.command()\ndef cmd() -> None:\n"
              "    from lgvtool.localize.registry import check_names\n    check_names([])\n")
    bad = [m for _, m in _imports(ast.parse(source)) if not _allowed(m)]
    assert bad == ["lgvtool.localize.registry"]
    assert _allowed("lgvtool.app.replay_job") and _allowed("lgvtool.devices.nav350.nav350_registration")


def test_help_imports_no_command_and_no_operation() -> None:
    import subprocess

    code = ("import sys\nfrom lgvtool.cli import main\ntry:\n    main(['--help'])\n"
            "except SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith(('lgvtool.app', "
            "'lgvtool.commands.', 'numpy', 'pandas'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_replay_imports_neither_pandas_nor_plotly(tmp_path: Path) -> None:
    """``replay`` (the estimators and the Foxglove view, its reference circle included) needs
    no table library: pandas' import alone is 0.2-0.4 s of a replay."""
    import subprocess

    code = ("import sys\nfrom lgvtool.app.replay_job import ReplayOptions, replay_log\n"
            f"replay_log(ReplayOptions({str(ROOT / 'sample_logs' / 'paper-circle.mcap')!r}, "
            f"{str(tmp_path / 'out.mcap')!r}, "
            "show_progress=False))\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pandas', 'plotly')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert (tmp_path / "out.mcap").stat().st_size > 0


def test_the_lazy_group_offers_only_commands_whose_module_is_there() -> None:
    import click
    from click.testing import CliRunner

    from lgvtool.lazy_group import LazyGroup

    table = {"info": ("lgvtool.commands.info", "info", "Summarise a log."),
             "gone": ("lgvtool.commands.no_such_command", "gone", "Not in the package.")}

    @click.group(cls=LazyGroup, lazy=table)
    def group() -> None:
        """A group."""

    res = CliRunner().invoke(group, ["--help"])
    assert res.exit_code == 0 and "Summarise a log." in res.output
    assert "gone" not in res.output
    assert CliRunner().invoke(group, ["gone"]).exit_code == 2
    assert isinstance(group.get_command(click.Context(group), "info"), click.Command)
