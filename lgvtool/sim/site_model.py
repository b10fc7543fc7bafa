"""The site as it really is: the one place the simulator keeps the true reflectors and floor.

The NAV and every consumer of the log use the *stored layout* (the configuration's reflectors);
the head measures the *true site*. :class:`Site` holds both sides of that difference:

- :class:`Landmarks`: every object the head can detect, one array per field: where it really
  stands (``x``, ``y``), where the stored layout puts it (``map_x``, ``map_y``: the survey error
  between them), its own constant range offset (``range_bias``: tape against cylinder, size
  tolerance, incidence), and whether it is a shiny object rather than a layout reflector
  (``is_false``). Later site mechanisms (moved, missing, weak and extra reflectors) belong here.
- :class:`Floor`: the floor's height field; a vehicle on its slope carries its head leaning
  and tilted (:mod:`lgvtool.sim.nav_model`, ``docs/simulator.md``).

True identities stay here: ``Landmarks.ids`` are the layout ids of the real reflectors and
:data:`FALSE_ID` for the shiny objects; no log and no estimator input carries them (the NAV
reports the ids of its own matches, :mod:`lgvtool.sim.nav_model`).

Random draws (the ``landmarks`` stream of :data:`lgvtool.sim.simulation.STREAMS`), always made
in this order and number whatever the settings: the survey error (2 per reflector), the floor
(:data:`FLOOR_WAVES` x 3 / 2), the range biases (1 per reflector, then 1 for a shiny object,
present or not), then 1 for each further object not in the layout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Area, Reflector
from lgvtool.errors import ConfigError
from lgvtool.sim.kinematics import FloatArray
from lgvtool.sim.settings import FaultSettings, SiteSettings

__all__ = ["FALSE_ID", "FLOOR_WAVES", "Floor", "Landmarks", "Site", "build_site"]

FALSE_ID = -2
"""The shiny object's identity inside the simulator: in no log (it has no layout id, so its
occlusions' /diagnostics give it -1, a log's "no id"), no id the device reports."""

FLOOR_WAVES = 16
"""Plane waves of the floor's height field (in pairs at right angles, one pair per
wavelength)."""


@dataclass(frozen=True)
class Landmarks:
    """Everything the head can detect, in one array per field (index = landmark).

    ``x``/``y`` are where the landmarks really are (m); ``map_x``/``map_y`` where the device's
    stored layout puts the reflectors (NaN for the shiny object); ``ids`` the true identity
    (layout id, or :data:`FALSE_ID`); ``range_bias`` the landmark's own constant range offset
    (m), added to every range the head measures to it.
    """

    ids: NDArray[np.int64]
    x: FloatArray
    y: FloatArray
    map_x: FloatArray
    map_y: FloatArray
    is_false: NDArray[np.bool_]
    range_bias: FloatArray
    detection: FloatArray
    """Each landmark's own detection probability per revolution: NaN for a layout reflector
    seen as ``nav.detection_probability`` says, 0 for a missing one, a weak one's own; an
    object not in the layout its own (at any range, noise on or off)."""

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Floor:
    """The floor's height field ``h(p) = sum_i amplitude_i cos(k_i . p + phase_i)`` (m), whose
    gradient is the slope the vehicle stands on (:func:`_floor` builds it: each slope
    component has the standard deviation ``tan(floor_tilt_deg)``, over the floor, and the
    field is isotropic). A zero amplitude everywhere: a level floor."""

    kx: FloatArray
    ky: FloatArray
    phase: FloatArray
    amplitude: FloatArray

    @property
    def level(self) -> bool:
        """True when the floor has no slope anywhere."""
        return not np.any(self.amplitude)

    def slope(self, x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The floor's gradient (dh/dx, dh/dy) at the points (x, y) m: the floor rises along
        it, by its length per metre."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        gx = np.zeros(x.shape)
        gy = np.zeros(x.shape)
        if self.level:
            return gx, gy
        for kx, ky, ph, a in zip(self.kx.tolist(), self.ky.tolist(), self.phase.tolist(),
                                 self.amplitude.tolist(), strict=True):
            s = a * np.sin(kx * x + ky * y + ph)
            gx -= kx * s
            gy -= ky * s
        return gx, gy


@dataclass(frozen=True)
class Site:
    """The true site of a run: its landmarks and its floor."""

    landmarks: Landmarks
    floor: Floor


def _wall_tangent(r: Reflector, area: Area) -> tuple[float, float]:
    """Unit vector along the wall nearest to reflector ``r`` (counter-clockwise round the hall)."""
    gaps = {
        (1.0, 0.0): r.y - area.y_min,   # south wall, run east
        (0.0, 1.0): area.x_max - r.x,   # east wall, run north
        (-1.0, 0.0): area.y_max - r.y,  # north wall, run west
        (0.0, -1.0): r.x - area.x_min,  # west wall, run south
    }
    return min(gaps, key=lambda k: gaps[k])


def _floor(site: SiteSettings, rng: np.random.Generator) -> Floor:
    """The floor's height field: :data:`FLOOR_WAVES` plane waves in pairs at right angles, one
    pair per wavelength from half to twice ``site.floor_wavelength_m`` (spaced evenly in log),
    each pair in a random direction, each wave with a random phase, and all with the same
    slope amplitude, so that each slope component's standard deviation is exactly
    ``tan(site.floor_tilt_deg)`` (a pair at right angles has the same variance along x and y,
    whatever its direction). Draws :data:`FLOOR_WAVES` / 2 directions, then
    :data:`FLOOR_WAVES` phases."""
    pairs = FLOOR_WAVES // 2
    direction = rng.random(pairs) * (math.pi / 2.0)
    phase = rng.random(FLOOR_WAVES) * (2.0 * math.pi)
    wavelength = site.floor_wavelength_m * 2.0 ** ((2.0 * np.arange(pairs) - (pairs - 1))
                                                   / (pairs - 1))
    k = np.repeat(2.0 * math.pi / wavelength, 2)
    theta = np.repeat(direction, 2) + np.tile([0.0, math.pi / 2.0], pairs)
    # wave i: h_i = a_i cos(k_i . p + phase_i) with a_i k_i = c; a pair adds c^2 / 2 to the
    # variance of each slope component: sigma^2 = pairs c^2 / 2
    sigma = math.tan(math.radians(site.floor_tilt_deg))
    c = sigma * math.sqrt(2.0 / pairs)
    return Floor(kx=k * np.cos(theta), ky=k * np.sin(theta), phase=phase, amplitude=c / k)


def _layout_index(reflectors: Sequence[Reflector], rid: int, key: str) -> int:
    """The index in the layout of reflector ``rid``; ConfigError naming ``key`` otherwise."""
    for i, r in enumerate(reflectors):
        if r.id == rid:
            return i
    raise ConfigError(f"{key} names reflector {rid}, which is not in the layout "
                      f"({len(reflectors)} reflectors)")


def build_site(reflectors: Sequence[Reflector], area: Area, site: SiteSettings,
               faults: FaultSettings, rng: np.random.Generator) -> Site:
    """The true site of a run.

    The reflectors really stand at their layout position plus a survey error of
    ``site.survey_sigma_mm`` per axis (drawn even when zero, so other draws do not shift),
    each with its own range offset of ``site.range_bias_sigma_mm`` (a normal draw per
    reflector, constant over the run). The site faults: a ``site.moved`` reflector stands at
    its layout position plus (dx, dy) instead; a ``site.missing`` one is never detected
    (``detection`` 0); a ``site.weak`` one has its own ``detection``. The objects not in the
    layout follow the reflectors: first, with ``faults.false_reflector`` (the older form), a
    shiny object at (false_x, false_y), or, when those are NaN, ``false_offset`` m along the
    wall from reflector ``false_near_id``, then each ``site.extra`` object; each has a range
    offset of its own too (the first the draw made for it before these faults existed, the
    others drawn after it).

    :raises ConfigError: (exit 2) for a site fault naming a reflector not in the layout.
    """
    n = len(reflectors)
    ids = np.array([r.id for r in reflectors], dtype=np.int64)
    mx = np.array([r.x for r in reflectors], dtype=np.float64)
    my = np.array([r.y for r in reflectors], dtype=np.float64)
    survey = rng.standard_normal((2, n)) * (site.survey_sigma_mm * 1e-3)
    floor = _floor(site, rng)
    bias = rng.standard_normal(n + 1) * (site.range_bias_sigma_mm * 1e-3)
    x, y = mx + survey[0], my + survey[1]
    detection = np.full(n, np.nan)
    for m in site.moved:
        i = _layout_index(reflectors, m.id, "site.moved")
        x[i], y[i] = mx[i] + m.dx, my[i] + m.dy
    for w in site.weak:
        detection[_layout_index(reflectors, w.id, "site.weak")] = w.detection
    for rid in site.missing:
        detection[_layout_index(reflectors, rid, "site.missing")] = 0.0
    objects: list[tuple[float, float, float]] = []
    if faults.false_reflector:
        if math.isfinite(faults.false_x) and math.isfinite(faults.false_y):
            fx, fy = faults.false_x, faults.false_y
        else:
            near = [r for r in reflectors if r.id == faults.false_near_id]
            if not near:
                raise ConfigError(f"faults.false_near_id {faults.false_near_id} is not a "
                                  "reflector of the map")
            ux, uy = _wall_tangent(near[0], area)
            fx = near[0].x + faults.false_offset * ux
            fy = near[0].y + faults.false_offset * uy
        objects.append((fx, fy, faults.false_detection_probability))
    objects.extend((e.x, e.y, e.detection) for e in site.extra)
    range_bias = bias[:n]
    if objects:
        more = rng.standard_normal(len(objects) - 1) * (site.range_bias_sigma_mm * 1e-3)
        range_bias = np.concatenate([bias, more])
    k = len(objects)
    ox, oy, od = (np.array([o[i] for o in objects], dtype=np.float64) for i in range(3))
    marks = Landmarks(ids=np.append(ids, np.full(k, FALSE_ID)), x=np.append(x, ox),
                      y=np.append(y, oy), map_x=np.append(mx, np.full(k, np.nan)),
                      map_y=np.append(my, np.full(k, np.nan)),
                      is_false=np.append(np.zeros(n, dtype=bool), np.ones(k, dtype=bool)),
                      range_bias=range_bias, detection=np.append(detection, od))
    return Site(landmarks=marks, floor=floor)
