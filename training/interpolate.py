"""`python -m training.interpolate`: weight interpolation between a model and its fine-tune, chosen on validation.

WiSE-FT (Wortsman et al., 2022): ``θ(α) = (1 − α) θ_A + α θ_B`` for a model A and a fine-tune B of it (same
architecture and config, e.g. the shipped VGRU-d and a long-horizon fine-tune started from it with
``train.py --init-weights``). Each α is saved as the file that would ship (``--dtype``, default f16) and scored,
reloaded from that file, on the S5 **validation** windows: the protocol's mean reference NPSS (4 s) and the 8-12 s
speed ratio per action of a 300-frame closed loop (``long_horizon.speed_ratios``, plan noise 0).

The choice rule (fixed before any interpolation was scored): eligible are the α > 0 whose validation
NPSS is at most ``1 + NPSS_SLACK`` times α = 0's (the short-term fit kept within 10 %); among them the most actions
with an 8-12 s speed ratio >= ``long_horizon.ELIGIBLE_RATIO``, ties to the lower NPSS; none when no α > 0 is
eligible. α = 0 is always scored (it is the reference of the rule).

    python -m training.interpolate --a weights/vgru_d_multi.safetensors --b training/runs/vgru_alive_d/best.pt \\
        --alphas 0.25,0.5,0.75,1 --out-dir /tmp/wise

``--export ALPHA --out FILE`` writes one blend without scoring it, its provenance holding both parents' (how the
game default's blend was made, ``training/README.md``).
"""

from __future__ import annotations

import argparse
import datetime
import json
import shlex
import sys
from pathlib import Path

import numpy as np
import torch

from . import data as h36m
from .evaluate import load_model
from .export import load_weights, read_metadata, save_weights
from .long_horizon import ELIGIBLE_RATIO, long_closed_loop, speed_ratios
from .train import Validator

NPSS_SLACK = 0.10


def interpolate(a: dict[str, torch.Tensor], b: dict[str, torch.Tensor], alpha: float) -> dict[str, torch.Tensor]:
    """``(1 − alpha) a + alpha b`` for floating-point tensors (computed in f64, stored in ``a``'s dtype); other
    tensors are ``a``'s. The two state dicts must have the same names and shapes."""
    if a.keys() != b.keys():
        raise ValueError(f"the models differ in their tensors: {sorted(a.keys() ^ b.keys())[:5]}")
    out = {}
    for name, ta in a.items():
        tb = b[name]
        if ta.shape != tb.shape:
            raise ValueError(f"{name}: shape {tuple(ta.shape)} against {tuple(tb.shape)}")
        if ta.is_floating_point():
            out[name] = ((1.0 - alpha) * ta.double() + alpha * tb.double()).to(ta.dtype)
        else:
            out[name] = ta.clone()
    return out


def choose(rows: list[dict]) -> dict | None:
    """The module doc's rule over rows ``{"alpha", "npss_ref", "awake"}`` (one with alpha 0)."""
    base = next(r["npss_ref"] for r in rows if r["alpha"] == 0)
    eligible = [r for r in rows if r["alpha"] > 0 and r["npss_ref"] <= (1.0 + NPSS_SLACK) * base]
    return max(eligible, key=lambda r: (r["awake"], -r["npss_ref"]), default=None)


def provenance_of(path: str) -> dict:
    """The provenance a weights file carries (empty for a training checkpoint, which has none)."""
    if not path.endswith(".safetensors"):
        return {}
    return json.loads(read_metadata(path).get("provenance", "{}"))


def blend_provenance(a: str, b: str, alpha: float, command: str, choice: str | None, date: str) -> dict:
    """The provenance of ``(1 - alpha) A + alpha B`` written by ``--export``: both parents' own provenance kept."""
    pa, pb = provenance_of(a), provenance_of(b)
    prov = {
        "data": pa.get("data") or pb.get("data") or "unknown",
        "date": date,
        "command": command,
        "export_command": command,
        "iterations": [pa.get("iterations"), pb.get("iterations")],
        "weights": f"WiSE-FT interpolation {1 - alpha:g} x A + {alpha:g} x B of the two files' tensors (in f64)",
        "interpolated": [{"file": a, "weight": 1 - alpha, "provenance": pa},
                         {"file": b, "weight": alpha, "provenance": pb}],
    }
    if choice:
        prov["checkpoint_choice"] = choice
    return prov


