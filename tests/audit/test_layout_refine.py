"""``lgvtool layout refine``: the least-squares adjustment of the layout against the simulator's
truth (a moved reflector recovered, ``--fix`` held), its Jacobian, and its bad input."""

from __future__ import annotations

import importlib.util
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from inprocess import run_command

ROOT = Path(__file__).resolve().parents[2]

MOVED_ID = 7
MOVED_DX_M = 0.06
SHIFT_TOLERANCE_M = 0.010
"""A moved reflector's refined shift lies within this of the truth (m): the issue's 10 mm for a
moved reflector's estimated shift. On this 60 s drive the error is 1-5 mm: the drive fixes
the reflector against the others to about 1 mm, and the rest is the frame (only the surveyed
layout's prior fixes it, and the moved reflector's own prior pulls it a little)."""


@dataclass(frozen=True)
class Logs:
    """The module's simulated logs and what the simulator knows of them."""

    nav350: Path
    """60 s of warehouse, NAV350, exact survey, reflector 7 moved by 60 mm in x."""
    nav200: Path
    """10 s of warehouse, NAV200 (poses only)."""
    truth: dict[int, tuple[float, float]]
    """Where each layout reflector of :attr:`nav350` really stands, m."""


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Logs:
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    tmp = tmp_path_factory.mktemp("refine")
    sim = simulate("warehouse", seed=5, duration=60.0, overrides={
        "sim.nav_device": "nav350", "site.survey_sigma_mm": 0.0,
        "site.moved": [{"id": MOVED_ID, "dx": MOVED_DX_M, "dy": 0.0}]})
    nav350 = tmp / "nav350.mcap"
    write_log(sim, nav350)
    marks = sim.landmarks
    truth = {int(i): (float(x), float(y)) for i, x, y, extra in
             zip(marks.ids, marks.x, marks.y, marks.is_false, strict=True) if not extra}
    nav200 = tmp / "nav200.mcap"
    write_log(simulate("warehouse", seed=5, duration=10.0,
                       overrides={"sim.paper_scans": False}), nav200)
    return Logs(nav350, nav200, truth)


@dataclass(frozen=True)
class Row:
    """One reflector of the document (m)."""

    x: float
    y: float
    surveyed: tuple[float, float]
    shift: tuple[float, float]
    sigma: tuple[float, float]
    observations: int
    fixed: bool


def _pair(value: object) -> tuple[float, float]:
    assert isinstance(value, list) and len(value) == 2
    return float(value[0]), float(value[1])


