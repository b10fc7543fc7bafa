"""The MRCLAM estimator profile chosen by a rule fixed before scoring: choose on one half of
every robot's run, score on the other half (docs/mrclam.md, "A rule fixed before scoring").

Each robot's scored span (its first camera frame with a landmark to the end of its ground truth
or odometry, whichever comes first) is split at its midpoint in time into halves A and B. Every
candidate (:data:`CANDIDATES`) is replayed on each half from the ground truth at the half's
start (half B: at the midpoint, moved by the odometry to the first camera frame after it), with
its odometry scales at 1, and scored as :mod:`mrclam_accuracy` scores a run: position RMSE (m)
at every odometry step of the half where the ground truth exists. The reference EKF's figure
for a half is the dataset's published whole-run figure apportioned by a plain EKF
(:data:`PLAIN_EKF`, no odometry scales, the odometry as stamped) run once over the whole run
from the ground truth: ``ref(half) = ref(run) x plain(half) / plain(run)``.

The rule (:func:`choose`): on the choice halves of all robots, the candidate with the least fit
score (:func:`mrclam_cv.fit_score`: the worst ratio plus a quarter of the mean; ties to the
earlier candidate); A -> B chooses on the first halves and scores on the second, B -> A the
reverse. Beside it, per robot, the choice made on the other robots' choice halves only.

Usage::

    python benchmarks/mrclam_halves.py DIR                  # any MRCLAM dataset folder
    python benchmarks/mrclam_halves.py DIR --robots 3,5 --json
    python benchmarks/mrclam_halves.py DIR --prototypes     # and the variants tried after it
    python benchmarks/mrclam_halves.py DIR --extra "gate 0.995=ekf.gate_probability=0.995"
    python benchmarks/mrclam_halves.py DIR --set ekf.update_iterations=10   # every ekf candidate

``--extra LABEL=EST.KEY=V[,EST.KEY=V...]`` adds a candidate that is scored and shown but never
chosen (it is not part of the rule): for prototyping a setting before it is proposed;
``adapt.alpha=A[,adapt.range=1]`` among its values makes it the prototype of ``ekf`` with its
camera noise estimated online, ``adapt.huber=C`` with a frame its prior does not explain
weighed less, ``adapt.rscale=A`` with the camera's range scale estimated online
(:func:`adaptive_ekf`); ``camera.bearing=true`` sets each robot's
bearing noise to what the importer measured from the camera
(:attr:`Candidate.bearing_from_camera`).
Imported logs are cached as :mod:`mrclam_cv` caches them (``--cache``).

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mrclam_accuracy import (
    TARGET_RATIO,
    default_dataset,
    references,
    scan_drive,
    traced_run,
)
from mrclam_cv import best_fit, cached_log
from mrclam_metrics import estimates_at_odometry, position_rmse


@dataclass(frozen=True)
class Candidate:
    """One estimator with settings over the log's stored profile (``{"est.key": value}``)."""

    label: str
    estimator: str
    settings: dict[str, object]
    adapt: dict[str, float] | None = None
    """A prototype, not an estimator of lgvtool: ``ekf`` run as :func:`adaptive_ekf` with
    ``alpha`` (camera noise estimated online; ``range`` 1: the range noise too), ``huber``
    (frames its prior does not explain weigh less), ``rscale`` (a range scale estimated
    online)."""
    bearing_from_camera: bool = False
    """Each robot's ``sigma_bearing_rad`` (rad) is the RMS residual of the bearing changes the
    importer measured from the camera alone (``timing.bearing_rms_with_delay_rad`` of the
    log's ``importer`` record; no ground truth)."""


RULE_PROFILE: dict[str, object] = {"ekf.scale_sigma_w": 0.15, "ekf.scale_walk_v": 0.01,
                                   "ekf.scale_walk_w": 0.01}
"""The ``ekf`` odometry scales of the stored profile when the rule was written (prior 1-sigma
of the turn scale; random walks per sqrt(m) and per sqrt(rad)): the candidates that vary the
profile vary that one, so that their figures stay what the rule saw whatever the stored profile
becomes."""

