"""Held-out real dance through a checkpoint's VQ-VAE: how high the feet step and how far the arms rise.

    OMP_NUM_THREADS=1 python packages/dance-tokens/scripts/vq_reconstruction.py CHECKPOINT [CHECKPOINT ...]
        [--mocap ../shared/mocap/cmu-dance] [--json FILE]

The seven CMU takes every recipe holds out (``benchmarks/realism.py``'s ``HELD_OUT``, on ``dance24`` at
30 fps) go through each checkpoint's ``head.tokenizer`` (encoder, nearest codes, decoder; and the decoder
on the encoder's continuous output, "unquantized"), are decoded to skeletal motion (not grounded) and
scored with the window statistics of ``dance_core.evaluation`` (4-s windows every 0.5 s, pooled over the
takes): the medians of the feet's height range (leg lengths) and the arms' raise (degrees), beside the
takes' own. Prints one row per checkpoint.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from dance_core import DatasetContext, get_registry
from dance_core.checkpoint import load_checkpoint
from dance_core.evaluation import STATISTICS, window_statistics
from dance_tokens.configs import TokenizerConfig
from dance_tokens.vqvae import MotionVQVAE

FPS = 30.0
HOP = 0.5
HELD_OUT = ("salsa_60_09", "salsa_61_09", "salsa_60_10", "salsa_61_10", "modern_05_10", "modern_05_11",
            "modern_05_12")
SHOWN = ("foot_height_range", "arm_raise", "pelvis_bob", "knee_bend")


def held_out_takes(folder: Path) -> list:
    """The held-out takes on dance24 at 30 fps (the mocap dataset's retargeting, cached)."""
    dataset = get_registry().create("dataset", "mocap", {"path": str(folder)}, DatasetContext(fps=FPS))
    clips = {c.name: c.motion.skeleton_motion for c in dataset.clips()}
    return [clips[n] for n in HELD_OUT]


def medians(motions: list) -> dict[str, float]:
    """Median window statistics pooled over the motions."""
    windows = np.concatenate([window_statistics(m.positions(), m.fps, m.skeleton.names, hop=HOP) for m in motions])
    med = np.median(windows, axis=0)
    return {s: float(med[STATISTICS.index(s)]) for s in SHOWN}


def through_vqvae(path: Path, takes: list) -> tuple[list, list]:
    """The takes through the checkpoint's VQ-VAE: (quantized, unquantized) reconstructions."""
    ckpt = load_checkpoint(path)
    registry = get_registry()
    rep = ckpt.motion.build_representation(registry)
    config = TokenizerConfig(**ckpt.recipe["model"]["head"]["tokenizer"])
    vq = MotionVQVAE(ckpt.motion.dim, config).eval()
    prefix = "head.tokenizer."
    vq.load_state_dict({k[len(prefix):]: v for k, v in ckpt.weights.items() if k.startswith(prefix)})
    quantized, continuous = [], []
    with torch.no_grad():
        for take in takes:
            values = ckpt.stats.motion.apply(rep.encode(take))
            n = len(values) // config.downsample * config.downsample
            x = torch.tensor(values[None, :n])
            latent = vq.encode_latent(x)
            decodings = ((quantized, vq.decode(vq.quantizer.nearest(latent))), (continuous, vq.decode_codes(latent)))
            for out, decoded in decodings:
                back = ckpt.stats.motion.invert(decoded[0].numpy())
                out.append(rep.decode(back, ckpt.motion.skeleton, take.fps))
    return quantized, continuous


def main(argv: list[str] | None = None) -> int:
    """Print the takes' medians and each checkpoint's reconstructions'."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("checkpoints", nargs="+", type=Path)
    p.add_argument("--mocap", type=Path, default=Path(__file__).resolve().parents[3] / ".." / "shared" / "mocap"
                   / "cmu-dance")
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    takes = held_out_takes(args.mocap)
    rows = {"the takes": medians(takes)}
    for path in args.checkpoints:
        quantized, continuous = through_vqvae(path, takes)
        rows[f"{path} (codes)"] = medians(quantized)
        rows[f"{path} (unquantized)"] = medians(continuous)
    print("| | " + " | ".join(SHOWN) + " |")
    for name, row in rows.items():
        print(f"| {name} | " + " | ".join(f"{row[s]:.3f}" for s in SHOWN) + " |")
    if args.json:
        from dance_core.atomic import write_text

        write_text(args.json, json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
