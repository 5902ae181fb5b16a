"""The README's first example with one model file, per rng seed, for `select_game.py --readme`:

    motion-cli predict --seed examples/walk_seed.bvh --action walking --frames 1500 --rng-seed S --model FILE --out P
    motion-cli score --pred P --seed-frames 50 --action walking --metric speed_ratio,drift,foot_contact --json

written as one JSON file ``{"model": FILE, "rng_seeds": [...], "reports": [score report per seed]}``. Name it after
the candidate's eval report (``X.val.json`` -> ``X.val.readme.json``), where `select_game.py --readme` looks:

    python -m training.readme_check --model FILE --out FILE.val.readme.json [--seeds 8]

Needs the built CLI (``cargo build --release -p motion-cli``) and the H3.6M data (``MOTION_DATA_DIR`` or
``../shared/data`` or ``--data``, for the real walking statistics). Standard library only.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
FRAMES = 1500
SEED_FRAMES = 50


def run_seed(cli: Path, model: Path, rng_seed: int, workdir: Path, data: Path | None) -> dict:
    """The score report of one rng seed's 60 s README walk."""
    out = workdir / f"walk{rng_seed}.bvh"
    subprocess.run([str(cli), "predict", "--seed", str(REPO / "examples/walk_seed.bvh"), "--action", "walking",
                    "--frames", str(FRAMES), "--rng-seed", str(rng_seed), "--model", str(model), "--out", str(out)],
                   check=True, capture_output=True)
    scored = subprocess.run([str(cli), "score", "--pred", str(out), "--seed-frames", str(SEED_FRAMES), "--action",
                             "walking", "--metric", "speed_ratio,drift,foot_contact", "--json",
                             *(["--data", str(data)] if data else [])],
                            check=True, capture_output=True, text=True)
    return json.loads(scored.stdout)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m training.readme_check", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", type=Path, required=True, help="the candidate's .safetensors")
    p.add_argument("--out", type=Path, required=True, help="where the JSON goes (X.val.readme.json beside X.val.json)")
    p.add_argument("--seeds", type=int, default=8, help="rng seeds 0 .. N-1 (default 8)")
    p.add_argument("--data", type=Path, default=None,
                   help="H3.6M data root for the real walking statistics (default: motion-cli's: $MOTION_DATA_DIR, "
                        "then ../shared/data)")
    p.add_argument("--cli", type=Path, default=REPO / "target/release/motion-cli", help="the motion-cli binary")
    args = p.parse_args(argv)
    if not args.cli.is_file():
        print(f"error: {args.cli}: no motion-cli binary (cargo build --release -p motion-cli)", file=sys.stderr)
        return 2
    if not args.model.is_file():
        print(f"error: {args.model}: no such model file", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        try:
            reports = [run_seed(args.cli, args.model, s, Path(tmp), args.data) for s in range(args.seeds)]
        except subprocess.CalledProcessError as e:
            print(f"error: {' '.join(e.cmd[:2])} failed: {(e.stderr or b'')[-2000:]!r}", file=sys.stderr)
            return 2
    result = {"model": str(args.model), "rng_seeds": list(range(args.seeds)), "reports": reports}
    tmp_out = args.out.with_name(args.out.name + ".tmp")
    tmp_out.write_text(json.dumps(result))
    tmp_out.replace(args.out)
    print(f"wrote {args.out} ({args.seeds} rng seeds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
