"""The composed model drives windowed and song-level families through one contract."""

import torch
from torch import nn

from dance_core import ComponentConfig, SpanTable, TextSpan, TextSpans, hookimpl
from dance_core.protocols import Encoder, OutputHead, TrainContext, Window
from dance_core.recipe import load_recipe
from dance_core.testing import registered_plugin
from dance_core.train import Trainer


class SongEncoder(nn.Module):
    """Song-level: a per-frame linear map of the whole conditioning sequence."""

    window = Window(0, None, 0)
    latent_tokens = None

    def __init__(self, cond_dims):
        super().__init__()
        self.out_dim = 16
        self.proj = nn.Linear(sum(cond_dims.values()), 16)
        self.calls = 0

    def forward(self, motion, cond):
        assert motion is None
        self.calls += 1
        return self.proj(torch.cat(list(cond.values()), dim=-1))


class StatefulHead(nn.Module):
    """One frame per step from the previous frame, the aligned latent and a GRU state."""

    frames, keep, history_frames, latent_tokens = 1, 1, 1, None

    def __init__(self, motion_dim, latent_dim):
        super().__init__()
        self.cell = nn.GRUCell(motion_dim + latent_dim, 32)
        self.out = nn.Linear(32, motion_dim)
        self.steps = 0

    def loss(self, latent, target, history, ctx: TrainContext):
        h = torch.zeros(target.shape[0], 32)
        prev, err = history[:, -1], []
        for t in range(target.shape[1]):
            h = self.cell(torch.cat([prev, latent[:, t]], -1), h)
            err.append((self.out(h) - target[:, t]).abs().mean())
            prev = target[:, t]
        self.seen_streams = {n: tuple(x.shape) for n, x in ctx.streams.items()}
        self.seen_spans = tuple(ctx.spans.index.shape)
        return {"loss": torch.stack(err).mean(), "q": torch.tensor(ctx.values.get("q", 0.0))}

    def init_state(self, batch, generator, song=None):
        self.song_shapes = (tuple(song.latent.shape), {n: tuple(x.shape) for n, x in song.streams.items()})
        self.song_spans = song.spans
        return torch.randn(batch, 32, generator=generator) * 0.0

    def step(self, latent, history, state, temperature, generator):
        self.steps += 1
        h = self.cell(torch.cat([history[:, -1], latent[:, 0]], -1), state)
        return self.out(h)[:, None], h

    def finish(self, motion, state):
        return motion


class Plugin:
    @hookimpl
    def register_encoders(self, register):
        register("test-song", ComponentConfig, lambda c, *, cond_dims, **_: SongEncoder(cond_dims))

    @hookimpl
    def register_heads(self, register):
        register(
            "test-gru", ComponentConfig, lambda c, *, motion_dim, latent_dim, **_: StatefulHead(motion_dim, latent_dim)
        )


SMALL = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.batch_size=8", "training.val_every=1000"]


def test_song_level_family_trains_and_generates_through_core(tmp_path):
    with registered_plugin(Plugin(), "contract"):
        recipe = load_recipe(
            "core-synthetic",
            [
                *SMALL,
                "model.encoder={plugin: test-song}",
                "model.head={plugin: test-gru}",
                "data.segment_frames=24",
                "training.steps=60",
                "training.schedules={q: {plugin: constant, value: 3}}",
            ],
        )
        trainer = Trainer(recipe, tmp_path, quiet=True)
        model = trainer.model
        assert isinstance(model.encoder, Encoder) and isinstance(model.head, OutputHead)
        assert model.segment_frames(24) == 24
        result = trainer.run()
        assert result.last_loss < result.first_loss
        import json

        logged = [json.loads(line) for line in (tmp_path / "log.jsonl").read_text().splitlines()]
        assert any(entry.get("q") == 3.0 for entry in logged)  # the head's other values are logged
        streams = {"music": torch.randn(2, 50, 4)}
        seed = torch.full((2, 1, 18), 0.5)
        model.encoder.calls = 0
        spans = TextSpans.stack([SpanTable.at((TextSpan("a person jumps", 2.0, None),), 60, 20.0)] * 2)
        out = model.generate(streams, 50, seed, generator=torch.Generator().manual_seed(0), spans=spans)
    assert out.shape == (2, 50, 18)
    assert torch.equal(out[:, 0], seed[:, 0])
    assert model.encoder.calls == 1  # song-level: encoded once
    assert model.head.steps == 49  # one frame per step after the seed frame
    # a sequence head sees the streams aligned with its target, and the whole song before generating
    assert model.head.seen_streams == {"music": (8, 23, 32)}  # conditioned (mlp, dim 32)
    assert model.head.song_shapes[0][:2] == (2, 51) and model.head.song_shapes[1] == {"music": (2, 51, 32)}
    # and the text spans over the same frames: the segment after its history, the song padded as its streams
    assert model.head.seen_spans == (8, 23)
    song = model.head.song_spans
    assert song.index.shape == (2, 51) and song.index[:, 39:].tolist() == [[-1] + [0] * 11, [-1] + [1] * 11]
    assert song.frames.tolist() == [[40, 51], [40, 51]]


