"""How many corrupted-but-valid-checksum NAV200 pose telegrams the plausibility gate catches,
and how many good poses it wrongly rejects.

Run by hand::

    python benchmarks/gate_fuzz.py [LOG ...] [--corruptions 200000] [--seed 1]

For each log (default: the sample logs) the valid NAV poses and the odometry are read as the
replay reads them. Each trial takes a random pose of the log, encodes it as the PP reply the
NAV200 sends (17 bytes), flips 2 random bits of the telegram, and feeds it to the host-side
stream decoder. A telegram the decoder delivers as a valid pose that differs from the sent one
(the XOR checksum lets about 6 % of 2-bit corruptions through) joins the corpus. Corpus poses
replace their originals in the log's trajectory, at least 10 poses apart, and the gate runs
over it: a corrupt pose rejected is caught, a good pose rejected is a false reject. The catch
rate is given over every delivered corruption that changes the pose, and over those that move
it by more than 0.1 m or 1 degree (smaller changes are within the NAV's own noise).
"""

from __future__ import annotations

import argparse
import math
import random
import sys
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from lgvtool.devices.nav200.nav200_commands import Reply  # noqa: E402
from lgvtool.devices.nav200.nav200_payloads import Pose  # noqa: E402
from lgvtool.devices.nav200.nav200_replies import build_pose_reply  # noqa: E402
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder  # noqa: E402
from lgvtool.localize.gate import gate_poses  # noqa: E402
from lgvtool.localize.logdata import load_log  # noqa: E402
from lgvtool.localize.motion import MotionSettings, MotionTrack  # noqa: E402
from lgvtool.log import LogReader  # noqa: E402


def corpus(x: float, y: float, h: float, rng: random.Random, tries: int
           ) -> list[tuple[float, float, float]]:
    """Poses delivered from ``tries`` 2-bit corruptions of the PP reply of ``(x, y, h)``
    that differ from it."""
    good = build_pose_reply(x, y, h, 90, 8)
    sent = Pose.from_si(x, y, h, 90, 8)
    out = []
    for _ in range(tries):
        raw = bytearray(good)
        a, b = rng.sample(range(8 * len(raw)), 2)
        raw[a // 8] ^= 1 << (a % 8)
        raw[b // 8] ^= 1 << (b % 8)
        dec = Nav200ReplyDecoder()
        for frame in dec.feed(bytes(raw)) + dec.flush():
            if isinstance(frame, Reply) and isinstance(frame.payload, Pose) \
                    and frame.payload.valid:
                p = frame.payload
                if (p.x_mm, p.y_mm, p.heading_raw) != (sent.x_mm, sent.y_mm, sent.heading_raw):
                    out.append((p.x, p.y, p.heading))
    return out


def run(log: Path, corruptions: int, seed: int) -> dict[str, int]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors or None)
    nav = data.nav
    assert nav is not None and data.has_motion, f"{log}: needs NAV poses and odometry"
    ms = MotionSettings()
    odo = MotionTrack(data.increments(ms, cfg.vehicle), ms.step_form).poses_at(nav["t"])
    vx, vy = cfg.vehicle.nav_x, cfg.vehicle.nav_y
    valid = nav["valid"]
    base = gate_poses(nav["t"], nav["x"], nav["y"], nav["heading"], valid, odo, vx, vy)
    counts = {"poses": int(valid.sum()), "false_rejects_clean": len(base.rejected),
              "delivered": 0, "changed": 0, "caught": 0, "harmful": 0, "harmful_caught": 0,
              "false_rejects": 0}
    rng = random.Random(seed)
    good_idx = np.nonzero(valid)[0][1:].tolist()
    slots = good_idx[::10]
    per_trial = 1
    done = 0
    while done < corruptions:
        x, y, h = nav["x"].copy(), nav["y"].copy(), nav["heading"].copy()
        hit: dict[int, bool] = {}
        for k in slots:
            if done >= corruptions:
                break
            got = corpus(float(x[k]), float(y[k]), float(h[k]), rng, per_trial)
            done += per_trial
            if not got:
                continue
            cx, cy, ch = got[0]
            counts["delivered"] += 1
            harmful = (math.hypot(cx - x[k], cy - y[k]) > 0.1
                       or abs(math.remainder(ch - h[k], 2 * math.pi)) > math.radians(1.0))
            x[k], y[k], h[k] = cx, cy, ch
            hit[k] = harmful
        if not hit:
            continue
        verdict = gate_poses(nav["t"], x, y, h, valid, odo, vx, vy)
        for k, harmful in hit.items():
            counts["changed"] += 1
            counts["harmful"] += harmful
            if not verdict.accepted[k]:
                counts["caught"] += 1
                counts["harmful_caught"] += harmful
        counts["false_rejects"] += sum(1 for r in verdict.rejected if r[0] not in hit)
    return counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("logs", nargs="*", type=Path,
                    default=[REPO / "sample_logs" / "paper-circle.mcap",
                             REPO / "sample_logs" / "degraded.mcap"])
    ap.add_argument("--corruptions", type=int, default=200_000,
                    help="2-bit corruptions tried per log")
    ap.add_argument("--seed", type=int, default=1)
    opts = ap.parse_args()
    for log in opts.logs:
        c = run(log, opts.corruptions, opts.seed)
        rate = c["caught"] / c["changed"] if c["changed"] else float("nan")
        hrate = c["harmful_caught"] / c["harmful"] if c["harmful"] else float("nan")
        print(f"{log.name}: {c['poses']} good poses, {c['false_rejects_clean']} rejected "
              f"as they are; {opts.corruptions} corruptions, {c['delivered']} delivered as "
              f"valid poses ({100 * c['delivered'] / opts.corruptions:.2f} %), "
              f"{c['caught']} caught ({100 * rate:.1f} %); moving the pose > 0.1 m or > 1 deg: "
              f"{c['harmful']}, caught {c['harmful_caught']} ({100 * hrate:.1f} %); good poses "
              f"rejected beside them: {c['false_rejects']}")


if __name__ == "__main__":
    main()
