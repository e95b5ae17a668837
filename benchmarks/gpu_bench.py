"""The GPU path measured (issue 15): generation frames/s single-stream and batched, training samples/s
and model FLOP utilisation in bf16, for paper-size Transflower, DanceRevolution and TM2D.

    bash benchmarks/gpu.sh                 # on a GPU machine: the paper-size recipes (killed at 290 s)
    .venv/bin/python benchmarks/gpu_bench.py --smoke    # CPU: the small recipes, tiny sizes, seconds

Untrained weights (weights do not change the cost) and random inputs of the recipes' widths. FLOPs are
counted with ``torch.utils.flop_counter.FlopCounterMode`` over one training step's forward and backward
(the optimizer step not counted); MFU = counted FLOPs x steps/s / the device's peak dense bf16 FLOP/s,
from ``PEAK_TFLOPS`` by device name or ``DANCE_PEAK_TFLOPS``. Precision follows the recipe's
``training.precision`` (``auto``: bf16 autocast on CUDA, fp32 on CPU) unless ``--precision`` is given;
``--compile`` (or the recipe's ``training.compile`` on CUDA) wraps the training loss in
``torch.compile``, compiled during the untimed warm-up steps. Generation runs as ``dance compose`` does
(``ComposedModel.generate``, fp32; a batch is that many songs as ``compose.batch_songs`` runs them
where the model allows it, else one song's samples), and with ``--gen-bf16`` also under bf16
autocast. Prints one JSON object per measurement (and writes them to ``--json``), then a table with
the issue's targets beside.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path

import torch
from torch.utils.flop_counter import FlopCounterMode

from dance_core import RowGenerators, TrainContext
from dance_core.api import (
    ComposedModel,
    Recipe,
    RotationKinematics,
    batching_note,
    build_model,
    load_checkpoint,
    load_recipe,
    stream_dims,
)

#: peak dense bf16 tensor FLOP/s (TFLOP/s) by a substring of ``torch.cuda.get_device_name()``
PEAK_TFLOPS = {"H200": 989.0, "H100": 989.0, "GH200": 989.0, "A100": 312.0, "L40S": 362.0, "L4": 121.0,
               "A10G": 70.0, "RTX 4090": 165.0, "V100": 125.0}
#: motion widths of the synthetic dancer's representations (the cost barely depends on them)
MOTION_DIM = {"rotations": 76, "positions": 50}
#: the issue's targets on one H100-class GPU
TARGETS = {
    ("transflower", "generate", 1): ">= 200 frames/s",
    ("transflower", "generate", "batched"): ">= 5,000 frames/s",
    ("tm2d", "generate", 1): "<= 0.02 s per s of music (paper: 0.143)",
    "train": "MFU >= 40 %",
}
#: what each family is measured with: the paper-size recipe, and the small one with tiny sizes (--smoke)
FULL = {
    "transflower": {"gen_frames": 300, "batches": [64, 256], "batch_frames": 60},
    "dancerevolution": {"gen_frames": 900, "batches": [64], "batch_frames": 900},
    "tm2d": {"gen_frames": 3600, "batches": [64], "batch_frames": 3600, "stages": ["tokenizer", "prior"]},
}
SMOKE = {
    "transflower-small": {"gen_frames": 6, "batches": [3], "batch_frames": 6, "train_batch": 2},
    "dancerevolution-small": {"gen_frames": 10, "batches": [3], "batch_frames": 10, "train_batch": 2},
    "tm2d-small": {"gen_frames": 48, "batches": [3], "batch_frames": 48, "train_batch": 2,
                   "stages": ["tokenizer", "prior"]},
}


def peak_flops(device: torch.device) -> tuple[float | None, str]:
    """The device's peak dense bf16 FLOP/s and where the figure came from (None when unknown)."""
    env = os.environ.get("DANCE_PEAK_TFLOPS")
    if env:
        return float(env) * 1e12, "DANCE_PEAK_TFLOPS"
    if device.type == "cuda":
        name = torch.cuda.get_device_name(device)
        for key, tflops in PEAK_TFLOPS.items():
            if key in name:
                return tflops * 1e12, f"table ({key})"
        return None, f"unknown device {name!r}: set DANCE_PEAK_TFLOPS"
    return None, "CPU: set DANCE_PEAK_TFLOPS for an MFU"


