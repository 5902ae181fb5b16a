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
