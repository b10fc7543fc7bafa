"""Does ``lgvtool audit``'s navigation section find the NAV's dropouts, and only them? The
``degraded`` scenario's injected NAV faults against the dropouts found, and the NAV's own losses
for site reasons (too few reflectors in range) on a drive with a short detection range.

Run by hand (never a timed test)::

    python benchmarks/audit_navigation.py [--seeds 1-8] [--workdir DIR] [--error-rate 0.03]

Per seed: ``lgvtool simulate --scenario degraded --seed S`` (a NAV200 polled every 0.45 s;
faults injected on 2-3 % of polls each: request lost, reply lost, reply corrupted, reply
'no valid position'; with ``--error-rate R`` also a share R of polls answered with an error
reply), then ``lgvtool audit LOG -o DIR``. The injected faults are read back from
the log's /diagnostics (source ``simulator``): every poll that lost its valid pose (its fault
time mapped to its poll by the poll period), consecutive polls merged into one interval.
Target: as many dropouts as injected intervals on every seed, each found start within one NAV
period of the injected one, causes matching (``error`` where an error reply arrived,
``no_position`` where a reply without a position did, else ``no_reply``).

Then the same drive with ``nav.detection_range_m=6`` and no injected NAV fault: the device
loses its position where fewer than three reflectors are in range (the simulator records no
event for that, only its count of valid revolutions in the metadata). Reported: the dropouts
found and their causes, and the share of replies without a position beside the simulator's
share of revolutions without a valid solution.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

NAV_FAULTS = {"nav_request_dropped": "no_reply", "nav_reply_dropped": "no_reply",
              "nav_reply_corrupted": "no_reply", "nav_no_position": "no_position",
              "nav_error_reply": "error"}
"""The simulator's NAV fault kinds that cost a poll its valid pose, and the cause the audit
should give (a lost or corrupted reply wins over a 'no position' or an error reply that never
arrived)."""
RANK = ("error", "no_position", "no_reply")
"""An interval's cause: the first of these that one of its polls has."""


def _injected(log: Path) -> tuple[list[tuple[float, str]], float]:
    """The injected intervals of ``log`` (start s after the log's data start, cause) and the
    poll period, s."""
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader

    reader = LogReader(log)
    sim = reader.metadata["simulator"]
    period, start = float(sim["settings"]["nav"]["poll_period_s"]), float(
        sim["settings"]["nav"]["poll_start_s"])
    epoch_ns = int(sim["start_epoch_s"]) * 1_000_000_000
    t0 = load_log(reader, reader.config().reflectors).t0_ns
    polls: dict[int, set[str]] = {}
    first: dict[int, float] = {}
    for m in reader.raw_messages(["/diagnostics"]):
        d = json.loads(m.data)
        if d.get("source") != "simulator" or d.get("kind") not in NAV_FAULTS:
            continue
        ns = d["timestamp"]["sec"] * 1_000_000_000 + d["timestamp"]["nsec"]
        k = round(((ns - epoch_ns) * 1e-9 - start) / period)  # the poll it happened to
        polls.setdefault(k, set()).add(NAV_FAULTS[d["kind"]])
        first[k] = min(first.get(k, (ns - t0) * 1e-9), (ns - t0) * 1e-9)
    # consecutive polls make one interval; the audit calls it no_position when any reply
    # without a position arrived in it, no_reply when none did
    out: list[tuple[float, str]] = []
    last = -10
    for k in sorted(polls):
        cause = "no_reply" if "no_reply" in polls[k] else min(polls[k], key=RANK.index)
        if k == last + 1:
            out[-1] = (out[-1][0], min((out[-1][1], cause), key=RANK.index))
        else:
            out.append((first[k], cause))
        last = k
    return out, period


def _run(cmd: list[str]) -> None:
    subprocess.run([sys.executable, "-m", "lgvtool", *cmd], check=True, capture_output=True)


def _audit(log: Path, out: Path) -> dict[str, Any]:
    _run(["audit", str(log), "-o", str(out), "--force", "--no-progress"])
    doc = json.loads((out / "audit.json").read_text(encoding="utf-8"))
    logs = doc["navigation"]["logs"]
    return dict(logs[0])


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", default="1-8", help="first-last seed (inclusive)")
    p.add_argument("--workdir", default=None, help="keep the logs and audits here")
    p.add_argument("--error-rate", type=float, default=0.0,
                   help="polls answered with an error reply (faults.nav_error_rate) on top "
                        "of the scenario's faults")
    a = p.parse_args()
    work = Path(a.workdir or tempfile.mkdtemp(prefix="audit_navigation_"))
    work.mkdir(parents=True, exist_ok=True)
    ok_all = True
    print("seed  injected  found  count  starts(max off s)  causes")
    for seed in _seeds(a.seeds):
        log = work / f"degraded-{seed}.mcap"
        _run(["simulate", "--scenario", "degraded", "--seed", str(seed), "-o", str(log),
              "--force", "--set", f"faults.nav_error_rate={a.error_rate}"])
        injected, period = _injected(log)
        found = _audit(log, work / f"audit-{seed}")
        drops = [d for d in found["dropouts"] if isinstance(d, dict)]
        same = len(drops) == len(injected)
        off = max((abs(float(d["start_s"]) - t) for d, (t, _) in zip(drops, injected,
                                                                       strict=False)),
                  default=0.0)
        causes = same and all(d["cause"] == c for d, (_, c) in zip(drops, injected, strict=True))
        ok = same and off <= period and causes
        ok_all &= ok
        print(f"{seed:4d}  {len(injected):8d}  {len(drops):5d}  {'ok' if same else 'NO':>5}  "
              f"{'ok' if off <= period else 'NO':>6} ({off:.3f})     {'ok' if causes else 'NO'}")
    log = work / "short-range.mcap"
    _run(["simulate", "--scenario", "paper-circle", "--seed", "1", "-o", str(log), "--force",
          "--set", "sim.paper_scans=false", "--set", "nav.detection_range_m=6"])
    from lgvtool.log import LogReader

    counts = LogReader(log).metadata["simulator"]["counts"]
    found = _audit(log, work / "audit-short-range")
    drops = [d for d in found["dropouts"] if isinstance(d, dict)]
    site_causes: dict[str, int] = {}
    for d in drops:
        site_causes[str(d["cause"])] = site_causes.get(str(d["cause"]), 0) + 1
    replies, navigating = int(found["replies"]), int(found["navigating"])
    print(f"site losses (nav.detection_range_m=6, no NAV fault injected): {len(drops)} dropouts "
          f"{site_causes}; replies without a position {1 - navigating / replies:.1%}, the "
          f"simulator's revolutions without a valid solution "
          f"{1 - counts['nav_valid_solutions'] / counts['nav_revolutions']:.1%}")
    print("target met" if ok_all else "target NOT met")
    sys.exit(0 if ok_all else 1)


if __name__ == "__main__":
    main()