CANDIDATES: tuple[Candidate, ...] = (
    Candidate("ekf profile", "ekf", dict(RULE_PROFILE)),
    Candidate("ekf gate 0.99", "ekf", {**RULE_PROFILE, "ekf.gate_probability": 0.99}),
    Candidate("ekf camera noise x1.5", "ekf", {**RULE_PROFILE, "ekf.sigma_bearing_rad": 0.01875,
                                               "ekf.sigma_range_per_m": 0.42}),
    Candidate("ekf scales slow", "ekf", {"ekf.scale_sigma_w": 0.075, "ekf.scale_walk_v": 0.003,
                                         "ekf.scale_walk_w": 0.003}),
    Candidate("pf profile", "pf", {}),
)
"""The rule's candidates, in the order that breaks ties (fixed before scoring)."""

PROTOTYPES: tuple[Candidate, ...] = (
    Candidate("bearing noise x1.5", "ekf", {**RULE_PROFILE, "ekf.sigma_bearing_rad": 0.01875}),
    Candidate("range noise x1.5", "ekf", {**RULE_PROFILE, "ekf.sigma_range_per_m": 0.42}),
    Candidate("camera noise x2", "ekf", {**RULE_PROFILE, "ekf.sigma_bearing_rad": 0.025,
                                         "ekf.sigma_range_per_m": 0.56}),
    Candidate("bearing noise from the camera", "ekf", dict(RULE_PROFILE),
              bearing_from_camera=True),
    Candidate("online bearing noise 0.01", "ekf", dict(RULE_PROFILE), {"alpha": 0.01}),
    Candidate("online bearing noise 0.002", "ekf", dict(RULE_PROFILE), {"alpha": 0.002}),
    Candidate("online camera noise 0.01", "ekf", dict(RULE_PROFILE),
              {"alpha": 0.01, "range": 1.0}),
    Candidate("frame weight 5.99", "ekf", dict(RULE_PROFILE), {"huber": 5.99}),
    Candidate("online range scale 0.002", "ekf", dict(RULE_PROFILE), {"rscale": 0.002}),
)
"""Variants measured after the rule's table had been seen (``--prototypes``): scored beside
the rule's candidates, never chosen. Settings over the stored profile, or the prototypes of
:func:`adaptive_ekf` and :attr:`Candidate.bearing_from_camera`."""

PLAIN_EKF: dict[str, object] = {
    "ekf.odometry_scales": False,
    "ekf.sigma_range_m": 0.1, "ekf.sigma_range_per_m": 0.28, "ekf.sigma_bearing_rad": 0.0125,
    "ekf.gate_probability": 0.999,
    "ekf.noise_dist": 0.25, "ekf.noise_lat": 0.2125, "ekf.noise_rot": 8.0,
    "ekf.noise_rot_per_m": 0.42,
    "ekf.init_sigma_xy_m": 1.0, "ekf.init_sigma_heading_rad": 0.5,
}
"""The plain EKF that apportions the reference EKF's whole-run figure to the halves (camera
noise m, m/m, rad; gate probability; motion noise m/m, m/m, rad/rad, rad/m; start m, rad); run
on the log imported with the odometry as stamped (no delay), as the reference EKF had it."""

HALVES = ("A", "B")
"""The first and the second half of every run."""
FIT_WEIGHT_NOTE = "worst ratio + 0.25 x mean ratio"


@dataclass(frozen=True)
class Span:
    """A robot's scored span, s after the log's ``t0_ns``: ``start`` (first camera frame with a
    landmark), ``mid`` (the midpoint), ``end`` (the end of the ground truth or of the
    odometry, whichever comes first)."""

    start: float
    mid: float
    end: float


def span_of(data: Any) -> Span:
    """The scored span of a log's data (:class:`lgvtool.localize.logdata.LogData`)."""
    start = float(data.scan_received()[0]) if len(data.scans) else math.nan
    assert data.truth is not None and data.twist is not None
    end = min(float(data.truth.t[-1]), float(data.twist["t"][-1]))
    return Span(start, 0.5 * (start + end), end)


@dataclass
class RobotLog:
    """One robot's log, read once: its config, data (ground truth included), odometry and
    ground truth as tables (t in s since the epoch)."""

    config: Any
    data: Any
    odometry: pd.DataFrame
    truth: pd.DataFrame
    timing: dict[str, Any]

    @classmethod
    def read(cls, path: Path) -> RobotLog:
        """Read the log at ``path``."""
        from lgvtool.localize.logdata import load_log
        from lgvtool.log import LogReader, topics

        reader = LogReader(path)
        cfg = reader.config()
        data = load_log(reader, cfg.reflectors or None, truth=True)
        importer = reader.metadata.get("importer")
        timing = importer.get("timing", {}) if isinstance(importer, dict) else {}
        return cls(cfg, data, reader.dataframe(topics.ODOM)[["t", "v", "omega"]],
                   reader.dataframe(topics.TRUTH)[["t", "x", "y", "heading"]],
                   dict(timing) if isinstance(timing, dict) else {})

    @property
    def t0_s(self) -> float:
        """The data's time origin, s since the epoch."""
        return float(self.data.t0_ns) * 1e-9


