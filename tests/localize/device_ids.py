"""Reflector ids as a navigation device may report them, made from a log's scans in memory: none
at all (a NAV200, or a device that matched nothing), or a fraction of them wrong (a device that
matched the wrong layout reflector)."""

from __future__ import annotations

from dataclasses import replace
from itertools import pairwise

import numpy as np

from lgvtool.config import Reflector
from lgvtool.localize.logdata import scan_batch
from lgvtool.localize.observations import RawScan
from lgvtool.localize.replay_driver import LogData


def wrong_ids(ids: np.ndarray, reflectors: tuple[Reflector, ...], fraction: float,
              rng: np.random.Generator) -> np.ndarray:
    """``ids`` with about ``fraction`` of those in the layout replaced by another layout
    reflector's: half of them the one nearest the true reflector (the confusion of a device
    between two reflectors), half one drawn uniformly from the others."""
    lay = {r.id: complex(r.x, r.y) for r in reflectors}
    lid = np.array(sorted(lay), dtype=np.int64)
    lz = np.array([lay[int(i)] for i in lid])
    out = np.array(ids, dtype=np.int64).copy()
    for k in np.nonzero(np.isin(out, lid))[0].tolist():
        if rng.random() >= fraction:
            continue
        true = int(out[k])
        if rng.random() < 0.5:
            d = np.abs(lz - lay[true])
            d[lid == true] = np.inf
            out[k] = lid[int(np.argmin(d))]
        else:
            out[k] = int(rng.choice(lid[lid != true]))
    return out


def with_ids(data: LogData, mode: str, *, fraction: float = 0.2, seed: int = 0) -> LogData:
    """``data`` with its scans' ids as ``mode`` says: ``none`` (every id -1) or ``wrong``
    (``fraction`` of them wrong, :func:`wrong_ids`, drawn with ``seed``)."""
    b = scan_batch(data.scans)
    ids = np.array(b.ids, dtype=np.int64)
    if mode == "none":
        ids = np.full(len(ids), -1, dtype=np.int64)
    elif mode == "wrong":
        ids = wrong_ids(ids, data.reflectors, fraction, np.random.default_rng(seed))
    else:
        raise ValueError(mode)
    offs = np.concatenate(([0], np.cumsum(b.counts))).tolist()
    scans = [RawScan(float(b.t[i]), float(b.period[i]), b.ranges[a:e], b.bearings[a:e],
                     b.times[a:e], ids[a:e])
             for i, (a, e) in enumerate(pairwise(offs))]
    return replace(data, scans=scans)
