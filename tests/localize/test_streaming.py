"""The streaming pieces of the replay: compressed scan storage, observation streams, block-wise
motions and preparations give exactly what the whole-log construction gives."""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import orjson
import pytest
from simlogs import simulate_log

from lgvtool.localize import obsstream
from lgvtool.localize import replay_driver as R
from lgvtool.localize.logdata import LazyScans, LogData, load_log, scan_batch
from lgvtool.localize.motion import Increments, MotionSettings, MotionTrack
from lgvtool.localize.observations import scan_observations
from lgvtool.localize.packed import PackedBytes
from lgvtool.log import LogReader
from lgvtool.log.reader import RawBlock


def _packed(rng: np.random.Generator, longest: int) -> tuple[list[bytes], PackedBytes]:
    """900 random byte strings of up to ``longest`` bytes, and a store of them added 37 at a
    time."""
    items = [rng.bytes(int(n)) for n in rng.integers(0, longest, 900)]
    p = PackedBytes()
    for a in range(0, len(items), 37):
        p.append_block(items[a:a + 37])
    return items, p


def test_packed_bytes_round_trip_and_reorder() -> None:
    rng = np.random.default_rng(3)
    items, p = _packed(rng, 3000)
    assert len(p) == len(items)
    assert p.stored_bytes > 0
    idx = rng.permutation(len(items)).tolist()
    assert p.take(idx) == [items[i] for i in idx]
    order = np.argsort(rng.random(len(items)))
    p.reorder(order)
    assert p.take(range(len(items))) == [items[i] for i in order.tolist()]
    with pytest.raises(ValueError):
        p.append_block([b"x"])


def test_packed_bytes_consumed_in_order_free_their_blocks_as_they_go() -> None:
    rng = np.random.default_rng(4)
    items, p = _packed(rng, 6000)
    stored = p.stored_bytes
    lists = p.consume()
    first = next(lists)
    assert p.stored_bytes < stored  # the first block is freed once handed out
    assert first + [x for part in lists for x in part] == items
    assert len(p) == 0 and p.stored_bytes == 0
    q = PackedBytes()
    q.append_block(items)
    order = np.argsort(rng.random(len(items)))
    q.reorder(order)
    assert [x for part in q.consume() for x in part] == [items[i] for i in order.tolist()]
    assert len(q) == 0


def test_blockwise_motions_equal_the_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.05, 0.15, 300))
    track = MotionTrack(Increments(t, rng.normal(0, 0.01, 299), rng.normal(0, 0.01, 299)))
    q = np.sort(rng.uniform(0, t[-1], 101))
    monkeypatch.setattr(R, "_DELTA_BLOCK", 7)
    a, b = R._deltas(track, q), track.deltas(q[:-1], q[1:])
    for f in ("dx", "dy", "dth", "dist", "rot"):
        assert np.array_equal(getattr(a, f), getattr(b, f))


@pytest.fixture(scope="module")
def run_log(tmp_path_factory: pytest.TempPathFactory):
    return simulate_log(tmp_path_factory.mktemp("stream") / "run.mcap", 90, 6)


def _reader(log) -> LogReader:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return LogReader(log)


@pytest.fixture(scope="module")
def data(run_log):
    reader = _reader(run_log)
    cfg = reader.config()
    return cfg, load_log(reader, cfg.reflectors or None)