def adaptive_ekf(alpha: float, estimate_range: bool, huber: float = 0.0,
                 range_scale: float = 0.0) -> Any:
    """A prototype of ``ekf`` (no estimator of lgvtool) with three ways of treating the camera
    that read no ground truth; each is off at 0.

    - ``alpha``: the camera noise estimated online from the filter's own residuals. After each
      frame, for every landmark the update accepted (inside the chi-square gate before the
      update), the posterior residual ``e`` and the posterior variance ``h P+ h^T`` of the
      predicted measurement give one sample of the measurement variance, ``e^2 + h P+ h^T``
      (residual-based: ``E[e e^T] = R - H P+ H^T`` for a consistent filter). The bearing
      variance (rad^2) and, with ``estimate_range``, the range variance per squared metre of
      range beyond ``sigma_range_m`` follow the exponentially weighted mean of these samples,
      weight ``alpha`` per landmark, from the profile's values; the next frame uses them.
    - ``huber``: a frame that the prior does not explain weighs less. When the mean squared
      Mahalanobis distance (2 degrees of freedom each, at the prior) of the frame's landmarks
      inside the gate exceeds ``huber``, the frame's camera variances are multiplied by their
      ratio (a per-frame scale mixture: Huber's weight on the frame).
    - ``range_scale``: the camera's ranges are divided by a range scale estimated online
      (start 1): after each frame, measured over predicted range (at the posterior) of every
      landmark inside the gate, exponentially weighted with weight ``range_scale`` each.

    Runs the estimator's numpy path (the compiled kernels read the noise once)."""
    from dataclasses import replace

    from lgvtool.angles import wrap_angle
    from lgvtool.localize.ekf import Ekf
    from lgvtool.localize.gaussian_backend import NumpyGaussian
    from lgvtool.localize.observations import ScanObservation

    class AdaptiveEkf(Ekf):
        def __init__(self, params: Any, **context: Any) -> None:
            super().__init__(params, backend=NumpyGaussian(), **context)
            self.sb2 = float(params.sigma_bearing_rad) ** 2
            self.k2 = float(params.sigma_range_per_m) ** 2
            self.rs = 1.0

        def _predicted(self, obs: Any, idx: Any) -> tuple[Any, Any, Any, Any, Any]:
            """Range and bearing residuals (m, rad) of the landmarks ``idx`` of ``obs`` at
            the current mean, their Jacobians (n x 3) and the measured ranges (m)."""
            mu = self.mu
            assert mu is not None
            x, y, th = (float(v) for v in mu[:3])
            c, s = math.cos(th), math.sin(th)
            j = obs.map_index(self.map)[idx]
            ex, ey = self.map.x[j] - x, self.map.y[j] - y
            hx, hy = c * ex + s * ey, -s * ex + c * ey
            origin = obs.q[idx] - obs.ranges[idx] * obs.u[idx]
            vx, vy = hx - origin.real, hy - origin.imag
            r2 = np.maximum(vx * vx + vy * vy, 1e-12)
            rng = np.sqrt(r2)
            nr = obs.ranges[idx] - rng
            nb = wrap_angle(np.angle(obs.u[idx]) - np.arctan2(vy, vx))
            dvx = (-c * np.ones_like(hx), -s * np.ones_like(hx), hy)
            dvy = (s * np.ones_like(hx), -c * np.ones_like(hx), -hx)
            hr = np.stack([(vx * a + vy * b) / rng for a, b in zip(dvx, dvy, strict=True)], 1)
            hb = np.stack([(vx * b - vy * a) / r2 for a, b in zip(dvx, dvy, strict=True)], 1)
            return nr, nb, hr, hb, obs.ranges[idx]

        def update(self, obs: Any) -> bool:
            if self.mu is None or not isinstance(obs, ScanObservation) or len(obs) == 0:
                return bool(super().update(obs))
            p = self.params
            raw = obs
            if range_scale > 0.0:
                origin = obs.q - obs.ranges * obs.u
                ranges = obs.ranges / self.rs
                obs = ScanObservation(obs.t, origin + ranges * obs.u, obs.u, ranges, obs.ids)
            idx = np.flatnonzero(obs.map_index(self.map) >= 0)
            inside = idx
            if len(idx):
                nr, nb, hr, hb, r = self._predicted(obs, idx)
                P = self.P[:3, :3]
                sr2 = p.sigma_range_m ** 2 + self.k2 * r * r
                srr = np.einsum("ki,ij,kj->k", hr, P, hr) + sr2
                sbb = np.einsum("ki,ij,kj->k", hb, P, hb) + self.sb2
                srb = np.einsum("ki,ij,kj->k", hr, P, hb)
                det = srr * sbb - srb * srb
                d2 = (sbb * nr * nr - 2.0 * srb * nr * nb + srr * nb * nb) / det
                inside = idx[d2 <= self._gate2]
            f = 1.0
            if huber > 0.0 and len(inside):
                f = max(1.0, float(np.mean(d2[d2 <= self._gate2])) / huber)
            self.params = replace(p, sigma_bearing_rad=math.sqrt(self.sb2 * f),
                                  sigma_range_m=math.sqrt(f) * p.sigma_range_m,
                                  sigma_range_per_m=math.sqrt(self.k2 * f))
            ok = bool(super().update(obs))
            self.params = p
            if ok and len(inside) and range_scale > 0.0:
                nr, _, _, _, r = self._predicted(raw, inside)
                for k in range(len(inside)):
                    self.rs += range_scale * (r[k] / (r[k] - nr[k]) - self.rs)
            if ok and len(inside) and alpha > 0.0:
                nr, nb, hr, hb, r = self._predicted(obs, inside)
                P = self.P[:3, :3]
                for k in range(len(inside)):
                    self.sb2 += alpha * (nb[k] ** 2 + float(hb[k] @ P @ hb[k]) - self.sb2)
                    if estimate_range:
                        sample = (nr[k] ** 2 + float(hr[k] @ P @ hr[k])
                                  - p.sigma_range_m ** 2) / (r[k] * r[k])
                        self.k2 += alpha * (max(sample, 0.0) - self.k2)
            return ok

    return AdaptiveEkf


