"""How a `predict` output on any rig holds up over time: per window after the seed, the fraction of frames whose
lowest foot joint is within 0.1 m of the floor, the hip height against the seed's, the torso lean and the joint
speed against the seed's.

    motion-cli predict --seed examples/cmu_rig_walk.bvh --action walking --frames 1500 --out pred.bvh
    motion-cli convert pred.bvh pred.npy --positions
    python3 examples/rig_check.py pred.npy --bvh pred.bvh --seed-frames 240 --fps 120 --units-per-metre 14.29

Reads the world positions `T x J x 3` that `motion-cli convert --positions` writes (the rig's units, +y up) and the
joint names of the BVH (`--bvh pred.bvh`): feet are the joints whose names hold Foot, Toe or Ankle, the hips the
root, the torso top the first joint named Neck (else Spine2 / Head). The floor is the one `predict` levelled the
output onto: the seed's lowest foot points (their median height). numpy only.
"""

from __future__ import annotations

import argparse
import re

import numpy as np

WINDOWS_S = [(0, 10), (10, 20), (20, 30), (30, 40), (40, 50), (50, 60)]


def joint_names(bvh: str) -> list[str]:
    """Joint names of a BVH file, in file order (end sites excluded)."""
    names = []
    with open(bvh) as f:
        for line in f:
            m = re.match(r"\s*(ROOT|JOINT)\s+(\S+)", line)
            if m:
                names.append(m.group(2))
            if line.strip() == "MOTION":
                break
    return names


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("positions", help="T x J x 3 world positions (.npy) of convert --positions")
    p.add_argument("--bvh", required=True, help="the BVH the positions came from (joint names)")
    p.add_argument("--seed-frames", type=int, required=True)
    p.add_argument("--fps", type=float, required=True)
    p.add_argument("--units-per-metre", type=float, required=True)
    args = p.parse_args()

    pos = np.load(args.positions) / args.units_per_metre
    names = joint_names(args.bvh)
    if len(names) != pos.shape[1]:
        raise SystemExit(f"{args.bvh} names {len(names)} joints, {args.positions} holds {pos.shape[1]}")
    feet = [k for k, n in enumerate(names) if re.search(r"Foot|Toe|Ankle", n)]
    top = next((k for want in ("Neck", "Spine2", "Head") for k, n in enumerate(names) if n.endswith(want)), None)
    if not feet or top is None:
        raise SystemExit("no feet or torso top found by name")
    s = args.seed_frames
    lowest = pos[:, feet, 1].min(axis=1)
    floor = float(np.median(lowest[:s]))
    hip = pos[:, 0, 1] - floor
    torso = pos[:, top] - pos[:, 0]
    lean = np.degrees(np.arccos(np.clip(torso[:, 1] / np.linalg.norm(torso, axis=1), -1, 1)))
    body = pos - pos[:, :1]  # joints relative to the root
    speed = np.linalg.norm(np.diff(body, axis=0), axis=2).mean(axis=1) * args.fps
    seed_speed = speed[: s - 1].mean()
    print(f"floor {floor:.3f} m (seed's lowest foot, median); seed hip {hip[:s].mean():.2f} m, "
          f"lean p95 {np.percentile(lean[:s], 95):.1f} deg, joint speed {seed_speed:.3f} m/s")
    print("window s | on floor (|lowest foot| <= 0.1 m) | hip min-max m | lean p95 deg | speed / seed's")
    for a, b in WINDOWS_S:
        lo, hi = s + int(a * args.fps), min(s + int(b * args.fps), len(pos))
        if lo >= hi:
            break
        on = np.mean(np.abs(lowest[lo:hi] - floor) <= 0.1)
        print(f"{a}-{b} | {on:.2f} | {hip[lo:hi].min():.2f}-{hip[lo:hi].max():.2f} | "
              f"{np.percentile(lean[lo:hi], 95):.1f} | {speed[lo - 1:hi - 1].mean() / seed_speed:.2f}")


if __name__ == "__main__":
    main()
