#!/usr/bin/env python3
"""The hostile-input corpus: generates every case into a scratch directory, runs ``motion-cli``
on each under a memory cap and a time limit, and prints ``clean N / total M``.

A case is clean when the command neither crashed (signal, exit 101), hung (over ``--timeout``)
nor used more than ``--max-rss-mib`` of memory, and:
- ``refuse``: exit 2, one stderr line ``error: ...`` (printable, at most 1,000 characters, no run
  of more than 40 digits) holding the expected strings, no file left behind, inputs unchanged;
- ``accept``: exit 0;
- ``either`` (random corruptions): exit 0, or exit 2 under the ``refuse`` rules.

Usage: ``python3 tests/hostile/run.py --cli target/release/motion-cli [--only SUBSTRING]``. The
exit status is 1 when a case is not clean. Standard library only.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import resource
import shutil
import signal
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import files  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
FIXTURE_MODEL = REPO / "tests/fixtures/parity/vgru_d.safetensors"
WALK_SEED = REPO / "examples/walk_seed.bvh"


@dataclass
class Case:
    """One command line in its own directory: ``setup(dir, shared)`` writes its files."""

    name: str
    argv: list[str]
    expect: str = "refuse"
    contains: list[str] = field(default_factory=list)
    setup: object = None
    inputs: list[str] = field(default_factory=list)


def root_1e308() -> str:
    """The walk seed with every frame's root x position set to 1e308."""
    text = WALK_SEED.read_text()
    head, motion = text.split("MOTION", 1)
    lines = motion.splitlines()
    for i, line in enumerate(lines):
        if line.strip() and not line.strip().startswith(("Frame", "MOTION")):
            values = line.split()
            values[0] = "1e308"
            lines[i] = " ".join(values)
    return head + "MOTION" + "\n".join(lines) + "\n"


def shared_files(root: Path) -> dict[str, Path]:
    """The large files several cases read, written once."""
    root.mkdir(parents=True, exist_ok=True)
    out = {
        "bomb": root / "bomb.txt.gz",
        "longline": root / "longline.txt",
        "longline_gz": root / "longline.txt.gz",
        "thin_many": root / "thin_many.bvh",
        "thin_2m": root / "thin_2m.bvh",
        "slow": root / "slow.bvh",
        "walk": root / "walk.bvh",
        "rig": root / "rig.bvh",
        "expmap": root / "walk.txt",
        "e_npy": root / "e.npy",
        "pos_npy": root / "pos.npy",
    }
    files.gzip_bomb(out["bomb"], 300)
    files.long_line(out["longline"], 2)
    files.long_line(out["longline_gz"], 40, gz=True)
    files.thin_bvh(out["thin_many"], 4_000_000, 0.04)
    files.thin_bvh(out["thin_2m"], 2_000_000, 0.04)
    files.thin_bvh(out["slow"], 200_000, 1.0)
    shutil.copy(WALK_SEED, out["walk"])
    out["rig"].write_text(files.rig_bvh())
    out["expmap"].write_text(files.expmap_text(200))
    files.npy(out["e_npy"], (2, 30, 99))
    files.npy(out["pos_npy"], (2, 30, 32, 3))
    return out


