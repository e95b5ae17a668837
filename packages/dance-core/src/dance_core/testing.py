"""Helpers for testing dance plugins: contract checks any author can run, and temporary registration.

Each ``check_*`` function builds a component the way core does, through
``get_registry().create(kind, name, options, context)`` (so it works for installed plugins and for
plugin objects registered with :func:`registered_plugin`), then calls it the way the training and
composition loops call it (``dance_core.model.ComposedModel``), with small random tensors or a short
synthesized song. A broken contract is an ``AssertionError`` naming the component and what is wrong;
every check returns what it built, for further assertions. :func:`check_trains` trains a recipe for
a few steps. The pytest plugin ``dance_core.pytest_plugin`` wraps :func:`registered_plugin` as
fixtures. Importing this module imports no torch: the checks import it when they run.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from dance_core import registry
from dance_core.contexts import ConditionerContext, DatasetContext, EncoderContext, HeadContext
from dance_core.errors import DanceError, PluginError
from dance_core.media import Audio, FeatureInputs, TextSpan
from dance_core.plugins import check_hooks, get_plugin_manager
from dance_core.protocols import JointClip, MetricResult, MotionData, SongInputs, TrainContext, Window

__all__ = [
    "check_component",
    "check_conditioner",
    "check_dataset",
    "check_encoder",
    "check_feature",
    "check_head",
    "check_metric",
    "check_schedule",
    "check_trains",
    "dancing_clips",
    "registered_plugin",
    "synthetic_audio",
]


@contextlib.contextmanager
def registered_plugin(plugin: Any, name: str) -> Iterator[registry.Registry]:
    """Register ``plugin`` on the process-wide manager as ``name``; yield the fresh registry; undo after.

    Strict inside the block: a broken plugin raises ``PluginError`` instead of being skipped. When the
    plugin is already installed (an author running pytest on an installed package), the installed copy
    is set aside for the block and put back after, so its components are not registered twice.
    """
    pm = get_plugin_manager()
    set_aside = [(n, p) for n, p in pm.list_name_plugin() if n == name or p is plugin]
    for other, _ in set_aside:
        pm.unregister(name=other)
    strict, pm.strict = pm.strict, True
    try:
        pm.add(plugin, name)
        registry.reset()
        check_hooks(pm)
        yield registry.get_registry()
    finally:
        if pm.has_plugin(name):
            pm.unregister(name=name)
        for other, p in set_aside:
            pm.register(p, name=other)
        pm.strict = strict
        registry.reset()


class _Check:
    """Assertions whose messages start with the component's label."""

    def __init__(self, label: str):
        self.label = label

    def fail(self, what: str) -> NoReturn:
        """Raise ``AssertionError("<label>: <what>")``."""
        raise AssertionError(f"{self.label}: {what}")

    def that(self, condition: Any, what: str) -> None:
        """Fail with ``what`` unless ``condition`` holds."""
        if not condition:
            self.fail(what)

    @contextlib.contextmanager
    def calling(self, what: str) -> Iterator[None]:
        """Turn an exception raised inside the block into a failure naming the call."""
        try:
            yield
        except AssertionError:
            raise
        except Exception as exc:
            raise AssertionError(f"{self.label}: {what} raised {type(exc).__name__}: {exc}") from exc

    def count(self, value: Any, what: str, minimum: int = 0, optional: bool = False) -> None:
        """Fail unless ``value`` is an int ``>= minimum`` (or ``None`` when ``optional``)."""
        if optional and value is None:
            return
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= minimum
        kind = "an int" + (" or None" if optional else "")
        self.that(ok, f"{what} must be {kind} >= {minimum}, got {value!r}")

    def tensor(self, value: Any, what: str, shape: tuple[int, ...]) -> None:
        """Fail unless ``value`` is a finite tensor of ``shape``."""
        import torch

        self.that(isinstance(value, torch.Tensor), f"{what} is a {type(value).__name__}, not a torch.Tensor")
        self.that(tuple(value.shape) == shape, f"{what} has shape {tuple(value.shape)}, expected {shape}")
        self.that(bool(torch.isfinite(value).all()), f"{what} has NaN or inf values")


