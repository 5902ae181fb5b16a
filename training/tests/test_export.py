"""Weights file: save/load round trip, f16/bf16, rejected inputs."""

import json

import pytest
import torch
from safetensors import safe_open
from safetensors.torch import save_file

from training.export import load_weights, save_weights
from training.export_fixtures import H36M_DIMS_USED
from training.models import build_model, make_config

PROVENANCE = {"data": "test", "iterations": 3, "date": "2026-01-01T00:00:00Z", "command": "pytest", "seed": 1}


def _model(architecture="vgru-d"):
    torch.manual_seed(0)
    extra = {"plan_hidden": 4} if architecture == "vgru-d" else {}
    model = build_model(make_config(architecture, H36M_DIMS_USED, hidden=8, **extra))
    model.norm.set_stats(torch.randn(99), torch.rand(99) + 0.5)
    return model.eval()


@pytest.mark.parametrize("architecture", ["vgru-d", "gru-d"])
def test_round_trip_f32(tmp_path, architecture):
    model = _model(architecture)
    path = tmp_path / "m.safetensors"
    save_weights(model, path, PROVENANCE)
    loaded = load_weights(path)
    assert loaded.config == model.config and loaded.provenance == PROVENANCE
    assert not loaded.training
    for name, tensor in model.state_dict().items():
        assert torch.equal(loaded.state_dict()[name], tensor), name
    with safe_open(str(path), framework="pt") as f:
        meta = f.metadata()
    assert meta["format"] == "motion-weights" and meta["format_version"] == "1"
    assert json.loads(meta["config"])["architecture"] == architecture


@pytest.mark.parametrize("dtype", [torch.float16, torch.bfloat16])
def test_half_precision_export_loads(tmp_path, dtype):
    model = _model()
    path = tmp_path / "m.safetensors"
    save_weights(model, path, PROVENANCE, dtype=dtype)
    with safe_open(str(path), framework="pt") as f:
        assert f.get_tensor("body.weight_ih").dtype == dtype
        assert f.get_tensor("norm.mean").dtype == torch.float32  # statistics stay f32
    loaded = load_weights(path)
    assert loaded.decoder.weight.dtype == torch.float32
    torch.testing.assert_close(loaded.body.weight_hh, model.body.weight_hh.to(dtype).float(), rtol=0, atol=0)
    seed = torch.randn(6, 99)
    eps = torch.zeros(4)
    torch.testing.assert_close(
        loaded.predict(seed, "walking", 5, eps), model.predict(seed, "walking", 5, eps), rtol=0, atol=0.1
    )


def test_unknown_version_rejected(tmp_path):
    path = tmp_path / "m.safetensors"
    save_file({"x": torch.zeros(1)}, str(path), metadata={"format": "motion-weights", "format_version": "2"})
    with pytest.raises(ValueError, match="format_version"):
        load_weights(path)


def test_nan_weight_rejected_naming_the_tensor(tmp_path):
    model = _model("gru-d")
    with torch.no_grad():
        model.rnn[1].bias_hh[0] = float("nan")
    path = tmp_path / "m.safetensors"
    save_weights(model, path, PROVENANCE)
    with pytest.raises(ValueError, match="rnn.1.bias_hh"):
        load_weights(path)
