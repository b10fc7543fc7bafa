"""Command-line options shared by every command: one grammar for the whole tool.

* ``-e/--estimator NAME`` is repeatable and takes comma-separated lists (``-e laser,pf -e ekf``);
* ``--set KEY=VALUE`` wherever estimators (or the simulator) run;
* ``-o`` never replaces an existing file without ``--force`` (:mod:`lgvtool.outputs`);
* ``--compression`` defaults to :data:`DEFAULT_COMPRESSION` in every command that writes a log;
* every number goes through :func:`lgvtool.values.coerce` (:class:`Number`), so an option and
  the same value in a configuration file are refused alike;
* ``--scheduler`` with ``--tls-ca-file/--tls-cert/--tls-key`` wherever a Dask cluster is used.

Only click is imported here, so ``lgvtool --help`` stays instant.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import click

if TYPE_CHECKING:
    from click.shell_completion import CompletionItem

F = TypeVar("F", bound=Callable[..., Any])

DEFAULT_COMPRESSION = "zstd"
"""Chunk compression of every log lgvtool writes: zstd gives files about a third smaller than
lz4 at a decompression speed that is never the bottleneck of a replay (docs/performance.md)."""
COMPRESSIONS = ("zstd", "lz4", "none")


class Number(click.ParamType):  # type: ignore[type-arg,unused-ignore]  # generic in newer click
    """A number option checked by the one coercer (:func:`lgvtool.values.coerce`).

    ``kind`` is int or float; the bounds are as for ``coerce`` (an int without ``maximum``
    is at most :data:`lgvtool.values.MAX_COUNT`). NaN and infinity are refused.
    """

    def __init__(self, kind: type, minimum: float | None = None, maximum: float | None = None,
                 *, min_open: bool = False) -> None:
        self.kind = kind
        self.minimum = minimum
        self.maximum = maximum
        self.min_open = min_open
        self.name = "integer" if kind is int else "number"

    def convert(self, value: object, param: click.Parameter | None, ctx: click.Context | None
                ) -> int | float:
        from lgvtool.errors import ConfigError
        from lgvtool.values import coerce, parse_scalar

        where = max(param.opts, key=len) if param is not None and param.opts else "value"
        if isinstance(value, str):
            try:
                value = parse_scalar(value, self.kind)
            except ValueError:
                noun = "an integer" if self.kind is int else "a number"
                raise ConfigError(f"{where} must be {noun}, got {value!r}") from None
        number: int | float = coerce(where, value, self.kind, minimum=self.minimum,
                                     maximum=self.maximum, min_open=self.min_open)
        return number


def positive(maximum: float) -> Number:
    """A number above 0 and at most ``maximum`` (a duration, a period, a size)."""
    return Number(float, 0.0, maximum, min_open=True)


def split_names(values: Sequence[str], option: str = "-e") -> list[str]:
    """``-e`` values, repeated and comma-separated, flattened in order (spaces around a name
    dropped).

    :raises InputError: (exit 2) a value holds an empty name (``-e ''``, ``-e laser,,ekf``),
        which would otherwise quietly mean "the default set".
    """
    from lgvtool.errors import InputError

    names = [n.strip() for v in values for n in v.split(",")]
    if "" in names:
        bad = next(v for v in values if "" in (n.strip() for n in v.split(",")))
        raise InputError(f"{option} {bad!r}: an empty name; give names separated by commas")
    return names


def force_option(f: F) -> F:
    """``--force``: replace an existing output (one policy for every command)."""
    return click.option("--force", is_flag=True,
                        help="Replace an existing output (never an input).")(f)


def complete_estimators(ctx: click.Context, param: click.Parameter, incomplete: str
                        ) -> list[CompletionItem]:
    """Shell completion of estimator names, also after a comma (``-e laser,pf`` offers
    ``laser,pf-paper`` and ``laser,pf``); names already in the list are not offered again."""
    from click.shell_completion import CompletionItem

    from lgvtool.localize.registry import ESTIMATORS

    head, comma, last = incomplete.rpartition(",")
    given = {n.strip() for n in head.split(",")} if comma else set()
    return [CompletionItem(f"{head}{comma}{name}") for name in ESTIMATORS
            if name.startswith(last.strip()) and name not in given]


def complete_scenarios(ctx: click.Context, param: click.Parameter, incomplete: str
                       ) -> list[CompletionItem]:
    """Shell completion of scenario names (zsh and fish show each one's description)."""
    from click.shell_completion import CompletionItem

    from lgvtool.sim.scenarios import SCENARIOS

    return [CompletionItem(name, help=_first_clause(sc.description))
            for name, sc in SCENARIOS.items() if name.startswith(incomplete)]


def _first_clause(text: str, width: int = 70) -> str:
    """``text`` up to its first colon or full stop, at most ``width`` characters."""
    for stop in (": ", ". "):
        text = text.split(stop, 1)[0]
    return text if len(text) <= width else text[: width - 3] + "..."


def estimator_option(help_text: str) -> Callable[[F], F]:
    """``-e/--estimator NAME``: repeatable and comma-separated; flatten with :func:`split_names`.
    The shell completes the names (:func:`complete_estimators`)."""
    return click.option("-e", "--estimator", "estimators", multiple=True, metavar="NAME[,NAME]",
                        shell_complete=complete_estimators,
                        help=f"{help_text} (repeatable or comma-separated).")


def scenario_option(help_text: str) -> Callable[[F], F]:
    """``-s/--scenario NAME``, completed by the shell (:func:`complete_scenarios`)."""
    return click.option("--scenario", "-s", metavar="NAME", shell_complete=complete_scenarios,
                        help=help_text)


def set_option(help_text: str = "Estimator parameter, e.g. pf.particles=500 or "
               "pf-paper.spread_m=0.3 (repeatable; docs/filter.md lists them).") -> Callable[[F], F]:
    """``--set KEY=VALUE`` (repeatable)."""
    return click.option("--set", "sets", multiple=True, metavar="KEY=VALUE", help=help_text)


def compression_option(help_text: str = "MCAP chunk compression.") -> Callable[[F], F]:
    """``--compression`` with the one default :data:`DEFAULT_COMPRESSION`."""
    return click.option("--compression", type=click.Choice(COMPRESSIONS),
                        default=DEFAULT_COMPRESSION, show_default=True, help=help_text)


def seed_option(help_text: str) -> Callable[[F], F]:
    """``--seed N``: a non-negative integer."""
    from lgvtool.values import MAX_SEED

    return click.option("--seed", type=Number(int, 0, MAX_SEED), default=0, show_default=True,
                        help=help_text)


def workers_type() -> Number:
    """Worker processes: 1 to :func:`lgvtool.values.max_workers`."""
    from lgvtool.values import max_workers

    return Number(int, 1, max_workers())


def threads_option(default_text: str) -> Callable[[F], F]:
    """``--threads N``: threads the estimators run on at once (``default_text``: the default
    when the option is not given)."""
    from lgvtool.values import MAX_THREADS

    return click.option("--threads", type=Number(int, 1, MAX_THREADS), default=None,
                        help=f"Threads the estimators run on at once (default: {default_text});"
                             " the results are the same for any count.")


def scheduler_options(f: F) -> F:
    """``--scheduler URL`` and the TLS options of a remote Dask scheduler (docs/fleet.md)."""
    f = click.option("--tls-key", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
                     help="Private key of --tls-cert (PEM), when not in that file.")(f)
    f = click.option("--tls-cert", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
                     help="This client's certificate (PEM) for a tls:// scheduler.")(f)
    f = click.option("--tls-ca-file", type=click.Path(exists=True, dir_okay=False),
                     metavar="FILE", help="CA certificate (PEM) that signed the tls:// "
                                          "scheduler's certificate.")(f)
    return click.option("--scheduler", metavar="tls://HOST:PORT",
                        help="Run on this Dask scheduler instead of a local cluster; it and its "
                             "workers are trusted to run code here (docs/fleet.md).")(f)


def warn(text: str) -> None:
    """``lgvtool: warning: TEXT`` on stderr, control characters stripped (text from a log)."""
    from lgvtool.outputs import printable

    click.echo(f"lgvtool: warning: {printable(text)}", err=True)


def progress_option(help_text: str = "Progress on stderr once the work takes over a second.",
                    ) -> Callable[[F], F]:
    """``--progress/--no-progress`` (parameter ``show_progress``), on every long command."""
    return click.option("--progress/--no-progress", "show_progress", default=True,
                        show_default=True, help=help_text)


class JobResult(Protocol):
    """The two forms of an operation's result (:class:`lgvtool.app.job_output.JobOutput`):
    its JSON document, its text, the warnings before it and the line after it (stderr)."""

    @property
    def document(self) -> object: ...
    @property
    def text(self) -> str: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def epilogue(self) -> str | None: ...


def print_output(output: JobResult, as_json: bool) -> None:
    """Print a :class:`lgvtool.app.job_output.JobOutput`: its document as indented JSON with
    ``--json``, else its warnings, its text and its epilogue (on stderr)."""
    if as_json:
        import json

        click.echo(json.dumps(output.document, indent=2))
        return
    for w in output.warnings:
        warn(w)
    click.echo(output.text)
    if output.epilogue is not None:
        click.echo(output.epilogue, err=True)
