"""The training loop: stages, AdamW, schedules, validation, JSONL log, checkpoints, exact resume."""

from __future__ import annotations

import json
import math
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import yaml

from dance_core.atomic import write_text
from dance_core.checkpoint import (
    check_matches,
    load_checkpoint,
    load_train_state,
    load_weights,
    save_checkpoint,
    save_train_state,
)
from dance_core.data.features import FeatureStack
from dance_core.data.prepare import dataset_sources, motion_info, to_clip
from dance_core.data.sampling import SegmentSampler, split_clips
from dance_core.data.stats import NormStats
from dance_core.errors import CheckpointError, RecipeError, TrainingError
from dance_core.model import ComposedModel, build_model
from dance_core.protocols import TrainContext
from dance_core.recipe.schema import Recipe, StageSpec
from dance_core.registry import get_registry
from dance_core.runtime import pick_device, progress_bar, seed_everything

MODEL_FILE, STATE_FILE, LOG_FILE = "model.safetensors", "state.safetensors", "log.jsonl"


@dataclass
class TrainResult:
    """Where the run went and how it ended."""

    run_dir: Path
    checkpoint: Path
    steps: int
    first_loss: float
    last_loss: float
    val_loss: float | None


def run_dir_for(recipe: Recipe, out: str | None = None) -> Path:
    """The run folder: ``--out`` or ``training.output`` with ``{name}`` filled in."""
    return Path(out or recipe.training.output.format(name=recipe.name))


def stage_at(stages: list[StageSpec], step: int) -> tuple[int, int]:
    """(stage index, step within the stage) of a global step."""
    start = 0
    for i, stage in enumerate(stages):
        if step < start + stage.steps:
            return i, step - start
        start += stage.steps
    return len(stages) - 1, stages[-1].steps


def trainable_parameters(model: ComposedModel, stage: StageSpec) -> list[torch.nn.Parameter]:
    """Parameters whose names start with one of the stage's prefixes (all when none given)."""
    named = list(model.named_parameters())
    if not stage.trainable:
        return [p for _, p in named]
    chosen = [p for n, p in named if any(n.startswith(prefix) for prefix in stage.trainable)]
    if not chosen:
        raise TrainingError(f"training.stages.{stage.name}.trainable: no parameter matches {stage.trainable}")
    return chosen


def _autocast(device: torch.device, precision: str):
    if device.type != "cuda" or precision == "fp32":
        return nullcontext()
    dtype = torch.float16 if precision == "fp16" else torch.bfloat16
    return torch.autocast("cuda", dtype=dtype)


