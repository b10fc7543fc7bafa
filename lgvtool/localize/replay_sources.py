"""What ``replay`` adds to a log, as sources encoded a window at a time
(:mod:`lgvtool.log.windows`): per estimator its poses, states and particle clouds, the
Foxglove view channels (:mod:`lgvtool.log.view_channels`) and the NAV poses the plausibility gate left
out (/diagnostics and its foxglove.Log mirror). Sources are in the order in which messages at
one log time are written. Times in integer ns since the Unix epoch.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, cast

from lgvtool.log.windows import Source, source

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.config import Config
    from lgvtool.json_types import JSONObject
    from lgvtool.localize.replay_driver import ReplayResult
    from lgvtool.log.reader import LogReader
    from lgvtool.log.view_channels import EstimateTable, LogRows
    from lgvtool.trajectory import Trajectory

    #: a kept particle cloud: log time (ns since the epoch), x (m), y (m), heading (rad)
    Cloud = tuple[int, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


def _estimate_sources(name: str, tab: Trajectory) -> tuple[Source, Source]:
    import numpy as np

    from lgvtool.log import foxglove as fx
    from lgvtool.log import topics

    t = np.asarray(tab.t_ns, dtype=np.int64)
    x, y, h = (np.asarray(v, dtype=np.float64) for v in (tab.x, tab.y, tab.heading))
    cov = np.asarray(tab.covariance, dtype=np.float64).reshape(len(t), 9)
    particles = np.asarray(tab.particles, dtype=np.int64)
    ess = np.asarray(tab.ess, dtype=np.float64)

    def pose(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        return t[idx].tolist(), fx.pose_in_frame_many(t[idx], x[idx], y[idx], h[idx])

    def state(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        return t[idx].tolist(), fx.pose_estimate_many(name, t[idx], x[idx], y[idx], h[idx],
                                                      cov[idx], particles[idx], ess[idx])

    return (source(topics.estimate_pose(name), t, pose),
            source(topics.estimate_state(name), t, state))


def _cloud_source(name: str, clouds: list[Cloud]) -> Source:
    from lgvtool.log import foxglove as fx
    from lgvtool.log import topics

    def encode(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        chosen = [clouds[i] for i in idx.tolist()]
        return [int(c[0]) for c in chosen], fx.poses_in_frame_many(chosen)

    return source(topics.estimate_particles(name), [c[0] for c in clouds], encode)


GATE_EVENT = "pose_implausible"
"""The ``kind`` of the event a NAV pose the plausibility gate left out becomes."""

#: an event of a replay: (log time ns, source, kind, text)
_Event = tuple[int, str, str, str]


def replay_events(reader: LogReader, result: ReplayResult) -> list[_Event]:
    """The events a replay ``result`` adds to the log of ``reader``, in time order: the NAV
    poses the gate left out (source ``nav200``, kind ``pose_implausible``) and what each
    estimator did that its rows do not tell (source its name: ``restarted``, ``reanchored``),
    less those the log holds already (a replayed log replayed again)."""
    from lgvtool.log import topics

    events: list[_Event] = [(t, "nav200", GATE_EVENT, text) for t, text in result.gated]
    events += [(t, name, kind, text) for name, rows in result.events.items()
               for t, kind, text in rows]
    if events and reader.has_topic(topics.DIAGNOSTICS):
        held = {(m.log_time_ns, m.data.get("source"), m.data.get("kind"), m.data.get("message"))
                for m in reader.messages([topics.DIAGNOSTICS])}
        events = [e for e in events if e not in held]
    return sorted(events)


def _event_sources(events: list[_Event]) -> list[Source]:
    import orjson

    from lgvtool.log import messages, topics

    def diags(idx: NDArray[np.intp]) -> list[JSONObject]:
        return [messages.diagnostic_message(events[i][0], events[i][1], events[i][2],
                                            events[i][3], level=3) for i in idx.tolist()]

    def diagnostics(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        return [events[i][0] for i in idx.tolist()], [orjson.dumps(d) for d in diags(idx)]

    def mirror(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        return ([events[i][0] for i in idx.tolist()],
                [orjson.dumps(messages.log_message_of(d)) for d in diags(idx)])

    t = [e[0] for e in events]
    return [source(topics.DIAGNOSTICS, t, diagnostics),
            source(topics.DIAGNOSTICS_LOG, t, mirror)]


def replay_sources(reader: LogReader, result: ReplayResult, view_config: Config | None = None,
                   rows: LogRows | None = None) -> list[Source]:
    """The sources of a replay ``result`` (lgvtool.localize.replay_driver.ReplayResult) of the log of
    ``reader``: estimates, then (with ``view_config``, the configuration the view is drawn
    with) the view channels, then the replay's events (:func:`replay_events`). ``rows``: the
    log's rows the view draws, already gathered (:class:`lgvtool.log.view_channels.LogRows`;
    else the view reads them)."""
    from lgvtool.log.view_channels import view_streams

    pairs = [_estimate_sources(name, tab) for name, tab in result.estimates.items()]
    out = [p[0] for p in pairs] + [p[1] for p in pairs]
    out += [_cloud_source(name, clouds) for name, clouds in result.clouds.items()]
    if view_config is not None:
        tables = result.estimates
        if any(tab.covariance is None for tab in tables.values()):
            raise ValueError("a replay's estimates carry their covariances")
        # every estimate has its covariance: each is an EstimateTable
        out += view_streams(reader, view_config, cast("Mapping[str, EstimateTable]", tables),
                            rows)
    events = replay_events(reader, result)
    if events:
        out += _event_sources(events)
    return out
