"""`motion.evaluate` returns the report `motion-cli eval --json` prints (the same library call)."""

import os
from pathlib import Path

import pytest

import motion

from conftest import ROOT

DATA = Path(os.environ.get("MOTION_DATA_DIR", ROOT.parent / "shared" / "data"))


def test_evaluate_is_the_cli_report(cli):
    if not (DATA / "h3.6m" / "dataset" / "S5").is_dir():
        pytest.skip(f"SKIPPED: no H3.6M data at {DATA}")
    ours = motion.evaluate(data=DATA, actions=["walking"], horizon=25, classifier=False)
    theirs = cli("eval", "--data", DATA, "--actions", "walking", "--horizon", 25, "--no-classifier", "--json")
    assert ours["data"] == theirs["data"]
    assert ours == theirs
    walking = ours["actions"][0]
    assert walking["action"] == "walking" and walking["windows"] == 8


def test_evaluate_validation_windows_are_the_cli_report(cli):
    if not (DATA / "h3.6m" / "dataset" / "S5").is_dir():
        pytest.skip(f"SKIPPED: no H3.6M data at {DATA}")
    ours = motion.evaluate(data=DATA, actions="greeting", horizon=25, classifier=False, windows="validation")
    theirs = cli(
        "eval", "--data", DATA, "--actions", "greeting", "--horizon", 25, "--no-classifier",
        "--windows", "validation", "--json",
    )  # fmt: skip
    assert ours == theirs
    assert ours["protocol"]["windows"] == "validation"
    test = motion.evaluate(data=DATA, actions="greeting", horizon=25, classifier=False)
    starts = [{tuple(s) for s in r["actions"][0]["window_starts"]} for r in (ours, test)]
    assert len(starts[0]) == 8 and not starts[0] & starts[1]


def test_evaluate_refuses_bad_requests():
    with pytest.raises(ValueError, match='windows="train"'):
        motion.evaluate(data=ROOT, windows="train")
    with pytest.raises(ValueError, match="--horizon"):
        motion.evaluate(data=ROOT, horizon=0)
    with pytest.raises(ValueError, match="no H3.6M exp-map data|does not exist"):
        motion.evaluate(data=ROOT / "no-such-dir")


def test_posture_is_the_cli_score(cli, tmp_path):
    if not (DATA / "h3.6m" / "dataset" / "S5").is_dir():
        pytest.skip(f"SKIPPED: no H3.6M data at {DATA}")
    import numpy as np

    seed = motion.read_expmap(DATA / "h3.6m" / "dataset" / "S5" / "walking_1.txt.gz")[::2][:150]
    pred, truth = seed[100:], seed[:100]
    np.save(tmp_path / "pred.npy", pred[None])
    np.save(tmp_path / "seed.npy", truth[None])
    ours = motion.posture(pred[None], "walking", seeds=truth[None], data=DATA)
    theirs = cli(
        "score", "--pred", tmp_path / "pred.npy", "--seed", tmp_path / "seed.npy", "--action", "walking",
        "--metric", "posture", "--data", DATA, "--json",
    )["posture"]  # fmt: skip
    assert ours == theirs
    assert ours["windows"][0]["window"] == "0-2" and ours["windows"][0]["posture"]["frames"] == 50
    assert ours["real_vs_real"]["frechet"] < 2.0
    with pytest.raises(ValueError, match="99"):
        motion.posture(np.zeros((10, 3)), "walking", data=DATA)
