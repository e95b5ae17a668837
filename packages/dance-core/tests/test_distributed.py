"""Distributed training on 2 gloo CPU ranks: equal to one process with the whole batch, resumable on
any number of ranks, rank 0 alone writes, a NaN on one rank stops both with one message, and
``dance train --nproc-per-node`` launches the same through torch's launcher.

Tolerance of the equivalence: after 40 AdamW steps (2 ranks x 8 segments against 1 x 16) no weight
differs by more than 1 % of the largest change training made to any weight (observed: 3e-6 apart,
0.05 moved). The two runs differ only in the order of float reductions (each rank's mean over 8 rows,
averaged by the all-reduce, against one mean over 16), which AdamW can amplify for weights whose
gradient is nearly zero; a wrong share of the batch moves the weights apart by the order of the change.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from dance_core.checkpoint import load_checkpoint
from dance_core.data.sampling import SegmentSampler
from dance_core.data.sources import Clip
from dance_core.distributed import run_local
from dance_core.train import Trainer, train

sys.path.insert(0, str(Path(__file__).parent))
import core_dist_workers as workers  # noqa: E402 - spawned ranks import it by this name

BATCH = 8


def weights(path):
    return load_checkpoint(path).weights


def max_difference(a, b):
    assert a.keys() == b.keys()
    return max(float((a[k] - b[k]).abs().max()) for k in a)


def records(run):
    return [json.loads(line) for line in (Path(run) / "log.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """2 ranks x batch 8 (runs a, b, c of core_dist_workers.session) and 1 rank x batch 16."""
    root = tmp_path_factory.mktemp("dist")
    (root / "d").mkdir()
    (root / "d" / "train.lock").write_text(f"{os.getpid()}\n")  # this live process holds run d
    ranks = run_local(workers.session, 2, str(root), BATCH, timeout=240)
    for r in ranks:
        if isinstance(r, BaseException):
            raise r
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        single = train(workers.tiny(f"training.batch_size={2 * BATCH}"), out=str(root / "single"), quiet=True)
    finally:
        torch.set_num_threads(before)
    return root, ranks, single


def test_a_rank_draws_its_slice_of_the_batch_one_process_draws():
    rng = np.random.default_rng(0)
    clips = [Clip(f"c{i}", rng.normal(size=(30 + i, 3)).astype(np.float32),
                  {"music": rng.normal(size=(30 + i, 2)).astype(np.float32)}, f"s{i}") for i in range(3)]
    sampler = SegmentSampler(clips, 10, 4, seed=5)
    whole, streams = sampler.batch(7, size=12)
    parts = [sampler.batch(7, size=4, part=(k, 3)) for k in range(3)]
    assert torch.equal(torch.cat([m for m, _ in parts]), whole)
    assert torch.equal(torch.cat([s["music"] for _, s in parts]), streams["music"])


def test_two_ranks_of_batch_b_reach_the_weights_of_one_rank_of_batch_2b(runs):
    root, ranks, single = runs
    (steps0, loss0, val0, digest0, world), (_, loss1, val1, digest1, _) = ranks[0]["a"], ranks[1]["a"]
    assert world == 2 and steps0 == 40
    assert digest0 == digest1 and loss0 == loss1 and val0 == val1  # the ranks agree exactly
    a, s = weights(root / "a" / "model.safetensors"), weights(single.checkpoint)
    init = Trainer(workers.tiny(), root / "init", quiet=True).model.state_dict()
    assert max_difference(a, s) < 0.01 * max_difference(s, init)
    assert val0 == pytest.approx(single.val_loss, rel=1e-5)
    assert loss0 == pytest.approx(single.last_loss, rel=1e-5)
    logged = [r["loss"] for r in records(root / "a") if "loss" in r]
    alone = [r["loss"] for r in records(root / "single") if "loss" in r]
    assert logged == pytest.approx(alone, rel=1e-5) and len(logged) == 4


def test_rank_0_alone_writes_the_run_folder_and_the_log_records_the_world_size(runs):
    root, ranks, single = runs
    assert sorted(p.name for p in (root / "a").iterdir()) == [
        "log.jsonl", "model.safetensors", "recipe.yaml", "state.safetensors"]
    log = records(root / "a")
    steps = [r["step"] for r in log if "loss" in r]
    assert steps == [10, 20, 30, 40]  # one writer: no line twice
    assert [r["step"] for r in log if "val_loss" in r] == [20, 40]
    assert all(r["world_size"] == 2 for r in log if "loss" in r)
    assert all(r["world_size"] == 1 for r in records(root / "single") if "loss" in r)
    # segments/s counts both ranks' segments
    assert load_checkpoint(root / "a" / "model.safetensors").step == 40


def test_a_two_rank_run_resumes_on_one_rank(runs):
    root, ranks, single = runs
    assert ranks[0]["b"] == ranks[1]["b"] == 20
    assert load_checkpoint(root / "b" / "model.safetensors").step == 20
    torch.set_num_threads(1)
    resumed = train(workers.tiny(f"training.batch_size={2 * BATCH}"), out=str(root / "b"), quiet=True, resume=True)
    assert resumed.steps == 40
    init = Trainer(workers.tiny(), root / "init", quiet=True).model.state_dict()
    s = weights(single.checkpoint)
    assert max_difference(weights(resumed.checkpoint), s) < 0.01 * max_difference(s, init)
    log = records(root / "b")
    assert [r["world_size"] for r in log if "loss" in r] == [2, 2, 1, 1]


def test_a_nan_on_one_rank_stops_both_with_one_message(runs):
    root, ranks, _ = runs
    first, second = ranks[0]["c"], ranks[1]["c"]
    assert first == second and first[0] == "TrainingError"
    message = first[1]
    assert "step 25" in message and "loss is nan on rank 1" in message and "\n" not in message
    assert str(root / "c" / "model.safetensors") in message
    assert load_checkpoint(root / "c" / "model.safetensors").step == 20
    errors = [r for r in records(root / "c") if "error" in r]
    assert errors == [{"step": 25, "stage": "main", "error": "loss is nan on rank 1"}]


def test_an_error_only_rank_0_can_meet_stops_every_rank_with_its_message(runs):
    root, ranks, _ = runs
    assert ranks[0]["d"] == ranks[1]["d"]
    assert "run folder is in use by another dance train" in ranks[0]["d"] and str(os.getpid()) in ranks[0]["d"]
    assert sorted(p.name for p in (root / "d").iterdir()) == ["train.lock"]


@pytest.mark.slow
def test_dance_train_nproc_per_node_launches_the_same_run(runs, tmp_path):
    root, _, _ = runs
    sets = [a for s in workers.TINY + [f"training.batch_size={BATCH}"] for a in ("--set", s)]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env.pop("RANK", None)
    done = subprocess.run(
        [sys.executable, "-m", "dance_core.cli.main", "train", "core-synthetic", "--nproc-per-node", "2",
         "-o", str(tmp_path / "run"), *sets],
        capture_output=True, text=True, env=env, timeout=240,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("trained 40 steps") == 1  # rank 0 alone reports
    assert done.stdout.strip().splitlines()[-1] == str(tmp_path / "run" / "model.safetensors")
    a, b = weights(root / "a" / "model.safetensors"), weights(tmp_path / "run" / "model.safetensors")
    assert all(torch.equal(a[k], b[k]) for k in a)  # the same ranks, the same arithmetic
    assert all(r["world_size"] == 2 for r in records(tmp_path / "run") if "loss" in r)


def test_precision_and_compile_are_ignored_on_cpu_with_one_line_each(tmp_path, capsys):
    trainer = Trainer(workers.tiny("training.precision=bf16", "training.compile=true", "training.device=cpu"),
                      tmp_path, quiet=True)
    err = capsys.readouterr().err.splitlines()
    assert trainer.precision == "fp32" and trainer.compile is False
    assert [line for line in err if "training.precision" in line] == [
        "dance: warning: training.precision: bf16 autocast runs on CUDA only; training in fp32 on cpu"]
    assert [line for line in err if "training.compile" in line] == [
        "dance: warning: training.compile: torch.compile is used on CUDA only; ignored on cpu"]
