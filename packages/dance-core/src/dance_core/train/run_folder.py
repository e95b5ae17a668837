"""A training run's folder: its lock, its files, what it records and how a run resumes from it.

The folder holds ``model.safetensors`` (the checkpoint), ``state.safetensors`` (optimizer and RNG state),
``log.jsonl`` and ``recipe.yaml`` (the resolved recipe). It is locked while a run trains in it
(``train.lock`` holding the pid); the checkpoint and the state are written as one output set and carry
the same step and run id, so a resume can tell a pair that belongs together. Every write is atomic.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from dance_core.atomic import (
    OutputSet,
    output_mode,
    pid_alive,
    process_start,
    refuse_special,
    sigterm_as_interrupt,
    special_file,
    sweep_stale_temps,
    write_text,
)
from dance_core.checkpoint import (
    Checkpoint,
    check_matches,
    load_checkpoint,
    load_train_state,
    save_checkpoint,
    save_train_state,
    train_state_info,
)
from dance_core.errors import CheckpointError, DanceError, DataError
from dance_core.recipe.schema import Recipe

MODEL_FILE, STATE_FILE, LOG_FILE = "model.safetensors", "state.safetensors", "log.jsonl"
LOCK_FILE, RECIPE_FILE = "train.lock", "recipe.yaml"
#: a lock file still empty after this many seconds was left by a process that died creating it
EMPTY_LOCK_GRACE_S = 10.0

_held_locks: set[Path] = set()


def run_dir_for(recipe: Recipe, out: str | None = None) -> Path:
    """The run folder: ``--out`` or ``training.output`` with ``{name}`` replaced by the recipe's name
    (a plain replacement: the field is user input, never a format string)."""
    return Path(out or recipe.training.output.replace("{name}", recipe.name))


def refuse_existing_run(run_dir: str | Path, option: str = "--out") -> None:
    """One line when ``run_dir`` holds a run already (its checkpoint or training state): a new run
    never replaces one without ``--overwrite`` (``--resume`` continues it)."""
    run_dir = Path(run_dir)
    held = [name for name in (MODEL_FILE, STATE_FILE) if os.path.lexists(run_dir / name)]
    if held:
        raise DanceError(f"{option} {run_dir}: holds a training run already ({', '.join(held)}); --resume to "
                         "continue it, --overwrite to replace it, or train into another folder")


def run_id(recipe: Recipe) -> str:
    """The id a new run records in its checkpoints: a digest of the resolved recipe it starts from
    (no clock, no path), so that the same run gives the same bytes and a state from another run is told apart."""
    text = json.dumps(recipe.model_dump(mode="json"), sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


def _lock_holder(path: Path) -> int | None:
    """The pid a lock holds (its first word), or None."""
    token = _lock_token(path)
    return token[0] if token is not None else None


def _lock_token(path: Path) -> tuple[int, str | None] | None:
    """A lock's ``(pid, start time)``: ``PID START`` (see :func:`process_start`), or ``PID`` alone (written before
    start times, or where they cannot be read); None when the lock is empty, damaged or a link."""
    try:  # never through a link: a lock is a regular file this folder holds
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW)
    except OSError:
        return None
    with os.fdopen(fd, "rb") as fh:
        words = fh.read(128).decode("utf-8", "replace").split()
    if not words or not words[0].isdigit() or len(words[0]) >= 20:
        return None
    return int(words[0]), (words[1] if len(words) > 1 else None)


def _holder_alive(token: tuple[int, str | None]) -> bool:
    """True when the process that wrote a lock still runs: its pid exists and, when the lock records its start
    time, the process of that pid started then (a pid reused by another process is not the holder)."""
    pid, started = token
    if not pid_alive(pid):
        return False
    now = process_start(pid)
    return started is None or now is None or now == started


def _refuse_foreign_lock(path: Path) -> None:
    what = special_file(path)
    if what is not None:
        raise DanceError(f"{path}: is {what}, not a lock dance made; it is left alone (remove it yourself "
                         "if it is stale, or train into another folder with --out)")


def _take_lock(path: Path) -> None:
    for _ in range(3):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o644)
        except FileExistsError:
            _refuse_foreign_lock(path)
            token = _lock_token(path)
            holder = token[0] if token is not None else None
            if token is None:
                try:
                    age = time.time() - path.stat().st_mtime
                except FileNotFoundError:
                    continue
                if age < EMPTY_LOCK_GRACE_S:
                    raise DanceError(f"{path.parent}: run folder is being locked by another dance train "
                                     f"({path} is still empty); train into another folder (--out)") from None
            elif holder != os.getpid() and _holder_alive(token):
                raise DanceError(f"{path.parent}: run folder is in use by another dance train (pid {holder}, "
                                 f"lock {path}); wait for it or train into another folder (--out)") from None
            from dance_core.plugins import warn

            if _lock_token(path) != token:  # another trainer took it over meanwhile: look again
                continue
            who = "no pid" if holder is None else (
                f"pid {holder}, now another process" if pid_alive(holder) and holder != os.getpid()
                else f"pid {holder}, no longer running")
            _refuse_foreign_lock(path)
            warn(f"{path}: taking over a stale lock ({who})")
            path.unlink(missing_ok=True)
            continue
        except IsADirectoryError:
            raise DataError(f"{path}: is a folder; cannot lock the run folder") from None
        with os.fdopen(fd, "w", encoding="utf-8") as fh:  # the pid and when this process started: see _holder_alive
            fh.write(f"{os.getpid()} {process_start(os.getpid()) or ''}".strip() + "\n")
        return
    raise DanceError(f"{path.parent}: could not lock the run folder ({path} keeps reappearing)")


@contextlib.contextmanager
def run_lock(run_dir: str | Path) -> Iterator[Path]:
    """Hold the run folder's lock (``train.lock``, created with O_EXCL, holding this pid and its start time) while the
    block runs; a second trainer gets one line naming the holder, a dead holder's lock is taken over
    with a warning. Re-entrant within one process. Yields the lock file's path."""
    run_dir = Path(run_dir)
    if run_dir.exists() and not run_dir.is_dir():
        raise DataError(f"{run_dir}: is a file, not a run folder")
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir.resolve() / LOCK_FILE  # the folder resolved, never the lock itself (a link is refused)
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