def test_windowed_multi_frame_head_keeps_k_frames():
    from dance_core.model import build_model

    recipe = load_recipe("core-synthetic", ["model.head.frames=4", "model.encoder.tokens=4", "compose.keep=2"])
    model = build_model(recipe, 18, {"music": 4}).eval()
    calls = []
    original = model.encoder.forward
    model.encoder.forward = lambda m, c: calls.append(m.shape) or original(m, c)
    out = model.generate({"music": torch.randn(1, 31, 4)}, 31, torch.zeros(1, 10, 18), keep=2)
    assert out.shape == (1, 31, 18)
    assert len(calls) == 11 and calls[0] == (1, 10, 18)  # (31 - 10) / 2 steps, rounded up
    assert model.segment_frames(None) == 10 + 6  # motion_past + max(frames, cond_future)


class TwoFrameHead(StatefulHead):
    """Needs exactly 2 latent tokens per step (one per frame), like a flow over 2 frames."""

    frames, keep, history_frames, latent_tokens = 2, 2, 1, 2

    def loss(self, latent, target, history, ctx):
        self.seen = (latent, target, history)
        return {"loss": latent.mean()}


def test_song_level_encoder_feeds_a_k_token_head_aligned_windows():
    from dance_core.model import ComposedModel

    model = ComposedModel({}, SongEncoder({"music": 4}), TwoFrameHead(18, 16))
    motion, music = torch.randn(3, 9, 18), torch.randn(3, 9, 4)
    model.training_loss(motion, {"music": music}, TrainContext(step=0, epoch=0))
    latent, target, history = model.head.seen
    full = model.encoder(None, {"music": music})
    assert latent.shape == (12, 2, 16) and target.shape == (12, 2, 18) and history.shape == (12, 1, 18)
    for w, s in enumerate((1, 3, 5, 7)):  # windows after the history frame, folded batch-major
        assert torch.equal(target[w::4], motion[:, s : s + 2]) and torch.equal(history[w::4], motion[:, s - 1 : s])
        assert torch.equal(latent[w::4], full[:, s : s + 2])


def test_regression_head_after_a_song_level_encoder_predicts_every_frame(tmp_path):
    with registered_plugin(Plugin(), "contract"):
        recipe = load_recipe(
            "core-synthetic",
            [*SMALL, "model.encoder={plugin: test-song}", "data.segment_frames=20", "training.steps=80"],
        )
        trainer = Trainer(recipe, tmp_path, quiet=True)
        motion, streams = trainer.sampler.batch(0)
        ctx = TrainContext(step=0, epoch=0)
        cond = trainer.model.condition(streams)
        latent = trainer.model.encoder(None, cond)
        pred = trainer.model.head.predict(latent)
        assert pred.shape == motion.shape  # one frame per latent frame, not one broadcast frame
        loss = trainer.model.training_loss(motion, streams, ctx)["loss"]
        assert torch.allclose(loss, (pred - motion).abs().mean())
        out = trainer.model.generate(streams, 20, torch.zeros(8, 0, 18))
    assert out.shape == (8, 20, 18)


def test_categorical_feature_channels_are_not_standardized():
    import numpy as np

    from dance_core.data.sources import Clip
    from dance_core.data.stats import NormStats

    rng = np.random.default_rng(0)
    clips = [Clip(f"c{i}", rng.normal(size=(10, 3)).astype(np.float32),
                  {"text": np.concatenate([rng.integers(0, 50, (10, 2)), rng.normal(5, 2, (10, 1))], 1)
                   .astype(np.float32)}) for i in range(3)]
    stats = NormStats.fit(clips, {"text": np.array([True, True, False])})
    out = stats.apply(clips[0]).streams["text"]
    np.testing.assert_array_equal(out[:, :2], clips[0].streams["text"][:, :2])  # ids kept
    assert abs(out[:, 2].mean()) < 1.5 and not np.allclose(out[:, 2], clips[0].streams["text"][:, 2])