@pytest.mark.parametrize("deskew", [False, True])
def test_observation_stream_equals_the_sorted_list(data, deskew: bool,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    cfg, d = data
    monkeypatch.setattr(obsstream, "BLOCK_SCANS", 16)
    monkeypatch.setattr(obsstream, "KEEP_SCANS", 32)
    ms = MotionSettings()
    track = MotionTrack(d.increments(ms, cfg.vehicle), ms.step_form)
    poses = R._pose_observations(d, R.ESTIMATORS["ekf"], R.resolve_params("ekf", {}, None))
    v = cfg.vehicle
    stream = R._stream(d.scans, list(poses), None, v, track, deskew, 0.0, float("inf"))
    whole = list(poses) + scan_observations(scan_batch(d.scans), v.nav_x, v.nav_y, track=track,
                                            deskew=deskew)
    whole.sort(key=lambda o: o.t)
    assert len(stream) == len(whole) > 100
    assert np.array_equal(stream.times, [o.t for o in whole])
    for got, want in zip(stream, whole, strict=True):
        assert type(got) is type(want) and got.t == want.t
        if hasattr(want, "q"):
            assert np.array_equal(got.q, want.q) and np.array_equal(got.ids, want.ids)
    # random access after the blocks were dropped gives the same again
    k = len(whole) // 3
    assert stream[k].t == whole[k].t


def test_blockwise_map_equals_one_call() -> None:
    obs = list(range(50))

    def prepare(part: Sequence[int]) -> dict[int, int]:
        return {i: 10 * v for i, v in enumerate(part) if v % 3}

    m = obsstream.BlockwiseMap(prepare, obs, block=8)
    whole = prepare(obs)
    assert [m.get(i) for i in range(50)] == [whole.get(i) for i in range(50)]


def test_scan_start_times_are_decoded_from_the_store() -> None:
    from lgvtool.localize.logdata import LazyScans

    raw = [b'{"timestamp":{"sec":%d,"nsec":0},"scan_period":0.125,"observations":'
           b'[{"range":1.0,"bearing":0.1,"time_in_scan":0.01,"id":3}]}' % (1_704_067_200 + i)
           for i in range(10)]
    packed = PackedBytes()
    packed.append_block(raw)
    scans = LazyScans(1_704_067_200 * 10**9, np.arange(10) * 10**9, packed)
    start, period = scans.start_and_period([9, 0, 4])
    assert start.tolist() == pytest.approx([9.0, 0.0, 4.0], abs=1e-9)
    assert period.tolist() == pytest.approx([0.125] * 3, abs=1e-12)


def test_scans_are_decoded_once_and_any_selection_gathers_its_own_reflectors() -> None:
    from lgvtool.localize.installation import correct_scans
    from lgvtool.localize.logdata import LazyScans

    rng = np.random.default_rng(5)
    counts = rng.integers(0, 5, 40)
    raw, want = [], []
    for i, k in enumerate(counts.tolist()):
        obs = [{"range": float(rng.uniform(1, 20)), "bearing": float(rng.uniform(-3, 3)),
                "time_in_scan": 0.001 * j, "id": int(rng.integers(-1, 30))} for j in range(k)]
        raw.append(orjson.dumps({"timestamp": {"sec": 1_704_067_200 + i, "nsec": 0},
                                 "scan_period": 0.125, "observations": obs}))
        want.append(obs)
    packed = PackedBytes()
    packed.append_block(raw)
    scans = LazyScans(1_704_067_200 * 10**9, np.arange(40) * 10**9, packed)
    pick = [39, 0, 7, 7, -1, 12, 3]
    b = scans.batch(pick)
    assert b.counts.tolist() == [int(counts[i]) for i in pick]
    flat = [o for i in pick for o in want[i]]
    assert b.ranges.tolist() == [o["range"] for o in flat]
    assert b.bearings.tolist() == [o["bearing"] for o in flat]
    assert b.ids.tolist() == [o["id"] for o in flat]
    assert b.t.tolist() == pytest.approx([float(i % 40) for i in pick], abs=1e-9)
    assert scans._raw is None  # decoded once: the bytes are freed
    whole = scans.batch()
    assert not whole.ranges.flags.writeable  # shared between the estimators: read-only
    assert scans.batch([]).ranges.size == 0
    with pytest.raises(IndexError):
        scans.batch([40])
    turned = correct_scans(scans, 0.5, 0.25)
    c = scan_batch(turned, pick)
    assert c.bearings.tolist() == [o["bearing"] + 0.25 for o in flat]
    assert c.t.tolist() == pytest.approx([float(i % 40) - 0.5 for i in pick], abs=1e-9)


def test_reflector_ids_looked_up_in_a_table_as_by_search() -> None:
    """A map of compact ids looks them up in a table: the same index (-1 unknown) as the
    sorted search for ids inside, beside and far outside the map's range; a repeated id is
    its last reflector."""
    from lgvtool.config import Reflector
    from lgvtool.localize.observations import ReflectorMap

    probe = np.array([-2 ** 63, 2 ** 63 - 1, -(2 ** 31) - 1, 2 ** 31 + 1, -6, -5, -1, 0, 1, 2,
                      3, 4, 5, 6, 7, 8, 39, 40, 41, 10 ** 9, 10 ** 9 + 1, 10 ** 9 + 3],
                     dtype=np.int64)
    for ids in ([1, 2, 3, 7, 7, 40], [-5, 0, 3], [10 ** 9, 10 ** 9 + 3], [5]):
        rmap = ReflectorMap([Reflector(i, float(k), 0.0) for k, i in enumerate(ids)])
        assert rmap._table is not None
        got = rmap.index_of(probe)
        rmap._table = None  # the search
        want = rmap.index_of(probe)
        np.testing.assert_array_equal(got, want)
        assert got.dtype == np.int64 and (got >= 0).sum() == len(set(ids))
    assert ReflectorMap([Reflector(0, 0.0, 0.0), Reflector(1, 1.0, 0.0),
                         Reflector(1, 2.0, 0.0)]).index_of(np.array([1, 0, 2])).tolist() == \
        [2, 0, -1]
    wide = ReflectorMap([Reflector(0, 0.0, 0.0), Reflector(10 ** 6, 1.0, 0.0)])
    assert wide._table is None and wide.index_of(np.array([10 ** 6, 5])).tolist() == [1, -1]


class _Tap:
    """A tap that keeps what it is handed."""

    def __init__(self, topics: list[str]) -> None:
        self.topics = topics
        self.seen: dict[str, list[int]] = {}

    def add(self, block: RawBlock) -> None:
        for topic, (ns, raw) in block.items():
            assert len(ns) == len(raw)
            self.seen.setdefault(topic, []).extend(ns.tolist())


def test_a_tap_sees_every_message_of_its_topics_and_changes_nothing(data, run_log) -> None:
    """load_log hands a tap every chunk's messages of its topics (and of load_log's own) in
    stored order, and reads the same data with or without one: a tap on the truth moves no
    clock."""
    from lgvtool.log import topics as T

    cfg, plain = data
    reader = _reader(run_log)
    tap = _Tap([T.TRUTH, T.DIAGNOSTICS])
    tapped = load_log(reader, cfg.reflectors or None, tap=tap)
    for topic in (T.TRUTH, T.MCU_FRAME, T.NAV_REFLECTORS):
        want = [m.log_time_ns for m in reader.raw_messages([topic])]
        assert sorted(tap.seen[topic]) == want and len(want) > 100
    assert tapped.t0_ns == plain.t0_ns and tapped.truth is None
    for name in ("mcu", "nav"):
        a, b = getattr(plain, name), getattr(tapped, name)
        assert a.keys() == b.keys()
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])
    with_truth = load_log(reader, cfg.reflectors or None, truth=True)
    assert with_truth.t0_ns == plain.t0_ns
    np.testing.assert_array_equal(with_truth.mcu["t"], plain.mcu["t"])


