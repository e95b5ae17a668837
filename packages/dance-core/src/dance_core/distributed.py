"""Training on several processes with torch's own engine (``torch.distributed``).

A process started by ``torchrun`` (or ``dance train --nproc-per-node N``, which calls torch's
launcher) finds ``RANK``, ``WORLD_SIZE`` and ``LOCAL_RANK`` in its environment; :func:`session`
then joins the process group (NCCL on CUDA, gloo on CPU) for the length of a run. Everything here is
a no-op on a single process, so the training loop calls it unconditionally.

The helpers are collective: every rank calls them at the same point, in the same order.
:func:`run_local` starts ranks on this machine without torchrun (tests, benchmarks).
"""

from __future__ import annotations

import contextlib
import datetime
import os
import socket
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import torch
import torch.distributed as dist

from dance_core.errors import DanceError

#: seconds a rank waits in one collective (e.g. while another rank extracts its share of the
#: features) before the run fails; ``DANCE_DIST_TIMEOUT`` overrides
DEFAULT_TIMEOUT_S = 7200.0


@dataclass(frozen=True)
class Ranks:
    """This process's place in the run: rank, world size, rank on this machine, and the device
    collectives run on (``cuda:LOCAL_RANK`` with NCCL, else CPU)."""

    rank: int = 0
    world: int = 1
    local_rank: int = 0
    device: torch.device = torch.device("cpu")

    @property
    def main(self) -> bool:
        """Rank 0: the one that writes the log and the checkpoints."""
        return self.rank == 0

    @property
    def active(self) -> bool:
        """Whether a process group is up (even a world of one under torchrun)."""
        return dist.is_available() and dist.is_initialized()


def env_ranks() -> tuple[int, int, int] | None:
    """``(rank, world size, local rank)`` from torchrun's environment, or None outside it."""
    if "RANK" not in os.environ or "WORLD_SIZE" not in os.environ:
        return None
    try:
        rank, world = int(os.environ["RANK"]), int(os.environ["WORLD_SIZE"])
        local = int(os.environ.get("LOCAL_RANK", rank))
    except ValueError:
        raise DanceError(f"RANK={os.environ['RANK']!r} WORLD_SIZE={os.environ['WORLD_SIZE']!r}: "
                         "not whole numbers (set by torchrun)") from None
    if not 0 <= rank < world:
        raise DanceError(f"RANK={rank} is outside WORLD_SIZE={world} (set by torchrun)")
    return rank, world, local


def current() -> Ranks:
    """This process's ranks: from the process group when one is up, else a world of one."""
    if not (dist.is_available() and dist.is_initialized()):
        return Ranks()
    local = int(os.environ.get("LOCAL_RANK", dist.get_rank()))
    device = torch.device("cuda", local) if dist.get_backend() == "nccl" else torch.device("cpu")
    return Ranks(dist.get_rank(), dist.get_world_size(), local, device)


@contextlib.contextmanager
def session(device: str = "auto") -> Iterator[Ranks]:
    """Join the process group torchrun's environment describes for the block (and leave it after);
    NCCL when the recipe's ``training.device`` resolves to CUDA, gloo on CPU. Outside torchrun, or
    inside a group the caller already started, it changes nothing."""
    found = env_ranks()
    if found is None or (dist.is_available() and dist.is_initialized()):
        yield current()
        return
    if not dist.is_available():
        raise DanceError("torch.distributed is not available in this torch build; train on one process")
    rank, world, local = found
    if device == "mps":
        raise DanceError("training.device: mps cannot train on several processes; use cuda or cpu")
    if device == "cuda" and not torch.cuda.is_available():
        raise DanceError("device 'cuda' is not available on this machine (use 'auto' or 'cpu')")
    cuda = torch.cuda.is_available() and device in ("auto", "cuda")
    if cuda:
        if local >= torch.cuda.device_count():
            raise DanceError(f"LOCAL_RANK={local} but this machine has {torch.cuda.device_count()} GPU(s); "
                             "start at most one process per GPU (--nproc-per-node)")
        torch.cuda.set_device(local)
    timeout = datetime.timedelta(seconds=float(os.environ.get("DANCE_DIST_TIMEOUT", DEFAULT_TIMEOUT_S)))
    dist.init_process_group("nccl" if cuda else "gloo", rank=rank, world_size=world, timeout=timeout)
    try:
        yield current()
    finally:
        dist.destroy_process_group()


