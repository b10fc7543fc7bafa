"""Short simulated logs for tests that need real traffic (built in the test, never the
sample logs), and reading back what lgvtool writes into them."""

from __future__ import annotations

import base64
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np


def simulate_log(path: Path, duration: float, seed: int, scenario: str = "paper-circle",
                 paper_scans: bool = True, sets: Sequence[str] = (),
                 config: Path | None = None) -> Path:
    """Simulate ``scenario`` for ``duration`` s into ``path`` with ``lgvtool simulate``; with
    ``paper_scans`` in the paper's setup (the NAV200's reflector scans logged, as the sample
    logs), else as a NAV200 recording (poses only); ``sets``: more ``--set KEY=VALUE``
    settings, ``config``: a configuration file (``--config``)."""
    extra = [a for kv in sets for a in ("--set", kv)]
    if config is not None:
        extra += ["--config", str(config)]
    subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario", scenario,
                    "--duration", str(duration), "--seed", str(seed), "-o", str(path),
                    "--set", f"sim.paper_scans={str(paper_scans).lower()}", *extra],
                   check=True, capture_output=True)
    return path


def write_topic_log(path: Path, topic: str, schema: str, payloads: list[bytes],
                    start_ns: int = 1_704_067_200_000_000_000, step_ns: int = 10_000_000
                    ) -> Path:
    """A log of one JSON topic written with the ``mcap`` package (no lgvtool metadata): the
    ``payloads`` ``step_ns`` apart from ``start_ns``."""
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        cid = w.register_channel(topic, "json", w.register_schema(schema, "jsonschema", b"{}"))
        for i, data in enumerate(payloads):
            w.add_message(cid, start_ns + i * step_ns, data, start_ns + i * step_ns)
        w.finish()
    return path


def cloud_points(msg: dict[str, Any]) -> np.ndarray:
    """The points of a foxglove.PointCloud message, read by its own fields (name, byte offset,
    numeric type) and point stride."""
    kinds = {1: "<u1", 2: "<i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<f4", 8: "<f8"}
    dtype = np.dtype({"names": [f["name"] for f in msg["fields"]],
                      "formats": [kinds[f["type"]] for f in msg["fields"]],
                      "offsets": [f["offset"] for f in msg["fields"]],
                      "itemsize": msg["point_stride"]})
    return np.frombuffer(base64.b64decode(msg["data"]), dtype=dtype)