def _create(kind: str, name: str, options: Any, context: Any, reg: registry.Registry | None) -> tuple[Any, _Check]:
    """Build through the registry; a failure to look up, validate or build is an ``AssertionError``."""
    reg = reg or registry.get_registry()
    try:
        entry = reg.get(kind, name)
    except PluginError as exc:
        raise AssertionError(str(exc)) from None
    check = _Check(entry.label)
    try:
        return reg.create(kind, name, options, context), check
    except PluginError as exc:
        raise AssertionError(str(exc)) from exc
    except (DanceError, ValueError, TypeError) as exc:
        check.fail(f"cannot be built with options {dict(options or {})}: {type(exc).__name__}: {exc}")


def _check_gradients(module: Any, check: _Check, what: str) -> None:
    """At least one parameter got a gradient, and every gradient is finite."""
    import torch

    grads = [(n, p.grad) for n, p in module.named_parameters() if p.grad is not None]
    check.that(grads, f"{what} gave no parameter a gradient (are its layers registered as submodules?)")
    bad = [n for n, g in grads if not bool(torch.isfinite(g).all())]
    check.that(not bad, f"{what} gave non-finite gradients to {', '.join(bad[:3])}")


def _check_losses(out: Any, check: _Check, when: str) -> None:
    """A dict with a scalar ``"loss"`` tensor; every value a finite scalar."""
    import torch

    check.that(isinstance(out, Mapping), f"loss {when} returned a {type(out).__name__}, not a dict")
    check.that("loss" in out, f"loss {when} returned keys {sorted(out)}, without 'loss'")
    for key, value in out.items():
        check.that(
            isinstance(value, torch.Tensor) and value.numel() == 1,
            f"loss {when}: {key!r} must be a scalar tensor, got {getattr(value, 'shape', type(value).__name__)}",
        )
        if not bool(torch.isfinite(value).all()):
            check.fail(f"loss {when}: {key!r} is {float(value.detach())}")