def replay(log: RobotLog, name: str, settings: dict[str, object], start_t: float,
           end_t: float, *, seed: int, adapt: dict[str, float] | None = None) -> pd.DataFrame:
    """Estimator ``name`` with ``settings`` over the observations after ``start_t`` and
    before ``end_t`` (s after ``t0_ns``), started at the ground truth at ``start_t`` (from
    where it moves by the odometry to its first observation). Returns its estimates with their
    odometry calibration (:func:`mrclam_accuracy.traced_run`), ``t`` in s since the epoch."""
    from lgvtool.localize.registry import resolve_params, split_settings
    from lgvtool.localize.replay_driver import truth_pose_at

    params = resolve_params(name, log.config.estimators, split_settings(settings).get(name))
    _, track, obs = scan_drive(None, log.config, params, truth=True, data=log.data)
    todo = [o for o in obs if start_t <= o.t < end_t]
    observations: list[Any] = list(todo)
    times = [o.t for o in todo]
    if not todo or todo[0].t > start_t:
        observations.insert(0, None)
        times.insert(0, start_t)
    start = truth_pose_at(log.data, start_t)
    cls = None if adapt is None else adaptive_ekf(adapt.get("alpha", 0.0),
                                                  bool(adapt.get("range")),
                                                  adapt.get("huber", 0.0),
                                                  adapt.get("rscale", 0.0))
    rows = traced_run(name, params, log.data, log.config, track,
                      np.asarray(times, dtype=np.float64), observations, seed=seed, start=start,
                      cls=cls)
    rows["t"] = rows["t"] + log.t0_s
    return rows


def rmse_between(estimate: pd.DataFrame, log: RobotLog, t_from: float, t_to: float) -> float:
    """Position RMSE (m) at every odometry step at or after ``t_from`` and before ``t_to`` (s
    after ``t0_ns``; ``t_to`` = the span's end includes it), the estimate carried through the
    odometry between its rows."""
    carried = estimates_at_odometry(estimate, log.odometry)
    rel = carried["t"].to_numpy() - log.t0_s
    keep = (rel >= t_from - 1e-9) & (rel <= t_to + 1e-9)
    return float(position_rmse(carried[keep], log.truth)[0])


