"""motion: exact, fast human-motion metrics and real-time motion generators (Rust, via PyO3).

Score a prediction (exp-map frames, ``N x T x 99`` at 25 Hz)::

    import motion
    print(motion.npss(gt, pred, input_space="expmap"))      # Gopalakrishnan et al. 2019's NPSS
    print(motion.euler_error(gt, pred)[[1, 3, 7, 9, 13, 24]])  # the protocol's ms horizons
    db = motion.NdmsDatabase([motion.expmap_to_positions(f) for f in reference_clips])
    print(db.score(motion.expmap_to_positions(pred[0]))["mean"])

Evaluate a model on the H3.6M protocol (the report of ``motion-cli eval --json``)::

    report = motion.evaluate(actions=["walking"], horizon=100)   # the built-in model
    print(report["actions"][0]["model"]["npss"]["whole"])

Generate one::

    model = motion.Model.default()
    walks = model.predict("examples/walk_seed.bvh", action="walking", frames=250, samples=4)

Drive a character, from the shipped motion-matching database (CMU takes, free for products)
or a learned model, at any tick rate::

    c = motion.Character("weights/matching_cmu.safetensors")   # None: the game default model
    c.start("examples/walk_seed.bvh")                          # a BVH on any rig
    c.set_goal((1.2, 0.0))                                     # m/s along +x
    root, rotations = c.advance(1 / 60)                        # metres; joints x 4 (x, y, z, w)

Arrays are float64 numpy arrays (others are converted once); a float64 array is read in place
whatever its strides. Computation runs without the GIL, split over cores
(``motion.set_threads(n)`` before the first call to change how many). Bad input raises
``ValueError`` with the same one-line message as ``motion-cli``; unreadable files ``OSError``.
"""

from ._motion import (  # noqa: F401
    Character,
    Generator,
    Model,
    NdmsDatabase,
    Rig,
    __version__,
    apd,
    euler_error,
    evaluate,
    posture,
    expmap_to_positions,
    mpjpe,
    npss,
    npss_windows,
    read_bvh,
    read_expmap,
    sample_set_metrics,
    set_threads,
    write_bvh,
)

__all__ = [
    "Character",
    "Generator",
    "Model",
    "NdmsDatabase",
    "Rig",
    "apd",
    "euler_error",
    "evaluate",
    "posture",
    "expmap_to_positions",
    "mpjpe",
    "npss",
    "npss_windows",
    "read_bvh",
    "read_expmap",
    "sample_set_metrics",
    "set_threads",
    "write_bvh",
]
