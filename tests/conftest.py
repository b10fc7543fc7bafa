"""Shared fixtures: where the repository and the shared data are, and how to run the CLI."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
SAMPLE_LOGS = REPO / "sample_logs"


def mrclam_dir() -> Path:
    """The MRCLAM Dataset 6 folder: $LGVTOOL_MRCLAM, else ../shared/data/mrclam beside the repo."""
    env = os.environ.get("LGVTOOL_MRCLAM")
    if env:
        return Path(env)
    return REPO.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6"


@pytest.fixture
def run_cli():
    """Run ``lgvtool ARGS`` in a subprocess; returns the CompletedProcess (text mode)."""

    def run(*args: str, timeout: float = 300, **kw) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "lgvtool", *map(str, args)],
                              capture_output=True, text=True, timeout=timeout, **kw)

    return run


@pytest.fixture
def chunk_passes(monkeypatch: pytest.MonkeyPatch) -> list[list[str]]:
    """The topics of every pass over a log's chunks (``LogReader.raw_column_chunks``) made
    while the test runs, in order."""
    from lgvtool.log import LogReader

    passes: list[list[str]] = []
    chunks = LogReader.raw_column_chunks

    def counted(self: LogReader, wanted):
        passes.append(sorted(set(wanted)))
        return chunks(self, wanted)

    monkeypatch.setattr(LogReader, "raw_column_chunks", counted)
    return passes