class Trainer:
    """Trains the recipe's model on its dataset; one instance per run."""

    def __init__(self, recipe: Recipe, run_dir: Path, quiet: bool = False):
        self.recipe = recipe
        self.run_dir = run_dir
        self.quiet = quiet
        self.t = recipe.training
        self.registry = get_registry()
        self.device = pick_device(self.t.device, self.t.threads)
        seed_everything(recipe.seed)
        self.stack = FeatureStack(recipe)
        unknown = sorted(set(self.t.augment.input_dropout) - {"motion", *self.stack.dims()})
        if unknown:
            raise RecipeError(f"{recipe._origin}: training.augment.input_dropout.{unknown[0]}: no input of that name "
                              f"(inputs: motion, {', '.join(self.stack.dims())})")
        sources = dataset_sources(recipe)
        clips = []
        with progress_bar(quiet) as bar:
            task = bar.add_task("features", total=len(sources), info="") if bar else None
            for source in sources:
                clips.append(to_clip(source, self.stack, self.registry))
                if bar:
                    bar.update(task, advance=1, info=source.name)
        train, val = split_clips(clips, recipe.data.val_fraction, recipe.seed)
        self.stats = NormStats.fit(train, self.stack.categorical())
        train = [self.stats.apply(c) for c in train]
        val = [self.stats.apply(c) for c in val]
        motion_dim = train[0].motion.shape[1]
        self.motion_info = motion_info(recipe, sources, motion_dim)
        torch.manual_seed(recipe.seed)
        self.model = build_model(recipe, motion_dim, self.stack.dims()).to(self.device)
        aug = self.t.augment
        if self.model.window.song_level and (aug.motion_noise > 0 or aug.input_dropout.get("motion", 0.0) > 0):
            raise RecipeError(f"{recipe._origin}: training.augment: motion_noise and input_dropout.motion corrupt "
                              f"the past motion a windowed encoder sees; {recipe.model.encoder.plugin} sees none")
        length = self.model.segment_frames(recipe.data.segment_frames)
        self.sampler = SegmentSampler(train, length, self.t.batch_size, recipe.seed)
        self.val_sampler = (
            SegmentSampler(val, length, self.t.batch_size, recipe.seed + 1, "validation") if val else None
        )
        self.steps_per_epoch = max(1, math.ceil(self.sampler.windows() / self.t.batch_size))
        self.lr_schedule = self.t.lr_schedule.build()
        self.schedules = {name: spec.build() for name, spec in self.t.schedules.items()}
        self.stages = self.t.stage_list()
        self.total = sum(s.steps for s in self.stages)
        precision = self.t.precision
        self.precision = ("bf16" if self.device.type == "cuda" else "fp32") if precision == "auto" else precision
        self.scaler = torch.amp.GradScaler("cuda") if self.precision == "fp16" else None

    def _optimizer(self, stage: StageSpec) -> torch.optim.Optimizer:
        opt = self.t.optimizer
        return torch.optim.AdamW(
            trainable_parameters(self.model, stage),
            lr=stage.lr or opt.lr,
            betas=opt.betas,
            weight_decay=opt.weight_decay,
        )

    def _context(self, step: int, stage: StageSpec) -> TrainContext:
        epoch = step // self.steps_per_epoch
        values = {n: float(f(step, epoch, self.total)) for n, f in self.schedules.items()}
        # the same step draws the same augmentation noise, however the run was resumed
        generator = torch.Generator().manual_seed((self.recipe.seed * 1_000_003 + step) % 2**63)
        return TrainContext(step=step, epoch=epoch, stage=stage.name, values=values, generator=generator)

    def validate(self, step: int, stage: StageSpec) -> float | None:
        """Mean validation loss over fixed batches."""
        if self.val_sampler is None:
            return None
        self.model.eval()
        losses = []
        with torch.no_grad():
            for i in range(self.t.val_batches):
                motion, streams = self.val_sampler.batch(i, self.device)
                with _autocast(self.device, self.precision):
                    losses.append(float(self.model.training_loss(motion, streams, self._context(step, stage))["loss"]))
        self.model.train()
        return float(np.mean(losses))

    def save(self, step: int, optimizer: torch.optim.Optimizer) -> Path:
        """Write the model checkpoint and the training state."""
        path = self.run_dir / MODEL_FILE
        save_checkpoint(path, self.model, self.stats, self.recipe, self.motion_info, step)
        save_train_state(self.run_dir / STATE_FILE, optimizer, step)
        return path

    def _log(self, record: dict) -> None:
        with open(self.run_dir / LOG_FILE, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(record) + "\n")

    def _resume(self) -> int:
        ckpt = load_checkpoint(self.run_dir / MODEL_FILE)
        check_matches(ckpt, self.recipe)
        load_weights(self.model, ckpt)
        state_path = self.run_dir / STATE_FILE
        if not state_path.exists():
            raise CheckpointError(f"{state_path}: training state not found; cannot resume")
        return ckpt.step

    def _trim_log(self, step: int) -> None:
        path = self.run_dir / LOG_FILE
        if path.exists():
            lines = [ln for ln in path.read_text().splitlines() if ln and json.loads(ln).get("step", 0) <= step]
            write_text(path, "".join(ln + "\n" for ln in lines))

    def run(self, resume: bool = False, stop_at: int | None = None) -> TrainResult:
        """Train to the last step (or to ``stop_at``), continuing the run in the folder when ``resume``."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        start = 0
        if resume:
            start = self._resume()
            self._trim_log(start)
        else:
            (self.run_dir / LOG_FILE).unlink(missing_ok=True)
        write_text(self.run_dir / "recipe.yaml", yaml.safe_dump(self.recipe.model_dump(mode="json"), sort_keys=False))
        self.model.train()
        stage_index, _ = stage_at(self.stages, start)
        optimizer = self._optimizer(self.stages[stage_index])
        if resume and start < self.total:
            same_stage = start > 0 and stage_at(self.stages, start - 1)[0] == stage_index
            load_train_state(self.run_dir / STATE_FILE, optimizer if same_stage else None)
        first = last = float("nan")
        val_loss = None
        checkpoint = self.run_dir / MODEL_FILE
        tick, tick_step = time.perf_counter(), start
        with progress_bar(self.quiet) as bar:
            task = None
            if bar:
                task = bar.add_task(f"train {self.recipe.name}", total=self.total, completed=start, info="")
            end = min(self.total, stop_at) if stop_at else self.total
            for step in range(start, end):
                index, local = stage_at(self.stages, step)
                stage = self.stages[index]
                if index != stage_index:
                    stage_index, optimizer = index, self._optimizer(stage)
                ctx = self._context(step, stage)
                lr = (stage.lr or self.t.optimizer.lr) * self.lr_schedule(local, ctx.epoch, stage.steps)
                for group in optimizer.param_groups:
                    group["lr"] = lr
                loss = self._step(step, optimizer, ctx, stage.batch_size)
                first = loss if step == start else first
                last = loss
                done = step + 1
                if done % self.t.log_every == 0 or done == end:
                    now = time.perf_counter()
                    rate = (done - tick_step) * (stage.batch_size or self.t.batch_size) / max(now - tick, 1e-9)
                    tick, tick_step = now, done
                    self._log({"step": done, "stage": stage.name, "epoch": ctx.epoch, "lr": lr,
                               "loss": loss, "segments_per_s": rate, **ctx.values})
                    if bar:
                        bar.update(task, info=f"loss {loss:.4f}  {rate:.0f} seg/s")
                if done % self.t.val_every == 0 or done == end:
                    val_loss = self.validate(done, stage)
                    if val_loss is not None:
                        self._log({"step": done, "stage": stage.name, "val_loss": val_loss})
                if done % self.t.checkpoint_every == 0 or done == end:
                    checkpoint = self.save(done, optimizer)
                if bar:
                    bar.update(task, completed=done)
        return TrainResult(self.run_dir, checkpoint, end, first, last, val_loss)

    def _step(self, step: int, optimizer: torch.optim.Optimizer, ctx: TrainContext, size: int | None = None) -> float:
        motion, streams = self.sampler.batch(step, self.device, size)
        with _autocast(self.device, self.precision):
            loss = self.model.training_loss(motion, streams, ctx, self.t.augment)["loss"]
        value = float(loss.detach())
        if not math.isfinite(value):
            self._stop(step, f"loss is {value}", ctx)
        optimizer.zero_grad(set_to_none=True)
        if self.scaler is not None:
            self.scaler.scale(loss).backward()
            self.scaler.unscale_(optimizer)
        else:
            loss.backward()
        params = [p for g in optimizer.param_groups for p in g["params"]]
        if self.t.grad_clip is not None:
            norm = torch.nn.utils.clip_grad_norm_(params, self.t.grad_clip)
            if not torch.isfinite(norm) and self.scaler is None:
                self._stop(step, "gradient is not finite", ctx)
        if self.scaler is not None:
            self.scaler.step(optimizer)
            self.scaler.update()
        else:
            optimizer.step()
        return value

    def _stop(self, step: int, what: str, ctx: TrainContext) -> None:
        path = self.run_dir / MODEL_FILE
        kept = f"last good checkpoint: {path}" if path.exists() else "no checkpoint was written yet"
        self._log({"step": step, "stage": ctx.stage, "error": what})
        raise TrainingError(
            f"training stopped at step {step} (stage {ctx.stage}): {what}; {kept} "
            "(lower training.optimizer.lr or set training.grad_clip)"
        )


def train(
    recipe: Recipe, out: str | None = None, resume: bool = False, quiet: bool = False, stop_at: int | None = None
) -> TrainResult:
    """Train a recipe's model; the run folder holds checkpoint, state, log and resolved recipe."""
    return Trainer(recipe, run_dir_for(recipe, out), quiet).run(resume=resume, stop_at=stop_at)
