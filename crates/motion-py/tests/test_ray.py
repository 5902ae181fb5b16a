"""examples/ray_score.py: a local Ray cluster (2 CPUs) gives the single-process report, exactly."""

import importlib.util
import json
import sys

import numpy as np
import pytest

import motion
from conftest import ROOT, WALK_SEED


def load_example():
    spec = importlib.util.spec_from_file_location("ray_score", ROOT / "examples" / "ray_score.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["ray_score"] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    """Two 8 s reference clips (25 Hz .npy) and a generated corpus of 6 seeds x 3 samples."""
    ray_score = load_example()
    tmp = tmp_path_factory.mktemp("corpus")
    model = motion.Model.default()
    refs = []
    for k, clip in enumerate(model.predict(str(WALK_SEED), action="walking", frames=200, samples=2)):
        refs.append(tmp / f"ref_{k}.npy")
        np.save(refs[-1], clip)
    ray_score.generate_corpus(tmp / "corpus", refs, seeds=6, samples=3, frames=30, rng_seed=0)
    return ray_score, refs, tmp / "corpus"


def test_ray_report_equals_the_single_process_report(corpus):
    ray = pytest.importorskip("ray")
    ray_score, refs, root = corpus
    db = motion.NdmsDatabase(ray_score.reference_positions(refs))
    items = ray_score.corpus_items(root / "pred", root / "gt")
    assert len(items) == 6
    local = ray_score.score(items, db, local=True)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        distributed = ray_score.score(items, db, local=False, shard=2)
    finally:
        ray.shutdown()
    assert json.dumps(distributed, sort_keys=True) == json.dumps(local, sort_keys=True)
    summary = local["summary"]
    assert summary["files"] == 6
    assert {"npss", "ndms", "apd", "euler_ms"} <= set(summary)
    assert all(np.isfinite(v) for v in (summary["npss"], summary["ndms"], summary["apd"]))


def test_command_line_local_mode_and_bad_input(corpus, tmp_path, capsys):
    ray_score, refs, root = corpus
    out = tmp_path / "report.json"
    code = ray_score.main([str(root / "pred"), "--gt", str(root / "gt"), "--db", *map(str, refs), "--out", str(out), "--local"])
    assert code == 0
    assert json.loads(out.read_text())["summary"]["files"] == 6
    assert ray_score.main([str(tmp_path / "empty"), "--db", str(refs[0]), "--out", str(out), "--local"]) == 2
    assert "no .npy predictions" in capsys.readouterr().err
