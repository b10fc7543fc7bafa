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


def test_replayed_import_draws_its_scans_on_the_true_head(synthetic: Any, tmp_path: Path) -> None:
    """An imported dataset has no NAV pose: its scans are placed on the ground truth's head."""
    from lgvtool.log import LogReader, topics

    out, rep = tmp_path / "r1.mcap", tmp_path / "rep.mcap"
    for argv in (["import", "mrclam", str(synthetic.root), "--robot", "1", "-o", str(out)],
                 ["replay", str(out), "-o", str(rep), "-e", "deadreckoning"]):
        try:
            main(argv)
        except SystemExit as exc:
            assert not exc.code
    assert_reference_clean(rep)
    assert schema_errors(rep) == []
    frames = {m.data["frame_id"] for m in LogReader(rep).messages([topics.NAV_SCAN])}
    assert frames == {"truth/head"}
    assert LogReader(rep).topics()[topics.TRUTH_TF].count > 0
