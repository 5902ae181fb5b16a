"""Body-frame forward kinematics of H3.6M frames in torch, and the smoothness term built on it (issue 20).

Convention (``../shared/reference/h36m.md``, "Skeleton"; the same as ``motion_core``'s FK): row vectors,
``W_j = R_j · W_p`` and ``x_j = offset_j · W_p + x_p`` for child ``j`` of ``p``, ``R_j = expmap2rotmat(angles of
j)``. *Body frame*: the root's rotation and translation are left out (``W_0 = I``, ``x_0 = offset_0``): in the data
they are per-frame deltas, and what this module measures (how the limbs move relative to the body) does not need
them. Units: millimetres, y up, as the skeleton's offsets.

Why: NDMS (Tanke et al. 2021, ``metrics.md``) compares the frame-to-frame velocities of 12 joint *positions* with those
of the nearest real motion word. The exp-map speed and acceleration terms of ``long_horizon`` pool every angle,
and real data's small joints are rough at 25 Hz (their second difference is 0.8-1.2 times their first), so a
generator whose legs and arms jitter (successive position velocities 0.75 cosine-similar against real motion's
0.93) meets them. ``roughness_loss`` measures the roughness where NDMS does: on the positions of its joints.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import torch

from .data import REFERENCE_DIR
from .root_drift import expmap_rotmat

SKELETON = REFERENCE_DIR / "h36m_skeleton.json"
ROUGH_SPEED_FLOOR = 0.1  # mm per frame added to both speeds: joints at rest do not dominate the ratio
ROUGH_BAND = 1.2  # no penalty while a joint's roughness is within this factor of the truth's


@lru_cache(maxsize=4)
def skeleton(path: Path = SKELETON) -> tuple[list[int], torch.Tensor, list[list[int]], list[int]]:
    """``(parents, offsets [J, 3] f64, expmap_dims per joint, ndms joint indices)`` of an H3.6M skeleton file;
    ValueError naming the file when it is missing or not one (parents must precede their children)."""
    try:
        doc = json.loads(Path(path).read_text())
        joints = doc["joints"]
        parents = [int(j["parent"]) for j in joints]
        offsets = torch.tensor([j["offset_mm"] for j in joints], dtype=torch.float64)
        dims = [list(map(int, j["expmap_dims"])) for j in joints]
        ndms = [int(i) for v in doc["ndms_joints"].values() for i in v]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: not a readable H3.6M skeleton ({e})") from e
    if any(p >= i for i, p in enumerate(parents)) or parents[0] != -1 or offsets.shape != (len(joints), 3):
        raise ValueError(f"{path}: joints must list each parent before its children, the root first")
    return parents, offsets, dims, ndms


def body_positions(frames: torch.Tensor, joints: list[int] | None = None, path: Path = SKELETON) -> torch.Tensor:
    """Joint positions ``[..., len(joints), 3]`` (mm, body frame; module doc) of full exp-map frames ``[..., 99]``
    (un-normalized); ``joints`` defaults to all 32. Differentiable."""
    parents, offsets, dims, _ = skeleton(path)
    offsets = offsets.to(dtype=frames.dtype, device=frames.device)
    lead = frames.shape[:-1]
    eye = torch.eye(3, dtype=frames.dtype, device=frames.device).expand(*lead, 3, 3)
    world, pos = [eye], [offsets[0].expand(*lead, 3)]
    for j in range(1, len(parents)):
        p = parents[j]
        rot = expmap_rotmat(frames[..., dims[j]])
        world.append(rot @ world[p])
        pos.append((offsets[j] @ world[p]) + pos[p])
    wanted = range(len(parents)) if joints is None else joints
    return torch.stack([pos[j] for j in wanted], -2)


def roughness(positions: torch.Tensor) -> torch.Tensor:
    """Per joint, over every sequence and frame of ``positions [B, T, J, 3]``: mean |second difference| / (mean
    |first difference| + ``ROUGH_SPEED_FLOOR``), ``[J]``. 0 for uniform motion; jitter raises it, speed alone
    does not."""
    v = (positions[:, 1:] - positions[:, :-1]).norm(dim=-1)
    a = (positions[:, 2:] - 2 * positions[:, 1:-1] + positions[:, :-2]).norm(dim=-1)
    return a.mean(dim=(0, 1)) / (v.mean(dim=(0, 1)) + ROUGH_SPEED_FLOOR)


def roughness_loss(model, pred: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
    """Squared excess of each NDMS joint's ``roughness`` in ``pred`` over ``ROUGH_BAND`` times the truth's, as a
    fraction of the truth's, averaged over the joints; ``pred`` and ``truth`` are ``model``'s normalized frames
    ``[B, T, O]`` (T >= 3). Zero while the generated limbs move as smoothly as real ones."""
    _, _, _, ndms = skeleton()
    p = body_positions(model.norm.unnormalize(pred), ndms)
    with torch.no_grad():
        t = roughness(body_positions(model.norm.unnormalize(truth), ndms)).clamp_min(0.05)
    return (torch.relu(roughness(p) / t - ROUGH_BAND) ** 2).mean()
