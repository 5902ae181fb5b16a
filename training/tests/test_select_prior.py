"""select_prior: the radius rule and the fine-tune rule (README example precondition, ties to the first listed) on
synthetic eval reports."""

import json

from training import select_prior
from training.tests.test_select_game import readme, report


def with_posture(r: dict, frechet: list[float], band: float = 2.0) -> dict:
    """Adds a posture section: per action the grounded model's Fréchet in one window, the real band `band`."""
    for a, f in zip(r["actions"], frechet):
        a["posture"] = {
            "ground_truth": [{"posture": {"frechet": band, "arms_above_real_p99": 0.0}}],
            "model_grounded": [{"posture": {"frechet": f, "arms_above_real_p99": 0.0}}],
            "real_vs_real": {"frechet": band / 2},
        }
    return r


def choose(tmp_path, reports, readmes, *flags):
    paths = []
    for i, (r, rd) in enumerate(zip(reports, readmes)):
        p = tmp_path / f"r{i}.json"
        p.write_text(json.dumps(r))
        if rd is not None:
            (tmp_path / f"r{i}.readme.json").write_text(json.dumps(rd))
        paths.append(str(p))
    return select_prior.main([*paths, *flags])


def test_fine_tunes_need_the_readme_example_and_the_shipped_targets(tmp_path, capsys):
    shipped = with_posture(report("shipped", [810.0, 810.0]), [3.0, 1.0])  # 2 targets, 1 within
    slow = with_posture(report("slow", [810.0, 810.0]), [1.0, 1.0])  # 2 within, README walk slows
    crouched = with_posture(report("crouched", [700.0, 810.0]), [1.0, 1.0])  # 2 within, loses a target
    good = with_posture(report("good", [810.0, 810.0]), [1.5, 1.0])  # 2 within
    also = with_posture(report("also", [810.0, 810.0]), [1.0, 1.0])  # 2 within, listed later
    ok, bad = readme([0.6, 0.55]), readme([0.6, 0.45])
    args = [shipped, slow, crouched, good, also], [ok, bad, ok, ok, ok]
    assert choose(tmp_path, *args, "--fine-tunes") == 0
    out = capsys.readouterr().out
    assert "chosen: good" in out and "smallest speed ratio 0.450 (fails: not eligible)" in out


def test_fine_tunes_keep_the_shipped_file_on_a_tie_and_need_readme_files(tmp_path, capsys):
    shipped = with_posture(report("shipped", [810.0]), [1.0])
    tie = with_posture(report("tie", [810.0]), [0.5])
    assert choose(tmp_path, [shipped, tie], [readme([0.6]), readme([0.6])], "--fine-tunes") == 0
    assert "chosen: shipped" in capsys.readouterr().out
    (tmp_path / "r1.readme.json").unlink()
    assert choose(tmp_path, [shipped, tie], [None, None], "--fine-tunes") == 2
    assert "readme.json" in capsys.readouterr().err


def test_the_radius_rule_ties_to_the_largest_radius(tmp_path, capsys):
    off = with_posture(report("off", [810.0]), [3.0])
    r2 = with_posture(report("r2", [810.0]), [1.0])
    r1 = with_posture(report("r1", [810.0]), [1.0])
    assert choose(tmp_path, [off, r2, r1], [None] * 3, "--radii", "off,2.0,1.0") == 0
    assert "chosen: r2" in capsys.readouterr().out
