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
