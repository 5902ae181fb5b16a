"""Takes on their own rig for ``training/locomotion.py --takes``: a folder written by ``motion-cli takes export``
(``motion_core::takes::training``: ``takes.json``, ``rig.bvh``, one ``NAME.npy`` of exp-map frames per take, the
root as per-frame deltas), or a folder of BVH takes that is exported first with the project's own take reader.

The frames of a take are decoded by ``motion_core::pose::PoseDecoder`` with step 1; the first row of each file is
the take's first root pose from the origin (absolute), every later row a delta. Training reads the rows after the
first (``Take.frames``).

Controls (``controls_of``) follow ``training/locomotion.py``'s definition on the rig: what the root does over the
next ``k`` frames in the floor frame of the pelvis heading, the heading being ``facing_of(R * rest_forward)`` with
the rig's ``rest_forward`` from ``takes.json`` (``motion_core::steering::rest_forward``). Within ``k`` frames of a
take's end the control is measured over the frames left (a velocity over their duration, the turn scaled to ``k``
frames); the last frame repeats the one before.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .metrics_np import expmap2rotmat

REPO = Path(__file__).resolve().parents[1]
FORMAT = "motion-takes"
FORMAT_VERSION = 1


@dataclass
class Take:
    name: str
    frames: np.ndarray  # [n, frame_dims] float64, rows after the file's first (deltas only)


@dataclass
class TakeSet:
    fps: float
    frame_dims: int
    rest_forward: np.ndarray  # [3]
    mm_per_unit: float
    rig_bvh: str
    takes: list[Take]
    manifest: dict


def motion_cli() -> list[str]:
    """The command that runs ``motion-cli``: ``$MOTION_CLI``, the workspace's release build, or ``cargo run``."""
    if os.environ.get("MOTION_CLI"):
        return [os.environ["MOTION_CLI"]]
    built = REPO / "target" / "release" / "motion-cli"
    if built.exists():
        return [str(built)]
    return ["cargo", "run", "--release", "-q", "--manifest-path", str(REPO / "Cargo.toml"), "-p", "motion-cli", "--"]


def export_takes(bvh_dir: Path, out: Path, joint_map: Path | None = None, exclude: list[str] | None = None,
                 fps: float = 30.0, log=print) -> None:
    """``motion-cli takes export`` of a folder of BVH takes into the new folder ``out``."""
    cmd = motion_cli() + ["takes", "export", "--takes", str(bvh_dir), "--out", str(out), "--fps", str(fps)]
    if joint_map:
        cmd += ["--joint-map", str(joint_map)]
    if exclude:
        cmd += ["--exclude", ",".join(exclude)]
    log("exporting takes: " + " ".join(cmd))
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"motion-cli takes export failed ({done.returncode}): {done.stderr.strip()}")
    log(done.stdout.strip())


def read_takes(folder: Path) -> TakeSet:
    """A folder written by ``motion-cli takes export``."""
    manifest = json.loads((folder / "takes.json").read_text())
    if manifest.get("format") != FORMAT or manifest.get("format_version") != FORMAT_VERSION:
        raise SystemExit(f"{folder / 'takes.json'}: not a {FORMAT} v{FORMAT_VERSION} folder")
    takes = []
    for t in manifest["takes"]:
        frames = np.load(folder / t["file"]).astype(np.float64)
        if frames.ndim != 2 or frames.shape[1] != manifest["frame_dims"]:
            raise SystemExit(f"{folder / t['file']}: shape {frames.shape}, expected [n, {manifest['frame_dims']}]")
        takes.append(Take(t["name"], frames[1:]))
    return TakeSet(
        fps=float(manifest["fps"]), frame_dims=int(manifest["frame_dims"]),
        rest_forward=np.asarray(manifest["rest_forward"], np.float64), mm_per_unit=float(manifest["mm_per_unit"]),
        rig_bvh=(folder / manifest["rig_file"]).read_text(), takes=takes, manifest=manifest,
    )


def load_takes(source: Path, cache: Path, joint_map: Path | None = None, exclude: list[str] | None = None,
               fps: float = 30.0, log=print) -> TakeSet:
    """``source`` as a take set: an exported folder as it is, a folder of BVH takes exported to ``cache`` first
    (``cache`` is replaced)."""
    if (source / "takes.json").exists():
        if joint_map or exclude:
            raise SystemExit(f"{source} is an exported folder: --joint-map and --exclude apply when exporting")
        return read_takes(source)
    if cache.exists():
        shutil.rmtree(cache)
    export_takes(source, cache, joint_map, exclude, fps, log)
    return read_takes(cache)


def root_trajectory(frames: np.ndarray, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Absolute root rotations ``[n, 3, 3]`` (row vectors) and translations ``[n, 3]`` (mm) of frames whose dims
    0..5 are root deltas each applied ``step`` times, from the identity (``motion_core::root``)."""
    steps = expmap2rotmat(frames[:, 3:6])
    rot = np.eye(3)
    trans = np.zeros(3)
    rots, transes = [], []
    for t in range(frames.shape[0]):
        d = frames[t, 0:3]
        for _ in range(step):
            trans = trans + d @ rot
            rot = steps[t] @ rot
        rots.append(rot)
        transes.append(trans)
    return np.stack(rots), np.stack(transes)


def headings(rots: np.ndarray, rest_forward: np.ndarray) -> np.ndarray:
    """Pelvis heading (radians, 0 facing +z, pi/2 facing +x) of absolute root rotations ``[n, 3, 3]``: the rest
    forward as a row vector times ``R``, on the floor."""
    forward = rest_forward @ rots
    return np.arctan2(forward[:, 0], forward[:, 2])


def wrap(angle):
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def controls_of(frames: np.ndarray, k: int, fps: float, rest_forward: np.ndarray, step: int = 1) -> np.ndarray:
    """Controls ``[n, 3]`` (forward m/s, side m/s, turn rad over ``k`` frames) of every frame (see the module
    docs for the last ``k``)."""
    rots, trans = root_trajectory(frames, step)
    h = headings(rots, rest_forward)
    n = frames.shape[0]
    out = np.zeros((n, 3))
    for t in range(n - 1):
        span = min(k, n - 1 - t)
        d = (trans[t + span] - trans[t]) / 1000.0 / (span / fps)
        s, c = np.sin(h[t]), np.cos(h[t])
        out[t] = [d[0] * s + d[2] * c, d[0] * c - d[2] * s, wrap(h[t + span] - h[t]) * k / span]
    if n > 1:
        out[n - 1] = out[n - 2]
    return out


def validation_names(names: list[str], every: int = 6) -> list[str]:
    """The validation takes (the rule, fixed before any run was scored): in name order, every ``every``-th take
    starting with the ``every``-th (indices ``every - 1``, ``2 * every - 1``, ...)."""
    ordered = sorted(names)
    return [n for i, n in enumerate(ordered) if i % every == every - 1]
