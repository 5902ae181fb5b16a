"""Human3.6M exp-map data for training: the standard protocol of ../shared/reference/h36m.md.

Train subjects S1, S6, S7, S8, S9, S11; normalization statistics over all training frames at 50 Hz;
dims whose std is below 1e-4 are dropped (54 remain); sequences are then downsampled to 25 Hz (even frames).
Training windows are 151 consecutive 25 Hz frames (50 seed + 100 predicted + 1 target) drawn with a seeded
numpy Generator. Validation windows come from S5 and never overlap the protocol's test windows.
"""

from __future__ import annotations

import csv
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: The 15 H3.6M actions in the order of h36m.md (also the one-hot order of multi-action models).
ACTIONS = (
    "directions",
    "discussion",
    "eating",
    "greeting",
    "phoning",
    "posing",
    "purchases",
    "sitting",
    "sittingdown",
    "smoking",
    "takingphoto",
    "waiting",
    "walking",
    "walkingdog",
    "walkingtogether",
)
TRAIN_SUBJECTS = (1, 6, 7, 8, 9, 11)
VALIDATION_SUBJECT = 5
SUBACTIONS = (1, 2)
FRAME_DIMS = 99
STD_EPS = 1e-4
SEED_FRAMES = 50
HORIZON = 100
#: Frames of one training window: seed + horizon + 1 (the target of the last predicted step).
WINDOW = SEED_FRAMES + HORIZON + 1
#: Smallest start frame of a window (25 Hz), as in the protocol's sampler.
MIN_START = 16

REPO_ROOT = Path(__file__).resolve().parent.parent
REFERENCE_DIR = REPO_ROOT.parent / "shared" / "reference"


def data_root() -> Path:
    """The data directory: $MOTION_DATA_DIR, else `<repo>/../shared/data`."""
    env = os.environ.get("MOTION_DATA_DIR")
    return Path(env) if env else REPO_ROOT.parent / "shared" / "data"


def default_dataset_dir() -> Path:
    """`<data root>/h3.6m/dataset`, the folder holding S1 ... S11."""
    return data_root() / "h3.6m" / "dataset"


def sequence_path(dataset_dir: Path, subject: int, action: str, subaction: int) -> Path | None:
    """Path of `S{subject}/{action}_{subaction}.txt(.gz)`, or None when neither exists."""
    base = Path(dataset_dir) / f"S{subject}" / f"{action}_{subaction}.txt"
    for p in (base, base.with_name(base.name + ".gz")):
        if p.is_file():
            return p
    return None


def read_sequence(path: Path) -> np.ndarray:
    """One exp-map text file (plain or gzip), 50 Hz, as float64 [n, dims]. Raises ValueError naming the file."""
    try:
        arr = np.loadtxt(path, delimiter=",", dtype=np.float64, ndmin=2)
    except (ValueError, OSError, EOFError) as e:
        raise ValueError(f"{path}: cannot parse exp-map text: {e}") from e
    if arr.shape[0] == 0:
        raise ValueError(f"{path}: no frames")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{path}: non-finite values")
    return arr


def load_sequences(
    dataset_dir: Path, subjects, actions, subactions=SUBACTIONS, log=None
) -> dict[tuple[int, str, int], np.ndarray]:
    """Read every present `(subject, action, subaction)` at 50 Hz. Missing or unreadable files are reported
    once (one warning line listing them) and skipped."""
    seqs: dict[tuple[int, str, int], np.ndarray] = {}
    missing: list[str] = []
    for s in subjects:
        for a in actions:
            for sub in subactions:
                p = sequence_path(dataset_dir, s, a, sub)
                if p is None:
                    missing.append(f"S{s}/{a}_{sub}")
                    continue
                try:
                    seqs[(s, a, sub)] = read_sequence(p)
                except ValueError as e:
                    missing.append(f"S{s}/{a}_{sub} ({e})")
    if missing:
        msg = f"warning: {len(missing)} H3.6M file(s) missing or unreadable in {dataset_dir}, skipped: " + ", ".join(
            missing
        )
        (log or (lambda m: print(m, file=sys.stderr)))(msg)
    return seqs


@dataclass
class NormStats:
    """Per-dim mean/std over the full frame (std 1 for dropped dims) and the used dims."""

    mean: np.ndarray  # [frame_dims] float64
    std: np.ndarray  # [frame_dims] float64, 1 where dropped
    dims_used: np.ndarray  # [O] int64

    def normalize(self, frames: np.ndarray) -> np.ndarray:
        """Full frames [..., frame_dims] -> normalized used dims [..., O]."""
        d = self.dims_used
        return (frames[..., d] - self.mean[d]) / self.std[d]

    def unnormalize(self, norm: np.ndarray) -> np.ndarray:
        """Normalized used dims [..., O] -> full frames with dropped dims at the mean."""
        out = np.broadcast_to(self.mean, norm.shape[:-1] + self.mean.shape).copy()
        d = self.dims_used
        out[..., d] = norm * self.std[d] + self.mean[d]
        return out


