"""select_game: the default rule and `--rule targets` on synthetic eval reports."""

import json

from training import select_game


def report(source: str, hips: list[float], speed: float = 0.8, conditioned: bool = True, windows: str = "validation"):
    """A minimal `motion-cli eval --json` report: one action per entry of `hips` (its lowest window hip p5, mm,
    against a real p5 of 800)."""
    actions = []
    for k, hip in enumerate(hips):
        ground = {
            "real": {"s5_skating_fraction": 0.2, "lean_p95_deg": 40.0, "hip_height_p5_mm": 800.0,
                     "hip_height_p95_mm": 950.0},
            "windows": [{"on_floor_fraction": 1.0, "penetration_fraction": 0.0, "skating_fraction": 0.1,
                         "lean_p95_deg": 30.0, "hip_height_p5_mm": hip, "hip_height_p95_mm": 900.0}],
        }
        speed_ratio = {"windows": [{"ratio": speed}]}
        actions.append({"action": f"a{k}", "model": {"speed_ratio": speed_ratio},
                        "model_grounded": {"speed_ratio": speed_ratio, "ground": ground}})
    return {"model": {"source": source, "actions": ["a"] if conditioned else []},
            "protocol": {"windows": windows}, "actions": actions}


def choose(tmp_path, reports, *flags):
    paths = []
    for i, r in enumerate(reports):
        p = tmp_path / f"r{i}.json"
        p.write_text(json.dumps(r))
        paths.append(str(p))
    return select_game.main([*paths, *flags])


def test_targets_counts_actions_meeting_all_five_then_the_hip_shortfall(tmp_path, capsys):
    incumbent = report("old", [810.0, 790.0, 780.0])  # 1 of 3, 30 mm short
    better = report("new", [805.0, 801.0, 700.0])  # 2 of 3, 100 mm short
    assert choose(tmp_path, [incumbent, better], "--rule", "targets") == 0
    assert "chosen: new" in capsys.readouterr().out
    v = select_game.verdict(incumbent)
    assert (v["targets"], round(v["hip_short"], 6)) == (1, 30.0)


def test_targets_ties_go_to_the_smaller_shortfall_then_the_first_listed(tmp_path, capsys):
    a = report("a", [810.0, 790.0])
    b = report("b", [810.0, 795.0])
    c = report("c", [810.0, 795.0])
    assert choose(tmp_path, [a, b, c], "--rule", "targets") == 0
    assert "chosen: b" in capsys.readouterr().out


def test_a_frozen_action_fails_its_targets_and_the_default_rule_counts_alive(tmp_path, capsys):
    frozen = report("frozen", [900.0, 900.0], speed=0.3)
    v = select_game.verdict(frozen)
    assert (v["alive"], v["targets"]) == (0, 0)
    assert choose(tmp_path, [frozen, report("alive", [700.0, 700.0])]) == 0
    assert "chosen: alive" in capsys.readouterr().out


def test_test_windows_are_refused_without_allow_test(tmp_path, capsys):
    assert choose(tmp_path, [report("t", [800.0], windows="test")], "--rule", "targets") == 2
    assert "validation windows only" in capsys.readouterr().err


def test_the_table_shows_the_smallest_share_within_the_drift_band(tmp_path, capsys):
    r = report("d", [810.0, 810.0])
    r["actions"][0]["model_grounded"]["drift"] = {"windows": [
        {"hip_height_within_p95": 1.0, "lean_within_p95": 0.875},
        {"hip_height_within_p95": 0.375, "lean_within_p95": 1.0},
        {"hip_height_within_p95": None, "lean_within_p95": None},
    ]}
    assert select_game.verdict(r)["rows"][0]["drift"] == (0.375, 0.875)
    assert select_game.verdict(r)["rows"][1]["drift"] is None
    assert choose(tmp_path, [r], "--rule", "targets") == 0
    out = capsys.readouterr().out
    assert "| 0.38 / 0.88 |" in out and "| - |" in out


def readme(speeds: list[float], airborne: float = 0.0) -> dict:
    """A `training/readme_check.py` output: one score report per rng seed, its windows' speed ratios `speeds`."""
    windows = range(len(speeds))
    score = {"speed_ratio": {"windows": [{"ratio": s} for s in speeds]},
             "foot_contact": {"windows": [{"airborne_fraction": airborne} for _ in windows]},
             "drift": {"windows": [{"hip_height_within_p95": 1.0, "lean_within_p95": 1.0} for _ in windows]}}
    return {"model": "m", "rng_seeds": [0, 1], "reports": [score, score]}


def test_readme_makes_a_candidate_whose_readme_walk_slows_ineligible(tmp_path, capsys):
    incumbent = report("old", [810.0, 790.0])  # 1 of 2
    better = report("new", [810.0, 805.0])  # 2 of 2, but its README walk slows to 0.45
    (tmp_path / "r0.readme.json").write_text(json.dumps(readme([0.6, 0.55])))
    (tmp_path / "r1.readme.json").write_text(json.dumps(readme([0.6, 0.45])))
    assert choose(tmp_path, [incumbent, better], "--rule", "targets") == 0
    assert "chosen: new" in capsys.readouterr().out
    assert choose(tmp_path, [incumbent, better], "--rule", "targets", "--readme") == 0
    out = capsys.readouterr().out
    assert "chosen: old" in out and "smallest speed ratio 0.450 (fails: not eligible)" in out
    (tmp_path / "r1.readme.json").write_text(json.dumps(readme([0.6, 0.55], airborne=0.01)))
    assert choose(tmp_path, [incumbent, better], "--rule", "targets", "--readme") == 0
    assert "chosen: old" in capsys.readouterr().out
    assert select_game.readme_verdict(readme([0.6, 0.55]))["passes"]


def test_readme_without_its_file_exits_2_naming_it(tmp_path, capsys):
    assert choose(tmp_path, [report("a", [810.0])], "--readme") == 2
    assert "r0.readme.json" in capsys.readouterr().err