def barrier() -> None:
    """Wait for every rank (nothing on one process)."""
    if current().world > 1:
        dist.barrier()


def broadcast_object(value: Any = None) -> Any:
    """Rank 0's ``value`` on every rank (any picklable object; tensors should be on the CPU)."""
    ranks = current()
    if ranks.world == 1:
        return value
    box = [value if ranks.main else None]
    dist.broadcast_object_list(box, src=0, device=ranks.device if ranks.device.type == "cuda" else None)
    return box[0]


def share_outcome(error: BaseException | None = None) -> None:
    """After rank 0 tried something only it does (lock the run folder, read the checkpoint): rank 0
    passes its error or None, every other rank raises the same error (so no rank waits forever for
    one that stopped)."""
    ranks = current()
    if ranks.world == 1:
        return
    if ranks.main:
        message = None if error is None else (type(error).__name__, _one_line(error))
        broadcast_object((message, isinstance(error, DanceError)))
        return
    message, known = broadcast_object()
    if message is not None:
        name, text = message
        error = DanceError(text if known else f"rank 0 stopped: {name}: {text}")
        error.all_ranks = True  # rank 0 raised it too
        raise error


def on_main(fn: Callable[[], Any]) -> Any:
    """``fn()`` run on rank 0 only, its result handed to every rank; an error there is raised on every
    rank (the same message)."""
    ranks = current()
    if ranks.world == 1:
        return fn()
    value = None
    if ranks.main:
        try:
            value = fn()
        except BaseException as exc:
            share_outcome(exc)
            raise
    share_outcome(None)
    return broadcast_object(value)


def _one_line(exc: BaseException) -> str:
    return " ".join(line.strip() for line in str(exc).splitlines() if line.strip()) or type(exc).__name__


def all_sum(tensor: torch.Tensor) -> torch.Tensor:
    """``tensor`` summed over the ranks (in place on the collective device; returned on the CPU)."""
    ranks = current()
    if ranks.world == 1:
        return tensor.detach().cpu()
    t = tensor.detach().to(ranks.device)
    dist.all_reduce(t, op=dist.ReduceOp.SUM)
    return t.cpu()


def broadcast_module(module: torch.nn.Module) -> None:
    """Make every rank's parameters and buffers rank 0's."""
    ranks = current()
    if ranks.world == 1:
        return
    with torch.no_grad():
        for tensor in [*module.parameters(), *module.buffers()]:
            if tensor.device == ranks.device or ranks.device.type == "cpu":
                dist.broadcast(tensor.data, src=0)
            else:  # a CPU tensor in a NCCL run
                moved = tensor.data.to(ranks.device)
                dist.broadcast(moved, src=0)
                tensor.data.copy_(moved)


def fingerprint(params: Sequence[torch.Tensor]) -> torch.Tensor:
    """A float64 scalar that changes with any parameter's values (a position-weighted sum of sums
    and sums of squares): ranks compare it to find parameters a component changed outside the
    optimizer (TM2D's dead-code restart draws new codes from each rank's own batch)."""
    if not params:
        return torch.zeros((), dtype=torch.float64)
    total = torch.zeros((), dtype=torch.float64, device=params[0].device)
    for i, p in enumerate(params):
        x = p.detach().double()
        total = total + ((i + 1) * x.sum() + x.square().sum()).to(total.device)
    return total.cpu()  # one device sync per step


