"""The report in a real browser: headless Chromium renders ``report.html`` of the sample log at
1400, 800 and 420 px wide; the page must raise no error (script errors, console.error, failed
loads), must not be wider than the window (tables scroll inside their boxes), no figure may
spill over what follows it, and at 1400 x 900 the verdict and one plot must be on the first
screen. Skipped, with the reason, where no Chromium or Chrome can be run (``.ci/run`` installs
Debian's ``chromium``).

The browser is driven from its command line only (``--dump-dom`` after a virtual-time budget):
a small script put first into a copy of the page records every error and, once the page has
settled, measures it and writes what it found into the DOM as JSON, which the test reads back.
No Python package is needed for that. ``LGVTOOL_REPORT_SHOTS=DIR`` also saves a full-page
screenshot per width into DIR, to look at.
"""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
import sys
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_logs" / "paper-circle.mcap"
DEGRADED = REPO / "sample_logs" / "degraded.mcap"
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
WIDTHS = (1400, 800, 420)
FIRST_SCREEN = (1400, 900)
"""The first screen: the verdict and one plot must be on it without scrolling."""

PROBE = r"""
<script>
(function () {
  var seen = [];
  function note(kind, text) { seen.push(kind + ': ' + String(text).slice(0, 300)); }
  window.addEventListener('error', function (ev) {
    var t = ev.target;
    if (t && t !== window && (t.src || t.href)) { note('failed to load', t.src || t.href); }
    else {
      note('script error', (ev.message || '?') + ' at ' + (ev.filename || '') + ':' +
           (ev.lineno || ''));
    }
  }, true);
  window.addEventListener('unhandledrejection', function (ev) { note('unhandled rejection', ev.reason); });
  var error = console.error;
  console.error = function () {
    note('console.error', Array.prototype.map.call(arguments, String).join(' '));
    return error.apply(console, arguments);
  };
  function box(el) {
    var r = el.getBoundingClientRect();
    return {top: r.top + window.scrollY, bottom: r.bottom + window.scrollY,
            left: r.left, right: r.right, width: r.width, height: r.height};
  }
  function measure() {
    var de = document.documentElement;
    var figures = Array.prototype.map.call(document.querySelectorAll('[data-figure]'), function (f) {
      var gd = f.querySelector('.js-plotly-plot');
      var svg = gd && gd.querySelector('.main-svg');
      return {slug: f.getAttribute('data-figure'), box: box(f), plot: gd ? box(gd) : null,
              drawn: svg ? box(svg) : null,
              wrapper: gd ? box(gd.parentElement) : null};
    });
    var wide = [];
    document.querySelectorAll('body *').forEach(function (el) {
      if (el.closest('.box, .js-plotly-plot, script, style')) { return; }
      var r = el.getBoundingClientRect();
      if (r.width > 0 && r.right > window.innerWidth + 1) {
        wide.push(el.tagName.toLowerCase() + (el.className ? '.' + el.className : '') + ' ' +
                  Math.round(r.right));
      }
    });
    var verdict = document.querySelector('[data-part="verdict"]');
    var out = {errors: seen, innerWidth: window.innerWidth, innerHeight: window.innerHeight,
               scrollWidth: de.scrollWidth, bodyWidth: document.body.scrollWidth,
               plotly: !!window.Plotly, verdict: verdict ? box(verdict) : null,
               figures: figures, wide: wide.slice(0, 10)};
    var text = JSON.stringify(out);
    if (window.parent !== window) { window.parent.postMessage(text, '*'); return; }
    var pre = document.createElement('pre');
    pre.id = 'lgv-probe';
    pre.textContent = text;
    document.body.appendChild(pre);
  }
  window.addEventListener('load', function () { setTimeout(measure, 2000); });
})();
</script>
"""


def _browser() -> str | None:
    env = os.environ.get("LGVTOOL_CHROMIUM")
    if env:
        return env
    return next((p for p in (shutil.which(b) for b in BROWSERS) if p), None)


@pytest.fixture(scope="module")
def browser() -> str:
    exe = _browser()
    if exe is None:
        pytest.skip("no Chromium or Chrome on this machine (Debian: apt-get install chromium; "
                    "or set LGVTOOL_CHROMIUM): the report's browser check needs one")
    return exe


def _evaluate(out: Path, *logs: Path) -> Path:
    p = subprocess.run([sys.executable, "-m", "lgvtool", "evaluate", *map(str, logs), "-o",
                        str(out)], capture_output=True, text=True, timeout=600, check=False)
    assert p.returncode == 0, p.stderr
    return out / "report.html"


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """report.html of the sample log, made as a new user makes it."""
    return _evaluate(tmp_path_factory.mktemp("report"), SAMPLE)


@pytest.fixture(scope="module")
def two_logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _evaluate(tmp_path_factory.mktemp("two"), SAMPLE, DEGRADED)


MIN_WINDOW = 500
"""Headless Chromium makes no window narrower than this (px): a narrower page is shown in a
frame of its width inside a wider window (the frame is the page's window)."""

