"""The one colour table of lgvtool's drawings: a source (an estimator, the NAV's own pose) has
the same colour in the HTML report (:mod:`lgvtool.evaluate.plots`), in what ``replay`` and the
live view draw for Foxglove (:mod:`lgvtool.log.foxglove`) and in the Foxglove layout
``docs/foxglove-layout.json`` (``tests/evaluate/test_report_colours.py`` holds the three to
this table).

The hues are those the Foxglove layout has always had (laser blue, deadreckoning grey, ekf
green, pf-paper red, pf purple, the NAV's head amber), pf's purple made deep enough to stay
apart from deadreckoning's grey on a white page as on Foxglove's dark one. The truth is the
one source whose colour depends on the background: white on Foxglove's dark 3D panel, black in
the report. Pure: no imports, no I/O.
"""

from __future__ import annotations

SOURCE_COLOURS: dict[str, str] = {
    "nav": "#f2bf1a",            # amber: the NAV's own head pose and its scans
    "laser": "#1f78b5",          # blue: the NAV's pose converted to O (the paper's baseline)
    "deadreckoning": "#8c8c8c",  # grey: no correction at all (also unmatched scan points)
    "ekf": "#2ba12b",            # green
    "pf-paper": "#d62629",       # red: the paper's filter
    "pf": "#9c27b0",             # purple: the improved filter
}
"""``#rrggbb`` of each known source."""

OTHER_COLOUR = "#17bfcf"
"""Foxglove's colour of a source the table does not name (the report gives each such
estimator a colour of its own from plotly's palette instead)."""

TRUTH_ON_DARK = "#ffffff"
"""The truth on a dark background (Foxglove's 3D panel and plots)."""
TRUTH_ON_LIGHT = "#000000"
"""The truth on a light background (the report)."""


def rgb(colour: str) -> tuple[float, float, float]:
    """``#rrggbb`` as red, green, blue in 0..1."""
    c = colour.lstrip("#")
    if len(c) != 6:
        raise ValueError(f"not a #rrggbb colour: {colour!r}")
    return (int(c[0:2], 16) / 255.0, int(c[2:4], 16) / 255.0, int(c[4:6], 16) / 255.0)


def source_colour(source: str) -> str:
    """``#rrggbb`` of ``source`` (:data:`OTHER_COLOUR` for a source the table does not name)."""
    return SOURCE_COLOURS.get(source, OTHER_COLOUR)
