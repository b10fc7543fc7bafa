"""Several topics' tables in one pass (``LogReader.dataframes``): the same tables as each topic
read on its own in log-time order, a tap handed every chunk of its topics in that pass, and a
pose topic stored out of log-time order read again in order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from lgvtool.log import LogReader, topics
from lgvtool.log.foxglove import pose_in_frame_many
from lgvtool.log.frames import TopicTables, to_dataframe
from lgvtool.log.reader import LogWarning, RawBlock

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "degraded.mcap"
T0 = 1_704_067_200_000_000_000
A, B = topics.estimate_pose("a"), topics.estimate_pose("b")


class _Counting:
    """A tap that counts the messages it is handed per topic."""

    def __init__(self, wanted: list[str]) -> None:
        self.topics = wanted
        self.seen: dict[str, int] = dict.fromkeys(wanted, 0)

    def add(self, block: RawBlock) -> None:
        for topic, (t, data) in block.items():
            if topic in self.seen:
                assert len(t) == len(data)
                self.seen[topic] += len(data)


def _alone(reader: LogReader, topic: str) -> pd.DataFrame:
    """The table of ``topic`` from its messages merged in log-time order."""
    schema = reader.topics()[topic].schema
    return to_dataframe(schema, reader.messages([topic]))


def test_topics_in_one_pass_with_a_tap_and_the_same_tables(
        chunk_passes: list[list[str]]) -> None:
    reader = LogReader(SAMPLE)
    tap = _Counting([topics.DIAGNOSTICS, topics.NAV_POSE])
    wanted = [topics.TRUTH, topics.MCU_FRAME, topics.NAV_REFLECTORS, topics.MCU_RX]
    tables = reader.dataframes(wanted, tap=tap)
    # a pose topic, another schema and the tap's topics: one pass
    assert chunk_passes == [sorted([*wanted, *tap.topics])]
    infos = reader.topics()
    assert tap.seen == {t: infos[t].count for t in tap.topics} and all(tap.seen.values())
    for topic in wanted:
        pd.testing.assert_frame_equal(tables[topic], _alone(reader, topic))
        pd.testing.assert_frame_equal(reader.dataframe(topic), tables[topic])
    assert len(tables[topics.TRUTH]) == infos[topics.TRUTH].count > 100


def test_a_pose_topic_stored_out_of_order_is_read_again_in_order(tmp_path: Path) -> None:
    """Estimator b's poses go back in time inside a chunk: their table is the log-time-ordered
    one; a's, in order, come from the single pass."""
    from mcap.writer import Writer

    n = 400
    t = T0 + np.arange(n, dtype=np.int64) * 50_000_000
    rng = np.random.default_rng(2)
    x, y, h = rng.normal(size=n), rng.normal(size=n), rng.uniform(-3, 3, n)
    poses = pose_in_frame_many(t, x, y, h)
    back = np.arange(n)
    back[100:110] = back[100:110][::-1]  # /b: ten messages written newest first
    path = tmp_path / "two.mcap"
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=4096)
        w.start()
        sid = w.register_schema("foxglove.PoseInFrame", "jsonschema", b"{}")
        a = w.register_channel(A, "json", sid)
        b = w.register_channel(B, "json", sid)
        for i in range(n):
            w.add_message(a, int(t[i]), poses[i], int(t[i]))
            j = int(back[i])
            w.add_message(b, int(t[j]), poses[j], int(t[j]))
        w.finish()
    with pytest.warns(LogWarning, match="no lgvtool metadata"):
        reader = LogReader(path)
    single = TopicTables(reader, [A, B])
    for block in reader.raw_column_chunks([A, B]):
        single.add(block)
    assert single._builders[A] is not None and single._builders[B] is None  # b read again
    tables = reader.dataframes([A, B])
    for topic in (A, B):
        want = _alone(reader, topic)
        assert len(want) == n
        pd.testing.assert_frame_equal(tables[topic], want)
    np.testing.assert_array_equal(tables[B]["x"].to_numpy(), x)
