"""Shared helpers of the binding tests: the repository, the CLI to compare with, data."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
CLI = Path(os.environ.get("MOTION_CLI", ROOT / "target" / "release" / "motion-cli"))
WALK_SEED = ROOT / "examples" / "walk_seed.bvh"


@pytest.fixture(scope="session")
def cli():
    """Runs `motion-cli ARGS --json` and returns the parsed report (the release binary that
    `cargo test --workspace --release` or `cargo build --release -p motion-cli` leaves)."""
    if not CLI.exists():
        pytest.fail(f"{CLI} not built: run `cargo build --release -p motion-cli` first")

    def run(*args):
        done = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    return run


def smooth(rng, shape, scale=0.3):
    """Smooth random signals along axis -2 (frames): motion-like, not white noise."""
    x = rng.normal(size=shape)
    return scale * np.cumsum(x, axis=-2) / np.sqrt(shape[-2])


@pytest.fixture
def rng():
    return np.random.default_rng(20261202)