def check_head(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    motion_dim: int = 6,
    latent_dim: int = 16,
    latent_tokens: int | None = None,
    window: Window | None = None,
    batch: int = 4,
    length: int = 8,
    steps: int = 3,
    values: Mapping[str, float] | None = None,
    registry: registry.Registry | None = None,
    cond_dims: Mapping[str, int] | None = None,
) -> Any:
    """Build head ``name`` and check its contract the way ``ComposedModel`` drives it.

    ``window`` is the encoder's (default ``Window(4, 4, 2)``, windowed; ``Window(0, None, 0)`` for a
    song-level encoder); ``latent_tokens`` the tokens a windowed encoder gives (default: as many as the
    head asks for, else 1); ``length`` the training segment a sequence head (``latent_tokens=None``
    after a song-level encoder) sees; ``values`` the schedule values in ``TrainContext.values``.

    Checks: the attributes (``frames``, ``keep`` <= ``frames``, ``history_frames``, ``latent_tokens``);
    ``loss`` returns a dict of finite scalars with ``"loss"``, whose backward gives finite gradients to
    at least one parameter and to the latent (so the encoder learns); ``loss`` also runs in eval mode
    without gradients (validation); ``init_state``/``step`` give ``(batch, frames, motion_dim)`` finite
    frames and a state, at temperature 1 and 0, drawing randomness only from the generator; ``finish``
    keeps the motion's shape. Returns the head.
    """
    import torch

    window = window or Window(motion_past=4, cond_past=4, cond_future=2)
    song = window.song_level

    def context(tokens: int | None) -> HeadContext:
        return HeadContext(motion_dim, latent_dim, tokens, window, cond_dims)

    tokens = None if song else (latent_tokens or 1)
    head, check = _create("head", name, options, context(tokens), registry)
    asks = getattr(head, "latent_tokens", None)
    if not song and latent_tokens is None and isinstance(asks, int) and asks >= 1 and asks != tokens:
        tokens = asks  # rebuilt for an encoder that gives what the head asks for, as a recipe would pair them
        head, check = _create("head", name, options, context(tokens), registry)
    check.count(head.frames, "frames", 1)
    check.count(head.keep, "keep", 1)
    check.that(head.keep <= head.frames, f"keep ({head.keep}) cannot exceed frames ({head.frames})")
    check.count(head.history_frames, "history_frames", 0)
    check.count(head.latent_tokens, "latent_tokens", 1, optional=True)
    gives = head.frames if song else tokens
    if head.latent_tokens is not None:
        check.that(
            head.latent_tokens == gives,
            f"needs {head.latent_tokens} latent tokens but a {'song-level' if song else 'windowed'} encoder "
            f"{'gives one per frame, so it must ask for frames' if song else 'built with this context gives'} "
            f"({gives})",
        )
    frames, hist, d = head.frames, head.history_frames, motion_dim
    sequence = song and head.latent_tokens is None  # the whole segment in one call
    steps_in = max(length, frames) if sequence else frames
    torch.manual_seed(0)
    latent = torch.randn(batch, steps_in if song else tokens, latent_dim, requires_grad=True)
    target = torch.randn(batch, steps_in, d)
    history = torch.randn(batch, hist, d)
    ctx = TrainContext(step=0, epoch=0, values=dict(values or {}), generator=torch.Generator().manual_seed(1))
    head.train()
    head.zero_grad(set_to_none=True)
    with check.calling("loss"):
        out = head.loss(latent, target, history, ctx)
    _check_losses(out, check, "in training")
    check.that(out["loss"].requires_grad, "loss['loss'] does not require grad (detached, or from no parameter)")
    with check.calling("backward of loss['loss']"):
        out["loss"].backward()
    _check_gradients(head, check, "backward of loss['loss']")
    check.that(
        latent.grad is not None,
        "loss['loss'] does not depend on the latent, so the encoder and conditioners would never learn",
    )
    check.that(bool(torch.isfinite(latent.grad).all()), "the latent's gradient has NaN or inf values")
    head.eval()
    with torch.no_grad(), check.calling("loss in eval mode"):
        out = head.loss(latent.detach(), target, history, ctx)
    _check_losses(out, check, "in eval mode")

    def generate(seed: int, temperature: float, n_steps: int) -> torch.Tensor:
        gen = torch.Generator().manual_seed(seed)
        lat_gen = torch.Generator().manual_seed(99)
        with torch.inference_mode():
            with check.calling("init_state"):
                if song:  # behind a song-level encoder core hands the head the whole song first
                    whole = torch.randn(batch, frames * n_steps, latent_dim, generator=lat_gen)
                    state = head.init_state(batch, gen, song=SongInputs(whole, {}))
                else:
                    state = head.init_state(batch, gen)
            motion = torch.randn(batch, hist, d, generator=lat_gen)
            for i in range(n_steps):
                lat = torch.randn(batch, frames if song else tokens, latent_dim, generator=lat_gen)
                with check.calling(f"step {i}"):
                    result = head.step(lat, motion[:, motion.shape[1] - hist :], state, temperature, gen)
                check.that(
                    isinstance(result, tuple) and len(result) == 2,
                    f"step must return (frames, state), got {type(result).__name__}",
                )
                new, state = result
                check.tensor(new, f"frames of step {i} (temperature {temperature})", (batch, frames, d))
                motion = torch.cat([motion, new[:, : head.keep]], dim=1)
            with check.calling("finish"):
                done = head.finish(motion, state)
            check.tensor(done, "the motion returned by finish", tuple(motion.shape))
        return done

    first = generate(7, 1.0, steps)
    generate(7, 0.0, 1)
    check.that(
        torch.equal(first, generate(7, 1.0, steps)),
        "two generations with equally seeded generators differ: draw random numbers only from the "
        "`generator` argument (torch.randn(..., generator=generator)), so a seed reproduces a dance",
    )
    return head


