"""DanceRevolution trained on 2 gloo CPU ranks equals one process with the whole batch: the song-level
encoder, the LSTM's sequence loss and the auto-condition curriculum, whose q (read from the epoch)
every rank must see alike.

Tolerance: after 14 steps (2 x 4 segments against 1 x 8) no weight differs by more than 1 % of the
largest change training made to any weight. Only the order of float reductions differs (the
gradients agree to ~5e-7 relative), but AdamW divides by the root of each gradient's second moment,
so a weight whose gradient is nearly zero moves by up to the learning rate on rounding alone: the
weights end 1e-5 apart when training moved them 0.03; a wrong share of the batch or a curriculum on
another epoch moves them apart by the order of the change itself."""

import json
import sys
from pathlib import Path

import pytest
import torch

from dance_core.checkpoint import load_checkpoint
from dance_core.distributed import run_local
from dance_core.train import Trainer, train

sys.path.insert(0, str(Path(__file__).parent))
import rnn_dist_workers as workers  # noqa: E402 - spawned ranks import it by this name


def logged(run, key):
    lines = (Path(run) / "log.jsonl").read_text().splitlines()
    return [r[key] for r in map(json.loads, lines) if key in r]


@pytest.mark.slow
def test_two_ranks_train_dancerevolution_as_one_process_with_the_whole_batch(tmp_path):
    ranks = run_local(workers.run, 2, str(tmp_path / "two"), 4, timeout=240)
    for r in ranks:
        if isinstance(r, BaseException):
            raise r
    assert ranks[0] == ranks[1]
    torch.set_num_threads(1)
    single = train(workers.tiny("training.batch_size=8"), out=str(tmp_path / "one"), quiet=True)
    # the curriculum moved on with the epochs, alike in both runs
    q = logged(tmp_path / "two", "auto_condition")
    assert q == logged(tmp_path / "one", "auto_condition") and q[0] == 0 and q[-1] == 2
    assert logged(tmp_path / "two", "epoch") == logged(tmp_path / "one", "epoch")
    a = load_checkpoint(tmp_path / "two" / "model.safetensors").weights
    b = load_checkpoint(single.checkpoint).weights
    init = Trainer(workers.tiny("training.batch_size=8"), tmp_path / "init", quiet=True).model.state_dict()
    moved = max(float((b[k] - init[k]).abs().max()) for k in b)
    apart = max(float((a[k] - b[k]).abs().max()) for k in a)
    assert apart < 0.01 * moved
    steps, last, val = ranks[0]
    assert steps == 14 and abs(last - single.last_loss) < 1e-5 * single.last_loss
    assert abs(val - single.val_loss) < 1e-5 * single.val_loss
    assert last < logged(tmp_path / "one", "loss")[0]  # it learns