def candidate_settings(log: RobotLog, cand: Candidate) -> dict[str, object]:
    """The settings a candidate runs with on ``log``: its own, with the bearing noise the
    importer measured from the camera where it asks for that
    (:attr:`Candidate.bearing_from_camera`)."""
    settings = dict(cand.settings)
    if cand.bearing_from_camera:
        settings[f"{cand.estimator}.sigma_bearing_rad"] = float(
            log.timing["bearing_rms_with_delay_rad"])
    return settings


def half_scores(log: RobotLog, span: Span, cand: Candidate, seed: int) -> dict[str, float]:
    """RMSE (m) of a candidate on half A and half B, each replayed from the ground truth at
    the half's start."""
    settings = candidate_settings(log, cand)
    a = replay(log, cand.estimator, settings, span.start, span.mid, seed=seed,
               adapt=cand.adapt)
    b = replay(log, cand.estimator, settings, span.mid, span.end + 1.0, seed=seed,
               adapt=cand.adapt)
    # half A ends where B starts: its last odometry step is the one before the midpoint
    return {"A": rmse_between(a, log, span.start, span.mid - 1e-6),
            "B": rmse_between(b, log, span.mid, span.end)}


def plain_scores(log: RobotLog, span: Span, seed: int) -> dict[str, float]:
    """RMSE (m) of the plain EKF (:data:`PLAIN_EKF`) run once over the whole span from the
    ground truth, on the whole span and on each half."""
    est = replay(log, "ekf", PLAIN_EKF, span.start, span.end + 1.0, seed=seed)
    return {"run": rmse_between(est, log, span.start, span.end),
            "A": rmse_between(est, log, span.start, span.mid - 1e-6),
            "B": rmse_between(est, log, span.mid, span.end)}


def robot_with_plain(dataset: Path, robot: int, cache: Path, seed: int
                     ) -> tuple[RobotLog, Span, dict[str, float]]:
    """One robot of ``dataset``: its log as imported (the odometry delay measured), its scored
    span, and the plain EKF's RMSE (m) over the run and each half (:func:`plain_scores`), run on
    the log imported with the odometry as stamped over the same halves in time."""
    log = RobotLog.read(cached_log(dataset, robot, cache))
    span = span_of(log.data)
    stamped = RobotLog.read(cached_log(dataset, robot, cache, odometry_delay_s=0.0))
    shift = log.t0_s - stamped.t0_s
    plain = plain_scores(stamped, Span(span.start + shift, span.mid + shift, span.end + shift),
                         seed)
    return log, span, plain


def choose(ratio: np.ndarray) -> int:
    """The rule's choice from a candidates x robots matrix of ratios on the choice halves:
    the least fit score (:func:`mrclam_cv.fit_score`), ties to the earlier candidate."""
    return int(best_fit(ratio))