def check_encoder(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    motion_dim: int = 6,
    cond_dims: Mapping[str, int] | None = None,
    batch: int = 3,
    frames: int = 24,
    registry: registry.Registry | None = None,
) -> Any:
    """Build encoder ``name`` and check its contract the way ``ComposedModel`` drives it.

    ``cond_dims`` are the conditioning streams' widths (default ``{"music": 5}``); ``frames`` the song
    length a song-level encoder sees. A windowed encoder gets ``(batch, motion_past, motion_dim)``
    motion and ``(batch, cond_past + cond_future, width)`` per stream and must return
    ``(batch, latent_tokens, out_dim)``; a song-level one (``window.cond_past is None``) gets no motion
    and whole streams ``(batch, T, width)`` and must return ``(batch, T, out_dim)`` for any ``T``.
    Outputs are finite, and their backward reaches at least one parameter and an input. Returns the
    encoder.
    """
    import torch

    cond_dims = dict(cond_dims or {"music": 5})
    encoder, check = _create("encoder", name, options, EncoderContext(motion_dim, cond_dims), registry)
    w = encoder.window
    check.that(isinstance(w, Window), f"window must be a dance_core.Window, got {type(w).__name__}")
    check.count(encoder.out_dim, "out_dim", 1)
    check.count(w.motion_past, "window.motion_past", 0)
    check.count(w.cond_past, "window.cond_past", 0, optional=True)
    check.count(w.cond_future, "window.cond_future", 0)
    song = w.song_level
    if song:
        check.that(w.motion_past == 0, f"a song-level encoder sees no motion; window.motion_past is {w.motion_past}")
    else:
        check.count(encoder.latent_tokens, "latent_tokens (of a windowed encoder)", 1)
    torch.manual_seed(0)

    def inputs(length: int, grad: bool) -> tuple[torch.Tensor | None, dict[str, torch.Tensor]]:
        span = length if song else w.cond_past + w.cond_future
        cond = {n: torch.randn(batch, span, c, requires_grad=grad) for n, c in cond_dims.items()}
        motion = None if song else torch.randn(batch, w.motion_past, motion_dim, requires_grad=grad)
        return motion, cond

    def expect(length: int) -> tuple[int, int, int]:
        return (batch, length if song else encoder.latent_tokens, encoder.out_dim)

    encoder.train()
    encoder.zero_grad(set_to_none=True)
    motion, cond = inputs(frames, True)
    with check.calling("the forward pass"):
        out = encoder(motion, cond)
    check.tensor(out, "the latent", expect(frames))
    with check.calling("backward of the latent"):
        out.square().mean().backward()
    _check_gradients(encoder, check, "backward of the latent")
    reached = [x for x in [motion, *cond.values()] if x is not None and x.grad is not None]
    if (motion is not None and motion.shape[1]) or any(x.shape[1] for x in cond.values()):
        check.that(reached, "the latent does not depend on the motion or the conditioning streams")
    encoder.eval()
    for length in (frames, frames + 7) if song else (frames,):
        motion, cond = inputs(length, False)
        with torch.inference_mode(), check.calling(f"the forward pass in eval mode ({length} frames)"):
            out = encoder(motion, cond)
        check.tensor(out, f"the latent in eval mode ({length} frames)", expect(length))
    return encoder