def cases(shared: dict[str, Path]) -> list[Case]:
    m = str(FIXTURE_MODEL)
    s = {k: str(v) for k, v in shared.items()}
    predict = ["predict", "--model", m, "--action", "walking"]
    out: list[Case] = []
    add = out.append

    # -- eval on S5 files of the wrong width, or a bomb among them
    for cols in (98, 100):
        add(Case(f"eval-s5-{cols}-columns", ["eval", "--data", "d", "--actions", "walking", "--no-classifier", "--model", m],
                 contains=["walking_1"], setup=lambda d, c=cols: files.data_dir(d / "d", c)))

    def bomb_data(d: Path) -> None:
        files.data_dir(d / "d", 99)
        s5 = d / "d/h3.6m/dataset/S5"
        (s5 / "walking_1.txt").unlink()
        shutil.copy(shared["bomb"], s5 / "walking_1.txt.gz")
    add(Case("eval-s5-gzip-bomb", ["eval", "--data", "d", "--actions", "walking", "--no-classifier", "--model", m],
             contains=["walking_1"], setup=bomb_data))

    # -- decompression bombs and endless lines
    add(Case("predict-seed-gzip-bomb", predict + ["--seed", s["bomb"], "--out", "p.bvh"], contains=["bomb.txt.gz"]))
    add(Case("convert-gzip-bomb", ["convert", s["bomb"], "o.npy"], contains=["bomb.txt.gz"]))
    add(Case("score-db-gzip-bomb", ["score", "--pred", s["e_npy"], "--db", s["bomb"], "--metric", "ndms"], contains=["bomb.txt.gz"]))
    add(Case("convert-long-line", ["convert", s["longline"], "o.npy"], contains=["longline.txt"]))
    add(Case("convert-long-line-gz", ["convert", s["longline_gz"], "o.npy"], contains=["longline.txt.gz"]))
    add(Case("predict-long-line", predict + ["--seed", s["longline"], "--out", "p.bvh"], contains=["longline.txt"]))

    # -- sizes asked on the command line
    add(Case("bench-batch-1e9", ["bench", "--batch", "1000000000", "--steps", "1"], contains=["--batch"]))
    add(Case("bench-hidden-65536", ["bench", "--hidden", "65536", "--steps", "1"], contains=["--hidden"]))
    add(Case("bench-steps-1e12", ["bench", "--steps", "1000000000000"], contains=["--steps"]))
    add(Case("eval-samples-100000", ["eval", "--samples", "100000", "--model", m, "--no-classifier"], contains=["--samples"]))
    add(Case("predict-fps-10000-frames-20000", predict + ["--seed", s["walk"], "--out", "p.bvh", "--fps", "10000", "--frames", "20000"],
             contains=["MAX_CLIP_VALUES"]))
    add(Case("predict-frames-1350000", predict + ["--seed", s["walk"], "--out", "p.bvh", "--frames", "1350000"], contains=["--frames"]))
    add(Case("convert-frame-time-1-to-25-hz", ["convert", s["slow"], "o.bvh", "--fps", "25"], contains=["slow.bvh", "MAX_CLIP_VALUES"]))
    add(Case("predict-seed-frame-time-1", ["predict", "--model", m, "--action", "walking", "--seed", s["slow"], "--out", "p.bvh"],
             contains=["slow.bvh"]))
    add(Case("convert-thin-rig-4m-frames", ["convert", s["thin_many"], "o.bvh"], contains=["thin_many.bvh", "MAX_CLIP_VALUES"]))
    add(Case("convert-thin-rig-2m-frames-positions", ["convert", s["thin_2m"], "o.npy", "--positions"], expect="accept"))
    add(Case("render-gif-4096px", ["render", "big.bvh", "--out", "o.gif", "--width", "4096", "--height", "4096"],
             contains=["MAX_GIF_PIXELS"],
             setup=lambda d: (d / "big.bvh").write_text(files.rig_bvh(frames=3000, frame_time=0.04))))
    add(Case("render-sparse-300-mib", ["render", "big.bvh", "--out", "o.gif"], contains=["MAX_INPUT_BYTES"],
             setup=lambda d: files.sparse(d / "big.bvh", 300 << 20)))

    # -- FIFOs and devices as inputs
    mk = lambda name: (lambda d: files.fifo(d / name))  # noqa: E731
    add(Case("fifo-model", ["predict", "--model", "w.safetensors", "--seed", s["walk"], "--action", "walking", "--out", "p.bvh"],
             contains=["w.safetensors", "regular file"], setup=mk("w.safetensors")))
    add(Case("fifo-gt", ["score", "--gt", "g.npy", "--pred", s["e_npy"]], contains=["g.npy"], setup=mk("g.npy")))
    add(Case("fifo-pred", ["score", "--gt", s["e_npy"], "--pred", "p.npy"], contains=["p.npy"], setup=mk("p.npy")))
    add(Case("fifo-joint-map", predict + ["--seed", s["rig"], "--joint-map", "map.json", "--out", "p.bvh"],
             contains=["map.json"], setup=mk("map.json")))
    add(Case("fifo-convert-input", ["convert", "in.bvh", "o.npy"], contains=["in.bvh"], setup=mk("in.bvh")))
    add(Case("dev-zero-seed", predict + ["--seed", "/dev/zero", "--out", "p.bvh"], contains=["/dev/zero"]))

    # -- weights that would give NaN
    def weights(edit=None, fill=None):
        return lambda d: files.edit_safetensors(FIXTURE_MODEL, d / "w.safetensors", edit, fill)
    wp = ["predict", "--model", "w.safetensors", "--seed", s["walk"], "--action", "walking", "--out", "p.bvh"]
    add(Case("weights-std-1e-38", wp, contains=["w.safetensors"], setup=weights(fill={"norm.std": 1e-38})))
    add(Case("weights-mean-3e38", wp, contains=["w.safetensors"], setup=weights(fill={"norm.mean": 3e38})))
    add(Case("weights-duplicate-actions", wp, contains=["w.safetensors"],
             setup=weights(edit=lambda c: c["actions"].__setitem__(1, c["actions"][0]))))
    add(Case("weights-unknown-skeleton", wp, contains=["w.safetensors", "unknown skeleton"],
             setup=weights(edit=lambda c: c.__setitem__("skeleton", "cmu"))))
    add(Case("weights-unknown-skeleton-info", ["info", "w.safetensors"], contains=["w.safetensors", "unknown skeleton"],
             setup=weights(edit=lambda c: c.__setitem__("skeleton", "cmu"))))
    add(Case("weights-rig-without-bvh", wp, contains=["w.safetensors", "rig_bvh"],
             setup=weights(edit=lambda c: c.__setitem__("skeleton", "rig"))))
    add(Case("weights-prior-radius-without-tensors", wp, contains=["w.safetensors", "prior."],
             setup=weights(edit=lambda c: c.__setitem__("prior_radius", 1.5))))
    add(Case("weights-seed-frames-0", wp, contains=["w.safetensors"], setup=weights(edit=lambda c: c.__setitem__("seed_frames", 0))))
    add(Case("weights-hidden-huge", wp, contains=["w.safetensors"], setup=weights(edit=lambda c: c.__setitem__("hidden", 1 << 40))))
    add(Case("weights-truncated", wp, contains=["w.safetensors"],
             setup=lambda d: (d / "w.safetensors").write_bytes(FIXTURE_MODEL.read_bytes()[:5000])))

    # -- outputs that would clobber inputs or lie about their format
    def copy_model(name):
        return lambda d: shutil.copy(FIXTURE_MODEL, d / name)
    add(Case("eval-save-predictions-over-model", ["eval", "--model", "m.npy", "--save-predictions", "m.npy", "--no-classifier"],
             contains=["m.npy"], setup=copy_model("m.npy"), inputs=["m.npy"]))
    add(Case("eval-save-predictions-txt", ["eval", "--model", m, "--save-predictions", "p.txt", "--no-classifier"], contains=["p.txt"]))
    add(Case("convert-onto-itself", ["convert", "a.txt", "a.txt"], contains=["a.txt"],
             setup=lambda d: shutil.copy(shared["expmap"], d / "a.txt"), inputs=["a.txt"]))
    add(Case("convert-onto-itself-fps", ["convert", "a.txt", "a.txt", "--fps", "25"], contains=["a.txt"],
             setup=lambda d: shutil.copy(shared["expmap"], d / "a.txt"), inputs=["a.txt"]))

    def link_setup(d: Path) -> None:
        shutil.copy(shared["expmap"], d / "a.txt")
        os.symlink("a.txt", d / "link.txt")
    add(Case("convert-onto-symlink-to-input", ["convert", "a.txt", "link.txt"], contains=["link.txt"], setup=link_setup, inputs=["a.txt"]))

    def map_txt(d: Path) -> None:
        (d / "map.txt").write_text(__import__("json").dumps(files.CMU_MAP))
    add(Case("predict-out-is-joint-map", predict + ["--seed", s["rig"], "--joint-map", "map.txt", "--out", "map.txt"],
             contains=["map.txt"], setup=map_txt, inputs=["map.txt"]))
    add(Case("score-skeleton-missing", ["score", "--pred", s["pos_npy"], "--db", s["pos_npy"], "--metric", "ndms", "--input-space", "raw",
                                        "--skeleton", "missing.bvh"], contains=["missing.bvh"]))
    add(Case("score-skeleton-not-bvh", ["score", "--pred", s["pos_npy"], "--db", s["pos_npy"], "--metric", "ndms", "--input-space", "raw",
                                        "--skeleton", s["e_npy"]], contains=["e.npy"]))
    add(Case("score-ndms-raw-on-expmap", ["score", "--pred", s["e_npy"], "--db", s["e_npy"], "--metric", "ndms", "--input-space", "raw"],
             contains=["positions"]))

    # -- joint maps that are wrong
    def bad_map(edit):
        def setup(d: Path) -> None:
            text = __import__("json").dumps(edit(dict(files.CMU_MAP))) if callable(edit) else edit
            (d / "map.json").write_text(text)
        return setup
    mp = predict + ["--seed", s["rig"], "--joint-map", "map.json", "--out", "p.bvh"]
    add(Case("map-two-to-one", mp, contains=["map.json", "LeftForeArm"], setup=bad_map(lambda x: {**x, "LeftHand": "LeftForeArm"})))
    add(Case("map-hips-head-swapped", mp, contains=["map.json"], setup=bad_map(lambda x: {**x, "Hips": "Head", "Head": "Hips"})))
    add(Case("map-arm-to-leg", mp, contains=["map.json"],
             setup=bad_map(lambda x: {**x, "LeftArm": "LeftUpLeg", "LeftForeArm": "LeftLeg", "LeftHand": "LeftFoot",
                                      "LeftUpLeg": "LeftArm", "LeftLeg": "LeftForeArm", "LeftFoot": "LeftHand"})))
    dup = '{' + ", ".join(f'"{k}": "{v}"' for k, v in files.CMU_MAP.items()) + ', "Head": "Neck"}'
    add(Case("map-conflicting-duplicate-keys", mp, contains=["map.json", "twice"], setup=bad_map(dup)))
    add(Case("map-left-right-arms-swapped", mp, contains=["map.json"],
             setup=bad_map(lambda x: {**x, **{f"Left{p}": f"Right{p}" for p in ("Shoulder", "Arm", "ForeArm", "Hand")},
                                      **{f"Right{p}": f"Left{p}" for p in ("Shoulder", "Arm", "ForeArm", "Hand")}})))
    add(Case("map-not-json", mp, contains=["map.json"], setup=bad_map("Hips = Hips")))
    add(Case("map-good", mp, expect="accept", setup=bad_map(lambda x: x)))
    many = "{" + ", ".join(f'"k{i}": "v{i}"' for i in range(1_000_000)) + "}"
    add(Case("map-a-million-keys", mp, contains=["map.json", "bytes"], setup=bad_map(many)))
    add(Case("map-two-thousand-keys", mp, contains=["map.json", "entries"],
             setup=bad_map("{" + ", ".join(f'"k{i}": "v{i}"' for i in range(2_000)) + "}")))
    add(Case("map-with-npy-seed", predict + ["--seed", s["e_npy"], "--joint-map", "map.json", "--out", "p.bvh"],
             contains=["--joint-map", "e.npy", "no rig"], setup=bad_map(lambda x: x)))
    add(Case("map-with-expmap-seed", predict + ["--seed", s["expmap"], "--joint-map", "map.json", "--out", "p.bvh"],
             contains=["--joint-map", "walk.txt", "no rig"], setup=bad_map(lambda x: x)))
    add(Case("samples-overwrite-their-seed", ["predict", "--model", m, "--action", "walking", "--seed", "out_0.bvh",
                                               "--out", "out.bvh", "--samples", "2"],
             contains=["out_0.bvh", "input"], setup=lambda d: shutil.copy(WALK_SEED, d / "out_0.bvh"),
             inputs=["out_0.bvh"]))
    add(Case("bvh-root-1e308-to-npy", predict + ["--seed", "r.bvh", "--out", "p.npy"], contains=["finite"],
             setup=lambda d: (d / "r.bvh").write_text(root_1e308())))

    # -- values that overflow, rates out of range, error lines
    add(Case("bvh-offset-1e308-positions", ["convert", "o.bvh", "o.npy", "--positions"], contains=["o.bvh"],
             setup=lambda d: (d / "o.bvh").write_text(files.rig_bvh(frames=10, offset_scale=3e305))))
    add(Case("input-fps-1e300", predict + ["--seed", s["expmap"], "--out", "p.bvh", "--input-fps", "1e300"], contains=["--input-fps"]))
    add(Case("fps-1e300", ["convert", s["walk"], "o.bvh", "--fps", "1e300"], contains=["--fps"]))
    add(Case("action-control-chars", ["predict", "--model", m, "--seed", s["walk"], "--out", "p.bvh", "--action", "walk\x1b[31m\x07"],
             contains=["walk"]))
    add(Case("clap-usage-error", ["predict", "--frames", "abc"], contains=["--frames"]))
    add(Case("clap-unknown-flag", ["convert", "--nope"], contains=["--nope"]))
    add(Case("clap-missing-subcommand", [], contains=["no command given", "predict"]))

    # -- numbers out of any range are named in short form, with the file at fault
    def big_value_bvh(d: Path) -> None:
        lines = files.rig_bvh(frames=80, frame_time=0.04).splitlines()
        motion = lines.index("MOTION")
        row = lines[motion + 10].split()
        row[4] = "1e200"
        lines[motion + 10] = " ".join(row)
        (d / "big.bvh").write_text("\n".join(lines) + "\n")
    add(Case("seed-rotation-1e200", predict + ["--seed", "big.bvh", "--out", "p.bvh"], contains=["big.bvh"], setup=big_value_bvh))
    add(Case("weights-fps-1e-300", wp, contains=["w.safetensors"], setup=weights(edit=lambda c: c.__setitem__("fps", 1e-300))))
    add(Case("weights-fps-1e300", wp, contains=["w.safetensors"], setup=weights(edit=lambda c: c.__setitem__("fps", 1e300))))
    add(Case("score-pred-1e300-names-the-file", ["score", "--gt", s["e_npy"], "--pred", "p.npy"], contains=["p.npy"],
             setup=lambda d: files.npy(d / "p.npy", (2, 30, 99), values=[1e300] * (2 * 30 * 99))))
    add(Case("score-gt-nan-names-the-file", ["score", "--gt", "g.npy", "--pred", s["e_npy"]], contains=["g.npy"],
             setup=lambda d: files.npy(d / "g.npy", (2, 30, 99), values=[float("nan")] * (2 * 30 * 99))))

    def data_with_nan(d: Path) -> None:
        files.data_dir(d / "d", 99)
        s1 = d / "d/h3.6m/dataset/S1"
        s1.mkdir(parents=True)
        rows = files.expmap_text(400).splitlines()
        rows[7] = ",".join(["1e300"] * 99)
        (s1 / "walking_1.txt").write_text("\n".join(rows) + "\n")
    add(Case("eval-data-1e300-names-the-take", ["eval", "--data", "d", "--actions", "walking", "--no-classifier", "--model", m],
             expect="either", contains=["walking_1"], setup=data_with_nan))

    # -- the MPJPE protocol and the multi-sample metrics
    mp = ["eval", "--protocol", "mpjpe", "--model", m]
    add(Case("eval-mpjpe-s5-98-columns", mp + ["--data", "d", "--actions", "walking"], contains=["walking_1"],
             setup=lambda d: files.data_dir(d / "d", 98)))
    add(Case("eval-mpjpe-takes-too-short", mp + ["--data", "d", "--actions", "walking"], contains=["walking_1", "166"],
             setup=lambda d: files.data_dir(d / "d", 99, rows=300)))
    add(Case("eval-mpjpe-stride-0", mp + ["--windows", "all", "--stride", "0"], contains=["stride"]))
    add(Case("eval-mpjpe-stride-without-all", mp + ["--stride", "5"], contains=["stride"]))
    add(Case("eval-mpjpe-input-frames-1e6", mp + ["--input-frames", "1000000"], contains=["--input-frames"]))
    add(Case("eval-mpjpe-test-windows", mp + ["--windows", "test"], contains=["8", "256"]))
    add(Case("eval-mpjpe-samples-5", mp + ["--samples", "5"], contains=["--samples"]))
    st = ["eval", "--protocol", "stochastic", "--model", m]
    add(Case("eval-stochastic-windows-8", st + ["--windows", "8"], contains=["--windows"]))
    add(Case("eval-stochastic-samples-0", st + ["--samples", "0"], contains=["--samples"]))
    add(Case("eval-stochastic-samples-1e9", st + ["--samples", "1000000000"], contains=["--samples"]))
    add(Case("eval-stochastic-s9-98-columns", st + ["--data", "d", "--actions", "walking"], contains=["walking_1"],
             setup=lambda d: (files.data_dir(d / "d", 99), (d / "d/h3.6m/dataset/S9").mkdir(parents=True),
                              (d / "d/h3.6m/dataset/S9/walking_1.txt").write_text(files.expmap_text(400, 98)))))
    add(Case("eval-h36m-windows-256", ["eval", "--model", m, "--windows", "256", "--no-classifier"], contains=["mpjpe"]))
    add(Case("score-mpjpe-pred-1e300-names-the-file", ["score", "--gt", s["e_npy"], "--pred", "p.npy", "--metric", "mpjpe"],
             contains=["p.npy"], setup=lambda d: files.npy(d / "p.npy", (2, 30, 99), values=[1e300] * (2 * 30 * 99))))
    add(Case("score-mpjpe-positions-shape", ["score", "--gt", "g.npy", "--pred", "p.npy", "--metric", "mpjpe"],
             contains=["p.npy"], setup=lambda d: (files.npy(d / "g.npy", (2, 30, 32, 3)), files.npy(d / "p.npy", (2, 30, 7, 3)))))
    add(Case("score-multimodal-nan-names-the-file",
             ["score", "--gt", "g.npy", "--pred", "p.npy", "--seed", "s.npy", "--input-space", "raw", "--metric", "multimodal"],
             contains=["p.npy"], setup=lambda d: (files.npy(d / "g.npy", (2, 10, 6)), files.npy(d / "s.npy", (2, 4, 6)),
                                                  files.npy(d / "p.npy", (2, 3, 10, 6), values=[float("nan")] * 360))))
    add(Case("score-multimodal-threshold-nan",
             ["score", "--gt", "g.npy", "--pred", "p.npy", "--seed", "s.npy", "--input-space", "raw", "--metric", "multimodal",
              "--multimodal-threshold", "nan"],
             contains=["threshold"], setup=lambda d: (files.npy(d / "g.npy", (2, 10, 6)), files.npy(d / "s.npy", (2, 4, 6)),
                                                      files.npy(d / "p.npy", (2, 3, 10, 6)))))

    # -- thin rigs with millions of frames through the retargeting and resampling paths
    add(Case("predict-thin-rig-2m-frames", predict + ["--seed", s["thin_2m"], "--out", "p.bvh"], contains=["thin_2m.bvh"]))
    add(Case("convert-thin-rig-2m-frames-to-30-hz", ["convert", s["thin_2m"], "o.bvh", "--fps", "30"], expect="either",
             contains=["thin_2m.bvh"]))
    add(Case("render-thin-rig-2m-frames", ["render", s["thin_2m"], "--out", "r.png"], expect="either", contains=["thin_2m.bvh"]))

    # -- .npy headers that lie
    npy_cases = {
        "npy-huge-shape": dict(shape=(2, 3), header_shape="(1000000000000, 99)"),
        "npy-negative-shape": dict(shape=(2, 3), header_shape="(-5, 99)"),
        "npy-complex": dict(shape=(2, 3), descr="<c16"),
        "npy-truncated": dict(shape=(10, 99), truncate=100),
        "npy-object": dict(shape=(2, 3), descr="|O"),
    }
    for name, kw in npy_cases.items():
        add(Case(name, ["convert", "x.npy", "o.bvh"], contains=["x.npy"], setup=lambda d, kw=kw: files.npy(d / "x.npy", **kw)))
        add(Case(name + "-score", ["score", "--gt", "x.npy", "--pred", "x.npy"], contains=["x.npy"],
                 setup=lambda d, kw=kw: files.npy(d / "x.npy", **kw)))

    # -- ordinary use (the corpus must not pass by refusing everything)
    add(Case("ok-convert", ["convert", s["walk"], "o.npy"], expect="accept"))
    add(Case("ok-convert-rig-positions", ["convert", s["rig"], "o.npy", "--positions"], expect="accept"))
    add(Case("ok-predict", predict + ["--seed", s["walk"], "--out", "p.bvh", "--frames", "50"], expect="accept"))
    add(Case("ok-predict-rig", predict + ["--seed", s["rig"], "--out", "p.bvh", "--frames", "50"], expect="accept"))
    add(Case("ok-predict-expmap", predict + ["--seed", s["expmap"], "--out", "p.txt", "--frames", "50"], expect="accept"))
    add(Case("ok-render", ["render", s["walk"], "--out", "r.png"], expect="accept"))
    add(Case("ok-score", ["score", "--gt", s["e_npy"], "--pred", s["e_npy"]], expect="accept"))
    add(Case("ok-info", ["info", m], expect="accept"))

    # -- random corruptions of a BVH and of exp-map text (fixed seed): refused cleanly or read
    rng = random.Random(20261204)
    walk_text = WALK_SEED.read_text()
    rig_text = files.rig_bvh(frames=60)
    expmap = files.expmap_text(120)
    kinds = ["truncate", "drop-line", "dup-line", "token", "token", "bytes"]
    for i in range(240):
        source, ext = [(walk_text, "bvh"), (rig_text, "bvh"), (expmap, "txt")][i % 3]
        kind = kinds[i % len(kinds)]
        text = files.mutate_text(source, rng, kind)
        command = [
            ["convert", f"m.{ext}", "o.npy"],
            predict + ["--seed", f"m.{ext}", "--out", "p.bvh", "--frames", "20"],
            ["convert", f"m.{ext}", "o.npy", "--positions"],
            ["render", f"m.{ext}", "--out", "r.png"],
        ][i % 4]
        add(Case(f"mutant-{i:03}-{kind}-{ext}-{command[0]}", command, expect="either",
                 setup=lambda d, t=text, e=ext: (d / f"m.{e}").write_text(t, errors="replace")))
    # corrupted joint maps (JSON text) and .npy bytes
    map_text = __import__("json").dumps(files.CMU_MAP)
    for i in range(30):
        text = files.mutate_text(map_text.replace(", ", " "), rng, ["token", "bytes", "truncate"][i % 3])
        add(Case(f"mutant-map-{i:02}", predict + ["--seed", s["rig"], "--joint-map", "map.json", "--out", "p.bvh", "--frames", "20"],
                 expect="either", setup=lambda d, t=text: (d / "map.json").write_text(t, errors="replace")))
    good_npy = shared["e_npy"].read_bytes()
    for i in range(30):
        b = bytearray(good_npy)
        for _ in range(rng.randrange(1, 6)):
            b[rng.randrange(0, 128 if i % 2 else len(b))] = rng.randrange(256)
        command = [["convert", "x.npy", "o.bvh"], ["score", "--gt", "x.npy", "--pred", s["e_npy"]]][i % 2]
        add(Case(f"mutant-npy-{i:02}-{command[0]}", command, expect="either",
                 setup=lambda d, b=bytes(b): (d / "x.npy").write_bytes(b)))
    return out


