"""The step loop: stages, AdamW, schedules, AMP, validation, logging and checkpoints into a run folder.

Under torchrun (``dance_core.distributed``) every rank runs this loop on its share of each batch with
DistributedDataParallel: ``training.batch_size`` is per rank, the batch of step ``s`` is the one a
single process draws with ``batch_size × world_size`` and rank ``r`` takes its ``r``-th slice; the
loss and a non-finite flag are all-reduced before the backward pass (every rank stops together, with
one message); validation is all-reduced the same way; only rank 0 writes the run folder
(``train.run_folder``).
"""

from __future__ import annotations

import math
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from dance_core import distributed
from dance_core.checkpoint import load_weights
from dance_core.data.features import FeatureStack
from dance_core.data.prepare import PreparedData
from dance_core.data.sampling import SegmentSampler
from dance_core.errors import RecipeError, TrainingError
from dance_core.model import ComposedModel, build_model
from dance_core.motion.torch_fk import RotationKinematics
from dance_core.progress import progress_bar
from dance_core.protocols import TrainContext
from dance_core.recipe.schema import Recipe, StageSpec
from dance_core.registry import get_registry
from dance_core.runtime import pick_device, seed_everything
from dance_core.train.data import training_data, warm_feature_cache
from dance_core.train.run_folder import RunFolder, run_id, run_lock
from dance_core.train.stages import check_stop_at, stage_at, trainable_parameters
from dance_core.warm_start import init_checkpoint, init_weights


@dataclass
class TrainResult:
    """Where the run went and how it ended."""

    run_dir: Path
    checkpoint: Path
    steps: int
    first_loss: float
    last_loss: float
    val_loss: float | None


class _LossModule(torch.nn.Module):
    """The model's training loss as ``forward`` (DistributedDataParallel and torch.compile wrap a forward)."""

    def __init__(self, model: ComposedModel, idle: bool = False):
        super().__init__()
        self.model = model
        if idle:
            #: never used: DistributedDataParallel, which must look for parameters a step leaves unused
            #: (TM2D's text branch sits out a rank's share without a sentence), then always finds one
            #: and does not warn that looking was unnecessary
            self.idle = torch.nn.Parameter(torch.zeros(1))

    def forward(self, motion, streams, ctx, augment, spans=None):  # noqa: D102 - ComposedModel.training_loss
        return self.model.training_loss(motion, streams, ctx, augment, spans)


def _seed_for(seed: int, step: int, rank: int) -> int:
    """The seed of a step's draws on a rank: rank 0's is a single process's (so one rank is unchanged)."""
    if rank == 0:
        return (seed * 1_000_003 + step) % 2**63
    return int(np.random.SeedSequence([seed % 2**63, step, rank]).generate_state(2, np.uint64)[0]) % 2**63


def _note(message: str) -> None:
    from dance_core.plugins import warn

    warn(message)


def _autocast(device: torch.device, precision: str):
    if device.type != "cuda" or precision == "fp32":
        return nullcontext()
    dtype = torch.float16 if precision == "fp16" else torch.bfloat16
    return torch.autocast("cuda", dtype=dtype)


