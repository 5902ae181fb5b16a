"""The integrated root of H3.6M frames in torch, and a penalty on its drift (issue 15's `drift` target).

`motion-cli eval`'s `drift` (motion_metrics::plausibility) integrates the root deltas of dims 0..5 over seed +
motion from the first seed frame (identity before it) and measures, per window, the largest change of the hip
height ``h_t`` (y of Hips, mm) and of the torso lean ``λ_t`` (degrees between +y and Hips -> Neck) from the last
seed frame. The models predict the deltas only; they never see the integrated height or orientation, so a small
bias in the predicted vertical translation or tilt accumulates over 12 s (the long-horizon VGRU-d fine-tunes,
`docs/models.md` "Long-horizon fine-tunes of the VGRU-d", leaned and sank out of the real range on 8 of 11 actions).

This module is the differentiable counterpart: ``root_poses`` integrates exactly as ``motion_core::root`` (row
vectors, ``R(t) = Rd^s R(t-1)``, ``T(t) = T(t-1) + d (I + ... + Rd^(s-1)) R(t-1)``, the first frame applied once,
``s = ROOT_STEP`` at 25 Hz; checked against ``metrics_np.expmap2rotmat`` loops in the tests), and ``drift_loss``
(applied by ``drift_penalty`` to a closed loop's generated frames) penalises ``|h_t − h_s|`` and the root's lean
change beyond ``DRIFT_HIP_MM`` and ``DRIFT_LEAN_RAD``.

One approximation: the lean here is the angle of the root's own up axis (``+y · R_t``), i.e. the H3.6M rest pose's
Hips -> Neck direction (Spine, Spine1 and Neck offsets all lie along +y) without the spine's joint rotations; the
evaluation's lean includes them. What accumulates is the root's orientation; the spine's angles do not integrate.
"""

from __future__ import annotations

import math

import torch

from .metrics_np import EXPMAP_EPS

ROOT_STEP = 2  # each 25 Hz frame spans two 50 Hz source frames (motion_core::root::ROOT_STEP_25HZ)
DRIFT_HIP_MM = 100.0  # free band of the hip height change (every action's real p95 at 8-12 s is above 120 mm)
DRIFT_LEAN_RAD = math.radians(10.0)  # free band of the lean change (real p95 at 8-12 s: 18-98 degrees)


def expmap_rotmat(r: torch.Tensor) -> torch.Tensor:
    """Exponential maps ``[..., 3]`` -> rotation matrices ``[..., 3, 3]``, as ``metrics_np.expmap2rotmat``
    (Rodrigues with ``k = r / (|r| + EXPMAP_EPS)``: exact at 0, differentiable everywhere)."""
    theta = r.norm(dim=-1)
    k = r / (theta[..., None] + EXPMAP_EPS)
    kx, ky, kz = k.unbind(-1)
    z = torch.zeros_like(kx)
    K = torch.stack([torch.stack([z, -kz, ky], -1), torch.stack([kz, z, -kx], -1), torch.stack([-ky, kx, z], -1)], -2)
    eye = torch.eye(3, dtype=r.dtype, device=r.device).expand(K.shape)
    s = theta.sin()[..., None, None]
    c = theta.cos()[..., None, None]
    return eye + s * K + (1.0 - c) * (K @ K)


def root_poses(root: torch.Tensor, step: int = ROOT_STEP, start=None):
    """Integrates root deltas ``root [B, T, 6]`` (dims 0..5 of H3.6M frames: translation delta in mm, rotation
    delta as an exp-map). Returns ``(R [B, T, 3, 3], T [B, T, 3])``, the absolute pose after each frame, and
    continues from ``start = (R, T)`` (the pose after an earlier frame, every frame then applied ``step`` times)
    or, without it, from the identity with the first frame applied once."""
    b = root.shape[0]
    if start is None:
        rot = torch.eye(3, dtype=root.dtype, device=root.device).expand(b, 3, 3)
        trans = root.new_zeros(b, 3)
        first = True
    else:
        rot, trans = start
        first = False
    steps = expmap_rotmat(root[..., 3:6])
    rots, transes = [], []
    for t in range(root.shape[1]):
        d = root[:, t, None, 0:3]  # [B, 1, 3], a row vector
        for _ in range(1 if first else step):
            trans = trans + (d @ rot)[:, 0]
            rot = steps[:, t] @ rot
        first = False
        rots.append(rot)
        transes.append(trans)
    return torch.stack(rots, 1), torch.stack(transes, 1)


