"""The training loop: stages, AdamW, schedules, validation, JSONL log, checkpoints, exact resume.

A run folder is locked while a run trains in it (``train.lock`` holding the pid); the model
checkpoint and the training state are written as one output set and carry the same step and run id.

Under torchrun (``dance_core.distributed``) every rank runs this loop on its share of each batch with
DistributedDataParallel: ``training.batch_size`` is per rank, the batch of step ``s`` is the one a
single process draws with ``batch_size × world_size`` and rank ``r`` takes its ``r``-th slice; the
loss and a non-finite flag are all-reduced before the backward pass (every rank stops together, with
one message); validation is all-reduced the same way; only rank 0 locks the run folder and writes
the log, the recipe and the checkpoints.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import numbers
import os
import time
from collections.abc import Iterator
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import yaml

from dance_core import distributed
from dance_core.atomic import OutputSet, pid_alive, sigterm_as_interrupt, sweep_stale_temps, write_text
from dance_core.checkpoint import (
    check_matches,
    load_checkpoint,
    load_train_state,
    load_weights,
    save_checkpoint,
    save_train_state,
    train_state_info,
)
from dance_core.data.features import FeatureStack
from dance_core.data.prepare import cached_features, dataset_sources, motion_info, to_clip
from dance_core.data.sampling import SegmentSampler, split_clips
from dance_core.data.stats import NormStats
from dance_core.errors import CheckpointError, DanceError, DataError, RecipeError, TrainingError
from dance_core.model import ComposedModel, build_model
from dance_core.progress import progress_bar
from dance_core.protocols import TrainContext
from dance_core.recipe.schema import Recipe, StageSpec
from dance_core.registry import get_registry
from dance_core.runtime import pick_device, seed_everything
from dance_core.warm_start import init_checkpoint, init_stats, init_weights

MODEL_FILE, STATE_FILE, LOG_FILE = "model.safetensors", "state.safetensors", "log.jsonl"
LOCK_FILE, RECIPE_FILE = "train.lock", "recipe.yaml"
#: a lock file still empty after this many seconds was left by a process that died creating it
EMPTY_LOCK_GRACE_S = 10.0

_held_locks: set[Path] = set()


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


def run_id(recipe: Recipe) -> str:
    """The id a new run records in its checkpoints: a digest of the resolved recipe it starts from
    (no clock, no path), so that the same run gives the same bytes and a state from another run is told apart."""
    text = json.dumps(recipe.model_dump(mode="json"), sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _lock_holder(path: Path) -> int | None:
    try:
        text = path.read_text(encoding="utf-8").strip()
    except (FileNotFoundError, UnicodeDecodeError):
        return None
    return int(text) if text.isdigit() else None


def _take_lock(path: Path) -> None:
    for _ in range(3):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            holder = _lock_holder(path)
            if holder is None:
                try:
                    age = time.time() - path.stat().st_mtime
                except FileNotFoundError:
                    continue
                if age < EMPTY_LOCK_GRACE_S:
                    raise DanceError(f"{path.parent}: run folder is being locked by another dance train "
                                     f"({path} is still empty); train into another folder (--out)") from None
            elif holder != os.getpid() and pid_alive(holder):
                raise DanceError(f"{path.parent}: run folder is in use by another dance train (pid {holder}, "
                                 f"lock {path}); wait for it or train into another folder (--out)") from None
            from dance_core.plugins import warn

            if _lock_holder(path) != holder:  # another trainer took it over meanwhile: look again
                continue
            who = f"pid {holder}, no longer running" if holder is not None else "no pid"
            warn(f"{path}: taking over a stale lock ({who})")
            path.unlink(missing_ok=True)
            continue
        except IsADirectoryError:
            raise DataError(f"{path}: is a folder; cannot lock the run folder") from None
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(f"{os.getpid()}\n")
        return
    raise DanceError(f"{path.parent}: could not lock the run folder ({path} keeps reappearing)")


@contextlib.contextmanager
def run_lock(run_dir: str | Path) -> Iterator[Path]:
    """Hold the run folder's lock (``train.lock``, created with O_EXCL, holding this pid) while the
    block runs; a second trainer gets one line naming the holder, a dead holder's lock is taken over
    with a warning. Re-entrant within one process. Yields the lock file's path."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise DataError(f"{run_dir}: is a file, not a run folder")
    run_dir.mkdir(parents=True, exist_ok=True)
    path = (run_dir / LOCK_FILE).resolve()
    if path in _held_locks:
        yield path
        return
    with sigterm_as_interrupt():
        _take_lock(path)
        _held_locks.add(path)
        try:
            yield path
        finally:
            _held_locks.discard(path)
            if _lock_holder(path) == os.getpid():
                path.unlink(missing_ok=True)


