"""``lgvtool`` run in the test's own process (faster than a subprocess; output via capsys)."""

from __future__ import annotations

import pytest

from lgvtool.cli import main


def run_command(capsys: pytest.CaptureFixture[str], *args: object) -> tuple[int, str, str]:
    """``lgvtool ARGS`` in this process: (exit code, stdout, stderr)."""
    code = 0
    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err
