"""Intention labels of Tanke et al. 2021 (Salzmann et al., section 3.3): k-means on training poses, then cycles merged.

The paper clusters the training poses with k-means, assigns each frame to a cluster and then "sequentially
generates intention labels by detecting cycles of cluster ids", so that labels change slowly, with 8 labels for
every dataset (its supplementary material, which has the details, is not part of the reference). This module's
reading, fixed here and used unchanged by the Rust engine (``motion_core::model::intention``):

1. **k-means** with ``clusters`` centres (default 32) on normalized used dims of the training poses (25 Hz,
   S1, S6, S7, S8, S9, S11, all 15 actions): k-means++ seeding and Lloyd iterations, seeded, in float64.
2. **Cycles**: per training sequence, the frame-wise cluster ids are cut into runs. Whenever a cluster ``a``
   comes back within ``cycle_frames`` frames (default 50, 2 s) of leaving it, every cluster visited in between
   forms a cycle with ``a``: each pair ``(a, b)`` of that cycle adds one to ``cycles[a, b]`` (symmetric).
   Walking, which alternates between a few stride poses, is a cycle; a pose held and left for good is not.
3. **Merging**: clusters start as groups of one; the two groups with the highest cycle affinity
   ``cycles(G, H) / (frames(G) * frames(H))`` are merged (dividing by the product keeps one group from
   swallowing the rest: with the square root instead, one label took 81 % of the training frames), again and again, until ``intentions`` (default 8)
   groups remain (pairs that never cycle are merged last, closest centroids first). Groups are numbered by
   their smallest cluster id. The result is the **merge table** ``merge[k]`` = intention of cluster ``k``.

A frame's intention label is then ``merge[argmin_k |x - centroid_k|^2]`` (squared Euclidean distance in
normalized space, the lower index on ties): what the engine does to label a seed. Both tables are stored in the
weights file (``labels.centroids [clusters, O]``, ``labels.merge [clusters]``).
"""

from __future__ import annotations

import numpy as np

DEFAULT_CLUSTERS = 32
DEFAULT_INTENTIONS = 8
CYCLE_FRAMES = 50


def kmeans(points: np.ndarray, k: int, seed: int = 0, iterations: int = 50) -> np.ndarray:
    """k-means++ seeding then Lloyd iterations on ``points [N, D]``; returns centroids ``[k, D]`` (float64).
    An empty cluster is re-seeded with the point farthest from its centroid."""
    if points.ndim != 2 or points.shape[0] < k:
        raise ValueError(f"k-means needs at least {k} points of shape [N, D], got {points.shape}")
    rng = np.random.default_rng(seed)
    x = points.astype(np.float64)
    centroids = np.empty((k, x.shape[1]))
    centroids[0] = x[rng.integers(x.shape[0])]
    closest = ((x - centroids[0]) ** 2).sum(1)
    for j in range(1, k):
        probs = closest / closest.sum()
        centroids[j] = x[rng.choice(x.shape[0], p=probs)]
        closest = np.minimum(closest, ((x - centroids[j]) ** 2).sum(1))
    x_sq = (x**2).sum(1)
    for _ in range(iterations):
        assign, dist = _nearest(x, x_sq, centroids)
        moved = 0.0
        for j in range(k):
            members = assign == j
            if members.any():
                new = x[members].mean(0)
            else:
                new = x[int(np.argmax(dist))]
                dist[int(np.argmax(dist))] = 0.0
            moved = max(moved, float(np.abs(new - centroids[j]).max()))
            centroids[j] = new
        if moved < 1e-7:
            break
    return centroids


