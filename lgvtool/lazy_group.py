"""The one lazy click group: a command's module is imported only when that command runs.

``lgvtool --help`` (and a group's ``--help``) lists the commands from a table of
``name -> (module, attribute, one-line help)`` without importing any of them, so help stays
instant. A command whose module file is not in the package (an optional part left out) is not
offered. Used by :mod:`lgvtool.cli` and by the groups that have subcommands (``simulate``).
Only click is imported here (and, for a mistyped command name, :mod:`lgvtool.suggest`).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import click

LazyTable = Mapping[str, tuple[str, str, str]]
"""command name -> (module, attribute of the click command in it, one-line help)."""

_ROOT = Path(__file__).resolve().parent.parent
"""The folder that holds the ``lgvtool`` package."""


class LazyGroup(click.Group):
    """A click group whose commands, given as ``lazy`` (a :data:`LazyTable`), are imported
    only when used: ``@click.group(cls=LazyGroup, lazy=TABLE)``."""

    def __init__(self, *args: Any, lazy: LazyTable | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy: dict[str, tuple[str, str, str]] = dict(lazy or {})

    def _available(self) -> list[str]:
        # look for the module's file rather than import its packages: help stays instant
        return sorted(name for name, (module, _, _) in self.lazy.items()
                      if (_ROOT / (module.replace(".", "/") + ".py")).is_file())

    def list_commands(self, ctx: click.Context) -> list[str]:
        return self._available()

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self._available():
            return None
        module, attribute, _ = self.lazy[cmd_name]
        command = getattr(importlib.import_module(module), attribute)
        assert isinstance(command, click.Command)
        return command

    def resolve_command(self, ctx: click.Context, args: list[str]
                        ) -> tuple[str | None, click.Command | None, list[str]]:
        """click's, with the closest command names offered for an unknown one ("No such
        command 'evalute'. Did you mean 'evaluate'?"); click offers them for options only."""
        name = args[0] if args else ""
        if (name[:1].isalnum() and not ctx.resilient_parsing and ctx.token_normalize_func is None
                and name not in self._available()):
            from lgvtool.suggest import did_you_mean

            hint = did_you_mean(name, self._available())
            if hint:
                ctx.fail(f"No such command '{name}'. {hint[0].upper()}{hint[1:]}")
        return super().resolve_command(ctx, args)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, self.lazy[name][2]) for name in self._available()]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)
