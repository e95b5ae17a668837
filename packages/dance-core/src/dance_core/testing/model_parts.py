"""Contract checks of the model's parts: heads (driven by a real ``ComposedModel``), encoders, conditioners."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from dance_core import registry
from dance_core.contexts import ConditionerContext, EncoderContext, HeadContext
from dance_core.protocols import TrainContext, Window
from dance_core.testing.kit import check_gradients, check_losses, create


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
    """Build head ``name`` and check its contract by driving it with a real ``ComposedModel``
    (``dance_core.testing.driven_model``): ``training_loss`` and ``generate``, the calls ``dance train``
    and ``dance compose`` make, around a probe encoder whose latent the check chooses.

    ``window`` is the encoder's (default ``Window(4, 4, 2)``, windowed; ``Window(0, None, 0)`` for a
    song-level encoder); ``latent_tokens`` the tokens a windowed encoder gives (default: as many as the
    head asks for, else 1); ``length`` the frames a head behind a song-level encoder is trained on (after
    its history); ``values`` the schedule values in ``TrainContext.values``; ``cond_dims`` the feature
    streams' widths (default ``{"music": 5}``), given to the head in its context and, as silent (zero)
    streams, to the model (a head reading a stream such as TM2D's text must be given it here).

    Checks: the attributes (``frames``, ``keep`` <= ``frames``, ``history_frames``, ``latent_tokens``);
    ``loss`` returns a dict of finite scalars with ``"loss"``, whose backward gives finite gradients to
    at least one parameter and to the latent (so the encoder learns); ``loss`` also runs in eval mode
    without gradients (validation); ``init_state``/``step`` give ``(batch, frames, motion_dim)`` finite
    frames and a state, at temperature 1 and 0, drawing randomness only from the generator; ``finish``
    keeps the motion's shape. Returns the head.
    """
    import torch

    from dance_core.testing.driven_model import driven_model  # imports torch: only when a check runs

    window = window or Window(motion_past=4, cond_past=4, cond_future=2)
    song = window.song_level
    cond_dims = dict(cond_dims or {"music": 5})

    def context(tokens: int | None) -> HeadContext:
        return HeadContext(motion_dim, latent_dim, tokens, window, cond_dims)

    tokens = None if song else (latent_tokens or 1)
    head, check = create("head", name, options, context(tokens), registry)
    asks = getattr(head, "latent_tokens", None)
    if not song and latent_tokens is None and isinstance(asks, int) and asks >= 1 and asks != tokens:
        tokens = asks  # rebuilt for an encoder that gives what the head asks for, as a recipe would pair them
        head, check = create("head", name, options, context(tokens), registry)
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
    model, probe = driven_model(head, check, window, tokens, latent_dim, motion_dim)
    d = motion_dim
    with check.calling("the training segment"):  # behind a song-level encoder: history and `length` frames
        n = model.segment_frames(head.history_frames + max(length, head.frames) if song else None)
    torch.manual_seed(0)
    latent = torch.randn(batch, n if song else tokens, latent_dim, requires_grad=True)
    motion = torch.randn(batch, n, d)
    streams = {s: torch.zeros(batch, n, width) for s, width in cond_dims.items()}
    ctx = TrainContext(step=0, epoch=0, values=dict(values or {}), generator=torch.Generator().manual_seed(1))
    probe.latent = latent
    model.train()
    model.zero_grad(set_to_none=True)
    with check.calling("loss"):
        out = model.training_loss(motion, streams, ctx)
    check_losses(out, check, "in training")
    check.that(out["loss"].requires_grad, "loss['loss'] does not require grad (detached, or from no parameter)")
    with check.calling("backward of loss['loss']"):
        out["loss"].backward()
    check_gradients(head, check, "backward of loss['loss']")
    check.that(
        latent.grad is not None,
        "loss['loss'] does not depend on the latent, so the encoder and conditioners would never learn",
    )
    check.that(bool(torch.isfinite(latent.grad).all()), "the latent's gradient has NaN or inf values")
    model.eval()
    probe.latent = latent.detach()
    with torch.no_grad(), check.calling("loss in eval mode"):
        out = model.training_loss(motion, streams, ctx)
    check_losses(out, check, "in eval mode")
    probe.latent = None

    def generate(seed: int, temperature: float, n_steps: int) -> torch.Tensor:
        """``n_steps`` steps of ``ComposedModel.generate`` from a random seed motion, silent streams."""
        probe.generator = torch.Generator().manual_seed(99)
        start = model.start_frames()
        frames = start + n_steps * head.keep
        seed_motion = torch.randn(batch, start, d, generator=probe.generator)
        silent = {s: torch.zeros(batch, frames, width) for s, width in cond_dims.items()}
        return model.generate(silent, frames, seed_motion, temperature, generator=torch.Generator().manual_seed(seed))

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
    encoder, check = create("encoder", name, options, EncoderContext(motion_dim, cond_dims), registry)
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
    check_gradients(encoder, check, "backward of the latent")
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

    cond, check = create("conditioner", name, options, ConditionerContext(input, in_dim), registry)
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
    check_gradients(cond, check, "backward of the output")
    check.that(x.grad is not None, "the output does not depend on the input")
    cond.eval()
    for length in (1, frames + 5):
        with torch.inference_mode(), check.calling(f"the forward pass in eval mode ({length} frames)"):
            out = cond(torch.randn(batch, length, in_dim))
        check.tensor(out, f"the output in eval mode ({length} frames)", (batch, length, cond.out_dim))
    return cond