def hip_and_lean(rot: torch.Tensor, trans: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Hip height (mm, the root's y) and the root's lean (radians between +y and ``+y · R``) of poses ``[B, T]``."""
    cos_lean = rot[..., 1, 1].clamp(-1.0 + 1e-7, 1.0 - 1e-7)
    return trans[..., 1], torch.acos(cos_lean)


def drift_loss(hip: torch.Tensor, lean: torch.Tensor, hip_ref: torch.Tensor, lean_ref: torch.Tensor) -> torch.Tensor:
    """Mean over sequences and frames of ``relu(|h_t − h_s| − DRIFT_HIP_MM)² / DRIFT_HIP_MM²`` plus the same for
    the lean with ``DRIFT_LEAN_RAD``; ``hip, lean [B, T]``, references ``[B]`` (the last seed frame's). Zero while
    the root stays in the band; a drift of twice the band costs 1."""
    dh = torch.relu((hip - hip_ref[:, None]).abs() - DRIFT_HIP_MM) / DRIFT_HIP_MM
    dl = torch.relu((lean - lean_ref[:, None]).abs() - DRIFT_LEAN_RAD) / DRIFT_LEAN_RAD
    return (dh**2 + dl**2).mean()


def root_mm(model, x: torch.Tensor) -> torch.Tensor:
    """The root's 6 dims (mm and exp-map, f64) of ``model``'s normalized frames ``[B, T, O]`` (its dims_used
    start with 0..5, as every H3.6M model's here)."""
    used = model.norm.dims_used[:6]
    if used.tolist() != list(range(6)):
        raise ValueError(f"the model's first used dims are {used.tolist()}, not the root's 0..5")
    return (x[..., :6] * model.norm.std[used] + model.norm.mean[used]).double()


def scored_root_poses(model, seed: torch.Tensor, parts: list[tuple[torch.Tensor, bool]]):
    """The integrated root of a closed loop: from the first frame of ``seed [B, S, O]`` (normalized, as the model
    reads it) through ``parts``, the generated frames after it in time order, each ``(frames [B, T, O], scored)``.
    Returns ``(last seed pose, [(rot [B, T, 3, 3], trans [B, T, 3], frames) per scored part])``: the scored parts'
    poses keep the gradient through the integration; unscored parts only carry the pose forward."""
    with torch.no_grad():
        rot, trans = root_poses(root_mm(model, seed))
    seed_pose = (rot[:, -1], trans[:, -1])
    start = seed_pose
    scored = []
    for frames, keep in parts:
        if frames.shape[1] == 0:
            continue
        if keep:
            rot, trans = root_poses(root_mm(model, frames), start=start)
            scored.append((rot, trans, frames))
        else:
            with torch.no_grad():
                rot, trans = root_poses(root_mm(model, frames), start=start)
        start = (rot[:, -1], trans[:, -1])
    if not scored:
        raise ValueError("a closed loop's root needs at least one scored part")
    return seed_pose, scored


def drift_penalty(model, seed: torch.Tensor, parts: list[tuple[torch.Tensor, bool]]) -> torch.Tensor:
    """``drift_loss`` of a closed loop (``scored_root_poses``' ``seed`` and ``parts``): hip height and lean are
    measured against the last seed frame's on the frames of the scored parts."""
    return drift_of_poses(*scored_root_poses(model, seed, parts))


def drift_of_poses(seed_pose, scored) -> torch.Tensor:
    """``drift_penalty`` from ``scored_root_poses``' result (a loop integrated once for several terms)."""
    hip_s, lean_s = hip_and_lean(*seed_pose)
    hips, leans = zip(*(hip_and_lean(rot, trans) for rot, trans, _ in scored))
    return drift_loss(torch.cat(hips, 1), torch.cat(leans, 1), hip_s, lean_s)