class Trainer:
    """Trains the recipe's model on its dataset into a run folder; one instance per run.

    ``data``: the recipe's data prepared beforehand (``data.prepare.prepare_data``), for several runs
    on the same data; by default it is prepared here."""

    def __init__(self, recipe: Recipe, run_dir: Path, quiet: bool = False, data: PreparedData | None = None):
        self.recipe = recipe
        self.run_dir = run_dir
        self.ranks = distributed.current()
        self.world = self.ranks.world
        self.quiet = quiet or not self.ranks.main
        self.t = recipe.training
        self.registry = get_registry()
        self.device = pick_device(self.t.device, self.t.threads)
        if self.ranks.active:  # the group's device: cuda:LOCAL_RANK under NCCL, else the CPU
            self.device = self.ranks.device
        seed_everything(recipe.seed)
        self.stack = FeatureStack(recipe)
        unknown = sorted(set(self.t.augment.input_dropout) - {"motion", *self.stack.dims()})
        if unknown:
            raise RecipeError(f"{recipe.origin}: training.augment.input_dropout.{unknown[0]}: no input of that name "
                              f"(inputs: motion, {', '.join(self.stack.dims())})")
        init = init_checkpoint(recipe)  # read before the data, so a wrong path fails at once
        self.folder = RunFolder(run_dir, writes=self.ranks.main)
        self.data = training_data(recipe, self.stack, self.registry, init=init, prepared=data,
                                  warm=self._warm_feature_cache, quiet=self.quiet)
        self.stats = self.data.stats
        self.motion_info = self.data.motion
        self.kinematics = RotationKinematics.from_info(self.motion_info, self.stats.motion)
        motion_dim = self.motion_info.dim
        torch.manual_seed(recipe.seed)
        self.model = build_model(recipe, motion_dim, self.stack.dims()).to(self.device)
        if init is not None:
            init_weights(self.model, init, self.t.init.weights)
        aug = self.t.augment
        if self.model.window.song_level and (aug.motion_noise > 0 or aug.input_dropout.get("motion", 0.0) > 0):
            raise RecipeError(f"{recipe.origin}: training.augment: motion_noise and input_dropout.motion corrupt "
                              f"the past motion a windowed encoder sees; {recipe.model.encoder.plugin} sees none")
        length = self.model.segment_frames(recipe.data.segment_frames)
        self.sampler = SegmentSampler(self.data.train, length, self.t.batch_size, recipe.seed)
        val = self.data.val
        self.val_sampler = (
            SegmentSampler(val, length, self.t.batch_size, recipe.seed + 1, "validation") if val else None
        )
        # an epoch is the same number of steps on every rank (the curriculum reads it): global batches
        self.steps_per_epoch = max(1, math.ceil(self.sampler.windows() / (self.t.batch_size * self.world)))
        self.lr_schedule = self.t.lr_schedule.build()
        self.schedules = {name: spec.build() for name, spec in self.t.schedules.items()}
        self.stages = self.t.stage_list()
        self.total = sum(s.steps for s in self.stages)
        precision = self.t.precision
        cuda = self.device.type == "cuda"
        self.precision = ("bf16" if cuda else "fp32") if precision == "auto" else precision
        if not cuda and self.precision != "fp32":
            if self.ranks.main:
                _note(f"training.precision: {self.precision} autocast runs on CUDA only; "
                      f"training in fp32 on {self.device.type}")
            self.precision = "fp32"
        self.compile = self.t.compile and cuda
        if self.t.compile and not cuda and self.ranks.main:
            _note(f"training.compile: torch.compile is used on CUDA only; ignored on {self.device.type}")
        self.scaler = torch.amp.GradScaler("cuda") if self.precision == "fp16" else None
        self.run_id = run_id(recipe)
        self._loss_module: torch.nn.Module | None = None
        self._drifted = False
        #: steps after which rank 0's parameters were sent to the others (they had drifted apart)
        self.resyncs = 0

    def _warm_feature_cache(self, sources) -> None:
        """Several ranks share the extraction of the songs a dataset caches, then wait for each other."""
        if self.world > 1 and warm_feature_cache(sources, self.stack, self.registry, self.ranks.rank, self.world):
            distributed.barrier()

    def _part(self) -> tuple[int, int]:
        return self.ranks.rank, self.world

    def _optimizer(self, stage: StageSpec) -> torch.optim.Optimizer:
        opt = self.t.optimizer
        params = trainable_parameters(self.model, stage)
        self._prepare_stage(params)
        return torch.optim.AdamW(
            params,
            lr=stage.lr or opt.lr,
            betas=opt.betas,
            weight_decay=opt.weight_decay,
        )

    def _prepare_stage(self, params: list[torch.nn.Parameter]) -> None:
        """Only the stage's parameters require gradients; the loss is wrapped in DistributedDataParallel
        on several ranks (rebuilt per stage: it syncs the gradients of the parameters that require them)
        and compiled when ``training.compile`` (CUDA)."""
        chosen = {id(p) for p in params}
        for p in self.model.parameters():
            p.requires_grad_(id(p) in chosen)
        module: torch.nn.Module = _LossModule(self.model, idle=self.ranks.active)
        if self.ranks.active:
            from torch.nn.parallel import DistributedDataParallel

            module = DistributedDataParallel(module.to(self.device), find_unused_parameters=True)
        if self.compile:
            module = torch.compile(module)
        self._loss_module = module

    def _context(self, step: int, stage: StageSpec) -> TrainContext:
        epoch = step // self.steps_per_epoch
        values = {n: float(f(step, epoch, self.total)) for n, f in self.schedules.items()}
        # the same step draws the same augmentation noise, however the run was resumed (each rank its own)
        generator = torch.Generator().manual_seed(_seed_for(self.recipe.seed, step, self.ranks.rank))
        return TrainContext(step=step, epoch=epoch, stage=stage.name, values=values, generator=generator,
                            kinematics=self.kinematics)

    def validate(self, step: int, stage: StageSpec) -> float | None:
        """Mean validation loss over fixed batches."""
        if self.val_sampler is None:
            return None
        self.model.eval()
        losses = []
        with torch.no_grad():
            for i in range(self.t.val_batches):
                if self.world > 1:  # each rank its slice of the batch one process would draw
                    batch = self.val_sampler.draw(i, self.device, self.t.batch_size, self._part())
                else:
                    batch = self.val_sampler.draw(i, self.device)
                with _autocast(self.device, self.precision):
                    out = self.model.training_loss(batch.motion, batch.streams, self._context(step, stage),
                                                   spans=batch.spans)
                    losses.append(float(out["loss"]))
        self.model.train()
        mean = float(np.mean(losses))
        if self.world > 1:
            mean = float(distributed.all_sum(torch.tensor(mean, dtype=torch.float64))) / self.world
        return mean

    def save(self, step: int, optimizer: torch.optim.Optimizer) -> Path:
        """Write the model checkpoint and the training state as one output set (both or neither)."""
        return self.folder.save(self.model, self.stats, self.recipe, self.motion_info, step, self.run_id, optimizer)

    def _log(self, record: dict) -> None:
        self.folder.log(record)

    def _resume(self) -> int:
        ckpt = self.folder.resume_checkpoint(self.recipe)
        load_weights(self.model, ckpt)
        self.run_id = ckpt.run or self.run_id
        return ckpt.step

    def run(self, resume: bool = False, stop_at: int | None = None) -> TrainResult:
        """Train to the last step (or to ``stop_at``), continuing the run in the folder when ``resume``;
        the run folder is locked meanwhile."""
        check_stop_at(stop_at, self.total)
        if not self.ranks.main:
            try:
                return self._run(resume, stop_at)
            finally:
                self._release_stage()
        with run_lock(self.run_dir):
            self.folder.sweep()
            try:
                return self._run(resume, stop_at)
            finally:
                self._release_stage()

    def _release_stage(self) -> None:
        """Every parameter requires gradients again and the wrapped loss is dropped (the model is the
        caller's again)."""
        self._loss_module = None
        for p in self.model.parameters():
            p.requires_grad_(True)

    def _run(self, resume: bool, stop_at: int | None) -> TrainResult:
        start = 0
        if resume:  # rank 0 reads the run folder; the others get its step, run id, weights and optimizer state
            start, self.run_id = distributed.on_main(lambda: (self._resume(), self.run_id))
            distributed.broadcast_module(self.model)
            check_stop_at(stop_at, self.total, start)
        else:
            self.run_id = run_id(self.recipe)
        self.folder.start(self.recipe, start if resume else None)
        self.model.train()
        stage_index, _ = stage_at(self.stages, start)
        optimizer = self._optimizer(self.stages[stage_index])
        if resume and start < self.total:
            same_stage = start > 0 and stage_at(self.stages, start - 1)[0] == stage_index

            def restore():
                self.folder.load_state(optimizer if same_stage else None)
                return distributed.to_cpu(optimizer.state_dict()) if same_stage and self.world > 1 else None

            state = distributed.on_main(restore)
            if state is not None and not self.ranks.main:
                optimizer.load_state_dict(state)
        first = last = float("nan")
        val_loss = None
        checkpoint = self.folder.model
        tick, tick_step = time.perf_counter(), start
        with progress_bar(self.quiet) as bar:
            task = None
            if bar:
                task = bar.add_task(f"train {self.recipe.name}", total=self.total, completed=start, info="")
            end = self.total if stop_at is None else int(stop_at)
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
                    segments = (stage.batch_size or self.t.batch_size) * self.world
                    rate = (done - tick_step) * segments / max(now - tick, 1e-9)
                    tick, tick_step = now, done
                    self._log({"step": done, "stage": stage.name, "epoch": ctx.epoch, "lr": lr,
                               "loss": loss, "segments_per_s": rate, "world_size": self.world,
                               **ctx.values, **getattr(self, "extras", {})})
                    if bar:
                        bar.update(task, info=f"loss {loss:.4f}  {rate:.0f} seg/s")
                if done % self.t.val_every == 0 or done == end:
                    val_loss = self.validate(done, stage)
                    if val_loss is not None:
                        self._log({"step": done, "stage": stage.name, "val_loss": val_loss})
                if (done % self.t.checkpoint_every == 0 or done == end) and self.ranks.main:
                    self.save(done, optimizer)
                if bar:
                    bar.update(task, completed=done)
        distributed.barrier()  # every rank returns once rank 0's last checkpoint is written
        return TrainResult(self.run_dir, checkpoint, end, first, last, val_loss)

    def _step(self, step: int, optimizer: torch.optim.Optimizer, ctx: TrainContext, size: int | None = None) -> float:
        if self.world > 1:
            batch = self.sampler.draw(step, self.device, size or self.t.batch_size, self._part())
            # dropout on ranks > 0 draws from (seed, step, rank): resumable whatever the number of ranks
            torch.manual_seed(_seed_for(self.recipe.seed + 1, step, self.ranks.rank))
        else:
            batch = self.sampler.draw(step, self.device, size)
        forward = self._loss_module or _LossModule(self.model)
        with _autocast(self.device, self.precision):
            losses = forward(batch.motion, batch.streams, ctx, self.t.augment, batch.spans)
        loss = losses["loss"]
        #: the head's other scalar values (e.g. TM2D's codebook usage, per-branch cross-entropy), logged (rank 0's)
        self.extras = {k: float(v.detach()) for k, v in losses.items()
                       if k != "loss" and torch.is_tensor(v) and v.numel() == 1}
        value = self._agree(step, loss, optimizer, ctx)
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
        if self._drifted:  # a component changed parameters outside the optimizer, differently per rank
            distributed.broadcast_module(self.model)
            self.resyncs += 1
        return value

    def _agree(self, step: int, loss: torch.Tensor, optimizer: torch.optim.Optimizer, ctx: TrainContext) -> float:
        """The step's loss (the mean over ranks); a non-finite loss on any rank stops every rank here,
        before the backward pass, with the same message. Several ranks also compare a fingerprint of
        the parameters, to re-sync them after the step if a component changed them on its own."""
        if self.world == 1:
            value = float(loss.detach())
            if not math.isfinite(value):
                self._stop(step, f"loss is {value}", ctx)
            return value
        n, r = self.world, self.ranks.rank
        mine = torch.zeros(2 * n, dtype=torch.float64)
        mine[r] = float(loss.detach())
        mine[n + r] = distributed.fingerprint([p for g in optimizer.param_groups for p in g["params"]])
        both = distributed.all_sum(mine)
        losses, prints = both[:n], both[n:]
        bad = [i for i in range(n) if not math.isfinite(float(losses[i]))]
        if bad:
            where = ", ".join(f"{float(losses[i])} on rank {i}" for i in bad)
            self._stop(step, f"loss is {where}", ctx)
        self._drifted = bool((prints != prints[0]).any())
        return float(losses.mean())

    def _stop(self, step: int, what: str, ctx: TrainContext) -> None:
        kept = distributed.on_main(self.folder.last_good)
        self._log({"step": step, "stage": ctx.stage, "error": what})
        error = TrainingError(
            f"training stopped at step {step} (stage {ctx.stage}): {what}; {kept} "
            "(lower training.optimizer.lr or set training.grad_clip)"
        )
        error.all_ranks = True  # every rank raises this same message at this step
        raise error

