"""TM2D's two stages (VQ-VAE tokenizer, then the cross-modal prior) trained on 2 gloo CPU ranks, with a
stop and a resume at the stage boundary: each stage trains only its parameters, the ranks end with the
same weights although the tokenizer's dead-code restart draws new codes from each rank's own batch
(the trainer notices and re-syncs them from rank 0), and rank 0's checkpoint and log hold both stages."""

import json
import sys
from pathlib import Path

import pytest

from dance_core.checkpoint import load_checkpoint
from dance_core.distributed import run_local

sys.path.insert(0, str(Path(__file__).parent))
import tokens_dist_workers as workers  # noqa: E402 - spawned ranks import it by this name


@pytest.mark.slow
def test_tm2d_trains_both_stages_on_two_ranks(tmp_path):
    ranks = run_local(workers.run, 2, str(tmp_path / "run"), timeout=240)
    for r in ranks:
        if isinstance(r, BaseException):
            raise r
    first, second = ranks
    assert first["world"] == 2 and first["steps"] == 12
    assert first["digest"] == second["digest"] and first["loss"] == second["loss"] and first["val"] == second["val"]
    tokenizer, prior = first["changed"]
    assert tokenizer and all(k.startswith("head.tokenizer.") for k in tokenizer)
    assert prior and all(k.startswith(("encoder.", "head.prior.")) for k in prior)
    assert any(k.startswith("encoder.") for k in prior) and any(k.startswith("head.prior.") for k in prior)
    assert first["resyncs"] > 0 and first["resyncs"] == second["resyncs"]  # the codebooks did drift apart
    assert load_checkpoint(tmp_path / "run" / "model.safetensors").step == 12
    log = [json.loads(line) for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    steps = [(r["step"], r["stage"], r["world_size"]) for r in log if "loss" in r]
    assert steps == [(3, "tokenizer", 2), (6, "tokenizer", 2), (9, "prior", 2), (12, "prior", 2)]