def run(dataset: Path, robots: list[int], cache: Path, cands: list[Candidate], n_rule: int,
        seed: int) -> dict[str, Any]:
    """Score every candidate on both halves of every robot; apply the rule.

    :param n_rule: the first ``n_rule`` of ``cands`` are the rule's; the rest are scored only.
    :returns: JSON-ready: ``robots``, ``candidates``, ``reference_m`` (per robot and half),
        ``rmse_m`` and ``ratio`` [candidate][robot][half], ``choice`` per direction.
    """
    from lgvtool.errors import InputError

    ref_run = references(dataset)[0]
    if not robots or not all(r in ref_run for r in robots):
        raise InputError("the reference EKF's figures are known for Dataset 6 only (robots "
                         "1-5); the ratios of this rule need them")
    rmse = np.full((len(cands), len(robots), 2), math.nan)
    refs: dict[int, dict[str, float]] = {}
    plain: dict[int, dict[str, float]] = {}
    spans: dict[int, Span] = {}
    for k, robot in enumerate(robots):
        t0 = time.perf_counter()
        log, span, p = robot_with_plain(dataset, robot, cache, seed)
        spans[robot] = span
        plain[robot] = p
        refs[robot] = {h: ref_run[robot] * p[h] / p["run"] for h in HALVES}
        for c, cand in enumerate(cands):
            s = half_scores(log, span, cand, seed)
            rmse[c, k] = [s["A"], s["B"]]
        print(f"robot {robot}: " + ", ".join(
            f"{cand.label} {rmse[c, k, 0]:.3f}/{rmse[c, k, 1]:.3f}"
            for c, cand in enumerate(cands)) + f" m ({time.perf_counter() - t0:.0f} s)",
            file=sys.stderr)
    ref = np.array([[refs[r][h] for h in HALVES] for r in robots])
    ratio = rmse / ref[None]
    choice: dict[str, Any] = {}
    rule = ratio[:n_rule]
    for name, pick, score in (("A -> B", 0, 1), ("B -> A", 1, 0)):
        everyone = choose(rule[:, :, pick])
        others = [choose(rule[:, [j for j in range(len(robots)) if j != k], pick])
                  if len(robots) > 1 else everyone for k in range(len(robots))]
        choice[name] = {
            "chosen_on": HALVES[pick], "scored_on": HALVES[score],
            "chosen": everyone,
            "held_out": [float(ratio[everyone, k, score]) for k in range(len(robots))],
            "chosen_without_robot": others,
            "held_out_without_robot": [float(ratio[others[k], k, score])
                                       for k in range(len(robots))],
        }
    return {"robots": robots, "seed": seed, "candidates": [
                {"label": c.label, "estimator": c.estimator, "settings": c.settings,
                 "in_rule": i < n_rule} for i, c in enumerate(cands)],
            "spans_s": {r: [s.start, s.mid, s.end] for r, s in spans.items()},
            "plain_ekf_m": plain, "reference_m": refs,
            "reference_run_m": {r: ref_run[r] for r in robots},
            "rmse_m": rmse.tolist(), "ratio": ratio.tolist(),
            "ratio_to_run_reference": (rmse / np.array([ref_run[r] for r in robots])[None, :,
                                                                                     None]
                                       ).tolist(),
            "choice": choice}


def _held(ratio: float) -> str:
    """A held-out ratio to three decimals, in bold when over the target."""
    text = f"{ratio:.3f}"
    return f"**{text}**" if ratio > TARGET_RATIO else text


def markdown(res: dict[str, Any]) -> str:
    """The tables of docs/mrclam.md from :func:`run`'s result."""
    robots = res["robots"]
    cands = res["candidates"]
    ratio = np.array(res["ratio"])
    whole = np.array(res["ratio_to_run_reference"])
    lines = ["Reference EKF per half (m): the published whole-run figure apportioned by the "
             "plain EKF (its RMSE on the half / on the run):", "",
             "| robot | span (s) | plain EKF run / A / B (m) | published run | reference A | "
             "reference B |", "|---|---:|---:|---:|---:|---:|"]
    for r in robots:
        s = res["spans_s"][r]
        p = res["plain_ekf_m"][r]
        lines.append(f"| Robot{r} | {s[2] - s[0]:.0f} (midpoint {s[1] - s[0]:.0f}) | "
                     f"{p['run']:.3f} / {p['A']:.3f} / {p['B']:.3f} | "
                     f"{res['reference_run_m'][r]:.3f} | {res['reference_m'][r]['A']:.3f} | "
                     f"{res['reference_m'][r]['B']:.3f} |")
    lines += ["", "The rule's choice and its ratio to the reference EKF on the held-out half "
              "(in brackets: to the unapportioned whole-run figure):", "",
              "| direction | robot | chosen on all five robots' choice halves | held-out ratio "
              "| chosen on the other four robots' choice halves | held-out ratio |",
              "|---|---|---|---:|---|---:|"]
    met = total = 0
    for name, ch in res["choice"].items():
        score = HALVES.index(ch["scored_on"])
        for k, r in enumerate(robots):
            c, o = ch["chosen"], ch["chosen_without_robot"][k]
            met += ch["held_out"][k] <= TARGET_RATIO
            total += 1
            lines.append(f"| {name} | Robot{r} | `{cands[c]['label']}` | "
                         f"{_held(ch['held_out'][k])} ({whole[c, k, score]:.2f}) | "
                         f"`{cands[o]['label']}` | {_held(ch['held_out_without_robot'][k])} "
                         f"({whole[o, k, score]:.2f}) |")
    met_o = sum(x <= TARGET_RATIO for ch in res["choice"].values()
                for x in ch["held_out_without_robot"])
    lines += ["", f"Held-out ratio <= {TARGET_RATIO}: {met} of {total} with the choice on all "
              f"robots' choice halves, {met_o} of {total} with the choice on the other robots' "
              "(over the target in bold).", "",
              "Every candidate on every half, ratio to the reference EKF on that half "
              "(A / B):", ""]
    head = ["candidate", *[f"Robot{r}" for r in robots], f"fit A ({FIT_WEIGHT_NOTE})",
            "fit B"]
    lines += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for c, cand in enumerate(cands):
        tag = "" if cand["in_rule"] else " (not in the rule)"
        fits = [max(ratio[c, :, h]) + 0.25 * float(np.mean(ratio[c, :, h])) for h in (0, 1)]
        lines.append(f"| `{cand['label']}`{tag} | " + " | ".join(
            f"{ratio[c, k, 0]:.2f} / {ratio[c, k, 1]:.2f}" for k in range(len(robots)))
            + f" | {fits[0]:.3f} | {fits[1]:.3f} |")
    return "\n".join(lines)


