"""Table 1 on a small hand-made drive, checked against a hand computation."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pandas as pd
import pytest
from evaluate_synth import CENTRE, DELTA, PERIOD, T0, H, R

from lgvtool.evaluate.document import build_document, to_json
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.table import build_table, render_tables, to_csv, to_latex, to_markdown
from lgvtool.json_types import as_list, member

N = 8
"""Samples per rotation (even: alternating errors leave the centre fit unbiased)."""

# Radial errors in mm, alternating a, b within a rotation: (a, b) per rotation.
LASER = [(60.0, 40.0), (70.0, 30.0)]
PF = [(10.0, -10.0), (20.0, 0.0)]


def drive(pairs: list[tuple[float, float]]) -> pd.DataFrame:
    """Two complete rotations with the given errors, then half a rotation of 500 mm errors."""
    k = np.arange(int(2.5 * N))
    t = (k + 0.5) * PERIOD / N                       # never exactly on a rotation boundary
    a = 2 * math.pi * t / PERIOD
    err = np.array([pairs[i // N][i % 2] if i < 2 * N else 500.0 for i in k]) * 1e-3
    return pd.DataFrame({"t": T0 + t, "x": CENTRE[0] + (R + err) * np.cos(a),
                         "y": CENTRE[1] + (R + err) * np.sin(a), "heading": a + math.pi / 2})


def truth() -> pd.DataFrame:
    t = np.linspace(0.0, 2.5 * PERIOD, 2001)
    a = 2 * math.pi * t / PERIOD
    return pd.DataFrame({"t": T0 + t, "x": CENTRE[0] + R * np.cos(a),
                         "y": CENTRE[1] + R * np.sin(a), "heading": a + math.pi / 2})


def hand(pairs: list[tuple[float, float]]) -> dict[str, list[float]]:
    """Per rotation RMSE (mm), variance (mm^2), mean (mm), by hand."""
    return {
        "rmse": [math.sqrt((a * a + b * b) / 2) for a, b in pairs],
        "variance": [((a - b) / 2) ** 2 for a, b in pairs],
        "mean": [(a + b) / 2 for a, b in pairs],
    }


@pytest.fixture(scope="module")
def result():
    return evaluate_trajectories({"pf": drive(PF), "laser": drive(LASER)}, truth=truth(),
                                 steering_angle=DELTA, h=H, name="hand")


def test_rows_match_hand_computation(result) -> None:
    table = build_table([result])
    assert table.estimators == ("laser", "pf")            # laser first, as in the paper
    assert [r.number for r in table.rows] == [1, 2]
    assert table.partial == 1
    for name, pairs in (("laser", LASER), ("pf", PF)):
        h = hand(pairs)
        for i, row in enumerate(table.rows):
            s = row.stats[name]
            assert s.samples == N
            assert s.rmse * 1e3 == pytest.approx(h["rmse"][i], abs=1e-6)
            assert s.variance * 1e6 == pytest.approx(h["variance"][i], abs=1e-5)
            assert s.mean * 1e3 == pytest.approx(h["mean"][i], abs=1e-6)
        avg = table.average[name]
        assert avg.rmse * 1e3 == pytest.approx(np.mean(h["rmse"]), abs=1e-6)
        assert avg.variance * 1e6 == pytest.approx(np.mean(h["variance"]), abs=1e-5)
    laser_avg = np.mean(hand(LASER)["rmse"])
    pf_avg = np.mean(hand(PF)["rmse"])
    assert table.improvement["pf"] == pytest.approx(100 * (1 - pf_avg / laser_avg), abs=1e-6)
    assert table.improvement["laser"] == pytest.approx(0.0)
    # The estimate sits on the truth's angle, so the true error is the radial error.
    assert table.rows[0].truth_rmse["laser"] * 1e3 == pytest.approx(hand(LASER)["rmse"][0],
                                                                     abs=1e-3)


def test_markdown_layout(result) -> None:
    md = to_markdown(build_table([result]))
    assert "| Number | laser RMSE (mm) | laser variance (mm²) | pf RMSE (mm) | pf variance (mm²) |" in md
    assert "| 1 | 50.99 | 100.00 | 10.00 | 100.00 |" in md
    assert "| 2 | 53.85 | 400.00 | 14.14 | 100.00 |" in md
    assert "| Average | 52.42 | 250.00 | 12.07 | 100.00 |" in md
    assert "Partial rotations left out: 1." in md


def test_csv_and_latex(result) -> None:
    table = build_table([result])
    rows = list(csv.DictReader(io.StringIO(to_csv(table))))
    assert [r["number"] for r in rows] == ["1", "2", "Average"]
    assert float(rows[1]["laser_rmse_mm"]) == pytest.approx(math.sqrt(2900), abs=1e-6)
    assert float(rows[2]["pf_variance_mm2"]) == pytest.approx(100.0, abs=1e-5)
    assert float(rows[0]["pf_mean_mm"]) == pytest.approx(0.0, abs=1e-6)
    assert float(rows[1]["laser_max_abs_mm"]) == pytest.approx(70.0, abs=1e-6)
    tex = to_latex(table)
    assert r"\multicolumn{2}{c}{laser}" in tex and r"\multicolumn{2}{c}{pf}" in tex
    assert "Average (mm) & 52.4209 & 250.0000 & 12.0711 & 100.0000" in tex


def test_json_keys(result) -> None:
    doc = json.loads(to_json(build_document([result])))
    assert doc["format"] == "lgvtool.evaluation"
    assert doc["rotations"]["complete"] == 2 and doc["rotations"]["partial"] == 1
    laser = doc["estimators"]["laser"]
    assert laser["circle"]["rmse_mm"] == pytest.approx(np.mean(hand(LASER)["rmse"]), abs=1e-6)
    assert laser["circle"]["variance_mm2"] == pytest.approx(250.0, abs=1e-5)
    assert laser["circle"]["mean_mm"] == pytest.approx(50.0, abs=1e-6)
    assert len(laser["circle"]["rows"]) == 2
    assert laser["truth"]["position_rmse_m"] > 0.05
    assert "heading_rmse_deg" in laser["truth"]
    # Over the rotations the true error is the radial error (estimates on the truth's angle).
    pooled = math.sqrt(np.mean([(a * a + b * b) / 2 for a, b in LASER])) * 1e-3
    assert laser["truth"]["position_rmse_rotations_m"] == pytest.approx(pooled, abs=1e-6)
    assert doc["reference"]["kinematic_radius_m"] == pytest.approx(R)
    assert set(doc["reference"]["circles"]) == {"laser", "pf", "truth"}


def test_several_logs_aggregate(result) -> None:
    table = build_table([result, result])
    assert len(table.rows) == 4 and table.multi_log
    assert table.average["laser"].rmse == pytest.approx(build_table([result]).average["laser"].rmse)
    md = render_tables([result, result], "md")
    assert md.count("### Table 1") == 3                     # aggregated + one per log
    rows = list(csv.DictReader(io.StringIO(render_tables([result, result], "csv"))))
    assert [r["number"] for r in rows].count("Average") == 3
    doc = build_document([result, result])
    assert len(as_list(doc["per_log"])) == 2
    circle = member(member(doc["estimators"], "pf"), "circle")
    assert len(as_list(member(circle, "rows"))) == 4
