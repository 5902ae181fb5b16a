"""``training/locomotion.py --takes``: controls on a rig with a known answer, and the whole chain on takes the
project makes itself (copies of ``examples/walk_seed.bvh``): ``motion-cli takes export``, a short training run,
the export with its rig and licence, then ``motion-cli info`` and ``predict`` playing the file on that rig."""

import json
import math
import shutil
import subprocess

import numpy as np
import pytest
import torch

from training import locomotion
from training.export import read_metadata
from training.takes import REPO, controls_of, motion_cli, validation_names


def test_controls_follow_the_rigs_rest_forward():
    n = 40
    frames = np.zeros((n, 9))
    frames[:, 0] = 10.0  # 10 mm per frame along the root's +x, 30 Hz: 0.3 m/s
    # A rig facing +x at rest: the walk is all forward.
    c = controls_of(frames, 30, 30.0, np.array([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(c[:, 0], 0.3, atol=1e-9)
    np.testing.assert_allclose(c[:, 1:], 0.0, atol=1e-9)
    # Facing +z at rest: the same walk is to the side (+x when facing +z).
    c = controls_of(frames, 30, 30.0, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(c[:, 1], 0.3, atol=1e-9)
    # Turning 0.01 rad per frame about +y: -0.3 rad over 30 frames, also within 30 frames of the end.
    turning = np.zeros((n, 9))
    turning[:, 4] = 0.01
    c = controls_of(turning, 30, 30.0, np.array([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(c[:, 2], -0.3, atol=1e-4)


def test_validation_takes_are_every_sixth_by_name():
    names = [f"t{i:02d}" for i in range(14)]
    assert validation_names(list(reversed(names))) == ["t05", "t11"]


def cli_or_skip():
    cmd = motion_cli()
    if cmd[0] == "cargo" and shutil.which("cargo") is None:
        pytest.skip("SKIPPED: no motion-cli build and no cargo")
    return cmd


def test_takes_train_export_and_play_on_their_rig(tmp_path):
    cli = cli_or_skip()
    takes = tmp_path / "takes"
    takes.mkdir()
    walk = (REPO / "examples" / "walk_seed.bvh").read_text()
    for i in range(7):
        (takes / f"walk_{i}.bvh").write_text(walk)
    run = tmp_path / "run"
    argv = ["--takes", str(takes), "--run-dir", str(run), "--iterations", "4", "--val-every", "2", "--batch", "2",
            "--hidden", "8", "--seed-frames", "10", "--horizon", "15", "--fps", "25"]
    assert locomotion.main(argv) == 0
    manifest = json.loads((run / "takes" / "takes.json").read_text())
    assert manifest["format"] == "motion-takes" and len(manifest["takes"]) == 7
    frames = np.load(run / "takes" / manifest["takes"][0]["file"])
    assert frames.shape[1] == manifest["frame_dims"] == 3 + 3 * manifest["joints"]
    state = torch.load(run / "best.pt", weights_only=False)
    assert state["config"]["skeleton"] == "rig" and "ROOT" in state["config"]["rig_bvh"]
    out = tmp_path / "rig_model.safetensors"
    with pytest.raises(SystemExit, match="--licence"):
        locomotion.main(["--export", str(out), "--from", str(run / "best.pt")])
    assert locomotion.main(["--export", str(out), "--from", str(run / "best.pt"), "--licence", "test takes: CC0"]) == 0
    provenance = json.loads(read_metadata(out)["provenance"])
    assert provenance["licence"] == "test takes: CC0" and "walk_6" in provenance["data"]
    info = subprocess.run(cli + ["info", str(out)], capture_output=True, text=True)
    assert info.returncode == 0, info.stderr
    assert "test takes: CC0" in info.stdout and "rig" in info.stdout
    pred = tmp_path / "pred.bvh"
    done = subprocess.run(
        cli + ["predict", "--model", str(out), "--seed", str(takes / "walk_0.bvh"), "--seconds", "2",
               "--out", str(pred), "--json"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["kind"] == "learned" and report["predicted_frames"] == 50
    text = pred.read_text()
    assert text.count("JOINT") == walk.count("JOINT")
    rows = text.split("MOTION")[1].strip().splitlines()[2:]
    assert len(rows) == report["seed_frames"] + 50
    assert all(math.isfinite(float(v)) for v in rows[-1].split())