def export_blend(a: str, b: str, alpha: float, out: str, dtype: torch.dtype, command: str,
                 choice: str | None = None) -> None:
    """Writes ``(1 - alpha) A + alpha B`` to ``out`` (A's config, e.g. its noise scale) with its provenance."""
    model_a, model_b = load_model(a), load_model(b)
    if model_a.config != model_b.config:
        raise ValueError("the two models have different configs (B must be a fine-tune of A)")
    model_a.load_state_dict(interpolate(model_a.state_dict(), model_b.state_dict(), alpha))
    date = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat()
    save_weights(model_a, out, blend_provenance(a, b, alpha, command, choice, date), dtype=dtype)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m training.interpolate", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--a", required=True, help="the base model (.safetensors or .pt)")
    p.add_argument("--b", required=True, help="its fine-tune (.safetensors or .pt)")
    p.add_argument("--alphas", default="0.25,0.5,0.75,1", help="weights of B, comma-separated (0 is always added)")
    p.add_argument("--out-dir", default=None, help="where the interpolated files go (alpha_0.25.safetensors, ...)")
    p.add_argument("--dtype", choices=["float32", "float16", "bfloat16"], default="float16")
    p.add_argument("--data-dir", default=None)
    p.add_argument("--val-per-action", type=int, default=4)
    p.add_argument("--json", action="store_true")
    p.add_argument("--export", type=float, default=None, metavar="ALPHA",
                   help="write only (1 - ALPHA) A + ALPHA B to --out, with both parents' provenance (no scoring)")
    p.add_argument("--out", default=None, help="the file --export writes")
    p.add_argument("--choice", default=None, help="how ALPHA was chosen, stored in the provenance")
    args = p.parse_args(argv)
    dtype = {"float32": torch.float32, "float16": torch.float16, "bfloat16": torch.bfloat16}[args.dtype]
    if args.export is not None:
        if not args.out or not 0.0 <= args.export <= 1.0:
            print("error: --export ALPHA needs --out FILE and 0 <= ALPHA <= 1", file=sys.stderr)
            return 2
        command = "python -m training.interpolate " + " ".join(
            shlex.quote(x) for x in (sys.argv[1:] if argv is None else argv))
        try:
            export_blend(args.a, args.b, args.export, args.out, dtype, command, args.choice)
        except (OSError, ValueError, KeyError, RuntimeError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        print(f"wrote {args.out} ({1 - args.export:g} x {args.a} + {args.export:g} x {args.b})")
        return 0
    try:
        alphas = sorted({0.0} | {float(x) for x in args.alphas.split(",") if x.strip()})
    except ValueError:
        print(f"error: --alphas {args.alphas!r}: numbers separated by commas, e.g. 0.25,0.5", file=sys.stderr)
        return 2
    try:
        model_a, model_b = load_model(args.a), load_model(args.b)
        if model_a.config != model_b.config:
            raise ValueError("the two models have different configs (B must be a fine-tune of A)")
    except (OSError, ValueError, KeyError, RuntimeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if not args.out_dir:
        print("error: --out-dir is needed to score interpolations (or --export ALPHA --out FILE)", file=sys.stderr)
        return 2
    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stats = h36m.NormStats(mean=model_a.norm.mean.double().numpy(), std=model_a.norm.std.double().numpy(),
                           dims_used=np.array(model_a.dims_used, dtype=np.int64))
    actions = model_a.actions or list(h36m.ACTIONS)
    windows = h36m.validation_windows(Path(args.data_dir) if args.data_dir else None, actions, args.val_per_action,
                                      log=lambda m: None)
    validator = Validator(windows, stats, actions, int(model_a.config["seed_frames"]), int(model_a.config["horizon"]))
    sa, sb = model_a.state_dict(), model_b.state_dict()
    rows = []
    for alpha in alphas:
        model_a.load_state_dict(interpolate(sa, sb, alpha))
        path = out_dir / f"alpha_{alpha:.2f}.safetensors"
        save_weights(model_a, str(path), {"interpolation": f"{1 - alpha:g} x {args.a} + {alpha:g} x {args.b}"},
                     dtype=dtype)
        shipped = load_weights(str(path))
        val = validator(shipped)
        eps = torch.zeros(shipped.plan_size) if hasattr(shipped, "plan") else None
        ratios = speed_ratios(long_closed_loop(shipped, validator, eps), validator)
        row = {"alpha": alpha, "file": str(path), "npss_ref": val["npss_ref"],
               "awake": sum(r >= ELIGIBLE_RATIO for r in ratios.values()), "speed_8_12": ratios}
        rows.append(row)
        if not args.json:
            print(f"alpha {alpha:.2f}: validation npss_ref {row['npss_ref']:.4f}, 8-12 s ratio >= {ELIGIBLE_RATIO} "
                  f"on {row['awake']}/{len(ratios)}: " + " ".join(f"{a} {r:.2f}" for a, r in ratios.items()),
                  flush=True)
    chosen = choose(rows)
    if args.json:
        print(json.dumps({"rows": rows, "chosen": chosen["alpha"] if chosen else None}))
    else:
        print(f"chosen: alpha {chosen['alpha']:.2f} ({chosen['file']})" if chosen else
              f"chosen: none (no alpha > 0 within {NPSS_SLACK:.0%} of alpha 0's validation NPSS)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