def check_conditioner(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    input: str = "music",
    in_dim: int = 5,
    batch: int = 3,
    frames: int = 12,
    registry: registry.Registry | None = None,
) -> Any:
    """Build conditioner ``name`` for stream ``input`` of width ``in_dim`` and check its contract.

    ``(batch, T, in_dim)`` must give ``(batch, T, out_dim)`` finite values for any ``T``, with gradients
    reaching at least one parameter and the input. Returns the conditioner.
    """
    import torch

    cond, check = _create("conditioner", name, options, ConditionerContext(input, in_dim), registry)
    check.count(cond.out_dim, "out_dim", 1)
    torch.manual_seed(0)
    cond.train()
    cond.zero_grad(set_to_none=True)
    x = torch.randn(batch, frames, in_dim, requires_grad=True)
    with check.calling("the forward pass"):
        out = cond(x)
    check.tensor(out, "the output", (batch, frames, cond.out_dim))
    with check.calling("backward of the output"):
        out.square().mean().backward()
    _check_gradients(cond, check, "backward of the output")
    check.that(x.grad is not None, "the output does not depend on the input")
    cond.eval()
    for length in (1, frames + 5):
        with torch.inference_mode(), check.calling(f"the forward pass in eval mode ({length} frames)"):
            out = cond(torch.randn(batch, length, in_dim))
        check.tensor(out, f"the output in eval mode ({length} frames)", (batch, length, cond.out_dim))
    return cond


