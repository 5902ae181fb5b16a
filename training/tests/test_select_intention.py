"""The validation NDMS of select_intention: word alignment against a database holding the forecast, and bad input."""

import numpy as np
import pytest
import torch

from training import data, kinematics, select_intention, word_realism as wr

from .test_intention import small_model
from .test_word_realism import walking_frames


@pytest.fixture(autouse=True)
def skeleton_or_skip():
    if not kinematics.SKELETON.is_file():
        pytest.skip(f"H3.6M skeleton not found at {kinematics.SKELETON}")


def test_a_forecast_that_is_the_truth_scores_one_in_every_bin_and_a_model_less():
    frames = walking_frames(260)
    window = data.ValidationWindow(action="walking", subaction=1, start=40, frames=frames[40:190])
    bank = wr.WordBank([[frames]], stride=1, dtype=torch.float64)
    model = small_model()
    model.norm.set_stats(torch.zeros(99, dtype=torch.float64), torch.ones(99, dtype=torch.float64))
    real = model.closed_loop
    truth = model.norm.normalize(torch.from_numpy(window.frames[50:]))

    def the_truth(seed, horizon, action=None, eps=None):
        assert horizon == 100 and eps.shape == (seed.shape[0], model.noise_dims)
        return truth.expand(seed.shape[0], -1, -1).to(seed.dtype)

    model.closed_loop = the_truth
    bins = select_intention.validation_ndms(model, [window], bank, ["walking"], samples=2, scale=1.0)["walking"]
    assert bins.shape == (10,)
    np.testing.assert_allclose(bins, 1.0, atol=1e-9)
    model.closed_loop = real
    got = select_intention.validation_ndms(model, [window], bank, ["walking"], samples=2, scale=0.5)["walking"]
    assert ((got >= 0) & (got < 0.99)).all()


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert select_intention.main([str(tmp_path / "missing.pt")]) == 2
    assert select_intention.main([str(tmp_path / "missing.pt"), "--scales", "-1"]) == 2
    assert "error:" in capsys.readouterr().err
