"""The sweep's ``report.html``: each figure against each swept parameter, with 95 % bands.

Self-contained: plotly.js is embedded once in the page head and every figure is a div that
uses it, so the file opens offline. For a parameter ``p``, each line is an estimator (split by
the other swept parameters of that same estimator when they take at most :data:`MAX_COMBOS`
combinations); a point is the mean of the figure over all logs and seeds at that value of
``p``, the band its Student-t 95 % confidence interval. Figures that depend only on the log
(its duration, its rotations) are not drawn; they are in the tables. Failed tasks are listed
with their error.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, TypedDict, TypeGuard

from lgvtool import __version__
from lgvtool.fleet.stats import describe

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.json_types import SettingValue

MAX_COMBOS = 4
"""Most combinations of the other swept parameters drawn as separate lines."""
MAX_FAILURES = 200
"""Failed tasks listed one by one in the report."""


def _rgba(colour: str, alpha: float) -> str:
    c = colour.lstrip("#")
    r, g, b = (int(c[i:i + 2], 16) for i in (0, 2, 4))
    return f"rgba({r},{g},{b},{alpha})"


def _numeric(values: Sequence[object]) -> TypeGuard[Sequence[int | float]]:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _owner(key: str) -> str:
    """The estimator a setting belongs to: ``pf-paper.spread_m`` -> ``pf-paper``."""
    return key.rpartition(".")[0]


def _line_groups(ok: pd.DataFrame, others: Sequence[str]) -> list[tuple[str, pd.DataFrame]]:
    """(legend name, rows) per estimator; split further by the combinations of the other
    swept parameters that belong to that estimator, when there are at most
    :data:`MAX_COMBOS` of them (else pooled over them)."""
    out: list[tuple[str, pd.DataFrame]] = []
    estimators = list(dict.fromkeys(ok["estimator"].fillna("").tolist()))
    for est in estimators:
        rows = ok[ok["estimator"].fillna("") == est]
        mine = [k for k in others if _owner(k) == est]
        combos = list(dict.fromkeys(
            tuple(r) for r in rows[mine].itertuples(index=False, name=None))) if mine else []
        if not mine or len(combos) > MAX_COMBOS:
            out.append((est or "all", rows))
            continue
        for combo in combos:
            mask = (rows[mine] == list(combo)).all(axis=1)
            label = ", ".join(f"{k}={v}" for k, v in zip(mine, combo, strict=True))
            out.append((f"{est or 'all'} ({label})", rows[mask]))
    return out


def varies_within_logs(tidy: pd.DataFrame, metric: str) -> bool:
    """True when ``metric`` takes more than one value for some log: figures that depend only
    on the log (its duration, its rotations) are left out of the plots."""
    ok = tidy[tidy["status"] == "ok"]
    return bool((ok.groupby("log")[metric].nunique(dropna=True) > 1).any())


PALETTE = ("#636efa", "#ef553b", "#00cc96", "#ab63fa", "#ffa15a", "#19d3f3", "#ff6692",
           "#b6e880", "#ff97ff", "#fecb52")
"""Line colours (plotly's default qualitative palette)."""


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


class Layout(TypedDict):
    """A plotly figure's layout, as :func:`_layout` makes it (sizes in px)."""

    title: dict[str, str]
    height: int
    template: None
    paper_bgcolor: str
    plot_bgcolor: str
    margin: dict[str, int]
    xaxis: dict[str, object]
    yaxis: dict[str, object]
    legend: dict[str, object]


class Figure(TypedDict):
    """A plotly figure as a dict: its traces and its layout."""

    data: list[dict[str, object]]
    layout: Layout


def _layout(title: str, xtitle: str, ytitle: str, height: int) -> Layout:
    axis = {"gridcolor": "#e5e5e5", "zerolinecolor": "#cccccc", "automargin": True}
    return {"title": {"text": title}, "height": height, "template": None,
            "paper_bgcolor": "white", "plot_bgcolor": "white",
            "margin": {"l": 60, "r": 20, "t": 50, "b": 50},
            "xaxis": {**axis, "title": {"text": xtitle}},
            "yaxis": {**axis, "title": {"text": ytitle}},
            "legend": {"orientation": "h", "y": -0.22}}


def metric_figure(tidy: pd.DataFrame, metric: str, param: str,
                  grid: Mapping[str, Sequence[SettingValue]]) -> Figure:
    """A plotly figure (as a dict) of ``metric``, mean and 95 % band over logs and seeds,
    against the swept parameter ``param``."""
    ok = tidy[(tidy["status"] == "ok") & tidy[metric].notna()]
    values = list(grid[param])
    numeric = _numeric(values)
    xs: Sequence[SettingValue] = sorted(values) if _numeric(values) else values
    others = [k for k in grid if k != param and len(grid[k]) > 1]
    data: list[dict[str, object]] = []
    for i, (name, rows) in enumerate(_line_groups(ok, others)):
        colour = PALETTE[i % len(PALETTE)]
        column = rows[param] if numeric else rows[param].astype(str)
        pts = []
        for x in xs:
            s = describe(rows.loc[column == (x if numeric else str(x)), metric].tolist())
            if s.n:
                pts.append((x if numeric else str(x), s))
        if not pts:
            continue
        band = [(x, s) for x, s in pts if math.isfinite(s.ci_low)]
        if band:
            data.append({
                "type": "scatter", "mode": "lines", "fill": "toself",
                "x": [x for x, _ in band] + [x for x, _ in reversed(band)],
                "y": [s.ci_high for _, s in band] + [s.ci_low for _, s in reversed(band)],
                "fillcolor": _rgba(colour, 0.18), "line": {"width": 0}, "hoverinfo": "skip",
                "showlegend": False, "legendgroup": name, "name": f"{name} 95 % CI"})
        data.append({
            "type": "scatter", "mode": "lines+markers", "name": name, "legendgroup": name,
            "x": [x for x, _ in pts], "y": [s.mean for _, s in pts], "line": {"color": colour},
            "customdata": [[s.n, _num(s.ci_low), _num(s.ci_high)] for _, s in pts],
            "hovertemplate": (f"{html.escape(param)}=%{{x}}<br>{html.escape(metric)} mean "
                              "%{y:.4g}<br>95 % CI %{customdata[1]:.4g} .. %{customdata[2]:.4g}"
                              "<br>n=%{customdata[0]}<extra>%{fullData.name}</extra>")})
    layout = _layout(f"{metric} against {param}", param, metric, 420)
    if not numeric:
        layout["xaxis"].update({"type": "category", "categoryorder": "array",
                                "categoryarray": [str(v) for v in xs]})
    return {"data": data, "layout": layout}


def estimator_figure(tidy: pd.DataFrame, metric: str) -> Figure:
    """``metric`` per estimator (mean and 95 % interval over logs and seeds), as a plotly
    figure dict: the view when no parameter is swept."""
    ok = tidy[(tidy["status"] == "ok") & tidy[metric].notna()]
    names: list[str] = []
    means: list[float | None] = []
    lo: list[float] = []
    hi: list[float] = []
    for est, rows in ok.groupby(ok["estimator"].fillna("all"), sort=False):
        s = describe(rows[metric].tolist())
        names.append(str(est))
        means.append(_num(s.mean))
        lo.append(s.mean - s.ci_low if math.isfinite(s.ci_low) else 0.0)
        hi.append(s.ci_high - s.mean if math.isfinite(s.ci_high) else 0.0)
    bar: dict[str, object] = {"type": "bar", "x": names, "y": means, "marker": {"color": PALETTE[0]},
           "error_y": {"type": "data", "symmetric": False, "array": hi, "arrayminus": lo}}
    return {"data": [bar], "layout": _layout(f"{metric} per estimator", "estimator", metric, 380)}


def figure_html(fig: Mapping[str, object], div_id: str) -> str:
    """A div and the script that draws ``fig`` (a plotly figure dict) into it with the page's
    plotly.js."""
    payload = json.dumps({"data": fig["data"], "layout": fig["layout"]}, allow_nan=False)
    payload = payload.replace("</", "<\\/")
    return (f"<div id='{div_id}' class='fig'></div><script>(function(){{var f={payload};"
            f"Plotly.newPlot('{div_id}',f.data,f.layout,{{displaylogo:false,responsive:true}});"
            "})();</script>")


def _failures_html(tidy: pd.DataFrame) -> str:
    failed = tidy[tidy["status"] != "ok"].drop_duplicates("key")
    if failed.empty:
        return "<p>No task failed.</p>"
    head = "".join(f"<th>{html.escape(c)}</th>" for c in ("log", "setting", "seed", "error"))
    rows = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(v))}</td>"
                         for v in (r["log"], r["setting"], r["seed"], r["error"])) + "</tr>"
        for _, r in failed.head(MAX_FAILURES).iterrows())
    more = (f"<p>... and {len(failed) - MAX_FAILURES} more failed task(s): see summary.csv.</p>"
            if len(failed) > MAX_FAILURES else "")
    return (f"<p>{len(failed)} task(s) failed.</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>{more}")


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
th { background: #f3f3f3; }
h2 { margin-top: 2em; border-bottom: 1px solid #ddd; }
.note { color: #555; }
"""


def render_report(
    tidy: pd.DataFrame,
    *,
    grid: Mapping[str, Sequence[SettingValue]],
    metrics: Sequence[str],
    title: str = "lgvtool sweep",
    facts: Mapping[str, object] | None = None,
) -> str:
    """The report page as one HTML string (plotly.js embedded once)."""
    from plotly.offline import get_plotlyjs

    swept = [k for k, v in grid.items() if len(v) > 1]
    drawn = [m for m in metrics if m in tidy.columns
             and tidy.loc[tidy["status"] == "ok", m].notna().any() and varies_within_logs(tidy, m)]
    parts: list[str] = []
    facts_rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(str(v))}</td></tr>"
                         for k, v in (facts or {}).items())
    parts.append(f"<h1>{html.escape(title)}</h1>")
    parts.append(f"<table>{facts_rows}</table>")
    parts.append("<p class='note'>Each point is the mean of a figure over all logs and seeds "
                 "that share the parameter value; the band is the Student-t 95 % confidence "
                 "interval of that mean. Per-log figures are in summary.csv.</p>")
    parts.append("<h2>Failed tasks</h2>")
    parts.append(_failures_html(tidy))
    count = 0
    for metric in drawn:
        parts.append(f"<h2>{html.escape(metric)}</h2>")
        figs = ([metric_figure(tidy, metric, p, grid) for p in swept] if swept
                else [estimator_figure(tidy, metric)])
        for fig in figs:
            count += 1
            parts.append(figure_html(fig, f"fig{count}"))
    if not count:
        parts.append("<p>No figures: no figure varies with the settings or seeds within a log "
                     "(or no task finished). The tables hold every figure.</p>")
    body = "\n".join(parts)
    return (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style>"
        f"<script type='text/javascript'>{get_plotlyjs()}</script></head>\n"
        f"<body>\n{body}\n<p class='note'>lgvtool {__version__}</p>\n</body></html>\n"
    )

