"""`python -m training.evaluate`: score exported weights or training checkpoints on the S5 validation windows.

The metrics themselves (Euler conversion, Euler-angle error, NPSS, zero-velocity) live in `metrics_np`, which the
training loop imports; this module sits above both (it loads checkpoints through `train`), so no import goes in a
circle. The metric names are re-exported here for callers that use `training.evaluate.npss` and the like.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import data as h36m
from .metrics_np import (  # noqa: F401  (re-exported)
    EXPMAP_EPS,
    REPORT_FRAMES,
    REPORT_MS,
    expmap2rotmat,
    rotmat2euler,
    to_euler,
    euler_error,
    npss,
    zero_velocity,
    last_second_speed_ratio,
    score_windows,
    summarize,
    paired_bootstrap,
)
from .train import Validator, build_model, checkpoint_weights, fmt_val, load_checkpoint, positive_int


def load_model(path: str):
    """A model from an exported weights file (.safetensors) or a training checkpoint (.pt)."""
    if path.endswith(".pt"):
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