FRAME = """<!DOCTYPE html><html><head><meta charset="utf-8"></head><body style="margin:0">
<iframe src="{src}" style="display:block;border:0;width:{width}px;height:{height}px"></iframe>
<script>
window.addEventListener('message', function (ev) {{
  var pre = document.createElement('pre');
  pre.id = 'lgv-probe';
  pre.textContent = ev.data;
  document.body.appendChild(pre);
}});
</script></body></html>
"""


def _run(exe: str, page: Path, width: int, height: int, profile: Path, *what: str
         ) -> subprocess.CompletedProcess[str]:
    """Open ``page`` in a window ``width`` x ``height`` px (in a frame of that size when the
    width is below :data:`MIN_WINDOW`) and do ``what`` with it."""
    window = max(width, MIN_WINDOW)
    if width < MIN_WINDOW:
        host = page.with_name(f"frame-{width}-{page.name}")
        host.write_text(FRAME.format(src=page.name, width=width, height=height),
                        encoding="utf-8")
        page = host
    return subprocess.run(
        [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
         "--no-first-run", "--no-default-browser-check", "--hide-scrollbars",
         f"--user-data-dir={profile}", f"--window-size={window},{height}",
         "--virtual-time-budget=20000", *what, page.as_uri()],
        capture_output=True, text=True, timeout=300, check=False)


def render(exe: str, report: Path, width: int) -> dict[str, Any]:
    """What the probe measured in ``report`` at ``width`` x 900 px."""
    page = report.with_name(f"probed-{width}.html")
    text = report.read_text(encoding="utf-8")
    page.write_text(text.replace("<head>", "<head>" + PROBE, 1), encoding="utf-8")
    profile = report.with_name(f"profile-{width}")
    p = _run(exe, page, width, FIRST_SCREEN[1], profile, "--dump-dom")
    found = re.search(r'<pre id="lgv-probe">(.*?)</pre>', p.stdout, re.S)
    if found is None:
        if not p.stdout.strip():  # the browser did not start at all: none can be had here
            last = (p.stderr.strip().splitlines() or ["no output"])[-1]
            pytest.skip(f"{exe} does not run here ({last})")
        raise AssertionError(f"the page never settled at {width} px (no probe in the DOM)")
    shots = os.environ.get("LGVTOOL_REPORT_SHOTS")
    if shots:
        Path(shots).mkdir(parents=True, exist_ok=True)
        target = Path(shots) / f"{report.parent.name}-{width}.png"
        tall = json.loads(html.unescape(found.group(1)))
        height = int(max([FIRST_SCREEN[1]] + [f["box"]["bottom"] for f in tall["figures"]])) + 400
        _run(exe, report, width, height, profile, f"--screenshot={target}")
    return dict(json.loads(html.unescape(found.group(1))))


def _check_page(m: dict[str, Any], width: int) -> None:
    assert m["errors"] == [], f"errors in the page at {width} px: {m['errors']}"
    assert m["plotly"], "plotly.js did not load (it must be embedded: the report is offline)"
    assert m["innerWidth"] == width
    assert m["scrollWidth"] <= m["innerWidth"], (
        f"the page is {m['scrollWidth']} px wide in a {width} px window: {m['wide']}")
    assert not m["wide"], f"elements past the right edge at {width} px: {m['wide']}"
    figures = m["figures"]
    assert figures, "no figure"
    for f in figures:
        assert f["drawn"] is not None, f"{f['slug']} was not drawn at {width} px"
        # the drawing stays inside its figure box: nothing spills over what follows
        assert f["drawn"]["bottom"] <= f["box"]["bottom"] + 1, (f["slug"], width)
        assert f["wrapper"]["bottom"] <= f["box"]["bottom"] + 1, (f["slug"], width)
        assert f["drawn"]["right"] <= width + 1, (f["slug"], width)
    for a, b in pairwise(figures):
        assert a["box"]["bottom"] <= b["box"]["top"] + 1, (a["slug"], b["slug"], width)


@pytest.mark.parametrize("width", WIDTHS)
def test_report_renders_without_errors_or_overflow(browser: str, report: Path, width: int
                                                   ) -> None:
    m = render(browser, report, width)
    _check_page(m, width)
    assert m["verdict"] is not None
    if width == FIRST_SCREEN[0]:
        # the first screen: the verdict and one whole plot, without scrolling
        assert m["verdict"]["top"] >= 0 and m["verdict"]["bottom"] <= FIRST_SCREEN[1], m["verdict"]
        first = m["figures"][0]
        assert first["plot"]["bottom"] <= FIRST_SCREEN[1], first
    if width == 420:
        # the trajectories stack their two panels on a phone: taller than wide
        traj = next(f for f in m["figures"] if f["slug"] == "trajectories")
        assert traj["plot"]["height"] > traj["plot"]["width"]


@pytest.mark.parametrize("width", (1400, 420))
def test_report_of_two_logs_renders_without_errors_or_overflow(browser: str, two_logs: Path,
                                                               width: int) -> None:
    m = render(browser, two_logs, width)
    _check_page(m, width)
    assert m["figures"][0]["slug"] == "all-rotations"
    if width == FIRST_SCREEN[0]:
        assert m["verdict"]["bottom"] <= FIRST_SCREEN[1] + 200  # two logs' estimators
        assert m["figures"][0]["plot"]["bottom"] <= FIRST_SCREEN[1]
