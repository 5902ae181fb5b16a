"""Validation metrics of the H3.6M protocol in numpy (../shared/reference/h36m.md and metrics.md).

Euler conversion of the evaluation code, Euler-angle error, NPSS (paper definition and the reference-compatible
variant with which the published numbers were computed). Used to choose checkpoints on the S5 validation windows.
"""

from __future__ import annotations

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