def normalization_stats(sequences_50hz) -> NormStats:
    """Mean/std (ddof 0) over all given 50 Hz frames; dims with std < 1e-4 get std 1 and are dropped."""
    allf = np.concatenate(list(sequences_50hz), axis=0)
    mean = allf.mean(axis=0)
    std = allf.std(axis=0)
    used = np.nonzero(std >= STD_EPS)[0].astype(np.int64)
    std = std.copy()
    std[std < STD_EPS] = 1.0
    return NormStats(mean=mean, std=std, dims_used=used)


def minmax_stats(sequences_50hz) -> NormStats:
    """Min-max scaling to [0, 1] (Ghosh et al. 2017, section 4.1) in the NormStats form: ``mean`` holds the
    per-dim minimum and ``std`` the range (max - min) over all given 50 Hz frames, so ``normalize``
    maps the training range onto [0, 1]. The used dims are those of ``normalization_stats`` (std
    >= 1e-4); dropped dims get range 1 and are restored to their minimum (their constant value)."""
    allf = np.concatenate(list(sequences_50hz), axis=0)
    low = allf.min(axis=0)
    span = allf.max(axis=0) - low
    used = np.nonzero(allf.std(axis=0) >= STD_EPS)[0].astype(np.int64)
    span = span.copy()
    dropped = np.ones(span.shape, dtype=bool)
    dropped[used] = False
    span[dropped] = 1.0
    return NormStats(mean=low, std=span, dims_used=used)


def published_dims_used() -> list[int] | None:
    """`dims_used_by_published_models` of h36m_skeleton.json, or None if the reference is absent."""
    import json

    p = REFERENCE_DIR / "h36m_skeleton.json"
    if not p.is_file():
        return None
    return list(json.loads(p.read_text())["dims_used_by_published_models"])


def downsample(seq_50hz: np.ndarray) -> np.ndarray:
    """25 Hz: the even frames (0, 2, 4, ...)."""
    return seq_50hz[::2]


def one_hot(action_index: int, n_actions: int) -> np.ndarray:
    """One-hot float32 vector."""
    v = np.zeros(n_actions, dtype=np.float32)
    v[action_index] = 1.0
    return v


@dataclass
class TrainingSet:
    """Normalized 25 Hz training sequences (used dims only) grouped by action, plus the statistics."""

    actions: tuple[str, ...]
    stats: NormStats
    # per action index: list of (key, [n, O] float32 normalized 25 Hz)
    by_action: list[list[tuple[tuple[int, str, int], np.ndarray]]] = field(default_factory=list)

    @property
    def out_dims(self) -> int:
        """Number of used (predicted) dims."""
        return len(self.stats.dims_used)

    def sample_batch(self, rng: np.random.Generator, batch: int, window: int = WINDOW):
        """`batch` windows: action uniform over the actions given (with data), then a sequence of it uniformly,
        then a start uniform in [16, n - window). Returns (frames [B, window, O] float32, action_idx [B] int64)."""
        present = [i for i, seqs in enumerate(self.by_action) if seqs]
        frames = np.empty((batch, window, self.out_dims), dtype=np.float32)
        acts = np.empty(batch, dtype=np.int64)
        for b in range(batch):
            ai = present[int(rng.integers(len(present)))]
            seqs = self.by_action[ai]
            _, seq = seqs[int(rng.integers(len(seqs)))]
            start = int(rng.integers(MIN_START, seq.shape[0] - window))
            frames[b] = seq[start : start + window]
            acts[b] = ai
        return frames, acts


def load_training_set(
    dataset_dir: Path | None = None, actions=ACTIONS, subjects=TRAIN_SUBJECTS, log=None, scaling: str = "standard"
) -> TrainingSet:
    """Load the training subjects for `actions`. Normalization statistics are computed over ALL training frames
    of all 15 actions (the protocol's statistics do not depend on the actions a model is trained on):
    `scaling` "standard" (mean/std) or "min-max" (to [0, 1], `minmax_stats`)."""
    dataset_dir = Path(dataset_dir) if dataset_dir else default_dataset_dir()
    seqs = load_sequences(dataset_dir, subjects, ACTIONS, log=log)
    if not seqs:
        raise FileNotFoundError(f"no H3.6M training files found under {dataset_dir} (set MOTION_DATA_DIR)")
    if scaling not in ("standard", "min-max"):
        raise ValueError(f"unknown scaling {scaling!r}; expected 'standard' or 'min-max'")
    stats = normalization_stats(seqs.values()) if scaling == "standard" else minmax_stats(seqs.values())
    actions = tuple(actions)
    by_action: list[list] = []
    for a in actions:
        lst = []
        for key in sorted(k for k in seqs if k[1] == a):
            s25 = downsample(seqs[key])
            if s25.shape[0] <= MIN_START + WINDOW:
                continue
            lst.append((key, stats.normalize(s25).astype(np.float32)))
        by_action.append(lst)
    if not any(by_action):
        raise FileNotFoundError(f"no training sequences for actions {actions} under {dataset_dir}")
    return TrainingSet(actions=actions, stats=stats, by_action=by_action)