def _lazy(d: LogData) -> LazyScans:
    """The scans of ``d`` as load_log keeps them."""
    assert isinstance(d.scans, LazyScans)
    return d.scans


def _same_scans(a: LogData, b: LogData) -> None:
    """Two LogData's scans hold the same arrays (receive times, batch, start times)."""
    p, q = _lazy(a), _lazy(b)
    np.testing.assert_array_equal(p.received_ns, q.received_ns)
    np.testing.assert_array_equal(p.received, q.received)
    x, y = p.batch(), q.batch()
    for f in ("t", "period", "counts", "ranges", "bearings", "times", "ids"):
        u, v = getattr(x, f), getattr(y, f)
        assert u.dtype == v.dtype and not v.flags.writeable, f
        np.testing.assert_array_equal(u, v, err_msg=f)
    for u, v in zip(p.decoded_columns() or (), q.decoded_columns() or (), strict=True):
        np.testing.assert_array_equal(u, v)


def test_scans_decoded_as_they_are_read_equal_those_decoded_later(data, run_log,
                                                                  tmp_path) -> None:
    """``decode_scans``: the scans decoded chunk by chunk in the reading are the arrays the
    lazy store decodes later (none compressed on the way), also for scans stored out of log
    time order (put in order as the store reorders them), and the other topics are read as
    before."""
    from lgvtool.log import LogWriter
    from lgvtool.log import topics as T

    cfg, lazy = data
    reader = _reader(run_log)
    eager = load_log(reader, cfg.reflectors or None, decode_scans=True)
    assert _lazy(eager)._raw is None and _lazy(eager)._all is not None  # decoded in the read
    _lazy(lazy).decoded()
    _same_scans(lazy, eager)
    assert eager.t0_ns == lazy.t0_ns
    for k in lazy.mcu:
        np.testing.assert_array_equal(lazy.mcu[k], eager.mcu[k])
    # the same scans stored with neighbours swapped in time (log times out of order), the
    # motion and map as they are: every 7th scan and its next exchange log times
    msgs = list(reader.raw_messages([T.NAV_REFLECTORS, T.MCU_FRAME, T.MAP]))
    scans = [k for k, m in enumerate(msgs) if m.topic == T.NAV_REFLECTORS]
    times = [m.log_time_ns for m in msgs]
    for a, b in zip(scans[::7], scans[1::7], strict=False):
        times[a], times[b] = times[b], times[a]
    shuffled = tmp_path / "shuffled.mcap"
    with LogWriter(shuffled, source="test") as w:
        w.add_metadata("config", cfg.to_dict())
        w.write_encoded_many([m.topic for m in msgs], [m.data for m in msgs], times)
    r = _reader(shuffled)
    later = load_log(r, cfg.reflectors or None)
    now = load_log(r, cfg.reflectors or None, decode_scans=True)
    assert _lazy(later)._raw is not None and _lazy(now)._raw is None
    assert np.all(np.diff(_lazy(now).received_ns) >= 0)
    assert not np.array_equal(_lazy(now).batch().ranges[:200],
                              _lazy(eager).batch().ranges[:200])
    _same_scans(later, now)
    # without a map to match them against, the scans are left for later
    assert _lazy(load_log(r, (), decode_scans=True))._raw is not None


