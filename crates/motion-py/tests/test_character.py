"""The engine character from Python: a motion-matching database and a learned model."""

import numpy as np
import pytest

import motion
from conftest import ROOT, WALK_SEED

DATABASE = ROOT / "weights" / "matching_cmu.safetensors"


def test_a_database_character_walks_where_it_is_sent_on_its_own_rig():
    c = motion.Character(DATABASE)
    assert c.is_database and c.fps == pytest.approx(30.0)
    names = c.joint_names
    assert names[0] == "pelvis" and "lfemur" in names and len(names) != 32  # End Sites included
    c.start(WALK_SEED)  # the H3.6M example walk, retargeted onto the CMU rig
    c.set_goal((1.2, 0.0))
    start, _ = c.advance(0.0)
    for _ in range(360):
        root, rotations = c.advance(1 / 60)
    assert rotations.shape == (len(names), 4) and rotations.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(rotations, axis=1), 1.0, atol=1e-4)
    moved = root - start
    assert moved[0] > 4.0 and abs(moved[2]) < 1.5, moved
    c.set_action("walking")  # a database has no actions: ignored
    c.set_goal((0.0, 0.0))  # a stop keeps the way it faces
    for _ in range(120):
        stopped, _ = c.advance(1 / 60)
    later, _ = c.advance(0.5)
    assert np.hypot(*(later - stopped)[[0, 2]]) < 0.3


def test_a_model_character_and_bad_input():
    c = motion.Character()  # the built-in game default
    assert not c.is_database and len(c.joint_names) == 32
    c.start(WALK_SEED, action="walking", rng_seed=3)
    root, rotations = c.advance(1 / 30)
    assert np.isfinite(root).all() and rotations.shape == (32, 4)
    with pytest.raises(ValueError, match="finite"):
        c.set_goal((float("nan"), 0.0))
    with pytest.raises(ValueError, match="dt"):
        c.advance(-1.0)
    with pytest.raises(ValueError, match="missing.safetensors"):
        motion.Character(ROOT / "missing.safetensors")
    with pytest.raises((ValueError, OSError), match="missing.bvh"):
        motion.Character(DATABASE).start(ROOT / "missing.bvh")
