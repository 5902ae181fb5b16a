"""Checkpoint files of every training script: atomic writing, checked reading, and `--resume` of a run directory.

``train`` (VGRU-d, GRU-d), ``train_classifier``, ``train_dae`` and ``train_intention`` all keep ``last.pt`` in a run
directory, written atomically, and read it back with the same checks; the rules live here once.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import torch

CHECKPOINT = "last.pt"
BEST = "best.pt"


def add_run_arguments(p: argparse.ArgumentParser, log_every: int) -> None:
    """The "run" and "export" argument groups shared by the staged trainers (``train_dae``, ``train_intention``):
    device, threads, logging, validation and checkpoint intervals, ``--resume``, ``--data-dir``; ``--export OUT
    --from CKPT --dtype``."""
    g = p.add_argument_group("run")
    g.add_argument("--device", default="cpu", help="cpu or cuda")
    g.add_argument("--threads", type=int, default=1)
    g.add_argument("--log-every", type=int, default=log_every)
    g.add_argument("--val-every", type=int, default=250)
    g.add_argument("--val-per-action", type=int, default=4)
    g.add_argument("--checkpoint-every", type=int, default=100)
    g.add_argument("--resume", action="store_true", help="continue the run in --run-dir from last.pt")
    g.add_argument("--data-dir", type=Path, default=None)
    g = p.add_argument_group("export")
    g.add_argument("--export", type=Path, metavar="OUT", help="write a weights file from --from and exit")
    g.add_argument("--from", dest="from_", type=Path, metavar="CKPT")
    g.add_argument("--dtype", default="float32", choices=["float32", "float16"])


def atomic_save(obj, path: Path) -> None:
    """torch.save to a temp file in the same directory, then rename (never a half-written checkpoint)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".pt", dir=path.parent)
    os.close(fd)
    try:
        torch.save(obj, tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def read_checkpoint(path: Path, keys, what: str) -> dict:
    """The checkpoint at ``path`` holding every key of ``keys``; ValueError naming the file (as "not a ``what``
    checkpoint") when it cannot be unpickled or lacks a key."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # noqa: BLE001 - torch.load raises many types for a file that is not a checkpoint
        raise ValueError(f"{path}: not a {what} checkpoint ({e})") from None
    if not isinstance(state, dict) or any(k not in state for k in keys):
        raise ValueError(f"{path}: not a {what} checkpoint (expected keys {', '.join(sorted(keys))})")
    return state


def begin_run(args: argparse.Namespace, given: set[str], overridable, load) -> tuple[argparse.Namespace, dict | None]:
    """The arguments and resumed checkpoint of a run in ``args.run_dir``. With ``--resume``: ``last.pt`` read by
    ``load``, its saved arguments restored except those in ``overridable`` that were given on this command line
    (``given``; ``device`` always follows this command line). Without: a run directory that already holds
    ``last.pt`` is refused (SystemExit), so that no run is overwritten by accident."""
    run_dir = args.run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = run_dir / CHECKPOINT
    if not args.resume:
        if ckpt_path.exists():
            raise SystemExit(f"error: {ckpt_path} exists: --resume it or choose another --run-dir")
        return args, None
    if not ckpt_path.is_file():
        raise SystemExit(f"error: --resume but {ckpt_path} does not exist")
    resume = load(ckpt_path)
    saved = dict(resume["args"])
    for k in tuple(overridable) + ("device",):
        if k in given or k == "device":
            saved[k] = getattr(args, k)
    return argparse.Namespace(**{**vars(args), **saved, "resume": True, "run_dir": run_dir}), resume
