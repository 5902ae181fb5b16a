"""Weight interpolation (training/interpolate.py): the blend itself and the fixed choice rule."""

import pytest
import torch

from training.export_fixtures import H36M_DIMS_USED
from training.interpolate import choose, interpolate
from training.models import build_model, make_config


def two_models():
    torch.manual_seed(0)
    a = build_model(make_config("vgru-d", H36M_DIMS_USED, hidden=8, plan_hidden=8))
    b = build_model(make_config("vgru-d", H36M_DIMS_USED, hidden=8, plan_hidden=8))
    return a.state_dict(), b.state_dict()


def test_ends_are_the_models_and_the_middle_is_their_mean():
    a, b = two_models()
    for name, t in interpolate(a, b, 0.0).items():
        assert torch.equal(t, a[name]), name
    for name, t in interpolate(a, b, 1.0).items():
        if t.is_floating_point():
            assert torch.allclose(t, b[name], atol=1e-7), name
    mid = interpolate(a, b, 0.5)
    name = next(n for n, t in a.items() if t.is_floating_point() and not torch.equal(t, b[n]))
    assert torch.allclose(mid[name], (a[name] + b[name]) / 2, atol=1e-7)


def test_different_models_are_refused():
    a, b = two_models()
    b = dict(b)
    name = next(iter(b))
    b[name] = torch.zeros(3)
    with pytest.raises(ValueError, match="shape"):
        interpolate(a, b, 0.5)
    del b[name]
    with pytest.raises(ValueError, match="differ"):
        interpolate(a, b, 0.5)


def test_rule_keeps_the_short_term_fit_then_counts_actions_awake():
    rows = [
        {"alpha": 0.0, "npss_ref": 1.50, "awake": 0},
        {"alpha": 0.25, "npss_ref": 1.52, "awake": 1},
        {"alpha": 0.5, "npss_ref": 1.64, "awake": 4},  # within 10 %: 1.65
        {"alpha": 0.75, "npss_ref": 1.87, "awake": 11},  # too far from alpha 0
    ]
    assert choose(rows)["alpha"] == 0.5
    rows[2]["npss_ref"] = 1.66
    assert choose(rows)["alpha"] == 0.25
    rows[1]["npss_ref"] = 1.70
    rows[2]["npss_ref"] = 1.70
    assert choose(rows) is None


def test_export_writes_the_blend_with_both_parents_provenance(tmp_path):
    import json

    from training.export import load_weights, read_metadata, save_weights
    from training.interpolate import main

    torch.manual_seed(0)
    config = make_config("vgru-d", H36M_DIMS_USED, hidden=8, plan_hidden=8)
    a, b = build_model(config), build_model(config)
    pa, pb = tmp_path / "a.safetensors", tmp_path / "b.safetensors"
    save_weights(a, pa, {"data": "H3.6M", "iterations": 100})
    save_weights(b, pb, {"data": "H3.6M", "iterations": 200})
    out = tmp_path / "blend.safetensors"
    assert main(["--a", str(pa), "--b", str(pb), "--export", "0.75", "--out", str(out), "--dtype", "float32",
                 "--choice", "a test"]) == 0
    blend = load_weights(str(out)).state_dict()
    want = interpolate(load_weights(str(pa)).state_dict(), load_weights(str(pb)).state_dict(), 0.75)
    for name, t in want.items():
        assert torch.equal(blend[name], t), name
    prov = json.loads(read_metadata(out)["provenance"])
    assert [p["provenance"]["iterations"] for p in prov["interpolated"]] == [100, 200]
    assert [p["weight"] for p in prov["interpolated"]] == [0.25, 0.75]
    assert prov["checkpoint_choice"] == "a test" and "--export 0.75" in prov["command"]
    # Refused: no --out, an alpha outside [0, 1].
    assert main(["--a", str(pa), "--b", str(pb), "--export", "0.75"]) == 2
    assert main(["--a", str(pa), "--b", str(pb), "--export", "1.5", "--out", str(out)]) == 2
