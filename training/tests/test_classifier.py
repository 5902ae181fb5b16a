"""The action classifier (Ghosh et al. 2017, section 4.5): config, features, invariances, reports, checkpoints."""

import numpy as np
import pytest
import torch

from training.classifier import ActionClassifier, make_classifier_config
from training.export_fixtures import H36M_DIMS_USED
from training.train_classifier import accuracy_report, load_checkpoint, markdown


def _model(**overrides):
    torch.manual_seed(0)
    config = make_classifier_config(H36M_DIMS_USED, hidden=8, **overrides)
    return ActionClassifier(config).double().eval()


def test_config_defaults_and_errors():
    config = make_classifier_config(H36M_DIMS_USED)
    assert config["architecture"] == "action-classifier"
    assert config["window"] == 50 and config["fps"] == 25 and len(config["actions"]) == 15
    with pytest.raises(ValueError):
        make_classifier_config(H36M_DIMS_USED, colour="red")
    with pytest.raises(ValueError):
        make_classifier_config(H36M_DIMS_USED, derivative_order=4)


def test_logits_shape_and_probabilities():
    model = _model()
    x = torch.randn(3, 50, 99, dtype=torch.float64)
    assert model(x).shape == (3, 15)
    p = model.probabilities(x)
    assert torch.allclose(p.sum(-1), torch.ones(3, dtype=torch.float64))


def test_centering_ignores_a_static_pose_offset_but_not_root_deltas():
    model = _model(center=True)
    x = torch.randn(2, 20, 99, dtype=torch.float64)
    shifted = x.clone()
    shifted[..., 6:] += 0.7  # a constant pose offset on every non-root dim
    assert torch.allclose(model(x), model(shifted), atol=1e-12)
    moved = x.clone()
    moved[..., 0] += 5.0  # a different root speed
    assert not torch.allclose(model(x), model(moved))
    plain = _model(center=False)
    assert not torch.allclose(plain(x), plain(shifted))


def test_accuracy_report_counts_and_confusion():
    probs = np.array([[0.9, 0.1, 0.0], [0.2, 0.8, 0.0], [0.6, 0.3, 0.1], [0.1, 0.1, 0.8]])
    labels = np.array([0, 1, 1, 2])
    rep = accuracy_report(probs, labels, ["a", "b", "c"])
    assert rep["confusion"] == [[1, 0, 0], [1, 1, 0], [0, 0, 1]]
    assert rep["per_action"]["b"]["accuracy"] == 0.5
    assert rep["per_action"]["b"]["most_confused_with"] == "a"
    assert rep["mean_accuracy"] == pytest.approx((1 + 0.5 + 1) / 3)
    assert "| b | 2 | 0.500 |" in markdown(rep)


def test_a_file_that_is_not_a_checkpoint_is_a_clear_error(tmp_path):
    bad = tmp_path / "x.pt"
    bad.write_bytes(b"garbage")
    with pytest.raises(ValueError, match="not a classifier checkpoint"):
        load_checkpoint(bad)
    torch.save({"model": {}}, tmp_path / "y.pt")
    with pytest.raises(ValueError, match="not a classifier checkpoint"):
        load_checkpoint(tmp_path / "y.pt")
