"""The rule that picks a pose prior's radius for a shipped H3.6M model (``training/pose_prior.py``), from
``motion-cli eval --windows validation --horizon 1500 --no-classifier --json`` reports of the candidates (the model
without a prior first), and the table of what each does.

    motion-cli eval --model CANDIDATE --windows validation --horizon 1500 --no-classifier --json > CANDIDATE.json
    python -m training.select_prior OFF.json R2.json R1.5.json ...

The rule (written 2026-12-07 before any candidate's validation report was read):

1. **Posture within the real band**, per action: in every posture window to 60 s, the grounded model's Fréchet
   distance is at most the action's band, the largest Fréchet distance of the real continuation over the windows it
   covers (the same windows, the same frame counts: what real motion of the test subject reads), and its share of
   frames with an upper arm above the real p99 is at most 0.05 (or the real continuation's largest, if higher).
2. The **five targets** of ``training/select_game.py --rule targets`` (alive, on the floor, skating, lean, hips).
3. Among the candidates whose number of actions meeting the five targets is not below the model's without a prior,
   the most actions within the posture band wins; ties go to the largest radius (the least change to the model).

**Fine-tunes** (``--fine-tunes``, written 2026-12-07 before any fine-tune's report was read): the shipped file first,
then fine-tunes of it with the posture term (``train_intention.py --posture-weight``), and pose priors on them, in a
order fixed before scoring. A candidate is eligible when its README example passes (``select_game.py --readme``:
``X.readme.json`` beside each report, ``training/readme_check.py``) and its number of actions meeting the five
targets is not below the shipped file's; among the eligible, the most actions within the posture band wins; ties go
to the first listed (the shipped file before any fine-tune).

Validation windows only; the chosen file's test windows are scored once, afterwards. Standard library only.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .select_game import action_rows, readme_path, readme_verdict

ARMS_SHARE = 0.05


def posture_rows(report: dict) -> list[dict]:
    """Per action: the grounded model's largest Fréchet and arms share over the windows, and the real band."""
    out = []
    for a in report["actions"]:
        p = a.get("posture")
        if p is None:
            raise SystemExit(f"{report['model']['source']}: the report has no posture (an older motion-cli?)")
        real = [w["posture"] for w in p["ground_truth"] if w["posture"]]
        model = [w["posture"] for w in p["model_grounded"] if w["posture"]]
        band = max(w["frechet"] for w in real)
        arms_band = max(ARMS_SHARE, max(w["arms_above_real_p99"] for w in real))
        frechet = max(w["frechet"] for w in model)
        arms = max(w["arms_above_real_p99"] for w in model)
        out.append({"action": a["action"], "frechet": frechet, "band": band, "arms": arms, "arms_band": arms_band,
                    "within": frechet <= band and arms <= arms_band})
    return out


def verdict(report: dict) -> dict:
    targets = action_rows(report)
    posture = posture_rows(report)
    return {
        "source": report["model"]["source"],
        "windows": report["protocol"]["windows"],
        "targets": sum(r["all_targets"] for r in targets),
        "within": sum(r["within"] for r in posture),
        "actions": len(posture),
        "radius": report["model"].get("prior_radius"),
        "rows": list(zip(targets, posture)),
    }


def table(v: dict) -> str:
    out = [f"{v['source']}: {v['targets']} / {v['actions']} actions meet the five targets, {v['within']} within the "
           "posture band", "| action | five targets | Fréchet max (band) | arms above p99 max (band) |", "|---|---|---|---|"]
    for t, p in v["rows"]:
        out.append(f"| {p['action']} | {'yes' if t['all_targets'] else 'no'} | {p['frechet']:.2f} ({p['band']:.2f}) | "
                   f"{p['arms']:.2f} ({p['arms_band']:.2f}) |")
    return "\n".join(out)


def combined_table(reports: list[dict]) -> str:
    """Per action, each report's grounded Fréchet max and arms share max over the posture windows, beside the real
    band and the real-vs-real value (S5's takes against the reference)."""
    names = [Path(r["model"]["source"]).stem for r in reports]
    rows = {}
    real = {}
    for r in reports:
        for a, p in zip(r["actions"], posture_rows(r)):
            rows.setdefault(p["action"], []).append(p)
            rr = a["posture"]["real_vs_real"]
            real[p["action"]] = (p["band"], rr["frechet"] if rr else float("nan"))
    head = "| action | real band (real-vs-real) | " + " | ".join(f"{n}: Fréchet / arms above p99" for n in names) + " |"
    out = [head, "|" + "---|" * (2 + len(names))]
    within = [0] * len(names)
    for action, ps in rows.items():
        cells = []
        for i, p in enumerate(ps):
            within[i] += p["within"]
            mark = "**" if p["within"] else ""
            cells.append(f"{mark}{p['frechet']:.2f} / {p['arms']:.2f}{mark}")
        band, rvr = real[action]
        out.append(f"| {action} | {band:.2f} ({rvr:.2f}) | " + " | ".join(cells) + " |")
    out.append("| **within the band** | | " + " | ".join(f"**{w} of {len(rows)}**" for w in within) + " |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("reports", nargs="+", type=Path, help="the model without a prior first, then the candidates")
    p.add_argument("--radii", help="the candidates' radii in report order (comma list; 'off' for none)")
    p.add_argument("--table", action="store_true",
                   help="print one posture table of the reports (any windows: the shipped files' test windows) and stop")
    p.add_argument("--fine-tunes", action="store_true",
                   help="the fine-tune rule (module doc): README example a precondition, ties to the first listed")
    args = p.parse_args(argv)
    if args.table:
        print(combined_table([json.loads(path.read_text()) for path in args.reports]))
        return 0
    verdicts = []
    for path in args.reports:
        report = json.loads(path.read_text())
        if report["protocol"]["windows"] != "validation":
            print(f"{path}: not a validation report (the rule reads validation windows only)", file=sys.stderr)
            return 2
        v = verdict(report)
        if args.fine_tunes:
            readme = readme_path(path)
            try:
                v["readme"] = readme_verdict(json.loads(readme.read_text()))
            except (OSError, ValueError, KeyError) as e:
                print(f"error: {readme}: not a training/readme_check.py output ({e})", file=sys.stderr)
                return 2
        verdicts.append(v)
    radii = (args.radii or "").split(",") if args.radii else [None] * len(verdicts)
    for v, r in zip(verdicts, radii):
        v["radius"] = None if r in (None, "off") else float(r)
        print(table(v) + "\n")
    floor = verdicts[0]["targets"]
    eligible = [v for v in verdicts if v["targets"] >= floor]
    if args.fine_tunes:
        for v in verdicts:
            r = v["readme"]
            print(f"{v['source']}: README example smallest speed ratio {r['min_speed']:.3f}"
                  f"{'' if r['passes'] else ' (fails: not eligible)'}")
        eligible = [v for v in eligible if v["readme"]["passes"]]
        if not eligible:
            print("no candidate is eligible", file=sys.stderr)
            return 1
        best = max(eligible, key=lambda v: (v["within"], -verdicts.index(v)))
        print(f"chosen: {best['source']}: {best['within']} / {best['actions']} actions within the posture band, "
              f"{best['targets']} meeting the five targets (the shipped file: {floor})")
        return 0
    best = max(eligible, key=lambda v: (v["within"], v["radius"] if v["radius"] is not None else float("inf")))
    print(f"chosen: {best['source']} (radius {best['radius']}): {best['within']} / {best['actions']} actions within "
          f"the posture band, {best['targets']} meeting the five targets (without a prior: {floor})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