def synthetic_audio(seconds: float = 3.0, rate: int = 22050, bpm: float = 120.0, seed: int = 0) -> Audio:
    """A short test song: a bass note and a chord, a click on every beat (louder on downbeats), noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate))) / rate
    audio = 0.1 * np.sin(2 * np.pi * 55.0 * t)
    for freq in (220.0, 277.2, 329.6):
        audio += 0.05 * np.sin(2 * np.pi * freq * t)
    period = 60.0 / bpm
    since = t % period
    beat = np.floor(t / period).astype(int)
    click = np.sin(2 * np.pi * np.where(beat % 4 == 0, 1500.0, 1000.0) * t) * np.exp(-since / 0.02)
    audio += np.where(beat % 4 == 0, 0.5, 0.3) * click
    audio += 0.005 * rng.standard_normal(len(t))
    return Audio(np.clip(audio, -1.0, 1.0).astype(np.float32), rate)


_TEXTS = (TextSpan("step to the left", 0.0, 1.0), TextSpan("turn around and clap", 1.0, None))


def check_feature(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    fps: float = 30.0,
    audio: Audio | None = None,
    texts: Sequence[TextSpan] | None = None,
    registry: registry.Registry | None = None,
) -> Any:
    """Build feature extractor ``name`` and check ``extract`` on a short song (default
    :func:`synthetic_audio`) with timed text (as in training) and without (as when composing), for the
    song's frame count at ``fps`` and for fewer frames (training crops music to the motion): each call
    gives ``(n_frames, dim())`` finite float32 values. Returns the extractor."""
    extractor, check = _create("feature", name, options, None, registry)
    with check.calling("dim()"):
        dim = extractor.dim()
    check.count(dim, "dim()", 1)
    audio = audio or synthetic_audio()
    texts = tuple(_TEXTS if texts is None else texts)
    n = audio.n_frames(fps)
    for n_frames, spans in ((n, texts), (max(1, n - 3), ())):
        what = f"extract for {n_frames} frames at {fps:g} fps {'with' if spans else 'without'} text"
        with check.calling(what):
            values = extractor.extract(FeatureInputs(n_frames, audio, spans), fps)
        check.that(isinstance(values, np.ndarray), f"{what} returned a {type(values).__name__}, not a numpy array")
        check.that(values.shape == (n_frames, dim), f"{what} returned shape {values.shape}, expected {(n_frames, dim)}")
        check.that(values.dtype == np.float32, f"{what} returned {values.dtype}, expected float32")
        check.that(bool(np.isfinite(values).all()), f"{what} returned NaN or inf values")
    return extractor


def dancing_clips(n: int = 3, seconds: float = 4.0, fps: float = 30.0, seed: int = 0) -> list[JointClip]:
    """``n`` dancers on the default skeleton (SMPL-24 joints; metres, Y up, feet on the floor) bouncing on
    120 BPM beats with swinging limbs and a drifting root, with the music's beat times: input for metric
    checks."""
    from dance_core.motion.skeletons import SMPL_NAMES, dance24

    rest = dance24().rest_positions()
    t = np.arange(int(round(seconds * fps))) / fps
    beats = np.arange(0.25, seconds, 0.5)
    clips = []
    for k in range(n):
        rng = np.random.default_rng([seed, k])
        phase = rng.uniform(0, 2 * np.pi, (24, 3))
        swing = rng.normal(0.0, 0.06, size=(1, 24, 3)) * np.sin(2 * np.pi * t[:, None, None] + phase)
        bounce = 0.04 * (1 - np.cos(2 * np.pi * (t - 0.25) / 0.5))[:, None, None] * [0.0, 1.0, 0.0]
        drift = 0.3 * np.sin(2 * np.pi * 0.1 * t + k)[:, None, None] * [1.0, 0.0, 0.0]
        positions = rest[None] + swing * (rest[None, :, 1:2] > 0.3) + bounce + drift
        clips.append(JointClip(f"dance{k}", positions.astype(np.float64), fps, list(SMPL_NAMES), beats.copy()))
    return clips


def check_metric(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    generated: Sequence[JointClip] | None = None,
    reference: Sequence[JointClip] | None = None,
    registry: registry.Registry | None = None,
) -> MetricResult:
    """Build metric ``name``, check ``needs``, score ``generated`` (default :func:`dancing_clips`) against
    ``reference`` (when given, or by default when the metric needs one), and check the result: a
    ``MetricResult`` of finite floats."""
    metric, check = _create("metric", name, options, None, registry)
    needs = metric.needs
    check.that(
        isinstance(needs, tuple) and set(needs) <= {"reference", "music"},
        f"needs must be a tuple of 'reference' and/or 'music', got {needs!r}",
    )
    generated = list(generated or dancing_clips(3, seed=0))
    if reference is None and "reference" in needs:
        reference = dancing_clips(3, seed=1)
    with check.calling("scoring"):
        result = metric(generated, list(reference)) if reference is not None else metric(generated)
    check.that(isinstance(result, MetricResult), f"returned a {type(result).__name__}, not a MetricResult")
    check.that(result.values, "returned no values")
    for key, value in result.values.items():
        check.that(isinstance(key, str), f"value name {key!r} is not a string")
        check.that(isinstance(value, int | float) and math.isfinite(value), f"value {key!r} is {value!r}")
    for clip, values in result.per_clip.items():
        for key, value in values.items():
            check.that(isinstance(value, int | float), f"per_clip[{clip!r}][{key!r}] is {value!r}, not a number")
    return result


def check_dataset(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    fps: float = 20.0,
    seed: int = 0,
    root: str = ".",
    registry: registry.Registry | None = None,
) -> list[Any]:
    """Build dataset ``name`` and check its clips: at least one, uniquely named ``ClipSource``s with finite
    ``(T, D)`` motion (one ``D`` for all), a positive fps, and music (audio or a file) or text; a second
    build with the same seed gives the same first clip. Returns the clips."""
    from dance_core.data.sources import ClipSource

    context = DatasetContext(fps, seed, root)
    dataset, check = _create("dataset", name, options, context, registry)
    with check.calling("clips()"):
        clips = list(dataset.clips())
    check.that(clips, "clips() returned no clips")
    widths, names = set(), set()
    for clip in clips:
        check.that(isinstance(clip, ClipSource), f"clips() gave a {type(clip).__name__}, not a ClipSource")
        label = f"clip {clip.name!r}"
        check.that(clip.name not in names, f"two clips are named {clip.name!r}")
        names.add(clip.name)
        check.that(isinstance(clip.motion, MotionData), f"{label}: motion is not a MotionData")
        values = np.asarray(clip.motion.values)
        check.that(values.ndim == 2 and len(values) > 0, f"{label}: motion values have shape {values.shape}")
        check.that(bool(np.isfinite(values).all()), f"{label}: motion has NaN or inf values")
        check.that(clip.motion.fps > 0, f"{label}: fps is {clip.motion.fps}")
        check.that(
            clip.audio is not None or clip.audio_path is not None or clip.texts,
            f"{label}: has neither music (audio or audio_path) nor text",
        )
        widths.add(values.shape[1])
    check.that(len(widths) == 1, f"clips have different motion widths {sorted(widths)}")
    again, _ = _create("dataset", name, options, context, registry)
    with check.calling("clips() of a second build"):
        first = next(iter(again.clips()))
    same = np.array_equal(np.asarray(first.motion.values), np.asarray(clips[0].motion.values))
    check.that(
        first.name == clips[0].name and same,
        "two builds with the same seed give different first clips (derive every random draw from the seed)",
    )
    return clips


def check_schedule(
    name: str,
    options: Mapping[str, Any] | None = None,
    *,
    total_steps: int = 100,
    registry: registry.Registry | None = None,
) -> Any:
    """Build schedule ``name`` and check that it gives a finite number at the start, middle and end of
    training. Returns the schedule."""
    schedule, check = _create("schedule", name, options, None, registry)
    for step in (0, total_steps // 2, total_steps - 1):
        with check.calling(f"the value at step {step}"):
            value = schedule(step, step // 10, total_steps)
        check.that(
            isinstance(value, int | float | np.number) and math.isfinite(value),
            f"the value at step {step} is {value!r}, not a finite number",
        )
    return schedule


def check_component(
    kind: str,
    name: str,
    options: Mapping[str, Any] | None = None,
    context: Any = None,
    **kwargs: Any,
) -> Any:
    """Check component ``name`` of ``kind`` with the check of its kind, the context's fields (a
    ``HeadContext``, ``EncoderContext``, ``ConditionerContext`` or ``DatasetContext``) as its arguments;
    kinds without a check of their own are built and checked against their protocol. ``kwargs`` go to
    the kind's check. Returns what the check returns."""
    fields = {} if context is None else {k: getattr(context, k) for k in context.__dataclass_fields__}
    if kind == "head":
        return check_head(name, options, **fields, **kwargs)
    if kind == "encoder":
        return check_encoder(name, options, **fields, **kwargs)
    if kind == "conditioner":
        return check_conditioner(name, options, **fields, **kwargs)
    if kind == "dataset":
        return check_dataset(name, options, **fields, **kwargs)
    simple = {"feature": check_feature, "metric": check_metric, "schedule": check_schedule}
    if kind in simple:
        return simple[kind](name, options, **kwargs)
    return _create(kind, name, options, context, kwargs.get("registry"))[0]


