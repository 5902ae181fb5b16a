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
    assert c.floor is None or "level" in c.floor
    root, rotations = c.advance(1 / 30)
    assert np.isfinite(root).all() and rotations.shape == (32, 4)
    # The seed's floor the poses stand on (in the world the seed was integrated in), levelled.
    floor = c.floor
    assert floor is not None and len(floor["level"]) == 4 and len(floor["pivot"]) == 3
    assert abs(np.linalg.norm(floor["level"]) - 1.0) < 1e-5
    assert 0.0 <= floor["tilt_degrees"] < 30.0  # grounding.floor.MAX_TILT_DEG
    with pytest.raises(ValueError, match="finite"):
        c.set_goal((float("nan"), 0.0))
    with pytest.raises(ValueError, match="dt"):
        c.advance(-1.0)
    with pytest.raises(ValueError, match="missing.safetensors"):
        motion.Character(ROOT / "missing.safetensors")
    with pytest.raises((ValueError, OSError), match="missing.bvh"):
        motion.Character(DATABASE).start(ROOT / "missing.bvh")


def test_a_rig_from_the_mannequin_follows_the_character():
    import numpy as np

    glb = ROOT / "assets" / "mannequin.glb"
    c = motion.Character()
    c.start(ROOT / "examples" / "walk_seed.bvh", action="walking")
    rig = motion.Rig.from_gltf(glb, c)
    names = rig.joint_names()
    assert len(names) == 66 and names[rig.hips()] == "pelvis"
    thigh = names.index("thigh_l")
    first, _ = rig.pose(c)
    turns = []
    for _ in range(50):
        c.advance(1 / 30)
        rotations, hips = rig.pose(c)
        assert rotations.shape == (66, 4) and np.allclose(np.linalg.norm(rotations, axis=1), 1, atol=1e-4)
        assert 0.5 < hips[1] < 1.2 or 0.5 < abs(hips[2]) < 1.2
        turns.append(abs(float(np.dot(rotations[thigh], first[thigh]))))
    assert min(turns) < 0.998  # the thigh turned by more than about 7 degrees (the game default shuffles)
    with pytest.raises(ValueError, match="parents"):
        motion.Rig(["a", "b"], [-1], np.zeros((2, 4)), np.zeros((2, 3)), c)
