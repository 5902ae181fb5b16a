"""A pose prior for a model's closed loop: per action, a Gaussian of the real body poses in the model's
normalized used dims, applied to every generated frame before it is fed back (``motion_core::model::prior``).

Per action (each of the model's actions; an unconditioned model: one prior over ``--actions``), the frames of the
H3.6M training subjects (S1, S6-S9, S11) at 25 Hz from frame 50 (``motion_metrics::posture::REFERENCE_START_FRAME``:
the capture's arms-out pose before the action is left out) are normalized by the model's own statistics; the used
dims of the root (dims 0..5) are left out. ``prior.mean [A, O]`` is their mean and ``prior.components [A, K, O]``
(K = O, rows orthonormal, zero on the root's dims) with ``prior.inv_std [A, K]`` (1 / standard deviation along each,
variances floored at 1e-4 of the largest) their principal axes. A generated frame ``y`` (normalized used dims) of a
row doing action ``a`` has ``z = C_a (y - mu_a)`` and ``m = sqrt(mean_k (z_k * inv_std_ak)^2)`` over the axes with a positive ``inv_std`` (1 on average for real
poses); when ``m > r`` (``config.prior_radius``) the deviation inside the principal axes is shrunk to ``m = r``:
``y <- y - (1 - r / m) * C_a^T z``. The root's dims are never changed.

    python -m training.pose_prior --weights weights/intention_actions.safetensors --radius 2.0 --out prior.safetensors
    python -m training.pose_prior --weights weights/goal_gru_h36m.safetensors --actions walking,walkingdog,\\
        walkingtogether,waiting,directions --radius 2.0 --out goal_prior.safetensors
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from safetensors.numpy import load_file, save_file

from . import data as h36m
from .export import read_metadata

START_FRAME = 50
VARIANCE_FLOOR = 1e-4
ROOT_DIMS = 6


def prior_of(frames_norm: np.ndarray, dims_used: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean [O], components [O, O], inv_std [O]) of normalized frames [n, O] (see the module docs)."""
    o = frames_norm.shape[1]
    body = np.array([d >= ROOT_DIMS for d in dims_used])
    mean = frames_norm.mean(axis=0)
    centred = frames_norm[:, body] - mean[body]
    cov = centred.T @ centred / max(centred.shape[0] - 1, 1)
    values, vectors = np.linalg.eigh(cov)
    order = np.argsort(values)[::-1]
    values, vectors = values[order], vectors[:, order]
    values = np.maximum(values, values[0] * VARIANCE_FLOOR)
    components = np.zeros((o, o))
    inv_std = np.zeros(o)
    k = body.sum()
    components[:k, body] = vectors.T
    inv_std[:k] = 1.0 / np.sqrt(values)
    return mean, components, inv_std


def build(weights: Path, radius: float, actions: list[str] | None, dataset_dir: Path | None, log=print) -> dict:
    metadata = read_metadata(weights)
    config = json.loads(metadata["config"])
    if config.get("skeleton") != "h36m-32":
        raise SystemExit(f"{weights}: the prior is made from H3.6M data; this model is on {config.get('skeleton')!r}")
    groups = [[a] for a in config.get("actions", [])] or [actions or []]
    if not groups[0]:
        raise SystemExit(f"{weights} is unconditioned: give --actions for its one prior")
    tensors = load_file(os.fspath(weights))
    mean, std = tensors["norm.mean"].astype(np.float64), tensors["norm.std"].astype(np.float64)
    dims = [int(d) for d in config["dims_used"]]
    dataset_dir = Path(dataset_dir) if dataset_dir else h36m.default_dataset_dir()
    means, comps, invs = [], [], []
    for group in groups:
        seqs = h36m.load_sequences(dataset_dir, h36m.TRAIN_SUBJECTS, group, log=log)
        frames = [h36m.downsample(s)[START_FRAME:] for s in seqs.values()]
        frames = np.concatenate([f for f in frames if len(f)], axis=0)
        norm = (frames[:, dims] - mean[dims]) / std[dims]
        m, c, i = prior_of(norm, dims)
        means.append(m)
        comps.append(c)
        invs.append(i)
        log(f"prior {'+'.join(group)}: {frames.shape[0]} frames")
    tensors["prior.mean"] = np.stack(means).astype(np.float32)
    tensors["prior.components"] = np.stack(comps).astype(np.float32)
    tensors["prior.inv_std"] = np.stack(invs).astype(np.float32)
    config["prior_radius"] = float(radius)
    metadata["config"] = json.dumps(config, sort_keys=True)
    provenance = json.loads(metadata.get("provenance", "{}"))
    provenance["pose_prior"] = (
        f"radius {radius}: per-action Gaussian of H3.6M S1, S6-S9, S11 poses at 25 Hz from frame {START_FRAME} "
        f"({', '.join('+'.join(g) for g in groups)}), applied to every generated frame before feedback "
        "(training/pose_prior.py)"
    )
    metadata["provenance"] = json.dumps(provenance, sort_keys=True)
    return {"tensors": tensors, "metadata": metadata}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--weights", type=Path, required=True)
    p.add_argument("--radius", type=float, required=True)
    p.add_argument("--actions", help="an unconditioned model's actions (comma list) for its one prior")
    p.add_argument("--data-dir", type=Path)
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    if not (args.radius > 0 and np.isfinite(args.radius)):
        raise SystemExit("--radius must be a positive number")
    if args.out.resolve() == args.weights.resolve():
        raise SystemExit("--out must differ from --weights (the input is never overwritten)")
    built = build(args.weights, args.radius, args.actions.split(",") if args.actions else None, args.data_dir)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".safetensors", dir=args.out.resolve().parent)
    os.close(fd)
    try:
        save_file(built["tensors"], tmp, metadata=built["metadata"])
        os.chmod(tmp, 0o644)
        os.replace(tmp, args.out)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