@dataclass
class Outcome:
    code: int | None
    signal: int | None
    seconds: float
    rss_mib: float
    stderr: str
    timed_out: bool


def run_one(cli: str, case: Case, cwd: Path, timeout: float, cap_bytes: int) -> Outcome:
    """Runs one case under an address-space cap; the child's own peak RSS comes from wait4."""
    import subprocess

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (cap_bytes, cap_bytes))
        os.setsid()

    err_path = cwd.parent / (cwd.name + ".stderr")
    start = time.monotonic()
    with open(err_path, "wb") as err:
        proc = subprocess.Popen([cli] + case.argv, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=err, preexec_fn=limit, env={**os.environ, "RUST_BACKTRACE": "0"})
        timed_out = False
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > timeout:
                os.killpg(proc.pid, signal.SIGKILL)
                pid, status, usage = os.wait4(proc.pid, 0)
                timed_out = True
                break
            time.sleep(0.01)
    proc.returncode = 0  # reaped above
    seconds = time.monotonic() - start
    stderr = err_path.read_bytes().decode("utf-8", errors="replace")
    code = os.WEXITSTATUS(status) if os.WIFEXITED(status) else None
    sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
    return Outcome(code, sig, seconds, usage.ru_maxrss / 1024, stderr, timed_out)