def synchronize(device: torch.device) -> None:
    """Wait for the device's queued work (a no-op on CPU)."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def autocast(device: torch.device, precision: str):
    """bf16/fp16 autocast on CUDA; nothing for fp32 or on CPU."""
    if device.type != "cuda" or precision == "fp32":
        return contextlib.nullcontext()
    return torch.autocast("cuda", dtype=torch.float16 if precision == "fp16" else torch.bfloat16)


def build(recipe: Recipe, device: torch.device) -> tuple[ComposedModel, int, dict[str, int]]:
    """The recipe's model, untrained, on ``device``, with its motion and stream widths."""
    dims = stream_dims(recipe)
    motion_dim = MOTION_DIM.get(recipe.motion.plugin if recipe.motion else "", 76)
    torch.manual_seed(0)
    return build_model(recipe, motion_dim, dims).to(device), motion_dim, dims


def random_streams(dims: dict[str, int], batch: int, frames: int, device: torch.device) -> dict[str, torch.Tensor]:
    """Music streams of noise; a ``text`` stream of ``<pad>`` ids (id 0: no text, the music branch)."""
    g = torch.Generator().manual_seed(1)
    return {n: (torch.zeros(batch, frames, d) if n == "text" else torch.randn(batch, frames, d, generator=g)).to(device)
            for n, d in dims.items()}


def time_generation(
    model: ComposedModel, recipe: Recipe, dims: dict[str, int], motion_dim: int, device: torch.device,
    batch: int, frames: int, precision: str = "fp32",
) -> dict:
    """Frames generated per second (all streams) by ``ComposedModel.generate`` after a short warm-up,
    and seconds of generation per second of music (per stream). A batch of several streams is
    ``batch`` songs × 1 sample as ``compose.batch_songs`` runs it (each row its own song's music and
    random stream) when the model allows it (``dance_core.compose.batching_note``), else one song ×
    ``batch`` samples (``compose.samples``); the row says which (``songs``)."""
    model.eval()
    start = model.start_frames()
    total = start + frames
    streams = random_streams(dims, batch, total, device)
    seed = torch.zeros(batch, start, motion_dim, device=device)
    songs = batch if batch > 1 and batching_note(model) is None else 1

    def generator():
        if songs > 1:
            return RowGenerators.same_seed(0, songs, 1, device)
        return torch.Generator(device=device).manual_seed(0)

    warm = start + max(1, min(frames, 2 * model.head.frames))
    with autocast(device, precision):
        model.generate({n: x[:, :warm] for n, x in streams.items()}, warm, seed, generator=generator())
        synchronize(device)
        wall = time.perf_counter()
        model.generate(streams, total, seed, generator=generator())
        synchronize(device)
        wall = time.perf_counter() - wall
    return {"what": "generate", "batch": batch, "songs": songs, "frames": frames, "precision": precision,
            "seconds": round(wall, 4), "frames_per_s": round(batch * frames / wall, 1),
            "s_per_s_music": round(wall / (frames / recipe.fps), 5)}


