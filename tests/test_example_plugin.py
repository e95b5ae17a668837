"""The worked example in docs/plugins/ registers, passes dance_core.testing's feature check, validates
from a recipe and computes loudness."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.errors import RecipeError
from dance_core.media import Audio, FeatureInputs
from dance_core.recipe import load_recipe
from dance_core.testing import check_feature, registered_plugin

SRC = Path(__file__).resolve().parents[1] / "docs" / "plugins" / "dance-loudness" / "src"


@pytest.fixture
def example_plugin(monkeypatch):
    monkeypatch.syspath_prepend(str(SRC))
    module = importlib.import_module("dance_loudness.plugin")
    yield module
    for name in [n for n in sys.modules if n.startswith("dance_loudness")]:
        del sys.modules[name]


def test_example_plugin_works_from_a_recipe(example_plugin):
    with registered_plugin(example_plugin, "loudness") as registry:
        assert registry.get("feature", "loudness").plugin == "loudness"
        check_feature("loudness", {"window": 0.1}, fps=30.0)
        recipe = load_recipe("core-synthetic", ["features.music=[{plugin: energy}, {plugin: loudness, window: 0.1}]"])
        extractor = recipe.features["music"][1].build()
        rate = 8000
        samples = np.concatenate([np.zeros(rate), 0.5 * np.ones(rate)]).astype(np.float32)
        out = extractor.extract(FeatureInputs(20, Audio(samples, rate)), fps=10)
        assert out.shape == (20, 1)
        assert out[2, 0] == pytest.approx(-80.0) and out[15, 0] == pytest.approx(20 * np.log10(0.5), abs=1e-4)
        with pytest.raises(RecipeError, match=r"features\.music\.1\.window"):
            load_recipe("core-synthetic", ["features.music=[{plugin: energy}, {plugin: loudness, window: 5}]"])
