"""The rule that picks the game default (the model `Character`, `predict` and the engines load when given none)
from `motion-cli eval --windows validation --horizon 1500 --json` reports, and the table of what each candidate does.

    motion-cli eval --model FILE --windows validation --horizon 1500 --no-classifier --json > FILE.val.json
    python -m training.select_game FILE.val.json ...

The rule (written before any candidate of the action-conditioned intention runs was scored):

1. Only action-conditioned files are eligible (the engines switch actions with `set_action`).
2. Per action, *alive* means every grounded speed-ratio window to 60 s (0-2, 2-4, 4-8, 8-12, 12-20, ... 50-60 s) is
   at least 0.5 (the body-frame joint speed against the action's real speed).
3. The most actions alive wins; ties go to the highest mean over actions of the smallest fraction of frames whose
   lowest foot is within 0.1 m of the floor (grounded, over the windows).

`--rule targets` (written before any candidate of the crouch-penalty runs, `train_intention.py --crouch-weight`,
was scored): conditioned files only; the most actions meeting all five targets of the table (alive, on-floor
fraction >= 0.95, skating within the real S5 continuation's + 0.05, lean p95 within the real p95, hip p5 at or above
the real p5) wins; ties go to the smallest hip shortfall under the real p5 summed over the actions (mm), then to the
report listed first (list the incumbent first).

`--readme` (a precondition written 2026-12-07, after a candidate met all five targets on every validation action and
slowed the README example): a candidate is eligible only if its README example passes, read from ``X.readme.json``
beside its report ``X.json`` (`training/readme_check.py`: `motion-cli predict --seed examples/walk_seed.bvh --action
walking --frames 1500` per rng seed, scored by `motion-cli score`): in every window of every rng seed, speed ratio
>= 0.5, no frame with both feet over 0.1 m above the floor, hip height and lean change within real walking's p95.

Validation windows only (8 per action, disjoint from every test window); the test windows are scored once, for the
chosen file, afterwards. Besides the rule, the table shows the issue's other targets per action (grounded): lean p95
against the real p95, hip height within the real p5-p95, on-floor fraction >= 0.95, skating within the real S5
continuation's + 0.05, and the `drift` measure (the smallest share over the windows of sequences whose hip height and
lean change from the seed stay within the real 95th percentile; no rule reads it). Standard library only.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ALIVE = 0.5
ON_FLOOR = 0.95
SKATING_MARGIN = 0.05


def action_rows(report: dict) -> list[dict]:
    """Per action: the numbers of the table and of the rule."""
    rows = []
    for a in report["actions"]:
        raw, grounded = a["model"], a["model_grounded"]
        speed_raw = min(w["ratio"] for w in raw["speed_ratio"]["windows"])
        speed = min(w["ratio"] for w in grounded["speed_ratio"]["windows"])
        ground = grounded["ground"]
        real = ground["real"]
        wins = ground["windows"]
        rows.append({
            "action": a["action"],
            "speed_raw": speed_raw,
            "speed": speed,
            "alive": speed >= ALIVE,
            "on_floor": min(w["on_floor_fraction"] for w in wins),
            "penetrating": max(w["penetration_fraction"] for w in wins),
            "skating": max(w["skating_fraction"] for w in wins),
            "real_skating": real["s5_skating_fraction"],
            "lean": max(w["lean_p95_deg"] for w in wins),
            "real_lean": real["lean_p95_deg"],
            "hip_low": min(w["hip_height_p5_mm"] for w in wins),
            "hip_high": max(w["hip_height_p95_mm"] for w in wins),
            "real_hip": (real["hip_height_p5_mm"], real["hip_height_p95_mm"]),
        })
        r = rows[-1]
        r["drift"] = drift_within(grounded.get("drift"))
        r["hip_short"] = max(0.0, r["real_hip"][0] - r["hip_low"])
        r["all_targets"] = (r["alive"] and r["on_floor"] >= ON_FLOOR and r["skating"] <= r["real_skating"] + SKATING_MARGIN
                            and r["lean"] <= r["real_lean"] and r["hip_short"] == 0.0)
    return rows


def drift_within(drift: dict | None) -> tuple[float, float] | None:
    """The smallest share over the windows of sequences whose hip height change and lean change from the seed stay
    within the real 95th percentile (`motion-cli eval`'s `drift`), or None when the report has none."""
    windows = [w for w in (drift or {}).get("windows", []) if w.get("hip_height_within_p95") is not None]
    if not windows:
        return None
    return (min(w["hip_height_within_p95"] for w in windows), min(w["lean_within_p95"] for w in windows))


def verdict(report: dict) -> dict:
    rows = action_rows(report)
    conditioned = bool(report["model"]["actions"])
    return {
        "source": report["model"]["source"],
        "windows": report["protocol"]["windows"],
        "conditioned": conditioned,
        "alive": sum(r["alive"] for r in rows),
        "actions": len(rows),
        "floor": sum(r["on_floor"] for r in rows) / max(1, len(rows)),
        "targets": sum(r["all_targets"] for r in rows),
        "hip_short": sum(r["hip_short"] for r in rows),
        "rows": rows,
    }


def readme_verdict(readme: dict) -> dict:
    """Whether the README example passes (module doc), and its smallest speed ratio over windows and rng seeds."""
    reports = readme["reports"]
    if not reports:
        raise ValueError("no rng seed scored")
    speeds = [w["ratio"] for r in reports for w in r["speed_ratio"]["windows"]]
    grounded = all(w["airborne_fraction"] == 0.0 for r in reports for w in r["foot_contact"]["windows"])
    upright = all(w["hip_height_within_p95"] == 1.0 and w["lean_within_p95"] == 1.0
                  for r in reports for w in r["drift"]["windows"])
    return {"passes": min(speeds) >= ALIVE and grounded and upright, "min_speed": min(speeds),
            "grounded": grounded, "upright": upright, "seeds": len(reports)}


def readme_path(report: Path) -> Path:
    """Where `--readme` reads a report's README example: ``X.json`` -> ``X.readme.json``."""
    return report.with_name(report.stem + ".readme.json")


def key(v: dict) -> tuple:
    """Sort key of the default rule (smaller is better)."""
    return (not v["conditioned"], -v["alive"], -v["floor"])


def key_targets(v: dict) -> tuple:
    """Sort key of `--rule targets` (smaller is better; `min` keeps the first of equals)."""
    return (not v["conditioned"], -v["targets"], round(v["hip_short"], 1))


def table(v: dict) -> str:
    readme = v.get("readme")
    readme_text = "" if readme is None else (
        f"; README example over {readme['seeds']} rng seeds: smallest speed ratio {readme['min_speed']:.3f}"
        f"{'' if readme['grounded'] else ', off the floor'}{'' if readme['upright'] else ', drifting'}"
        f"{'' if readme['passes'] else ' (fails: not eligible)'}")
    out = [f"`{v['source']}` ({v['windows']} windows): alive on {v['alive']} of {v['actions']}, mean smallest on-floor "
           f"fraction {v['floor']:.3f}, all five targets on {v['targets']}, hip shortfall {v['hip_short']:.1f} mm"
           f"{'' if v['conditioned'] else ' (not action-conditioned: not eligible)'}{readme_text}",
           "",
           "| action | speed raw / grounded (min over windows) | on floor | penetrating | skating (real S5) | "
           "lean p95 (real) | hip p5-p95 mm (real) | drift within real p95: hip / lean |",
           "|---|---|---|---|---|---|---|---|"]
    for r in v["rows"]:
        drift = "-" if r["drift"] is None else f"{r['drift'][0]:.2f} / {r['drift'][1]:.2f}"
        out.append(
            f"| {r['action']} | {r['speed_raw']:.2f} / {r['speed']:.2f}{'' if r['alive'] else ' (frozen)'} | "
            f"{r['on_floor']:.2f} | {r['penetrating']:.2f} | {r['skating']:.2f} ({r['real_skating']:.2f}) | "
            f"{r['lean']:.1f} ({r['real_lean']:.1f}) | {r['hip_low']:.0f}-{r['hip_high']:.0f} "
            f"({r['real_hip'][0]:.0f}-{r['real_hip'][1]:.0f}) | {drift} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m training.select_game", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("reports", nargs="+", type=Path, help="motion-cli eval --json outputs, one per candidate")
    p.add_argument("--allow-test", action="store_true", help="accept test-window reports (for the final table only)")
    p.add_argument("--rule", choices=("alive", "targets"), default="alive",
                   help="alive: the game default's rule (alive, then on floor); targets: all five targets, then the hip "
                        "shortfall (module doc)")
    p.add_argument("--readme", action="store_true",
                   help="only candidates whose README example passes are eligible, read from X.readme.json beside each "
                        "report X.json (training/readme_check.py; module doc)")
    args = p.parse_args(argv)
    verdicts = []
    for path in args.reports:
        try:
            report = json.loads(path.read_text())
            v = verdict(report)
        except (OSError, ValueError, KeyError, TypeError) as e:
            print(f"error: {path}: not a motion-cli eval --json report with grounded measures ({e})", file=sys.stderr)
            return 2
        if v["windows"] != "validation" and not args.allow_test:
            print(f"error: {path}: scored on {v['windows']} windows; the rule reads validation windows only "
                  "(--allow-test to print a table)", file=sys.stderr)
            return 2
        if args.readme:
            readme = readme_path(path)
            try:
                v["readme"] = readme_verdict(json.loads(readme.read_text()))
            except (OSError, ValueError, KeyError, TypeError) as e:
                print(f"error: {readme}: not a training/readme_check.py output ({e})", file=sys.stderr)
                return 2
        verdicts.append(v)
    for v in verdicts:
        print(table(v))
        print()
    eligible = [v for v in verdicts if v["conditioned"] and v.get("readme", {"passes": True})["passes"]]
    if eligible and not args.allow_test:
        best = min(eligible, key=key if args.rule == "alive" else key_targets)
        print(f"chosen: {best['source']} (alive on {best['alive']} of {best['actions']}, floor {best['floor']:.3f}, "
              f"all five targets on {best['targets']}, hip shortfall {best['hip_short']:.1f} mm)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
