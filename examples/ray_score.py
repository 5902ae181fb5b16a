"""Score a corpus of motion predictions at scale with Ray, or in one process: one JSON report.

A corpus is a directory tree of ``.npy`` predictions, each ``S x T x 99`` (S samples) or
``T x 99`` exp-map frames at 25 Hz, optionally with ground truth at the same relative paths under
``--gt`` (``T' x 99``, T' >= T). Per file: NPSS and the protocol's Euler error against the ground
truth (every sample against it), APD over the samples, and NDMS against a reference database
(``--db``: exp-map clips, ``.txt``/``.txt.gz`` at 50 Hz or ``.npy`` at 25 Hz); the report adds
their means over files. The same function scores each file in both modes, so the report of
``--local`` and of any Ray cluster are identical.

  python examples/ray_score.py preds/ --gt truth/ --db S1/*.txt.gz --out report.json           # Ray, local
  python examples/ray_score.py preds/ --gt truth/ --db ... --out report.json --address auto    # a running cluster
  python examples/ray_score.py preds/ --gt truth/ --db ... --out report.json --local           # one process
  python examples/ray_score.py --generate 64 --samples 8 corpus/ --db S1/*.txt.gz --out r.json  # make a corpus first

The NDMS database is built once, in the driver; its words go to Ray's object store once
(``ray.put``) and every worker process builds its nearest-neighbour index from them once (cached
per process). Files are scored in shards of ``--shard`` files, one Ray task each. On a multi-node
cluster start Ray on every node (``ray start --head`` / ``ray start --address HEAD:6379``) and
give ``--address HEAD:6379`` (or ``auto`` on a node of it); the corpus and the database files must
be readable at the same paths on every node (a shared file system), or pass ``--gt``-less corpora
generated with ``--generate``, which writes where the driver runs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import motion

# The protocol's Euler-error horizons (ms) and their 25 Hz frame indices.
HORIZONS_MS = (80, 160, 320, 400, 560, 1000)
HORIZON_FRAMES = (1, 3, 7, 9, 13, 24)


def reference_positions(paths: list[Path]) -> list[np.ndarray]:
    """World positions (25 Hz) of every reference clip: 50 Hz text keeps every 2nd frame."""
    out = []
    for path in paths:
        frames = motion.read_expmap(path)
        if path.suffix != ".npy":
            frames = frames[::2]
        out.append(motion.expmap_to_positions(frames))
    return out


def score_file(rel: str, pred: np.ndarray, gt: np.ndarray | None, db: motion.NdmsDatabase) -> dict:
    """Every metric of one prediction file (see the module docstring)."""
    samples = pred[None] if pred.ndim == 2 else pred
    s, t, _ = samples.shape
    positions = [motion.expmap_to_positions(x) for x in samples]
    result: dict = {"samples": s, "frames": t, "ndms": db.score(positions)["mean"]}
    if s > 1:
        result["apd"] = motion.apd(np.stack(positions).reshape(s, -1))
    if gt is not None:
        if gt.shape[0] < t or gt.shape[1] != samples.shape[2]:
            raise ValueError(f"{rel}: ground truth {gt.shape} does not cover the prediction {samples.shape[1:]}")
        truth = np.broadcast_to(gt[:t], samples.shape)
        result["npss"] = motion.npss(truth, samples, input_space="expmap")
        per_frame = motion.euler_error(truth, samples)
        result["euler_ms"] = {str(ms): float(per_frame[f]) for ms, f in zip(HORIZONS_MS, HORIZON_FRAMES) if f < t}
    return result


def score_shard(items: list[tuple[str, str, str | None]], db: motion.NdmsDatabase) -> dict:
    """Scores (relative name, prediction path, ground-truth path) items."""
    out = {}
    for rel, pred_path, gt_path in items:
        gt = np.load(gt_path) if gt_path else None
        out[rel] = score_file(rel, np.load(pred_path), gt, db)
    return out


def summary(files: dict) -> dict:
    """Means over files, in sorted file order (the same floats in every mode)."""
    names = sorted(files)
    out = {"files": len(names)}
    for key in ("npss", "ndms", "apd"):
        values = [files[n][key] for n in names if key in files[n]]
        if values:
            out[key] = float(np.mean(values))
    for ms in map(str, HORIZONS_MS):
        values = [files[n]["euler_ms"][ms] for n in names if ms in files[n].get("euler_ms", {})]
        if values:
            out.setdefault("euler_ms", {})[ms] = float(np.mean(values))
    return out


def corpus_items(pred_dir: Path, gt_dir: Path | None) -> list[tuple[str, str, str | None]]:
    items = []
    for path in sorted(pred_dir.rglob("*.npy")):
        rel = path.relative_to(pred_dir).as_posix()
        gt = None
        if gt_dir is not None:
            gt_path = gt_dir / rel
            if not gt_path.exists():
                raise FileNotFoundError(f"{gt_path}: no ground truth for {path}")
            gt = str(gt_path)
        items.append((rel, str(path), gt))
    if not items:
        raise FileNotFoundError(f"{pred_dir}: no .npy predictions")
    return items


_INDEXES: dict[str, motion.NdmsDatabase] = {}


def _shard_task(items, db_box):
    """A Ray task: the database arrives as an object reference in a list (not resolved by Ray),
    so each worker process fetches and indexes it once."""
    import ray

    (ref,) = db_box
    key = ref.hex()
    if key not in _INDEXES:
        _INDEXES[key] = ray.get(ref)
    return score_shard(items, _INDEXES[key])


def score(items, db: motion.NdmsDatabase, local: bool, shard: int = 8, address: str | None = None) -> dict:
    """The report of `items` (one process with `local`, else Ray tasks over shards)."""
    if local:
        files = score_shard(items, db)
    else:
        import ray

        if __name__ != "__main__":
            # Imported from a file (tests, notebooks): workers cannot import this module by
            # name, so its functions travel by value.
            ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
        if not ray.is_initialized():
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        task = ray.remote(_shard_task)
        db_ref = ray.put(db)  # the words, once, into the object store
        shards = [items[i : i + shard] for i in range(0, len(items), shard)]
        files = {}
        for part in ray.get([task.remote(s, [db_ref]) for s in shards]):
            files.update(part)
    files = {k: files[k] for k in sorted(files)}
    return {"summary": summary(files), "files": files}


def generate_corpus(out_dir: Path, references: list[Path], seeds: int, samples: int, frames: int, rng_seed: int) -> Path:
    """`seeds` seed windows cut evenly from the reference clips, `samples` predictions of each by
    the built-in model (action "walking"), written as out_dir/pred/*.npy with the clips' real
    continuations as out_dir/gt/*.npy."""
    model = motion.Model.default()
    clips = []
    for path in references:
        clip = motion.read_expmap(path)
        clips.append(clip[::2] if path.suffix != ".npy" else clip)
    need = model.seed_frames + 1 + frames
    windows = [(c, start) for c in range(len(clips)) for start in range(0, clips[c].shape[0] - need + 1, 25)]
    if not windows:
        raise ValueError(f"no reference clip has {need} frames at 25 Hz")
    picks = [windows[i * len(windows) // seeds] for i in range(seeds)]
    (out_dir / "pred").mkdir(parents=True, exist_ok=True)
    (out_dir / "gt").mkdir(parents=True, exist_ok=True)
    for k, (c, start) in enumerate(picks):
        clip = clips[c][start : start + need]
        # One frame more than the model reads: the window starts mid-clip, its first root value
        # a delta like every other.
        seed = clip[: model.seed_frames + 1]
        pred = model.predict(seed, action="walking", frames=frames, samples=samples, rng_seed=rng_seed + 1000 * k)
        np.save(out_dir / "pred" / f"seed_{k:04d}.npy", pred)
        np.save(out_dir / "gt" / f"seed_{k:04d}.npy", clip[model.seed_frames + 1 :])
    return out_dir


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("pred", type=Path, help="directory tree of .npy predictions (with --generate: where to write the corpus)")
    parser.add_argument("--gt", type=Path, help="ground truth tree, same relative paths")
    parser.add_argument("--db", type=Path, nargs="+", required=True, help="reference exp-map clips for NDMS")
    parser.add_argument("--out", type=Path, required=True, help="the JSON report")
    parser.add_argument("--local", action="store_true", help="one process, no Ray")
    parser.add_argument("--address", help="a Ray cluster (HEAD:6379, or auto); default: start a local one")
    parser.add_argument("--shard", type=int, default=8, help="files per Ray task (default 8)")
    parser.add_argument("--generate", type=int, metavar="SEEDS", help="first generate a corpus of SEEDS seeds")
    parser.add_argument("--samples", type=int, default=8, help="samples per seed with --generate (default 8)")
    parser.add_argument("--frames", type=int, default=100, help="frames per sample with --generate (default 100)")
    args = parser.parse_args(argv)
    try:
        if args.generate:
            generate_corpus(args.pred, args.db, args.generate, args.samples, args.frames, 0)
            args.gt, args.pred = args.pred / "gt", args.pred / "pred"
        startup = 0.0
        if not args.local:
            import ray

            begin = time.perf_counter()
            ray.init(address=args.address, include_dashboard=False, log_to_driver=False)
            startup = time.perf_counter() - begin
        start = time.perf_counter()
        db = motion.NdmsDatabase(reference_positions(args.db))
        items = corpus_items(args.pred, args.gt)
        report = score(items, db, args.local, args.shard, args.address)
        elapsed = time.perf_counter() - start
    except (OSError, ValueError) as e:
        print(f"ray_score: {e}", file=sys.stderr)
        return 2
    args.out.write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    mode = "one process" if args.local else f"Ray, after {startup:.1f} s connecting"
    print(f"{len(items)} files scored in {elapsed:.2f} s ({len(items) / elapsed:.1f} files/s, {mode}): {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
