"""Models and files from Python against the CLI and the streaming API."""

import numpy as np
import pytest

import motion
from conftest import WALK_SEED


def test_predict_matches_the_cli(tmp_path, cli):
    model = motion.Model.default()
    out = tmp_path / "pred.npy"
    cli("predict", "--seed", WALK_SEED, "--action", "walking", "--frames", 20, "--samples", 3,
        "--rng-seed", 5, "--prediction-only", "--out", out, "--json")
    theirs = np.load(out)
    mine = model.predict(str(WALK_SEED), action="walking", frames=20, samples=3, rng_seed=5)
    assert mine.shape == (3, 20, model.frame_dims) == theirs.shape
    np.testing.assert_allclose(mine[:, :, 3:], theirs[:, :, 3:], rtol=0, atol=1e-9)
    # Sample i is the same whatever the sample count (noise from rng_seed + i).
    one = model.predict(str(WALK_SEED), action="walking", frames=20, samples=1, rng_seed=6)
    np.testing.assert_array_equal(one[0], mine[1])


def test_a_generator_streams_what_predict_returns():
    model = motion.Model.default()
    bvh = motion.read_bvh(WALK_SEED)
    assert bvh["fps"] == pytest.approx(model.fps)
    clip = bvh["expmap"]
    seed = clip[-model.seed_frames:]
    # predict reads the clip's last seed_frames frames (a clip's first frame is its absolute
    # start, so the whole 75-frame clip is passed: its window starts mid-clip).
    # The generator streams the model's raw frames: predict's without grounding.
    batch = model.predict(clip, action="eating", frames=12, rng_seed=9, grounding=False)[0]
    g = model.generator(rng_seed=9)
    g.start(seed, "eating")
    streamed = np.stack([g.step() for _ in range(12)])
    np.testing.assert_array_equal(streamed, batch)
    g.set_action("walking")
    assert np.isfinite(g.step()).all()
    # A seed array at another rate is resampled (50 Hz here: every 2nd frame kept).
    doubled = np.repeat(clip, 2, axis=0)
    assert model.predict(doubled, action="eating", frames=3, input_fps=50).shape == (1, 3, 99)


def test_a_control_needs_a_goal_gru_model():
    # The default model reads no control: a ValueError saying so.
    g = motion.Model.default().generator(rng_seed=1)
    with pytest.raises(ValueError, match="no control"):
        g.set_control([0.5, 0.0, 0.0])


def test_info_and_load(tmp_path):
    model = motion.Model.default()
    info = model.info()
    assert info["config"]["fps"] == model.fps
    assert "walking" in model.actions
    assert info["parameters"] > 0
    fixture = WALK_SEED.parents[1] / "tests" / "fixtures" / "parity" / "vgru_d.safetensors"
    small = motion.Model.load(str(fixture))
    assert small.info()["provenance"]["iterations"] == 0
    with pytest.raises(OSError, match="missing.safetensors"):
        motion.Model.load(str(tmp_path / "missing.safetensors"))
    junk = tmp_path / "junk.safetensors"
    junk.write_bytes(b"not a safetensors file")
    with pytest.raises(ValueError, match="junk.safetensors"):
        motion.Model.load(str(junk))


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        (dict(action="flying"), ValueError, "flying"),
        (dict(seed=np.zeros((60, 98))), ValueError, "98"),
        (dict(seed=np.zeros((10, 99))), ValueError, "at least 50"),
        (dict(seed="/no/such/seed.bvh"), OSError, "seed.bvh"),
        (dict(samples=0), ValueError, "samples"),
        (dict(samples=10**9), ValueError, "over the limit"),
        (dict(input_fps=-1.0), ValueError, "input_fps"),
    ],
)
def test_bad_predictions_raise(kwargs, error, message):
    model = motion.Model.default()
    args = dict(seed=str(WALK_SEED), action="walking", frames=5)
    args.update(kwargs)
    with pytest.raises(error, match=message):
        model.predict(**args)


def test_files_round_trip(tmp_path):
    model = motion.Model.default()
    frames = model.predict(str(WALK_SEED), action="walking", frames=30)[0]
    path = tmp_path / "walk.bvh"
    motion.write_bvh(path, frames, fps=25)
    back = motion.read_bvh(path)
    assert back["fps"] == pytest.approx(25)
    assert len(back["joints"]) == len(back["parents"]) == back["offsets"].shape[0]
    # Exp-map → BVH → exp-map keeps the pose (positions to 1e-6 mm).
    np.testing.assert_allclose(
        motion.expmap_to_positions(back["expmap"])[1:], motion.expmap_to_positions(frames)[1:], atol=1e-6
    )
    np.save(tmp_path / "f.npy", frames)
    np.testing.assert_array_equal(motion.read_expmap(tmp_path / "f.npy"), frames)
    with pytest.raises(OSError, match="nope.txt"):
        motion.read_expmap(tmp_path / "nope.txt")
    with pytest.raises(ValueError, match="98-dim"):
        motion.expmap_to_positions(np.zeros((5, 98)))
    # Bones keep their lengths: forward kinematics, not a reshape.
    p = motion.expmap_to_positions(frames)
    bone = np.linalg.norm(p[:, 2] - p[:, 1], axis=1)
    assert bone.std() < 1e-6 and bone.mean() > 100