def with_change(cands: list[Candidate], change: dict[str, object]) -> list[Candidate]:
    """``cands`` with ``change`` (``{"est.key": value}``, from ``--set``) over the settings of
    every candidate of that estimator: a change of the estimator under all of them, not a
    candidate (the labels stay; :data:`PLAIN_EKF`, which apportions the reference, is no
    candidate and stays as it is)."""
    return [replace(c, settings={**c.settings, **{k: v for k, v in change.items()
                                                  if k.partition(".")[0] == c.estimator}})
            for c in cands]


def parse_extra(text: str) -> Candidate:
    """``LABEL=EST.KEY=V[,EST.KEY=V...]`` -> a candidate of estimator EST."""
    from lgvtool.config import parse_set_options

    label, _, rest = text.partition("=")
    settings = parse_set_options([s for s in rest.split(",") if s])
    adapt = {k.partition(".")[2]: float(str(v)) for k, v in settings.items()
             if k.startswith("adapt.")}
    from_camera = bool(settings.pop("camera.bearing", False))
    settings = {k: v for k, v in settings.items() if not k.startswith("adapt.")}
    names = {k.partition(".")[0] for k in settings} or {"ekf"}
    if not label or len(names) != 1 or (adapt and names != {"ekf"}):
        raise ValueError(f"--extra {text!r}: LABEL=EST.KEY=V[,EST.KEY=V...] of one estimator "
                         "(adapt.alpha=A[,adapt.range=1][,adapt.huber=C]: ekf with its camera "
                         "noise estimated online, frames down-weighted)")
    return Candidate(label, names.pop(), dict(settings), adapt or None, from_camera)


def main(argv: list[str] | None = None) -> int:
    """Run the rule; print the Markdown tables (or JSON)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("dataset", nargs="?", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs, reused between runs")
    ap.add_argument("--seed", type=int, default=0, help="seed of the estimators' draws")
    ap.add_argument("--extra", action="append", default=[],
                    help="LABEL=EST.KEY=V[,...]: a candidate scored beside the rule's, never "
                         "chosen (repeatable)")
    ap.add_argument("--prototypes", action="store_true",
                    help="add the variants measured after the rule (PROTOTYPES), never chosen")
    ap.add_argument("--only-extra", action="store_true",
                    help="score the --extra candidates and the rule's `ekf profile` only")
    ap.add_argument("--set", dest="change", action="append", default=[],
                    help="EST.KEY=V: a setting over every candidate of EST (a change of the "
                         "estimator under the rule, e.g. ekf.update_iterations=10; "
                         "repeatable)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    ap.add_argument("--json-out", type=Path, default=None,
                    help="also write the JSON result to this file")
    args = ap.parse_args(argv)
    from lgvtool.config import parse_set_options
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    dataset = args.dataset or default_dataset()
    try:
        available = MrclamDataset.open(dataset).robots
        extra = [parse_extra(e) for e in args.extra]
        change = parse_set_options(args.change)
    except (InputError, ValueError) as exc:
        print(f"mrclam_halves: {exc}", file=sys.stderr)
        return 2
    robots = [int(r) for r in args.robots.split(",") if r.strip() and int(r) in available]
    rule = list(CANDIDATES[:1]) if args.only_extra else list(CANDIDATES)
    if args.prototypes:
        extra = list(PROTOTYPES) + extra
    try:
        res = run(dataset, robots, args.cache, with_change(rule + extra, change), len(rule),
                  args.seed)
    except InputError as exc:
        print(f"mrclam_halves: {exc}", file=sys.stderr)
        return 2
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(res, indent=2))
    print(json.dumps(res, indent=2) if args.json else markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