def check_stop_at(stop_at: int | None, total: int, start: int = 0) -> None:
    """``stop_at`` must be a step after ``start`` and within the run's ``total`` steps."""
    if stop_at is None:
        return
    if isinstance(stop_at, bool) or not isinstance(stop_at, numbers.Integral):
        raise DanceError(f"stop_at: must be a whole number of steps, got {stop_at!r}")
    stop_at = int(stop_at)
    if stop_at <= 0:
        raise DanceError(f"stop_at: must be a positive step, got {stop_at}")
    if stop_at > total:
        raise DanceError(f"stop_at: step {stop_at} is beyond the run's last step ({total}, training.steps)")
    if stop_at <= start:
        raise DanceError(f"stop_at: step {stop_at} is not after the step the run resumes from ({start})")


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

    def forward(self, motion, streams, ctx, augment):  # noqa: D102 - ComposedModel.training_loss
        return self.model.training_loss(motion, streams, ctx, augment)


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
    """Trains the recipe's model on its dataset; one instance per run."""

    def __init__(self, recipe: Recipe, run_dir: Path, quiet: bool = False):
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
        sources = dataset_sources(recipe)
        self._warm_feature_cache(sources)
        clips = []
        with progress_bar(self.quiet) as bar:
            task = bar.add_task("features", total=len(sources), info="") if bar else None
            for source in sources:
                clips.append(to_clip(source, self.stack, self.registry))
                if bar:
                    bar.update(task, advance=1, info=source.name)
        train, val = split_clips(clips, recipe.data.val_fraction, recipe.seed)
        self.stats = NormStats.fit(train, self.stack.categorical())
        if init is not None and self.t.init.stats:
            self.stats = init_stats(init, self.stats)
        train = [self.stats.apply(c) for c in train]
        val = [self.stats.apply(c) for c in val]
        motion_dim = train[0].motion.shape[1]
        self.motion_info = motion_info(recipe, sources, motion_dim)
        torch.manual_seed(recipe.seed)
        self.model = build_model(recipe, motion_dim, self.stack.dims()).to(self.device)
        if init is not None:
            init_weights(self.model, init, self.t.init.weights)
        aug = self.t.augment
        if self.model.window.song_level and (aug.motion_noise > 0 or aug.input_dropout.get("motion", 0.0) > 0):
            raise RecipeError(f"{recipe.origin}: training.augment: motion_noise and input_dropout.motion corrupt "
                              f"the past motion a windowed encoder sees; {recipe.model.encoder.plugin} sees none")
        length = self.model.segment_frames(recipe.data.segment_frames)
        self.sampler = SegmentSampler(train, length, self.t.batch_size, recipe.seed)
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
        """Several ranks: each extracts its share of the songs a dataset caches (``data.cache``) into the
        cache, then all wait for each other and read every song from it. A song that fails here fails
        again, on every rank alike, when the clips are made."""
        cached = [s for s in sources if s.meta.get("feature_cache") and s.audio_path is not None]
        songs: dict[tuple[str, str], object] = {}
        for source in cached:  # a mirrored copy shares its song's features
            songs.setdefault((str(source.audio_path), repr(source.texts)), source)
        cached = list(songs.values())
        if self.world == 1 or not cached:
            return
        for source in cached[self.ranks.rank :: self.world]:
            with contextlib.suppress(DanceError, OSError, ValueError):
                cached_features(source, self.stack, self.registry, source.meta["feature_cache"])
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
        return TrainContext(step=step, epoch=epoch, stage=stage.name, values=values, generator=generator)

    def validate(self, step: int, stage: StageSpec) -> float | None:
        """Mean validation loss over fixed batches."""
        if self.val_sampler is None:
            return None
        self.model.eval()
        losses = []
        with torch.no_grad():
            for i in range(self.t.val_batches):
                if self.world > 1:  # each rank its slice of the batch one process would draw
                    motion, streams = self.val_sampler.batch(i, self.device, self.t.batch_size, self._part())
                else:
                    motion, streams = self.val_sampler.batch(i, self.device)
                with _autocast(self.device, self.precision):
                    losses.append(float(self.model.training_loss(motion, streams, self._context(step, stage))["loss"]))
        self.model.train()
        mean = float(np.mean(losses))
        if self.world > 1:
            mean = float(distributed.all_sum(torch.tensor(mean, dtype=torch.float64))) / self.world
        return mean

    def save(self, step: int, optimizer: torch.optim.Optimizer) -> Path:
        """Write the model checkpoint and the training state as one output set (both or neither)."""
        path = self.run_dir / MODEL_FILE
        with OutputSet() as out:
            save_checkpoint(out.path(path), self.model, self.stats, self.recipe, self.motion_info, step, self.run_id)
            save_train_state(out.path(self.run_dir / STATE_FILE), optimizer, step, self.run_id)
        return path

    def _log(self, record: dict) -> None:
        if not self.ranks.main:
            return
        with open(self.run_dir / LOG_FILE, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(record) + "\n")

    def _resume(self) -> int:
        ckpt = load_checkpoint(self.run_dir / MODEL_FILE)
        check_matches(ckpt, self.recipe)
        state_path = self.run_dir / STATE_FILE
        if not state_path.exists():
            raise CheckpointError(f"{state_path}: training state not found; cannot resume")
        state_step, state_run = train_state_info(state_path)
        if state_step != ckpt.step:
            raise CheckpointError(f"{self.run_dir}: model checkpoint is at step {ckpt.step} but the training "
                                  f"state at step {state_step}; they do not belong together, cannot resume")
        if ckpt.run is not None and state_run is not None and state_run != ckpt.run:
            raise CheckpointError(f"{self.run_dir}: model checkpoint (run {ckpt.run}) and training state "
                                  f"(run {state_run}) come from different runs; cannot resume")
        load_weights(self.model, ckpt)
        self.run_id = ckpt.run or self.run_id
        return ckpt.step

    def _trim_log(self, step: int) -> None:
        if not self.ranks.main:
            return
        path = self.run_dir / LOG_FILE
        if path.exists():
            lines = [ln for ln in path.read_text().splitlines() if ln and json.loads(ln).get("step", 0) <= step]
            write_text(path, "".join(ln + "\n" for ln in lines))

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
            sweep_stale_temps(self.run_dir, [MODEL_FILE, STATE_FILE, LOG_FILE, RECIPE_FILE])
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
            self._trim_log(start)
        else:
            self.run_id = run_id(self.recipe)
            if self.ranks.main:
                (self.run_dir / LOG_FILE).unlink(missing_ok=True)
        if self.ranks.main:
            text = yaml.safe_dump(self.recipe.model_dump(mode="json"), sort_keys=False)
            write_text(self.run_dir / RECIPE_FILE, text)
        self.model.train()
        stage_index, _ = stage_at(self.stages, start)
        optimizer = self._optimizer(self.stages[stage_index])
        if resume and start < self.total:
            same_stage = start > 0 and stage_at(self.stages, start - 1)[0] == stage_index

            def restore():
                load_train_state(self.run_dir / STATE_FILE, optimizer if same_stage else None)
                return distributed.to_cpu(optimizer.state_dict()) if same_stage and self.world > 1 else None

            state = distributed.on_main(restore)
            if state is not None and not self.ranks.main:
                optimizer.load_state_dict(state)
        first = last = float("nan")
        val_loss = None
        checkpoint = self.run_dir / MODEL_FILE
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
            motion, streams = self.sampler.batch(step, self.device, size or self.t.batch_size, self._part())
            # dropout on ranks > 0 draws from (seed, step, rank): resumable whatever the number of ranks
            torch.manual_seed(_seed_for(self.recipe.seed + 1, step, self.ranks.rank))
        else:
            motion, streams = self.sampler.batch(step, self.device, size)
        forward = self._loss_module or _LossModule(self.model)
        with _autocast(self.device, self.precision):
            losses = forward(motion, streams, ctx, self.t.augment)
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
        path = self.run_dir / MODEL_FILE
        kept = distributed.on_main(
            lambda: f"last good checkpoint: {path}" if path.exists() else "no checkpoint was written yet"
        )
        self._log({"step": step, "stage": ctx.stage, "error": what})
        error = TrainingError(
            f"training stopped at step {step} (stage {ctx.stage}): {what}; {kept} "
            "(lower training.optimizer.lr or set training.grad_clip)"
        )
        error.all_ranks = True  # every rank raises this same message at this step
        raise error