def judge(case: Case, out: Outcome, before: set[str], after: set[str], changed: list[str], max_rss: float) -> list[str]:
    """What is wrong with an outcome (empty: clean)."""
    problems = []
    if out.timed_out:
        problems.append(f"ran past the time limit ({out.seconds:.0f} s)")
    if out.signal is not None:
        problems.append(f"killed by signal {out.signal}")
    if out.code == 101 or "panicked" in out.stderr:
        problems.append("panicked")
    if out.rss_mib > max_rss:
        problems.append(f"used {out.rss_mib:.0f} MiB")
    if problems:
        return problems
    refused = out.code == 2
    if case.expect == "accept" and out.code != 0:
        return [f"exit {out.code} on input it should accept: {out.stderr.strip()[:300]!r}"]
    if case.expect == "refuse" and not refused:
        return [f"exit {out.code} on input it should refuse"]
    if case.expect == "either" and out.code not in (0, 2):
        return [f"exit {out.code}"]
    if refused:
        lines = out.stderr.splitlines()
        if len(lines) != 1 or not lines[0].startswith("error: "):
            problems.append(f"{len(lines)} stderr lines, not one 'error:' line: {out.stderr[:300]!r}")
        line = lines[0] if lines else ""
        if any(ord(c) < 32 or ord(c) == 127 for c in line):
            problems.append("control characters in the error line")
        if len(line) > 1000:
            problems.append(f"error line of {len(line)} characters")
        if re.search(r"\d{41,}", line):
            problems.append("a number of more than 40 digits in the error line")
        for text in case.contains:
            if text not in line:
                problems.append(f"{text!r} missing from {line[:300]!r}")
        if after - before:
            problems.append(f"left files behind: {sorted(after - before)}")
    if changed:
        problems.append(f"inputs changed: {changed}")
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cli", default=str(REPO / "target/release/motion-cli"))
    parser.add_argument("--only", default=None, help="run the cases whose name contains this")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    parser.add_argument("--max-rss-mib", type=float, default=2048.0, help="peak resident memory per case")
    parser.add_argument("--cap-gib", type=float, default=4.0, help="address-space cap per case (RLIMIT_AS)")
    parser.add_argument("--keep", action="store_true", help="keep the scratch directory")
    args = parser.parse_args()
    cli = str(Path(args.cli).resolve())
    work = Path(tempfile.mkdtemp(prefix="motion-hostile-"))
    try:
        print(f"hostile corpus: writing shared files under {work} ...", flush=True)
        shared = shared_files(work / "shared")
        chosen = [c for c in cases(shared) if args.only is None or args.only in c.name]
        clean = 0
        for case in chosen:
            cwd = work / case.name
            cwd.mkdir()
            if case.setup:
                case.setup(cwd)
            sums = {p: files.adler(cwd / p) for p in case.inputs}
            before = set(os.listdir(cwd))
            out = run_one(cli, case, cwd, args.timeout, int(args.cap_gib * (1 << 30)))
            after = set(os.listdir(cwd))
            changed = [p for p, s in sums.items() if files.adler(cwd / p) != s]
            problems = judge(case, out, before, after, changed, args.max_rss_mib)
            status = "clean" if not problems else "FLAGGED"
            clean += not problems
            print(f"{status:7} {case.name:44} exit {out.code if out.code is not None else '-':>3} "
                  f"{out.seconds:6.2f} s {out.rss_mib:7.0f} MiB" + ("" if not problems else "  " + "; ".join(problems)),
                  flush=True)
            shutil.rmtree(cwd, ignore_errors=True)
        print(f"clean {clean} / total {len(chosen)}")
        return 0 if clean == len(chosen) else 1
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