def _refine(capsys: pytest.CaptureFixture[str], *args: object
            ) -> tuple[dict[int, Row], dict[str, object]]:
    """``layout refine ARGS --json``: each reflector's row by id, and the document."""
    code, out, err = run_command(capsys, "layout", "refine", *args, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert isinstance(doc, dict) and isinstance(doc["reflectors"], list)
    rows = {int(r["id"]): Row(float(r["x"]), float(r["y"]), _pair(r["surveyed"]),
                              _pair(r["shift_m"]), _pair(r["sigma_m"]), int(r["observations"]),
                              bool(r["fixed"])) for r in doc["reflectors"]}
    return rows, doc


def test_refine_recovers_a_moved_reflector(logs: Logs, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    """The 60 mm move is found within :data:`SHIFT_TOLERANCE_M` and within 3 sigma; every
    other reflector stays within the tolerance of where it stands; the layout file written
    holds the refined positions (to its 0.1 mm)."""
    from lgvtool.layout_file import read_layout

    out = tmp_path / "refined.toml"
    rows, doc = _refine(capsys, logs.nav350, "-o", out)
    assert set(rows) == set(logs.truth)
    (dx, dy), (sx, sy) = rows[MOVED_ID].shift, rows[MOVED_ID].sigma
    assert abs(dx - MOVED_DX_M) <= SHIFT_TOLERANCE_M and abs(dy) <= SHIFT_TOLERANCE_M
    assert abs(dx - MOVED_DX_M) <= 3.0 * sx and abs(dy) <= 3.0 * sy
    for rid, row in rows.items():
        tx, ty = logs.truth[rid]
        assert abs(row.x - tx) <= SHIFT_TOLERANCE_M and abs(row.y - ty) <= SHIFT_TOLERANCE_M
        assert row.observations > 0 and not row.fixed
    written = {r.id: r for r in read_layout(out)}
    for rid, row in rows.items():
        assert (written[rid].x, written[rid].y) == pytest.approx((row.x, row.y), abs=6e-5)
    counts = doc["observations"]
    assert isinstance(counts, dict) and counts["used"] > 1000


def test_fix_holds_a_reflector(logs: Logs, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    """``--fix 3,12``: those two stay at their surveyed positions with no uncertainty; the
    moved reflector is still found."""
    from lgvtool.layout_file import read_layout

    out = tmp_path / "fixed.toml"
    rows, _ = _refine(capsys, logs.nav350, "-o", out, "--fix", "3,12")
    for rid in (3, 12):
        row = rows[rid]
        assert row.fixed
        assert row.shift == (0.0, 0.0) and row.sigma == (0.0, 0.0)
        assert (row.x, row.y) == row.surveyed
    assert not rows[MOVED_ID].fixed
    assert abs(rows[MOVED_ID].shift[0] - MOVED_DX_M) <= SHIFT_TOLERANCE_M
    written = {r.id: r for r in read_layout(out)}
    assert (written[3].x, written[3].y) == pytest.approx(rows[3].surveyed, abs=6e-5)


def test_the_text_is_a_table(logs: Logs, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_command(capsys, "layout", "refine", logs.nav350, "-o",
                                 tmp_path / "t.toml", "--fix", "3")
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert lines[0].startswith("layout refine: 1 log, ")
    header = next(i for i, line in enumerate(lines) if line.split()[:1] == ["id"])
    table = lines[header + 1:header + 1 + len(logs.truth)]
    assert [int(line.split()[0]) for line in table] == sorted(logs.truth)
    assert table[2].endswith("fixed")
    assert lines[-1] == f"-> {tmp_path / 't.toml'} ({len(logs.truth)} reflectors)"


def test_the_jacobian_is_the_residuals_derivative(logs: Logs) -> None:
    """The analytic Jacobian against central differences, on columns of every kind (poses,
    reflectors, range offsets, the common offset), at a state away from the start."""
    import scipy.sparse as sp

    from lgvtool.audit import layout_refine as lr
    from lgvtool.localize.installation import apply_installation
    from lgvtool.localize.logdata import load_log
    from lgvtool.localize.noise import MotionParams
    from lgvtool.log import LogReader

    reader = LogReader(logs.nav350)
    cfg = reader.config()
    settings = lr.refine_settings()
    data = apply_installation(load_log(reader, cfg.reflectors, decode_scans=True), cfg.vehicle)
    drive = lr.prepare_drive("t", data, cfg.vehicle, cfg.reflectors, MotionParams(), settings)
    fixed = np.zeros(len(cfg.reflectors), dtype=bool)
    fixed[0] = True
    cols = lr._columns([drive], fixed, True)
    problem = lr._Problem([drive], np.array([r.x for r in cfg.reflectors]),
                          np.array([r.y for r in cfg.reflectors]), fixed, settings, cols)
    rng = np.random.default_rng(3)
    x = np.zeros(cols.size)
    x[:3 * drive.nodes] = drive.start.ravel() + rng.normal(0.0, 0.01, 3 * drive.nodes)
    free = cols.ref_x >= 0
    x[cols.ref_x[free]] = problem.lx[free] + rng.normal(0.0, 0.02, int(free.sum()))
    x[cols.ref_y[free]] = problem.ly[free] + rng.normal(0.0, 0.02, int(free.sum()))
    x[cols.offset] = rng.normal(0.0, 0.005, len(cols.offset))
    x[cols.common] = 0.004
    _, j, _ = problem.evaluate(x)
    assert isinstance(j, sp.csr_matrix)
    picks = [0, 1, 2, 3 * (drive.nodes // 2) + 2, 3 * drive.nodes - 1,
             int(cols.ref_x[5]), int(cols.ref_y[5]), int(cols.offset[5]), cols.common]
    for c in picks:
        h = 1e-6
        up, down = x.copy(), x.copy()
        up[c] += h
        down[c] -= h
        numeric = (problem.evaluate(up, jac=False)[0] - problem.evaluate(down, jac=False)[0]) / (
            2.0 * h)
        analytic = j[:, c].toarray().ravel()
        scale = max(1.0, float(np.abs(analytic).max()))
        assert np.abs(numeric - analytic).max() <= 1e-4 * scale, c


def _one_line(capsys: pytest.CaptureFixture[str], *args: object) -> str:
    code, out, err = run_command(capsys, "layout", "refine", *args)
    assert (code, out) == (2, "")
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("lgvtool: error: "), err
    return lines[0]


def test_a_nav200_log_has_no_landmarks(logs: Logs, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_line(capsys, logs.nav200, "-o", tmp_path / "x.toml")
    assert "no landmark observations" in line and "NAV200" in line
    assert not (tmp_path / "x.toml").exists()


def test_an_unknown_fix_id_is_refused(logs: Logs, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_line(capsys, logs.nav350, "-o", tmp_path / "x.toml", "--fix", "3,99")
    assert line.startswith("lgvtool: error: layout refine: --fix 99: no reflector 99 in the "
                           "layout (ids 1, 2, 3")
    line = _one_line(capsys, logs.nav350, "-o", tmp_path / "x.toml", "--fix", "3,x")
    assert line == "lgvtool: error: --fix 'x' is not a reflector id (an integer)"
    assert not (tmp_path / "x.toml").exists()


def test_a_bad_setting_is_refused(logs: Logs, tmp_path: Path,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    line = _one_line(capsys, logs.nav350, "-o", tmp_path / "x.toml", "--set",
                     "survey_sigma_m=0")
    assert line == "lgvtool: error: refine.survey_sigma_m must be above 0, got 0"


def test_without_scipy_the_missing_extra_is_named(logs: Logs, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    from lgvtool.extras import install_hint

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "scipy" else real(name, *a))
    line = _one_line(capsys, logs.nav350, "-o", tmp_path / "x.toml")
    assert line == ("lgvtool: error: layout refine needs scipy (not installed): "
                    f"{install_hint('calibrate')}")


def test_the_settings_table_in_the_docs_is_the_declarations() -> None:
    from lgvtool.audit.layout_refine import RefineSettings
    from lgvtool.declared import markdown_table

    text = (ROOT / "docs" / "audit.md").read_text(encoding="utf-8")
    begin = "<!-- layout refine settings: generated from RefineSettings -->"
    end = "<!-- end of layout refine settings -->"
    a, b = text.index(begin) + len(begin), text.index(end)
    assert text[a:b].strip() == markdown_table(RefineSettings).strip()
