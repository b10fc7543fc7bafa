"""``lgvtool import mrclam`` writes files the reference MCAP checker passes (tests/log)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "log"))
from mcap_doctor import assert_reference_clean, schema_errors

from lgvtool.cli import main


def test_imported_log_is_clean(synthetic: Any, tmp_path: Path) -> None:
    out = tmp_path / "r1.mcap"
    try:
        main(["import", "mrclam", str(synthetic.root), "--robot", "1", "-o", str(out)])
    except SystemExit as exc:
        assert not exc.code
    assert_reference_clean(out)
    assert schema_errors(out) == []