def to_cpu(value: Any) -> Any:
    """``value`` with every tensor in nested dicts/lists/tuples moved to the CPU (to send it to other ranks)."""
    if torch.is_tensor(value):
        return value.detach().cpu()
    if isinstance(value, dict):
        return {k: to_cpu(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(to_cpu(v) for v in value)
    return value


# -- starting ranks


def launch(argv: list[str], nproc: int) -> int:
    """``python -m dance_core.cli.main ARGV`` on ``nproc`` local processes through torch's launcher
    (what ``torchrun --standalone --nproc-per-node N`` does); returns the exit code: 0, or 1 when a
    rank failed (its own message is above)."""
    import signal

    from torch.distributed.elastic.multiprocessing.api import SignalException
    from torch.distributed.elastic.multiprocessing.errors import ChildFailedError
    from torch.distributed.run import parse_args, run

    from dance_core.atomic import Terminated

    if "OMP_NUM_THREADS" not in os.environ:  # torch's launcher would set it with a banner; same value, quietly
        os.environ["OMP_NUM_THREADS"] = "1"
    import logging

    quiet = [logging.getLogger(n) for n in ("torch.distributed.elastic", "torch.distributed.run")]
    levels = [log.level for log in quiet]
    for log in quiet:
        log.setLevel(logging.CRITICAL)  # each rank reports its own error in one line
    args = parse_args(["--standalone", f"--nproc-per-node={nproc}", "--max-restarts=0", "--monitor-interval=0.2",
                       "-m", "dance_core.cli.main", *argv])
    try:
        run(args)
    except ChildFailedError as exc:
        codes = sorted({f.exitcode for f in exc.failures.values()})
        if codes == [1]:
            return 1
        ranks = ", ".join(f"rank {r} (exit code {f.exitcode})" for r, f in sorted(exc.failures.items()))
        raise DanceError(f"distributed training failed: {ranks}") from None
    except SignalException as exc:  # the launcher stopped its ranks; say so as dance does for itself
        if exc.sigval == signal.SIGTERM:
            raise Terminated("terminated (SIGTERM)") from None
        raise KeyboardInterrupt from None
    finally:
        for log, level in zip(quiet, levels, strict=True):
            log.setLevel(level)
    return 0


def free_port() -> int:
    """A TCP port on localhost that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _rank_entry(rank: int, world: int, port: int, threads: int, fn: Callable, args: tuple, queue: Any) -> None:
    os.environ.update(MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port), RANK=str(rank), WORLD_SIZE=str(world),
                      LOCAL_RANK=str(rank), LOCAL_WORLD_SIZE=str(world), OMP_NUM_THREADS=str(threads))
    torch.set_num_threads(threads)
    try:
        queue.put((rank, "ok", fn(*args)))
    except BaseException as exc:  # handed to the parent, which raises or returns it
        # as a plain DanceError: any exception class reaches the parent intact, whatever its constructor
        text = _one_line(exc) if isinstance(exc, DanceError) else f"{type(exc).__name__}: {_one_line(exc)}"
        queue.put((rank, "error", DanceError(text)))


def run_local(fn: Callable, world: int, *args: Any, timeout: float = 300.0, threads: int = 1) -> list[Any]:
    """``fn(*args)`` on ``world`` fresh local processes with torchrun's environment (gloo on CPU),
    ``threads`` torch threads each; returns each rank's result or the exception it raised, by rank.
    ``fn`` must be importable by name (a module-level function)."""
    import multiprocessing as mp

    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    port = free_port()
    procs = [ctx.Process(target=_rank_entry, args=(r, world, port, threads, fn, args, queue)) for r in range(world)]
    for p in procs:
        p.start()
    results: dict[int, Any] = {}
    try:
        import queue as queues
        import time

        deadline = time.monotonic() + timeout
        while len(results) < world:
            try:
                rank, status, value = queue.get(timeout=0.5)
                results[rank] = value
                if status == "error":  # the others may wait for it in a collective: a little longer only
                    deadline = min(deadline, time.monotonic() + 30.0)
            except queues.Empty:
                if all(p.exitcode is not None for p in procs) or time.monotonic() > deadline:
                    break
        for r, p in enumerate(procs):
            if r not in results:
                results[r] = DanceError(f"rank {r} gave no result (exit code {p.exitcode})")
    finally:
        for p in procs:
            p.join(timeout=10)
            if p.is_alive():
                p.kill()
                p.join()
    return [results[r] for r in range(world)]
