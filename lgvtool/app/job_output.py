"""What a command prints of an operation's result: :class:`JobOutput`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class JobOutput:
    """The two forms of an operation's result: the JSON document (``--json``) and the text
    for the terminal, with what goes to stderr around that text."""

    document: Any
    """The result as JSON-able data (dicts, lists, numbers, strings)."""
    text: str
    """The result for the terminal, ready to print."""
    warnings: list[str] = field(default_factory=list)
    """Warnings printed (``lgvtool: warning: ...``) before :attr:`text`, not with ``--json``."""
    epilogue: str | None = None
    """A line printed on stderr after :attr:`text` (a live view's figures), not with
    ``--json``."""
