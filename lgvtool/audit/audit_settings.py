"""The thresholds of the reflector audit (``lgvtool audit --set audit.<key>=<value>``), each
declared once with its unit, range and reason (docs/audit.md explains each one)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from lgvtool.declared import make, setting

__all__ = ["AuditSettings", "audit_settings"]


@dataclass(frozen=True)
class AuditSettings:
    """What the audit calls ``missing``, ``weak``, ``moved``, ``ambiguous`` and ``unmapped``."""

    match_tolerance_m: float = setting(
        0.4,
        "A sighting belongs to a layout reflector when the audit's placement of it (the replayed "
        "pose, the measured range and bearing) lies within this distance of it, m; two layout "
        "reflectors closer than this are ambiguous (the NAV350 matches within a window of this "
        "order: the simulator's nav.gate).",
        unit="m", minimum=0.0, min_open=True, maximum=5.0)
    ambiguity_ratio: float = setting(
        1.5,
        "A sighting without a device id whose second-nearest layout reflector is within this "
        "ratio of the nearest's distance (both inside the tolerance) is left unassigned "
        "(lgvtool.localize.association).",
        unit="", minimum=1.0, maximum=10.0)
    max_pose_sigma_m: float = setting(
        0.1,
        "Revolutions are judged only where the replayed pose's position 1-sigma (its "
        "covariance) is within this, m: a filter still settling says nothing of the layout.",
        unit="m", minimum=0.0, min_open=True)
    min_chances: int = setting(
        40,
        "Fewest expected sightings (revolutions with the reflector in range, in view and not "
        "hidden) before a reflector can be called missing or weak: 5 s of a NAV350's 8 Hz.",
        unit="", minimum=1, maximum=10**9)
    missing_max_share: float = setting(
        0.05,
        "Missing: seen on at most this share of the sightings the other reflectors' detection "
        "rate at the same ranges predicts ('never or almost never').",
        unit="", minimum=0.0, maximum=1.0)
    weak_max_share: float = setting(
        0.6,
        "Weak: seen on at most this share of the sightings the other reflectors' detection rate "
        "at the same ranges predicts.",
        unit="", minimum=0.0, maximum=1.0)
    weak_sigmas: float = setting(
        4.0,
        "Weak also needs the shortfall of sightings to be this many standard deviations (of a "
        "Poisson count) below the prediction, so that a short drive flags nothing by chance.",
        unit="", minimum=0.0)
    moved_min_shift_m: float = setting(
        0.035,
        "Moved: the reflector's shift (the mean offset of its sightings) is at least this "
        "long, m (3.5 times a good survey's 10 mm per axis: a correctly surveyed reflector is "
        "that far off once in about 450, and a smaller offset cannot be told from the survey's "
        "own error).",
        unit="m", minimum=0.0)
    moved_sigmas: float = setting(
        4.0,
        "Moved also needs the shift to be this many of its own standard deviations from zero "
        "(each axis over its 1-sigma, in quadrature).",
        unit="", minimum=0.0)
    offset_outlier_m: float = setting(
        0.1,
        "A sighting whose offset lies farther than this from the median of the reflector's "
        "offsets in its log is left out of the shift, m (about five times the scatter of one "
        "sighting's offset): it is something else inside the matching tolerance, a reflective "
        "object beside the reflector taken for it when the reflector itself was missed.",
        unit="m", minimum=0.0, min_open=True)
    shift_floor_m: float = setting(
        0.005,
        "Added in quadrature to each axis of a reflector's offset sigma, m: its own range "
        "offset (tape against cylinder, diameter, incidence: a few mm) moves its sightings as a "
        "shift would, however long the drive.",
        unit="m", minimum=0.0)
    min_fit_reflectors: int = setting(
        4,
        "A sighting gives an offset only when its revolution matched at least this many "
        "reflectors: the head pose is refitted to the others (three at least) and the sighting "
        "compared with that fit, so that a moved reflector does not pull the pose it is judged "
        "by.",
        unit="", minimum=4, maximum=64)
    block_s: float = setting(
        10.0,
        "Sightings are averaged in blocks of this much log time, s, and the offset's standard "
        "deviation is that of the block means: sightings a few revolutions apart share their "
        "pose error and are not independent.",
        unit="s", minimum=0.1)
    range_bin_m: float = setting(
        2.0,
        "Width of the range bins in which reflectors' detection rates are compared, m (the "
        "detection rate falls with range).",
        unit="m", minimum=0.1)
    unmapped_radius_m: float = setting(
        0.25,
        "Detections that match no layout reflector are clustered on a grid of this cell size, "
        "m (neighbouring cells join).",
        unit="m", minimum=0.01, maximum=5.0)
    unmapped_min_sightings: int = setting(
        20,
        "Fewest detections of a cluster before it is listed as unmapped (recurring, not a "
        "passing reflection).",
        unit="", minimum=1, maximum=10**9)


def audit_settings(overrides: Mapping[str, object] | None = None) -> AuditSettings:
    """The audit's thresholds with ``overrides`` (``{key: value}``, each checked by its
    declaration) applied over the defaults.

    :raises ConfigError: (exit 2) an unknown key or a bad value.
    """
    return make(AuditSettings, "audit", dict(overrides or {}), what="setting",
                more="{n} settings of audit; docs/audit.md lists them")
