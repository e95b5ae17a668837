"""dance live refuses DanceRevolution (a song-level encoder whose LSTM head has no live form) with one line."""

import pytest
import torch


def test_dancerevolution_cannot_dance_live_and_says_so_in_one_line():
    from dance_core.errors import DataError
    from dance_core.live.generator import LiveGenerator
    from dance_core.model import build_model
    from dance_core.recipe import load_recipe

    recipe = load_recipe("dancerevolution-small")
    model = build_model(recipe, 10, {"music": 12}).eval()
    with pytest.raises(DataError, match=r"is song-level and the head \(LSTMDecoder\) has no live form") as err:
        LiveGenerator(model, recipe, torch.zeros(max(1, model.start_frames()), 10), torch.device("cpu"))
    assert "\n" not in str(err.value)
