"""What each rank runs in test_tokens_distributed.py (a module of its own: spawned ranks import it by name)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import dance_tokens.plugin
from dance_core.recipe import load_recipe

VOCAB = Path(dance_tokens.plugin.RECIPES) / "tm2d-vocab.txt"

#: tm2d-small shrunk to seconds: energy features (no beat tracking), 3 songs and 8 text clips, a tiny
#: VQ-VAE whose dead codes restart after 2 idle batches (each rank from its own batch: the ranks'
#: codebooks drift apart and must be re-synced), both stages 6 steps
TINY = [
    f"features={{music: [{{plugin: energy}}], text: [{{plugin: word-tokens, vocab: {VOCAB}, max_words: 12}}]}}",
    "data.dataset.datasets.0.songs=3",
    "data.dataset.datasets.0.seconds=6",
    "data.dataset.datasets.0.dance_to_tracker=null",
    "data.dataset.datasets.1.clips=8",
    "data.dataset.datasets.1.seconds=[3, 4]",
    "data.val_fraction=0.2",
    "data.mirror=false",
    "data.segment_frames=32",
    "model.encoder={plugin: tm2d-audio, dim: 16, layers: 1, heads: 2, ffn: 32, dropout: 0.0, radius: 4}",
    "model.head.tokenizer={codes: 32, code_dim: 8, width: 16, crop: 32, recon: smooth-l1, restart_after: 2}",
    "model.head.prior={dim: 16, layers: 1, text_layers: 1, heads: 2, ffn: 32, dropout: 0.0, vocab_size: 96,"
    " context: 4, radius: 4}",
    "training.stages=[{name: tokenizer, steps: 6, trainable: [head.tokenizer.], lr: 3.0e-3, batch_size: 4},"
    " {name: prior, steps: 6, trainable: [encoder., head.prior.], lr: 2.0e-3, batch_size: 4}]",
    "training.val_every=6",
    "training.checkpoint_every=6",
    "training.log_every=3",
]


def digest(model) -> str:
    """SHA-256 of every weight's bytes."""
    h = hashlib.sha256()
    for name, value in sorted(model.state_dict().items()):
        h.update(name.encode())
        h.update(value.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()


def run(out: str) -> dict:
    """Both stages on this rank, stopping after the tokenizer and resuming: what changed in each
    stage, the resyncs, and a digest of the final weights."""
    from dance_core import distributed
    from dance_core.train import Trainer

    with distributed.session() as ranks:
        trainer = Trainer(load_recipe("tm2d-small", TINY), Path(out), quiet=True)
        start = {k: v.clone() for k, v in trainer.model.state_dict().items()}
        trainer.run(stop_at=6)
        middle = {k: v.clone() for k, v in trainer.model.state_dict().items()}
        resyncs = trainer.resyncs
        result = trainer.run(resume=True)
        end = trainer.model.state_dict()
        changed = [sorted(k for k in a if not (a[k] == b[k]).all()) for a, b in ((start, middle), (middle, end))]
        return {"world": ranks.world, "steps": result.steps, "loss": result.last_loss, "val": result.val_loss,
                "changed": changed, "resyncs": resyncs + trainer.resyncs, "digest": digest(trainer.model)}