@pytest.mark.parametrize("budget", [1, 5_000, 10**9])
def test_the_decoding_block_does_not_change_what_is_read(data, run_log, budget: int,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """Messages decoded one at a time, a few at a time or all of a topic's gathered block at
    once (``_DECODE_BYTES``) give the same arrays, scans and the other topics alike."""
    from lgvtool.localize import logdata

    cfg = data[0]
    default = load_log(_reader(run_log), cfg.reflectors or None, decode_scans=True)
    monkeypatch.setattr(logdata, "_DECODE_BYTES", budget)
    blocks = load_log(_reader(run_log), cfg.reflectors or None, decode_scans=True)
    _same_scans(default, blocks)
    assert default.t0_ns == blocks.t0_ns
    for part in ("mcu", "nav"):
        a, b = getattr(default, part), getattr(blocks, part)
        assert a.keys() == b.keys()
        for k in a:
            np.testing.assert_array_equal(a[k], b[k])


def test_a_scan_that_breaks_the_contract_is_one_error_naming_its_topic(data, run_log,
                                                                       tmp_path) -> None:
    """Decoded as it is read, a scan whose observations are not a list is one LogFormatError
    naming the log and /nav/reflectors; left for later, the same scan fails when decoded."""
    from lgvtool.errors import LogFormatError
    from lgvtool.log import LogWriter
    from lgvtool.log import topics as T

    cfg, _ = data
    msgs = list(_reader(run_log).raw_messages([T.NAV_REFLECTORS, T.MCU_FRAME]))
    bad = [k for k, m in enumerate(msgs) if m.topic == T.NAV_REFLECTORS][30]
    path = tmp_path / "bad-scan.mcap"
    with LogWriter(path, source="test") as w:
        w.write_encoded_many([m.topic for m in msgs],
                             [b'{"observations":"x"}' if k == bad else m.data
                              for k, m in enumerate(msgs)], [m.log_time_ns for m in msgs])
    r = _reader(path)
    with pytest.raises(LogFormatError, match=r"bad-scan\.mcap: topic /nav/reflectors: .*"
                                             r"TypeError"):
        load_log(r, cfg.reflectors, decode_scans=True)
    later = load_log(r, cfg.reflectors)
    with pytest.raises(LogFormatError, match=r"bad-scan\.mcap: .*TypeError"):
        _lazy(later).decoded()
