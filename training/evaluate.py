"""Validation metrics of the H3.6M protocol in numpy (../shared/reference/h36m.md and metrics.md).

Euler conversion of the evaluation code, Euler-angle error, NPSS (paper definition and the reference-compatible
variant with which the published numbers were computed). Used to choose checkpoints on the S5 validation windows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: float32 epsilon, as in the evaluation code's expmap2rotmat.
EXPMAP_EPS = 1.1920929e-07
#: Predicted frames (0-based) reported by the protocol: 80, 160, 320, 400, 560, 1000 ms at 25 Hz.
REPORT_FRAMES = (1, 3, 7, 9, 13, 24)
REPORT_MS = (80, 160, 320, 400, 560, 1000)


def expmap2rotmat(r: np.ndarray) -> np.ndarray:
    """Exponential maps [..., 3] -> rotation matrices [..., 3, 3] (Rodrigues, k = r / (|r| + eps))."""
    r = np.asarray(r, dtype=np.float64)
    theta = np.linalg.norm(r, axis=-1)
    k = r / (theta[..., None] + EXPMAP_EPS)
    kx, ky, kz = k[..., 0], k[..., 1], k[..., 2]
    z = np.zeros_like(kx)
    K = np.stack([np.stack([z, -kz, ky], -1), np.stack([kz, z, -kx], -1), np.stack([-ky, kx, z], -1)], -2)
    eye = np.broadcast_to(np.eye(3), K.shape)
    s = np.sin(theta)[..., None, None]
    c = np.cos(theta)[..., None, None]
    return eye + s * K + (1.0 - c) * (K @ K)


def rotmat2euler(R: np.ndarray) -> np.ndarray:
    """Rotation matrices [..., 3, 3] -> [E1, E2, E3] [..., 3] with the evaluation code's special cases."""
    R = np.asarray(R, dtype=np.float64)
    r02 = R[..., 0, 2]
    out = np.empty(R.shape[:-2] + (3,), dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        e2 = -np.arcsin(np.clip(r02, -1.0, 1.0))
        ce = np.cos(e2)
        e1 = np.arctan2(R[..., 1, 2] / ce, R[..., 2, 2] / ce)
        e3 = np.arctan2(R[..., 0, 1] / ce, R[..., 0, 0] / ce)
    delta = np.arctan2(R[..., 0, 1], R[..., 0, 2])
    minus = r02 == -1.0
    plus = r02 == 1.0
    e1 = np.where(minus, delta, np.where(plus, delta, e1))  # E3 = 0: E1 = E3 + delta or -E3 + delta
    e2 = np.where(minus, np.pi / 2, np.where(plus, -np.pi / 2, e2))
    e3 = np.where(minus | plus, 0.0, e3)
    out[..., 0], out[..., 1], out[..., 2] = e1, e2, e3
    return out


def to_euler(frames: np.ndarray) -> np.ndarray:
    """Full exp-map frames [..., D] (D = 3 + 3k) -> Euler sequences: every triple at dims 3.. converted, then
    dims 0..5 set to 0."""
    frames = np.asarray(frames, dtype=np.float64)
    d = frames.shape[-1]
    trip = frames[..., 3:].reshape(frames.shape[:-1] + ((d - 3) // 3, 3))
    eul = rotmat2euler(expmap2rotmat(trip)).reshape(frames.shape[:-1] + (d - 3,))
    out = np.concatenate([np.zeros(frames.shape[:-1] + (3,)), eul], axis=-1)
    out[..., :6] = 0.0
    return out


def euler_error(gt_euler: np.ndarray, pred_euler: np.ndarray) -> np.ndarray:
    """Per-window Euler error curves [N, T]: dims where the ground truth's std over the predicted frames is
    > 1e-4, error(t) = sqrt(sum over those dims of (gt - pred)^2). Inputs [N, T, D] Euler sequences."""
    gt = np.asarray(gt_euler, dtype=np.float64)
    pr = np.asarray(pred_euler, dtype=np.float64)
    out = np.empty(gt.shape[:2])
    for i in range(gt.shape[0]):
        keep = np.std(gt[i], axis=0) > 1e-4
        out[i] = np.sqrt(np.sum((gt[i][:, keep] - pr[i][:, keep]) ** 2, axis=1))
    return out


def npss(gt: np.ndarray, pred: np.ndarray, variant: str = "paper") -> float:
    """NPSS over N sequences [N, T, D] (metrics.md). `variant="paper"`: power |DFT|^2; `"reference"`: the
    published code's Re(DFT)^2. Returns nan when every weight is 0 (undefined)."""
    gt = np.asarray(gt, dtype=np.float64)
    pred = np.asarray(pred, dtype=np.float64)
    fx = np.fft.fft(gt, axis=1)
    fy = np.fft.fft(pred, axis=1)
    if variant == "paper":
        X, Y = np.abs(fx) ** 2, np.abs(fy) ** 2
    elif variant == "reference":
        X, Y = fx.real**2, fy.real**2
    else:
        raise ValueError(f"unknown NPSS variant {variant!r} (paper|reference)")
    sx = X.sum(axis=1, keepdims=True)
    sy = Y.sum(axis=1, keepdims=True)
    Xn = np.divide(X, sx, out=np.zeros_like(X), where=sx > 0)
    Yn = np.divide(Y, sy, out=np.zeros_like(Y), where=sy > 0)
    emd = np.abs(np.cumsum(Yn, axis=1) - np.cumsum(Xn, axis=1)).sum(axis=1)  # [N, D]
    w = sx[:, 0, :]
    if w.sum() <= 0:
        return float("nan")
    return float((w * emd).sum() / w.sum())


def zero_velocity(seed_frames: np.ndarray, horizon: int) -> np.ndarray:
    """Zero-velocity baseline: the last seed frame repeated. [N, S, D] -> [N, horizon, D]."""
    return np.repeat(seed_frames[:, -1:, :], horizon, axis=1)


def last_second_speed_ratio(gt_full: np.ndarray, pred_full: np.ndarray, frames: int = 25) -> float:
    """Mean absolute frame-to-frame change of the joint angles (exp-map dims 6..) over the last `frames` predicted
    frames, prediction / ground truth: ~1 keeps moving like the data, ~0 froze (to the mean pose or a still pose)."""
    g = np.abs(np.diff(gt_full[:, -frames - 1 :, 6:], axis=1)).mean()
    p = np.abs(np.diff(pred_full[:, -frames - 1 :, 6:], axis=1)).mean()
    return float(p / g) if g > 0 else float("nan")


def score_windows(gt_full: np.ndarray, pred_full: np.ndarray) -> dict:
    """Scores of one action's windows (full exp-map frames [N, T, D] of the predicted horizon):
    reference- and paper-variant NPSS over the horizon, the mean Euler error curve [T] and the last second's
    speed ratio (prediction / ground truth)."""
    ge, pe = to_euler(gt_full), to_euler(pred_full)
    err = euler_error(ge, pe).mean(axis=0)
    return {
        "npss_ref": npss(ge, pe, "reference"),
        "npss_paper": npss(ge, pe, "paper"),
        "euler": err,
        "speed_ratio": last_second_speed_ratio(gt_full, pred_full),
    }


def summarize(per_action: dict[str, dict]) -> dict:
    """Mean over actions of NPSS (both variants) and Euler error at 80 ms and 1000 ms (frames 1 and 24)."""
    acts = list(per_action)
    f = lambda key: float(np.nanmean([per_action[a][key] for a in acts]))  # noqa: E731
    e = np.stack([per_action[a]["euler"] for a in acts])
    if e.shape[1] < 2:
        e = np.pad(e, ((0, 0), (0, 2 - e.shape[1])), constant_values=np.nan)
    return {
        "npss_ref": f("npss_ref"),
        "npss_paper": f("npss_paper"),
        "euler_80": float(e[:, 1].mean()),
        "euler_1000": float(e[:, 24].mean()) if e.shape[1] > 24 else float("nan"),
        "speed_ratio": f("speed_ratio"),
    }


def paired_bootstrap(gt_euler: np.ndarray, preds_euler: list[np.ndarray], window_actions: list[str], reps: int,
                     seed: int = 0) -> np.ndarray:
    """Mean-over-actions reference NPSS of every prediction set under `reps` bootstrap resamples of the windows
    (drawn with replacement within each action, the same draw for every prediction set, so differences are
    paired). Inputs: Euler sequences [N, T, D]; returns [reps, len(preds_euler)]."""
    acts = sorted(set(window_actions))
    idx = {a: np.array([i for i, w in enumerate(window_actions) if w == a]) for a in acts}
    rng = np.random.default_rng(seed)
    out = np.empty((reps, len(preds_euler)))
    for r in range(reps):
        sel = {a: rng.choice(idx[a], size=len(idx[a]), replace=True) for a in acts}
        for j, pe in enumerate(preds_euler):
            out[r, j] = np.mean([npss(gt_euler[sel[a]], pe[sel[a]], "reference") for a in acts])
    return out


def load_model(path: str):
    """A model from an exported weights file (.safetensors) or a training checkpoint (.pt)."""
    if path.endswith(".pt"):
        from .train import build_model, checkpoint_weights, load_checkpoint

        ck = load_checkpoint(Path(path))
        model = build_model(ck["config"])
        model.load_state_dict(checkpoint_weights(ck))
        model.eval()
        return model
    from .export import load_weights

    return load_weights(path)


def main(argv=None) -> int:
    """`python -m training.evaluate --weights FILE [FILE ...] [--val-per-action N]`: score weights files or training
    checkpoints (.pt) on the S5 validation windows (never the test windows) next to zero-velocity. One file: one line
    per action. Several files (a checkpoint sweep): one line per file, all on the same windows, and the file with the
    lowest mean reference NPSS named as the pick."""
    import argparse
    import json
    import sys

    from . import data as h36m
    from .train import Validator, fmt_val, positive_int

    p = argparse.ArgumentParser(prog="python -m training.evaluate", description=main.__doc__)
    p.add_argument("--weights", required=True, nargs="+", help=".safetensors weights or .pt checkpoints")
    p.add_argument("--data-dir", default=None)
    p.add_argument("--val-per-action", type=int, default=4)
    p.add_argument("--val-stride", type=positive_int, default=None,
                   help="frames between validation window starts (default 150: no overlap); e.g. 50 with a large "
                   "--val-per-action gives a denser set for a final choice between candidates")
    p.add_argument("--bootstrap", type=int, default=0, metavar="REPS",
                   help="with several files: paired bootstrap over the windows (REPS resamples) of each file's mean "
                   "reference NPSS minus the first file's: 95%% interval and how often it is lower")
    p.add_argument("--noise-seed", type=int, default=None, metavar="N",
                   help="sample the plan noise eps ~ N(0, I) per window from seed N, as `motion-cli eval` does "
                   "(default: eps = 0, the plan's mean)")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    models = []
    for path in args.weights:
        try:
            models.append(load_model(path))
        except (OSError, ValueError, KeyError, RuntimeError) as e:
            print(f"error: {path}: {e}", file=sys.stderr)
            return 2
    first = models[0]
    actions = first.actions or list(h36m.ACTIONS)
    stats = h36m.NormStats(
        mean=first.norm.mean.double().numpy(), std=first.norm.std.double().numpy(),
        dims_used=np.array(first.dims_used, dtype=np.int64),
    )
    data_dir = Path(args.data_dir) if args.data_dir else None
    windows = h36m.validation_windows(
        data_dir, actions, args.val_per_action, log=lambda m: None, stride=args.val_stride
    )
    v = Validator(windows, stats, actions, int(first.config["seed_frames"]), int(first.config["horizon"]))
    base = v.baseline()
    preds = [v.predict(m, args.noise_seed) for m in models]
    results = [v.score(pred) for pred in preds]
    if args.json:
        out = {"zero_velocity": base, "windows": len(v.windows)}
        if len(models) == 1:
            out["model"] = results[0]
        else:
            out["models"] = dict(zip(args.weights, results))
        print(json.dumps(out))
        return 0
    if len(models) > 1:
        print(f"{len(v.windows)} validation windows; zero-velocity: {fmt_val(base)}")
        for path, res in zip(args.weights, results):
            print(f"{path}: {fmt_val(res)}")
        best = min(range(len(models)), key=lambda i: results[i]["npss_ref"])
        print(f"pick (lowest mean reference NPSS): {args.weights[best]}")
        if args.bootstrap > 0:
            ge = to_euler(v.gt_full)
            boots = paired_bootstrap(ge, [to_euler(pred) for pred in preds], v.window_actions, args.bootstrap)
            print(f"paired bootstrap over the windows ({args.bootstrap} resamples), mean reference NPSS minus "
                  f"{args.weights[0]}'s:")
            for j, path in enumerate(args.weights[1:], start=1):
                d = boots[:, j] - boots[:, 0]
                print(f"  {path}: {results[j]['npss_ref'] - results[0]['npss_ref']:+.4f}, 95% interval "
                      f"[{np.percentile(d, 2.5):+.4f}, {np.percentile(d, 97.5):+.4f}], lower in {np.mean(d < 0):.0%}")
        return 0
    res = results[0]
    print(f"model:         {fmt_val(res)}")
    print(f"zero-velocity: {fmt_val(base)}")
    print("action             npss_ref (zero-vel)   euler@80 (zero-vel)   euler@1000 (zero-vel)   speed ratio")
    for a, m in res["per_action"].items():
        b = base["per_action"][a]
        print(
            f"{a:16s}  {m['npss_ref']:8.4f} ({b['npss_ref']:.4f})   {m['euler_80']:8.4f} ({b['euler_80']:.4f})"
            f"   {m['euler_1000']:8.4f} ({b['euler_1000']:.4f})     {m['speed_ratio']:.2f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
