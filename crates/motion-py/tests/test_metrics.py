"""The metrics from Python against `motion-cli score` on the same arrays (to 1e-12)."""

import numpy as np
import pytest

import motion
from conftest import smooth


def test_npss_and_euler_error_match_the_cli(tmp_path, rng, cli):
    gt = smooth(rng, (3, 60, 99))
    pred = gt + smooth(rng, (3, 60, 99), 0.1)
    np.save(tmp_path / "gt.npy", gt)
    np.save(tmp_path / "pred.npy", pred)
    for space in ["raw", "expmap"]:
        report = cli(
            "score", "--gt", tmp_path / "gt.npy", "--pred", tmp_path / "pred.npy",
            "--metric", "npss,npss-reference" + (",euler" if space == "expmap" else ""),
            "--input-space", space, "--json",
        )
        assert abs(motion.npss(gt, pred, input_space=space) - report["npss"]) < 1e-12
        ref = motion.npss(gt, pred, variant="reference", input_space=space)
        assert abs(ref - report["npss_reference"]) < 1e-12
        windows = motion.npss_windows(gt, pred, input_space=space)
        for label, value in report["npss_windows"]["npss"].items():
            assert abs(windows[label] - value) < 1e-12
        if space == "expmap":
            per_frame = motion.euler_error(gt, pred)
            np.testing.assert_allclose(per_frame, report["euler_error"], rtol=0, atol=1e-12)


def test_apd_matches_the_cli(tmp_path, rng, cli):
    samples = smooth(rng, (2, 5, 30, 12))
    np.save(tmp_path / "samples.npy", samples)
    report = cli("score", "--pred", tmp_path / "samples.npy", "--metric", "apd", "--input-space", "raw", "--json")
    mean, per = motion.apd(samples, per_sequence=True)
    assert abs(mean - report["apd"]) < 1e-12
    np.testing.assert_allclose(per, report["apd_per_sequence"], rtol=0, atol=1e-12)
    # One forecast's S x F samples.
    assert abs(motion.apd(samples[0].reshape(5, -1)) - per[0]) < 1e-12


def test_ndms_matches_the_cli_and_survives_pickling(tmp_path, rng, cli):
    import pickle

    model = motion.Model.default()
    clips = model.predict(str(motion_seed()), action="walking", frames=60, samples=3, rng_seed=2)
    positions = np.stack([motion.expmap_to_positions(c) for c in clips])  # 3 x 60 x 32 x 3
    reference, queries = positions[:2], positions[2:]
    np.save(tmp_path / "db.npy", reference)
    np.save(tmp_path / "pred.npy", queries)
    report = cli(
        "score", "--pred", tmp_path / "pred.npy", "--db", tmp_path / "db.npy",
        "--metric", "ndms", "--input-space", "raw", "--json",
    )["ndms"]
    db = motion.NdmsDatabase(list(reference))
    mine = db.score(queries)
    assert abs(mine["mean"] - report["mean"]) < 1e-12
    np.testing.assert_allclose(mine["per_word"], report["per_word"], rtol=0, atol=1e-12)
    assert mine["first_word_end"] == report["first_word_end"]
    assert len(db) == report["database_words"]
    # A copy through pickle (how Ray ships it) scores the same, whatever its index.
    copy = pickle.loads(pickle.dumps(db))
    assert len(copy) == len(db)
    assert copy.score(queries)["mean"] == mine["mean"]
    brute = motion.NdmsDatabase.from_words(db.words(), 8, "brute-force")
    assert brute.score(queries)["mean"] == mine["mean"]


def motion_seed():
    from conftest import WALK_SEED

    return WALK_SEED


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: motion.npss(np.zeros((2, 10, 3)), np.zeros((2, 9, 3))), "shape mismatch"),
        (lambda: motion.npss(np.zeros((10, 3)), np.zeros((10, 3))), "expected N x T x D"),
        (lambda: motion.npss(np.full((1, 10, 3), np.nan), np.zeros((1, 10, 3))), "NPSS"),
        (lambda: motion.npss(np.zeros((1, 10, 3)), np.zeros((1, 10, 3)), variant="fast"), "variant"),
        (lambda: motion.npss(np.zeros((1, 10, 3)), np.zeros((1, 10, 3)), input_space="euler"), "input_space"),
        (lambda: motion.apd(np.zeros(5)), "samples"),
        (lambda: motion.NdmsDatabase([np.zeros((4, 32, 3))]), "NDMS database"),
        (lambda: motion.NdmsDatabase([np.zeros((20, 32, 3))], method="annoy"), "method"),
        (lambda: motion.npss("gt", "pred"), "gt"),
    ],
)
def test_bad_input_raises_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_float64_arrays_are_read_in_place(rng):
    a = rng.normal(size=(4, 20, 6))
    assert motion._motion.data_address(a) == a.ctypes.data  # C-contiguous: no copy
    strided = a[:, ::2, :]
    assert motion._motion.data_address(strided) == strided.ctypes.data  # any strides: no copy
    single = a.astype(np.float32)
    assert motion._motion.data_address(single) != single.ctypes.data  # converted once
    # In place or converted, the same numbers give the same score.
    assert motion.npss(strided, a[::-1, ::2]) == motion.npss(strided.copy(), a[::-1, ::2].copy())
    assert motion.npss(single, a) == motion.npss(single.astype(np.float64), a)


GIL_SCRIPT = """
import threading, time
import numpy as np
import motion

motion.set_threads(1)  # one Rust thread per call: parallelism can only come from Python threads
rng = np.random.default_rng(0)
gt = np.cumsum(rng.normal(size=(64, 200, 99)), axis=1) * 0.02
pred = gt + 0.01 * rng.normal(size=gt.shape)

def work():
    for _ in range(4):
        motion.npss(gt, pred, input_space="expmap")

work()
start = time.perf_counter(); work(); one = time.perf_counter() - start
threads = [threading.Thread(target=work) for _ in range(2)]
start = time.perf_counter()
for t in threads: t.start()
for t in threads: t.join()
two = time.perf_counter() - start
print(f"GIL released: one thread {one:.3f} s; two threads, twice the work, {two:.3f} s ({two / one:.2f}x one thread's time)")
"""


def test_two_threads_score_in_parallel():
    """The GIL is released while Rust computes: two Python threads scoring at once take less
    than twice one thread's time (on 2 cores about 1x). A printout: timings are not asserted."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", GIL_SCRIPT], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    print("\n" + done.stdout.strip())