def _nearest(x: np.ndarray, x_sq: np.ndarray, centroids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = x_sq[:, None] - 2.0 * x @ centroids.T + (centroids**2).sum(1)[None, :]
    assign = np.argmin(d, axis=1)
    return assign, d[np.arange(x.shape[0]), assign]


def nearest_cluster(frames: np.ndarray, centroids: np.ndarray) -> np.ndarray:
    """Cluster id of each frame ``[..., D]``: the nearest centroid by squared distance, computed as the engine
    does (sum of squared differences, lowest index on ties)."""
    flat = frames.reshape(-1, frames.shape[-1]).astype(np.float64)
    c = centroids.astype(np.float64)
    d = ((flat[:, None, :] - c[None, :, :]) ** 2).sum(-1)
    return np.argmin(d, axis=1).reshape(frames.shape[:-1])


def cycle_counts(sequences: list[np.ndarray], k: int, cycle_frames: int = CYCLE_FRAMES) -> np.ndarray:
    """Symmetric ``[k, k]`` counts of clusters that share a cycle (module doc, step 2), from per-frame cluster
    ids of each sequence."""
    counts = np.zeros((k, k), dtype=np.int64)
    for ids in sequences:
        runs = _runs(ids)
        for i, (a, start, length) in enumerate(runs):
            left = start + length
            between: set[int] = set()
            for b, b_start, _ in runs[i + 1 :]:
                if b_start - left > cycle_frames:
                    break
                if b == a:
                    for c in between:
                        counts[a, c] += 1
                        counts[c, a] += 1
                    break
                between.add(b)
    return counts


def _runs(ids: np.ndarray) -> list[tuple[int, int, int]]:
    """(cluster, first frame, frames) of each run of equal ids."""
    runs = []
    start = 0
    for t in range(1, len(ids) + 1):
        if t == len(ids) or ids[t] != ids[start]:
            runs.append((int(ids[start]), start, t - start))
            start = t
    return runs


def merge_cycles(counts: np.ndarray, sizes: np.ndarray, centroids: np.ndarray, intentions: int) -> np.ndarray:
    """The merge table (module doc, step 3): ``merge[k]`` in ``0..intentions``."""
    k = counts.shape[0]
    if not 1 <= intentions <= k:
        raise ValueError(f"cannot merge {k} clusters into {intentions} intentions")
    groups: list[list[int]] = [[j] for j in range(k)]
    while len(groups) > intentions:
        best, pair = None, None
        for i in range(len(groups)):
            for j in range(i + 1, len(groups)):
                c = counts[np.ix_(groups[i], groups[j])].sum()
                affinity = c / (max(1, sizes[groups[i]].sum()) * max(1, sizes[groups[j]].sum()))
                # never-cycling pairs rank below any cycling pair, closest mean centroids first
                gap = np.linalg.norm(centroids[groups[i]].mean(0) - centroids[groups[j]].mean(0))
                key = (1, affinity) if c > 0 else (0, -gap)
                if best is None or key > best:
                    best, pair = key, (i, j)
        i, j = pair
        groups[i] = sorted(groups[i] + groups[j])
        del groups[j]
    groups.sort(key=lambda g: g[0])
    merge = np.empty(k, dtype=np.int64)
    for label, g in enumerate(groups):
        merge[g] = label
    return merge


def fit_labels(sequences: list[np.ndarray], clusters: int = DEFAULT_CLUSTERS, intentions: int = DEFAULT_INTENTIONS,
               seed: int = 0, cycle_frames: int = CYCLE_FRAMES, max_points: int = 100_000) -> tuple[np.ndarray, np.ndarray]:
    """Centroids ``[clusters, O]`` and merge table ``[clusters]`` from normalized training sequences ``[n_i, O]``
    (k-means on at most ``max_points`` frames drawn evenly, then cycles over every frame)."""
    allf = np.concatenate(sequences, axis=0)
    step = max(1, allf.shape[0] // max_points)
    centroids = kmeans(allf[::step], clusters, seed=seed)
    ids = [nearest_cluster(s, centroids) for s in sequences]
    sizes = np.bincount(np.concatenate(ids), minlength=clusters)
    merge = merge_cycles(cycle_counts(ids, clusters, cycle_frames), sizes, centroids, intentions)
    return centroids, merge


def label(frames: np.ndarray, centroids: np.ndarray, merge: np.ndarray) -> np.ndarray:
    """Intention label of each normalized frame ``[..., O]``."""
    return merge[nearest_cluster(frames, centroids)]


def mean_run_length(sequences_labels: list[np.ndarray]) -> float:
    """Mean frames per run of equal labels (how slowly labels change)."""
    runs = [len(_runs(s)) for s in sequences_labels]
    return float(sum(len(s) for s in sequences_labels) / max(1, sum(runs)))
