"""NDMS at the size of the whole H3.6M evaluation: motion-cli (exact) vs numba + Annoy (approximate).

The public NDMS package finds each query word's nearest database word with Annoy (10 trees, f32
vectors) and scores words with numpy/numba. This script re-implements its algorithm as
metrics.md states it (word normalization: z up, hip centre, heading along +x; 12 joints; κ = 8)
with numba for the word maths and Annoy for the search, and times it against ours on the same
positions.

Data: with the H3.6M files (``$MOTION_DATA_DIR``, default ``../shared/data``), for every action
the database holds the words of its S5 files at 25 Hz (world joint positions from
``motion-cli convert --positions``, untimed) and the queries are 8 windows of 107 frames (100 words
each) of S1's first file of that action: the size of the whole evaluation. Without the data (or with
``--synthetic``) smooth synthetic motions of the same sizes are used. ``--check`` also computes
exact NDMS with numpy brute force for one action and compares it with ours to 1e-9.

What is timed, on both sides the whole evaluation from positions in memory to f_sim per action:

- **ours**: ``motion-cli bench --ndms MANIFEST`` (one process for all actions; the .npy files are
  read before its clock starts, as the Python side has its arrays in memory): every action's
  database words, index build, query words, exact nearest neighbours and similarities, actions in
  parallel; the median of ``--inner-reps`` evaluations, at 1 and at ``--threads`` rayon threads;
- **numba + Annoy**: database words, Annoy index (add items, build 10 trees), query words,
  ``get_nns_by_vector`` and the numba similarity, one thread (numba and Annoy's build and queries
  run single-threaded here);
- for information, ours as one ``motion-cli score --metric ndms`` process per action (start-up and
  reading the .npy files included, 13 processes).

Engines alternate within each round; the table shows medians over ``--reps`` rounds.

    cargo build --release -p motion-cli
    training/.venv/bin/pip install -r benches/compare/requirements.txt   # numba, annoy
    training/.venv/bin/python benches/compare/compare_ndms.py --check
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np
from annoy import AnnoyIndex

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
KAPPA = 8
EPS = 1e-7
# ndms_joints of shared/reference/h36m_skeleton.json: wrists, elbows, shoulders, hips, knees, ankles.
NDMS_JOINTS = np.array([19, 27, 18, 26, 17, 25, 6, 1, 7, 2, 8, 3])
LEFT_HIP, RIGHT_HIP = 6, 1


@numba.njit(cache=True)
def words_of(seq: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """All stride-1 words of ``seq [T, J, 3]`` (y up), normalized, flattened: ``[T-κ+1, κ*12*3]``."""
    t_len = seq.shape[0]
    n = t_len - KAPPA + 1
    out = np.empty((n, KAPPA * joints.shape[0] * 3))
    for w in range(n):
        # z up: (x, y, z) -> (x, z, y)
        lx, ly = seq[w, LEFT_HIP, 0], seq[w, LEFT_HIP, 2]
        rx, ry = seq[w, RIGHT_HIP, 0], seq[w, RIGHT_HIP, 2]
        cx, cy = 0.5 * (lx + rx), 0.5 * (ly + ry)
        theta = np.arctan2(ry - ly, rx - lx)
        c, s = np.cos(theta), np.sin(theta)
        k = 0
        for f in range(KAPPA):
            for jj in range(joints.shape[0]):
                j = joints[jj]
                x = seq[w + f, j, 0] - cx
                y = seq[w + f, j, 2] - cy
                z = seq[w + f, j, 1]
                out[w, k] = c * x + s * y
                out[w, k + 1] = -s * x + c * y
                out[w, k + 2] = z
                k += 3
    return out


@numba.njit(cache=True)
def ndms_pair(n: np.ndarray, q: np.ndarray, joints: int) -> float:
    """NDMS of a neighbour word ``n`` and a query word ``q`` (flattened ``[κ, J, 3]``)."""
    total = 0.0
    for t in range(1, KAPPA):
        for j in range(joints):
            a = (t * joints + j) * 3
            b = ((t - 1) * joints + j) * 3
            vn0, vn1, vn2 = n[a] - n[b], n[a + 1] - n[b + 1], n[a + 2] - n[b + 2]
            vq0, vq1, vq2 = q[a] - q[b], q[a + 1] - q[b + 1], q[a + 2] - q[b + 2]
            mn = max(np.sqrt(vn0 * vn0 + vn1 * vn1 + vn2 * vn2), EPS)
            mq = max(np.sqrt(vq0 * vq0 + vq1 * vq1 + vq2 * vq2), EPS)
            cos = (vn0 * vq0 + vn1 * vq1 + vn2 * vq2) / (mn * mq)
            total += 0.5 * (1.0 + cos) * min(mn, mq) / max(mn, mq)
    return total / ((KAPPA - 1) * joints)


def ndms_annoy(db: np.ndarray, queries: np.ndarray, trees: int = 10) -> float:
    """f_sim of ``queries [N, T, J, 3]`` against ``db [M, T', J, 3]`` with an Annoy index."""
    database = np.concatenate([words_of(s, NDMS_JOINTS) for s in db])
    index = AnnoyIndex(database.shape[1], "euclidean")
    for i, w in enumerate(database.astype(np.float32)):
        index.add_item(i, w)
    index.build(trees)
    scores = []
    for s in queries:
        for w in words_of(s, NDMS_JOINTS):
            nn = index.get_nns_by_vector(w.astype(np.float32), 1)[0]
            scores.append(ndms_pair(database[nn], w, len(NDMS_JOINTS)))
    return float(np.mean(scores))


def ndms_exact(db: np.ndarray, queries: np.ndarray) -> float:
    """f_sim with exact nearest neighbours (numpy brute force), for the value check."""
    database = np.concatenate([words_of(s, NDMS_JOINTS) for s in db])
    norms = (database**2).sum(axis=1)
    scores = []
    for s in queries:
        words = words_of(s, NDMS_JOINTS)
        d2 = norms[None, :] - 2 * words @ database.T + (words**2).sum(axis=1)[:, None]
        for w, nn in zip(words, d2.argmin(axis=1)):
            scores.append(ndms_pair(database[nn], w, len(NDMS_JOINTS)))
    return float(np.mean(scores))


def synthetic(rng, sequences: int, frames: int) -> np.ndarray:
    """Smooth 32-joint motions ``[sequences, frames, 32, 3]`` around a fixed rest pose."""
    rest = rng.uniform(-0.5, 0.5, size=(1, 1, 32, 3)) + np.array([0.0, 1.0, 0.0])
    t = np.arange(frames)[None, :, None, None]
    freq = rng.uniform(0.01, 0.08, size=(sequences, 1, 32, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(sequences, 1, 32, 3))
    drift = np.cumsum(rng.standard_normal((sequences, frames, 1, 3)) * 0.005, axis=1) * np.array([1, 0, 1])
    return rest + 0.1 * np.sin(2 * np.pi * freq * t + phase) + drift


ACTIONS = [
    "directions", "discussion", "eating", "greeting", "phoning", "posing", "purchases", "sitting",
    "sittingdown", "smoking", "takingphoto", "waiting", "walking", "walkingdog", "walkingtogether",
]  # fmt: skip


def positions_25hz(cli: str, path: str, tmp: str) -> np.ndarray:
    """World joint positions ``[T, 32, 3]`` of an H3.6M exp-map file, every second 50 Hz frame."""
    out = os.path.join(tmp, "positions.npy")
    subprocess.run([cli, "convert", path, out, "--positions"], check=True, capture_output=True)
    return np.load(out)[::2]


def h36m(cli: str, data_dir: str, tmp: str) -> list[tuple[list[np.ndarray], np.ndarray]]:
    """Per action: (S5 sequences, S1 query windows ``[8, 107, 32, 3]``); empty if the data is absent."""
    root = os.path.join(data_dir, "h3.6m", "dataset")
    out = []
    for action in ACTIONS:
        db = [
            positions_25hz(cli, os.path.join(root, "S5", f"{action}_{k}.txt.gz"), tmp)
            for k in (1, 2)
            if os.path.exists(os.path.join(root, "S5", f"{action}_{k}.txt.gz"))
        ]
        query_file = os.path.join(root, "S1", f"{action}_1.txt.gz")
        if not db or not os.path.exists(query_file):
            continue
        q = positions_25hz(cli, query_file, tmp)
        starts = np.linspace(0, len(q) - 107, 8).astype(int)
        out.append((db, np.stack([q[s : s + 107] for s in starts])))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--actions", type=int, default=15)
    parser.add_argument("--reps", type=int, default=3, help="rounds (engines alternate; median)")
    parser.add_argument("--threads", type=int, default=2, help="rayon threads of ours (also timed at 1)")
    parser.add_argument("--inner-reps", type=int, default=5, help="evaluations per `bench --ndms` run (median)")
    parser.add_argument("--check", action="store_true", help="also check ours against exact numpy NDMS")
    parser.add_argument("--synthetic", action="store_true", help="synthetic motions even if the data is there")
    parser.add_argument("--cli", default=os.path.join(REPO, "target", "release", "motion-cli"))
    args = parser.parse_args()
    if not os.path.exists(args.cli):
        print(f"error: {args.cli} not found; run `cargo build --release -p motion-cli` first", file=sys.stderr)
        return 2
    data_dir = os.environ.get("MOTION_DATA_DIR", os.path.join(REPO, "..", "shared", "data"))

    with tempfile.TemporaryDirectory(prefix="motion-ndms-") as tmp:
        data = [] if args.synthetic else h36m(args.cli, data_dir, tmp)[: args.actions]
        source = f"H3.6M S5 databases, S1 queries ({data_dir})"
        if not data:
            rng = np.random.default_rng(3)
            data = [(list(synthetic(rng, 2, 1400)), synthetic(rng, 8, 107)) for _ in range(args.actions)]
            source = "synthetic motions"
        ndms_annoy([data[0][0][0][:40]], data[0][1][:, :20])  # numba compile, untimed
        paths, sets = [], []
        for a, (db, q) in enumerate(data):
            dbps = []
            for k, seq in enumerate(db):
                dbps.append(os.path.join(tmp, f"db{a}_{k}.npy"))
                np.save(dbps[-1], seq[None])
            qp = os.path.join(tmp, f"q{a}.npy")
            np.save(qp, q)
            paths.append((dbps, qp))
            sets.append({"name": f"set{a}", "pred": os.path.basename(qp), "db": [os.path.basename(p) for p in dbps]})
        manifest = os.path.join(tmp, "manifest.json")
        with open(manifest, "w") as f:
            json.dump({"sets": sets}, f)

        def bench(threads: int):
            """``bench --ndms``: per-action f_sim; its own median time replaces the wall time."""

            def run() -> tuple[list[float], float]:
                env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
                cmd = [args.cli, "bench", "--ndms", manifest, "--reps", str(args.inner_reps), "--json"]
                out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=env).stdout
                report = json.loads(out)["ndms"]
                phases[threads] = report["phases_ms"]
                return [s["mean"] for s in report["sets"]], report["median_ms"] / 1e3

            return run

        def processes() -> list[float]:
            env = dict(os.environ, RAYON_NUM_THREADS=str(args.threads))
            values = []
            for dbps, qp in paths:
                cmd = [args.cli, "score", "--pred", qp, "--db", *dbps, "--metric", "ndms"]
                cmd += ["--input-space", "raw", "--json"]
                out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=env).stdout
                values.append(json.loads(out)["ndms"]["mean"])
            return values

        def annoy() -> list[float]:
            return [ndms_annoy(db, q) for db, q in data]

        phases: dict[int, dict] = {}
        engines = [(f"ours, {args.threads} threads (bench --ndms)", bench(args.threads))]
        if args.threads != 1:
            engines.append(("ours, 1 thread (bench --ndms)", bench(1)))
        engines += [
            ("numba + Annoy (10 trees)", annoy),
            (f"ours, {len(paths)} score processes", processes),
        ]
        times: dict[str, list[float]] = {name: [] for name, _ in engines}
        values = {}
        for rep in range(args.reps):
            k = rep % len(engines)
            for name, fn in engines[k:] + engines[:k]:
                start = time.perf_counter()
                result = fn()
                elapsed = time.perf_counter() - start
                if isinstance(result, tuple):  # bench --ndms reports its own clock
                    result, elapsed = result
                values[name] = result
                times[name].append(elapsed)
        exact0 = ndms_exact(*data[0]) if args.check else None

    med = {n: statistics.median(t) for n, t in times.items()}
    annoy_name = "numba + Annoy (10 trees)"
    words = sum(len(words_of(s, NDMS_JOINTS)) for db, _ in data for s in db)
    print(f"NDMS on {source}: {len(data)} actions, {words} database words, {len(data) * 800} query words")
    print(f"median of {args.reps} rounds; `bench --ndms` rows: median of {args.inner_reps} evaluations each")
    print(f"{'implementation':<36} {'seconds':>9} {'Annoy / this':>12} {'mean f_sim':>11}")
    for name in times:
        print(f"{name:<36} {med[name]:>9.4f} {med[annoy_name] / med[name]:>12.1f} {np.mean(values[name]):>11.6f}")
    exact = values[engines[0][0]]
    diff = max(abs(a - b) for a, b in zip(exact, values[annoy_name]))
    same = max(abs(a - b) for name, _ in engines if name != annoy_name for a, b in zip(exact, values[name]))
    print(f"max per-action |ours - Annoy|: {diff:.1e} (Annoy is approximate); between our runs: {same:.1e}")
    for threads, p in sorted(phases.items()):
        parts = ", ".join(f"{k} {v:.1f} ms" for k, v in p.items())
        print(f"ours, one sequential pass over all actions ({threads} thread(s)): {parts}")
    if exact0 is not None:
        err = abs(exact0 - exact[0])
        print(f"ours vs exact numpy, action 0: |diff| = {err:.1e}")
        return 0 if err < 1e-9 else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