def check_trains(
    recipe: str | Path,
    out_dir: str | Path,
    *,
    steps: int = 20,
    overrides: Sequence[str] = (),
    weights: str | None = None,
) -> Any:
    """Train ``recipe`` (a file or a registered recipe name) for ``steps`` steps into ``out_dir`` through
    ``dance_core.train`` and check the run: finite losses and a checkpoint, which holds weights named
    ``weights*`` when given (``"head."``, ``"encoder."``, ``"conditioners.music."``). ``overrides`` are
    ``--set`` assignments (``"data.dataset.songs=4"``). Returns the ``TrainResult``."""
    from dance_core.checkpoint import load_checkpoint
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    check = _Check(f"recipe {str(recipe)!r}")
    sets = [f"training.steps={steps}", f"training.val_every={steps}", f"training.checkpoint_every={steps}"]
    try:
        result = train(load_recipe(recipe, [*sets, *overrides]), out=str(out_dir), quiet=True)
    except DanceError as exc:
        raise AssertionError(f"{check.label}: {exc}") from exc
    check.that(result.steps == steps, f"trained {result.steps} steps, expected {steps}")
    for what, value in (("first", result.first_loss), ("last", result.last_loss), ("validation", result.val_loss)):
        check.that(value is None or math.isfinite(value), f"the {what} loss is {value}")
    check.that(Path(result.checkpoint).is_file(), f"no checkpoint at {result.checkpoint}")
    if weights is not None:
        names = [k for k in load_checkpoint(result.checkpoint).weights if k.startswith(weights)]
        check.that(names, f"the checkpoint holds no weights named {weights}* (is the component an nn.Module?)")
    return result
