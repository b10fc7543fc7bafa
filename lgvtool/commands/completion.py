"""``lgvtool completion``: the shell completion script for bash, zsh or fish."""

from __future__ import annotations

import click


@click.command()
@click.argument("shell", type=click.Choice(["bash", "zsh", "fish"]))
def completion(shell: str) -> None:
    """Print the completion script of SHELL; load it with e.g.
    eval "$(lgvtool completion bash)" in ~/.bashrc, or
    lgvtool completion fish > ~/.config/fish/completions/lgvtool.fish.
    """
    from click.shell_completion import get_completion_class

    from lgvtool.cli import cli

    cls = get_completion_class(shell)
    assert cls is not None  # the three shells are click's own
    click.echo(cls(cli, {}, "lgvtool", "_LGVTOOL_COMPLETE").source())