def training_batch(
    model: ComposedModel, recipe: Recipe, dims: dict[str, int], motion_dim: int, device: torch.device, batch: int,
    segment: int | None = None,
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """One batch of aligned random segments of the recipe's training length."""
    frames = segment or model.segment_frames(recipe.data.segment_frames if recipe.data else None)
    g = torch.Generator().manual_seed(2)
    return torch.randn(batch, frames, motion_dim, generator=g).to(device), random_streams(dims, batch, frames, device)


def trainable(model: ComposedModel, recipe: Recipe, stage: str | None) -> list[torch.nn.Parameter]:
    """The parameters a stage trains (by prefix, as the recipe's ``training.stages`` name them)."""
    prefixes = None
    for s in recipe.training.stages or []:
        if s.name == stage:
            prefixes = tuple(s.trainable) if s.trainable else None
    params = []
    for name, p in model.named_parameters():
        p.requires_grad_(prefixes is None or name.startswith(prefixes))
        if p.requires_grad:
            params.append(p)
    return params


@contextlib.contextmanager
def rnn_flops(model: torch.nn.Module):
    """Count the forward FLOPs of every ``nn.LSTM`` call (2 x 4 gates x hidden x (input + hidden) per
    frame, layer and direction), which ``FlopCounterMode`` does not see (cuDNN's and ATen's fused
    kernels); yields a one-element list holding the running total."""
    total = [0]

    def hook(module: torch.nn.LSTM, inputs, output) -> None:
        x = inputs[0]
        frames = x.shape[0] * x.shape[1] if x.dim() == 3 else x.shape[0]
        dirs, h = (2 if module.bidirectional else 1), module.hidden_size
        for layer in range(module.num_layers):
            width = module.input_size if layer == 0 else h * dirs
            total[0] += 2 * 4 * h * (width + h) * frames * dirs

    handles = [m.register_forward_hook(hook) for m in model.modules() if isinstance(m, torch.nn.LSTM)]
    try:
        yield total
    finally:
        for handle in handles:
            handle.remove()


def recipe_kinematics(recipe: Recipe, motion_dim: int) -> RotationKinematics | None:
    """The joint positions a loss may ask of the training context (as the trainer gives them), from the
    recipe's own checkpoint's motion description and statistics; None without a checkpoint of that width."""
    if not recipe.compose.checkpoint:
        return None
    path = recipe.resolve_path(recipe.compose.checkpoint)
    if not Path(path).is_file():
        return None
    ckpt = load_checkpoint(path)
    if ckpt.motion.dim != motion_dim:
        return None
    return RotationKinematics.from_info(ckpt.motion, ckpt.stats.motion)


def stage_batch(recipe: Recipe, stage: str | None) -> int:
    """The recipe's batch size for a stage."""
    for s in recipe.training.stages or []:
        if s.name == stage and s.batch_size:
            return s.batch_size
    return recipe.training.batch_size


def time_training(
    model: ComposedModel, recipe: Recipe, dims: dict[str, int], motion_dim: int, device: torch.device,
    batch: int, steps: int, precision: str, stage: str | None = None, compile_loss: bool = False,
    segment: int | None = None,
) -> dict:
    """Training samples (segments) per second over ``steps`` AdamW steps after two warm-up steps, the
    FLOPs of one forward and backward, and the model FLOP utilisation when the peak is known."""
    model.train()
    params = trainable(model, recipe, stage)
    opt = torch.optim.AdamW(params, lr=1e-5)
    motion, streams = training_batch(model, recipe, dims, motion_dim, device, batch, segment)
    schedules = {n: spec.build() for n, spec in recipe.training.schedules.items()}
    values = {n: float(f(1000, 10, 2000)) for n, f in schedules.items()}
    loss_fn: Callable = model.training_loss
    if compile_loss:
        loss_fn = torch.compile(loss_fn)
    kinematics = recipe_kinematics(recipe, motion_dim)

    def step(k: int) -> None:
        ctx = TrainContext(step=k, epoch=0, stage=stage or "main", values=values,
                           generator=torch.Generator().manual_seed(k), kinematics=kinematics)
        with autocast(device, precision):
            loss = loss_fn(motion, streams, ctx)["loss"]
        loss.backward()
        opt.step()
        opt.zero_grad(set_to_none=True)

    counter = FlopCounterMode(display=False)
    with counter, rnn_flops(model) as rnn:  # one forward + backward, counted (not timed)
        ctx = TrainContext(step=0, epoch=0, stage=stage or "main", values=values,
                           generator=torch.Generator().manual_seed(0), kinematics=kinematics)
        with autocast(device, precision):
            model.training_loss(motion, streams, ctx)["loss"].backward()
    opt.zero_grad(set_to_none=True)
    flops = counter.get_total_flops() + 3 * rnn[0]  # backward of a product: twice its forward
    for k in range(2):
        step(k)
    synchronize(device)
    wall = time.perf_counter()
    for k in range(steps):
        step(2 + k)
    synchronize(device)
    wall = time.perf_counter() - wall
    peak, source = peak_flops(device)
    achieved = flops * steps / wall
    return {"what": "train", "stage": stage, "batch": batch, "segment_frames": motion.shape[1],
            "precision": precision, "compile": compile_loss, "steps": steps, "seconds": round(wall, 3),
            "samples_per_s": round(batch * steps / wall, 2), "gflop_per_step": round(flops / 1e9, 2),
            "tflops_achieved": round(achieved / 1e12, 3),
            "mfu": round(achieved / peak, 4) if peak else None, "peak_source": source,
            "params_M": round(sum(p.numel() for p in params) / 1e6, 2)}


def measure(name: str, plan: dict, device: torch.device, precision: str | None, train_steps: int,
            compile_loss: bool, gen_bf16: bool, emit: Callable[[dict], None]) -> None:
    """Every measurement of one recipe, each emitted as soon as it is made."""
    recipe = load_recipe(name)
    model, motion_dim, dims = build(recipe, device)
    prec = precision or recipe.training.precision
    prec = ("bf16" if device.type == "cuda" else "fp32") if prec == "auto" else prec
    # the recipe's training.compile (CUDA only, as the trainer applies it), or --compile anywhere
    compile_loss = compile_loss or (bool(getattr(recipe.training, "compile", False)) and device.type == "cuda")
    base = {"recipe": name, "params_M": round(sum(p.numel() for p in model.parameters()) / 1e6, 2)}
    gens = [("fp32", 1, plan["gen_frames"])] + [("fp32", b, plan["batch_frames"]) for b in plan["batches"]]
    if gen_bf16 and device.type == "cuda":
        gens += [("bf16", b, f) for _, b, f in gens]
    for gen_precision, batch, frames in gens:
        emit({**base, **time_generation(model, recipe, dims, motion_dim, device, batch, frames, gen_precision)})
    for stage in plan.get("stages", [None]):
        batch = plan.get("train_batch") or stage_batch(recipe, stage)
        segment = plan.get("train_segment")
        emit({**base, **time_training(model, recipe, dims, motion_dim, device, batch, train_steps, prec, stage,
                                      compile_loss, segment)})
    del model
    if device.type == "cuda":
        torch.cuda.empty_cache()


def target_for(row: dict) -> str:
    """The issue's target for a measurement, or an empty string."""
    family = row["recipe"].removesuffix("-small")
    if row["what"] == "train":
        return TARGETS["train"]
    if row["batch"] == 1:
        return TARGETS.get((family, "generate", 1), "")
    return TARGETS.get((family, "generate", "batched"), "")


def table(rows: list[dict]) -> str:
    """The measurements as a Markdown table, targets beside."""
    lines = ["| recipe | what | batch | precision | figure | target |", "|---|---|---|---|---|---|"]
    for r in rows:
        if r["what"] == "generate":
            figure = f"{r['frames_per_s']:,.0f} frames/s"
            if r["recipe"].startswith("tm2d"):
                figure += f", {r['s_per_s_music']:.4f} s per s of music"
            layout = f"{r['batch']} songs x 1" if r.get("songs", 1) > 1 else f"1 song x {r['batch']}"
            what = f"generate {r['frames']} frames" + (f" ({layout})" if r["batch"] > 1 else "")
        else:
            mfu = "MFU n/a" if r["mfu"] is None else f"MFU {100 * r['mfu']:.1f} %"
            figure = f"{r['samples_per_s']:,.1f} samples/s, {r['tflops_achieved']:.2f} TFLOP/s, {mfu}"
            what = f"train{' ' + r['stage'] if r['stage'] else ''} ({r['segment_frames']} frames)"
        lines.append(f"| {r['recipe']} | {what} | {r['batch']} | {r['precision']} | {figure} | {target_for(r)} |")
    return "\n".join(lines)


def run(smoke: bool, recipes: list[str] | None = None, precision: str | None = None, train_steps: int | None = None,
        compile_loss: bool = False, gen_bf16: bool = False, device: str | None = None,
        out: Path | None = None, quiet: bool = False) -> list[dict]:
    """Measure the recipes (all of the plan by default) and return the rows."""
    plans = SMOKE if smoke else FULL
    dev = torch.device(device or ("cuda" if torch.cuda.is_available() else "cpu"))
    rows: list[dict] = []

    def emit(row: dict) -> None:
        rows.append(row)
        if not quiet:
            print(json.dumps(row), flush=True)
        if out is not None:
            out.write_text(json.dumps(rows, indent=1) + "\n")

    for name in recipes or list(plans):
        measure(name, plans[name], dev, precision, train_steps or (2 if smoke else 10), compile_loss, gen_bf16, emit)
    return rows


def main() -> None:
    """Parse the options, describe the machine, measure and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="small recipes and tiny sizes (checks it runs, on CPU)")
    parser.add_argument("--recipes", nargs="+", help="recipes to measure (default: all of the plan)")
    parser.add_argument("--precision", choices=["fp32", "bf16", "fp16"], help="default: training.precision")
    parser.add_argument("--train-steps", type=int, help="timed training steps (default 10; smoke 2)")
    parser.add_argument("--compile", action="store_true", help="torch.compile the training loss")
    parser.add_argument("--gen-bf16", action="store_true", help="also time generation under bf16 autocast")
    parser.add_argument("--device", help="default: cuda when available, else cpu")
    parser.add_argument("--json", type=Path, help="also write every measurement to this JSON file")
    args = parser.parse_args()
    dev = args.device or ("cuda" if torch.cuda.is_available() else "cpu")
    name = torch.cuda.get_device_name() if dev.startswith("cuda") else platform.processor() or platform.machine()
    print(f"# {name}, {os.cpu_count()} CPUs, torch {torch.__version__}, load average {os.getloadavg()[0]:.2f}",
          flush=True)
    rows = run(args.smoke, args.recipes, args.precision, args.train_steps, args.compile, args.gen_bf16, dev,
               args.json)
    print("\n" + table(rows))


if __name__ == "__main__":
    main()