# ---------------------------------------------------------------- validation windows (S5, disjoint from test)


def read_test_windows(path: Path | None = None) -> list[dict]:
    """Rows of h36m_test_windows.csv (comment lines skipped): action, sample, subaction, seed_start,
    predict_start (ints where numeric)."""
    path = Path(path) if path else REFERENCE_DIR / "h36m_test_windows.csv"
    rows = []
    with open(path, newline="") as f:
        lines = [ln for ln in f if ln.strip() and not ln.lstrip().startswith("#")]
    for r in csv.DictReader(lines):
        rows.append(
            {
                "action": r["action"],
                "sample": int(r["sample"]),
                "subaction": int(r["subaction"]),
                "seed_start": int(r["seed_start"]),
                "predict_start": int(r["predict_start"]),
            }
        )
    return rows


def test_intervals(rows) -> dict[tuple[str, int], list[tuple[int, int]]]:
    """Per (action, subaction): the 25 Hz half-open intervals [seed_start, predict_start + 100) of test windows."""
    out: dict[tuple[str, int], list[tuple[int, int]]] = {}
    for r in rows:
        out.setdefault((r["action"], r["subaction"]), []).append((r["seed_start"], r["predict_start"] + HORIZON))
    return out


def free_window_starts(n: int, blocked: list[tuple[int, int]], length: int, stride: int | None = None) -> list[int]:
    """Window starts (greedy tiling left to right, from MIN_START, every `stride` frames; default `length`, i.e.
    non-overlapping) of `length` frames in a sequence of n frames that avoid every blocked half-open interval."""
    stride = length if stride is None else stride
    if stride < 1:
        raise ValueError(f"window stride must be >= 1, got {stride}")
    starts = []
    t = MIN_START
    blocked = sorted(blocked)
    while t + length <= n:
        clash = [b for b in blocked if t < b[1] and b[0] < t + length]
        if clash:
            t = max(b[1] for b in clash)
            continue
        starts.append(t)
        t += stride
    return starts


@dataclass
class ValidationWindow:
    """One fixed S5 window: 50 seed + 100 ground-truth frames at 25 Hz (full frames, 50 Hz file's even frames)."""

    action: str
    subaction: int
    start: int  # 25 Hz frame of the first seed frame
    frames: np.ndarray  # [150, frame_dims] float64


def validation_windows(
    dataset_dir: Path | None = None, actions=ACTIONS, per_action: int = 4, test_rows=None, log=None,
    stride: int | None = None,
) -> list[ValidationWindow]:
    """Deterministic S5 windows of 150 frames, `per_action` per action (fewer if the free frames do not allow),
    disjoint from every test window of h36m_test_windows.csv. Candidates are tiled per file (every `stride`
    frames; by default windows do not overlap each other); the chosen ones alternate between subactions and are
    spread evenly over each file's candidates."""
    dataset_dir = Path(dataset_dir) if dataset_dir else default_dataset_dir()
    rows = read_test_windows() if test_rows is None else test_rows
    blocked = test_intervals(rows)
    length = SEED_FRAMES + HORIZON
    seqs = load_sequences(dataset_dir, [VALIDATION_SUBJECT], actions, log=log)
    out: list[ValidationWindow] = []
    for a in actions:
        cands: dict[int, list[int]] = {}
        s25: dict[int, np.ndarray] = {}
        for sub in SUBACTIONS:
            if (VALIDATION_SUBJECT, a, sub) not in seqs:
                continue
            s25[sub] = downsample(seqs[(VALIDATION_SUBJECT, a, sub)])
            cands[sub] = free_window_starts(s25[sub].shape[0], blocked.get((a, sub), []), length, stride)
        # round-robin over subactions, each file's candidates taken spread out (evenly spaced indices)
        picks: list[tuple[int, int]] = []
        order = {sub: _spread(len(c)) for sub, c in cands.items()}
        while len(picks) < per_action and any(order.values()):
            for sub in sorted(order):
                if order[sub] and len(picks) < per_action:
                    picks.append((sub, cands[sub][order[sub].pop(0)]))
        for sub, st in picks:
            out.append(ValidationWindow(action=a, subaction=sub, start=st, frames=s25[sub][st : st + length].copy()))
    return out


def _spread(n: int) -> list[int]:
    """Indices 0..n-1 in an order that spreads early picks over the range (middle, then quarters, ...)."""
    if n == 0:
        return []
    order: list[int] = []
    frac = [0.5]
    seen = set()
    while len(order) < n:
        nxt = []
        for f in frac:
            i = min(n - 1, int(f * n))
            if i not in seen:
                seen.add(i)
                order.append(i)
        step = 1.0 / (2 * len(frac) * 2)
        frac = [f + d for f in frac for d in (-step, step)]
        if step < 1.0 / (4 * n):
            break
    order += [i for i in range(n) if i not in seen]
    return order

