"""The ``lgvtool`` command line.

Each command lives in its own module under :mod:`lgvtool.commands` and is imported only when it
runs, so ``lgvtool --help`` and ``lgvtool --version`` never load numpy, pandas or plotly.

Exit codes: 0 success, 1 a checked threshold failed, 2 bad input or usage, 130 interrupted.
Errors are one line on stderr; set ``LGVTOOL_DEBUG=1`` to see the traceback of an internal error
(and, after the line, the details an error leaves out of it, which ``--json`` also prints).
"""

from __future__ import annotations

import os
import sys
from typing import Any, TextIO

import click

from lgvtool import __version__
from lgvtool.lazy_group import LazyGroup

#: command name -> (module, attribute, one-line help shown by ``lgvtool --help``)
COMMANDS: dict[str, tuple[str, str, str]] = {
    "info": ("lgvtool.commands.info", "info", "Summarise a log: topics, rates, gaps, metadata."),
    "simulate": (
        "lgvtool.commands.simulate",
        "simulate",
        "Simulate a scenario into a log, or serve it as emulated devices.",
    ),
    "record": (
        "lgvtool.commands.record",
        "record",
        "Record the MCU and a NAV200 or NAV350 into a crash-safe log.",
    ),
    "recover": (
        "lgvtool.commands.recover",
        "recover",
        "Rebuild a complete, indexed log from a broken one.",
    ),
    "decode": (
        "lgvtool.commands.decode",
        "decode",
        "Re-decode the raw device traffic of a log into fresh channels.",
    ),
    "import": ("lgvtool.commands.importer", "import_", "Import a dataset into the log format."),
    "replay": (
        "lgvtool.commands.replay",
        "replay",
        "Run estimators over a log and write their estimates into a new log.",
    ),
    "evaluate": (
        "lgvtool.commands.evaluate",
        "evaluate",
        "Table 1, error metrics, plots and report for one or more logs.",
    ),
    "export": (
        "lgvtool.commands.export",
        "export",
        "Write a log's trajectories as TUM, KITTI, CSV or Parquet files.",
    ),
    "sweep": (
        "lgvtool.commands.sweep",
        "sweep",
        "Parameter sweeps over many logs and seeds on a Dask cluster.",
    ),
    "view": (
        "lgvtool.commands.view",
        "view",
        "Play a log to a live Foxglove view at N x speed.",
    ),
    "calibrate": (
        "lgvtool.commands.calibrate",
        "calibrate",
        "Estimate the vehicle's installation (NAV mounting, wheels, gyro, timing) from logs.",
    ),
    "audit": (
        "lgvtool.commands.audit",
        "audit",
        "Audit a site's reflectors (missing, moved, weak, unmapped) and coverage from logs.",
    ),
    "compare": (
        "lgvtool.commands.compare_command",
        "compare",
        "Compare two results (audit.json or table1.json) KPI by KPI, with a tolerance gate.",
    ),
    "layout": (
        "lgvtool.commands.layout",
        "layout",
        "Convert reflector layout files (lgvtool TOML, SICK .imk).",
    ),
    "config": (
        "lgvtool.commands.config_file",
        "config",
        "Print or check a vehicle/reflector/filter configuration file.",
    ),
    "completion": (
        "lgvtool.commands.completion",
        "completion",
        "Print the shell completion script for bash, zsh or fish.",
    ),
}


@click.group(cls=LazyGroup, lazy=COMMANDS,
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="lgvtool")
def cli() -> None:
    """lgvtool: how well does a laser-guided vehicle know where it is?

    Record the MCU (encoders, gyro) and a SICK NAV200 or NAV350 into MCAP logs, replay them
    through the paper's particle filter and baselines, and evaluate the accuracy against the
    kinematic reference circle or ground truth.
    """


_JSON = {"on": False}
"""Whether the running command was given --json (its errors then also go to stdout as JSON)."""


def _fail(message: str, code: int, error: BaseException | None = None) -> None:
    """Print ``message`` as the one error line and exit with ``code``. An ``error`` that
    carries ``details`` (JSON-able) adds them to the ``--json`` document, and its
    ``detail_lines`` follow the error line with ``LGVTOOL_DEBUG=1``."""
    from lgvtool.outputs import printable

    message = printable(message)
    click.echo(f"lgvtool: error: {message}", err=True)
    if os.environ.get("LGVTOOL_DEBUG"):
        for line in getattr(error, "detail_lines", None) or ():
            click.echo(f"lgvtool: detail: {printable(str(line))}", err=True)
    if _JSON["on"]:
        import json

        document: dict[str, Any] = {"error": message, "exit_code": code}
        details = getattr(error, "details", None)
        if details:
            document["details"] = details
        click.echo(json.dumps(document))
    sys.exit(code)


def main(argv: list[str] | None = None) -> None:
    """Run the command line; map every failure to one line on stderr and an exit code.

    With ``--json`` an error is also printed on stdout as ``{"error": ..., "exit_code": N}``.
    ``argv`` None: the process's own arguments, and the process exits after the command.
    """
    args = sys.argv[1:] if argv is None else argv
    _JSON["on"] = "--json" in args[: args.index("--") if "--" in args else len(args)]
    _log_warnings_as_lines()
    try:
        _run(argv)
    finally:
        if argv is None:
            _skip_final_collection()


def _skip_final_collection() -> None:
    """Spare the process's exit a full garbage collection over every object still alive.

    Called once the command has ended (its files closed) in a process that exits next:
    :func:`gc.freeze` moves those objects out of the collector's reach, so the collection that
    ends the interpreter does not walk them (0.1-0.2 s after a run that loaded the compiled
    kernels, whose compiler keeps hundreds of thousands of objects; docs/performance.md). The
    objects are still released and their finalisers run as the modules are torn down."""
    import gc

    gc.freeze()


def _run(argv: list[str] | None) -> None:
    """The command of ``argv``, its failures mapped as :func:`main` says."""
    from lgvtool.errors import LgvError

    try:
        cli.main(args=argv, prog_name="lgvtool", standalone_mode=False)
    except click.exceptions.Abort:
        _fail("interrupted", 130)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        _fail(_click_message(exc), exc.exit_code)
    except LgvError as exc:
        _fail(str(exc), exc.exit_code, exc)
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    except BrokenPipeError:
        sys.exit(0)
    except (FileNotFoundError, IsADirectoryError, PermissionError, NotADirectoryError) as exc:
        _fail(f"{exc.strerror}: {exc.filename}", 2)
    except OSError as exc:
        _fail(str(exc), 2)
    except Exception as exc:
        if os.environ.get("LGVTOOL_DEBUG"):
            raise
        _fail(f"internal error: {type(exc).__name__}: {exc} (set LGVTOOL_DEBUG=1 for details)", 3)


def _log_warnings_as_lines() -> None:
    """Print a warning about a log (a corrupt chunk skipped while reading) as one line."""
    import warnings

    from lgvtool.outputs import printable

    shown = warnings.showwarning

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:
        if category.__name__ == "LogWarning":
            click.echo(f"lgvtool: warning: {printable(str(message))}", err=True)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show


def _click_message(exc: click.ClickException) -> str:
    """Flatten a click usage error to one line, naming the subcommand (``lgvtool info: No
    such option ...``; the line already starts with ``lgvtool: error:``)."""
    message = exc.format_message().replace("\n", " ")
    ctx: Any = getattr(exc, "ctx", None)
    path = getattr(ctx, "command_path", None) if ctx is not None else None
    if path and path != "lgvtool":
        return f"{path}: {message}"
    return message