def _write_all(fd: int, data: bytes) -> None:
    """Write every byte of ``data`` to ``fd`` (``os.write`` may write part of it)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


class RunFolder:
    """The files of one run folder. ``writes=False`` (a rank other than 0) reads it but never writes
    its log: only rank 0 writes a run folder."""

    def __init__(self, path: str | Path, writes: bool = True):
        self.path = Path(path)
        self.writes = writes

    @property
    def model(self) -> Path:
        """The model checkpoint."""
        return self.path / MODEL_FILE

    @property
    def state(self) -> Path:
        """The training state (optimizer and RNG) that goes with the checkpoint."""
        return self.path / STATE_FILE

    @property
    def log_file(self) -> Path:
        """The JSONL log, one record per logged step."""
        return self.path / LOG_FILE

    def sweep(self) -> None:
        """Remove what a killed run left of its temporary files beside the run's own."""
        sweep_stale_temps(self.path, [MODEL_FILE, STATE_FILE, LOG_FILE, RECIPE_FILE])

    def start(self, recipe: Recipe, resume_step: int | None) -> None:
        """Begin writing: a new run drops the old log; a resumed one cuts it after ``resume_step``;
        both record the resolved recipe."""
        if not self.writes:
            return
        if resume_step is None:
            self.log_file.unlink(missing_ok=True)
        elif self.log_file.exists():
            lines = [ln for ln in self.log_file.read_text().splitlines()
                     if ln and json.loads(ln).get("step", 0) <= resume_step]
            write_text(self.log_file, "".join(ln + "\n" for ln in lines))
        write_text(self.path / RECIPE_FILE, yaml.safe_dump(recipe.model_dump(mode="json"), sort_keys=False))

    def log(self, record: dict[str, Any]) -> None:
        """Append one record to the log."""
        if not self.writes:
            return
        refuse_special(self.log_file)  # appended to in place: never through a link or into a device
        fd = os.open(self.log_file, os.O_WRONLY | os.O_APPEND | os.O_CREAT | _NOFOLLOW, output_mode())
        try:
            size = os.fstat(fd).st_size
            try:
                _write_all(fd, (json.dumps(record) + "\n").encode("utf-8"))
            except OSError as exc:
                with contextlib.suppress(OSError):
                    os.ftruncate(fd, size)  # never half a record: a resume reads every line
                raise self._disk_full(exc, f"appending step {record.get('step')} to {LOG_FILE}") or exc
        finally:
            os.close(fd)

    def _disk_full(self, exc: OSError, doing: str) -> DataError | None:
        """One line for a full disk (or quota) while ``doing``, naming the last good checkpoint; None for
        another error."""
        if exc.errno not in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
            return None
        try:
            kept = f"{MODEL_FILE} keeps the last good checkpoint (step {train_state_info(self.state)[0]})"
        except (OSError, DanceError):
            kept = "no checkpoint was written yet"
        return DataError(f"{self.path}: disk full ({exc.strerror or exc}) while {doing}; {kept}; free some space "
                         "and continue with --resume")

    @property
    def previous_model(self) -> Path:
        """The checkpoint being replaced, kept while a new pair is renamed into place."""
        return self.path / "model.previous.safetensors"

    def save(self, model: Any, stats: Any, recipe: Recipe, motion: Any, step: int, run: str, optimizer: Any) -> Path:
        """Write the model checkpoint and the training state as one output set (both or neither). The
        set is renamed into place model first; a SIGKILL between the two renames (signals cannot be held
        off against it) would leave a new model beside the old state, so the old model is kept, hard
        linked, until both are in place, and :meth:`resume_checkpoint` goes back to it."""
        try:
            with OutputSet() as out:
                save_checkpoint(out.path(self.model), model, stats, recipe, motion, step, run)
                save_train_state(out.path(self.state), optimizer, step, run)
                if self.model.exists():
                    self.previous_model.unlink(missing_ok=True)
                    os.link(self.model, self.previous_model)
        except OSError as exc:  # a full disk: nothing of this step written, the last pair kept
            raise self._disk_full(exc, f"saving the checkpoint of step {step}") or exc
        self.previous_model.unlink(missing_ok=True)
        return self.model

    def resume_checkpoint(self, recipe: Recipe) -> Checkpoint:
        """The checkpoint a run resumes from, after checking that it fits ``recipe`` and that the
        training state beside it belongs to it (same step, same run)."""
        ckpt = load_checkpoint(self.model)
        check_matches(ckpt, recipe)
        if not self.state.exists():
            raise CheckpointError(f"{self.state}: training state not found; cannot resume")
        state_step, state_run = train_state_info(self.state)
        if state_step != ckpt.step and self.previous_model.exists():
            previous = load_checkpoint(self.previous_model)
            if previous.step == state_step:  # killed between the pair's two renames: the old pair is whole
                os.replace(self.previous_model, self.model)
                ckpt = previous
        if state_step != ckpt.step:
            raise CheckpointError(f"{self.path}: model checkpoint is at step {ckpt.step} but the training "
                                  f"state at step {state_step}; they do not belong together, cannot resume")
        if ckpt.run is not None and state_run is not None and state_run != ckpt.run:
            raise CheckpointError(f"{self.path}: model checkpoint (run {ckpt.run}) and training state "
                                  f"(run {state_run}) come from different runs; cannot resume")
        return ckpt

    def load_state(self, optimizer: Any | None) -> int:
        """Restore RNG and (unless None) optimizer state from the training state; returns its step."""
        return load_train_state(self.state, optimizer)

    def last_good(self) -> str:
        """What a stopped run leaves: its last checkpoint, or that none was written yet."""
        return f"last good checkpoint: {self.model}" if self.model.exists() else "no checkpoint was written yet"