def train(
    recipe: Recipe, out: str | None = None, resume: bool = False, quiet: bool = False, stop_at: int | None = None
) -> TrainResult:
    """Train a recipe's model; the run folder holds checkpoint, state, log and resolved recipe.

    ``stop_at`` (a step in ``1..training.steps``) and the run folder's lock are checked before any
    data is read; a folder this call created is removed again if the run fails before writing to it.
    Started by torchrun (``RANK``/``WORLD_SIZE`` set), it joins the process group for the run and
    trains on every rank (``dance_core.distributed``); rank 0 alone locks and writes the run folder.
    """
    check_stop_at(stop_at, sum(s.steps for s in recipe.training.stage_list()))
    run_dir = run_dir_for(recipe, out)
    with distributed.session(recipe.training.device) as ranks:
        if not ranks.main:
            distributed.share_outcome()  # raises rank 0's error if it could not lock the run folder
            return Trainer(recipe, run_dir, quiet=True).run(resume=resume, stop_at=stop_at)
        created = not run_dir.exists()
        try:
            with contextlib.ExitStack() as stack:
                try:
                    stack.enter_context(run_lock(run_dir))
                except BaseException as exc:
                    distributed.share_outcome(exc)
                    raise
                distributed.share_outcome(None)
                return Trainer(recipe, run_dir, quiet).run(resume=resume, stop_at=stop_at)
        except BaseException:
            if created and run_dir.is_dir() and not any(run_dir.iterdir()):
                run_dir.rmdir()
            raise
