"""Fine-tune the VQ-VAE decoder of a trained tm2d-small against jitter, keeping its tokens.

    OMP_NUM_THREADS=1 python packages/dance-tokens/scripts/finetune_decoder.py CHECKPOINT OUT_DIR
        [--steps 1000] [--velocity 0.5] [--acceleration 0.5] [--lr 3e-4] [--set FIELD=VALUE ...]

Only ``head.tokenizer.decoder.*`` trains, on the recipe's tokenizer loss plus L1 losses on the
reconstruction's first and second frame differences (``model.head.tokenizer.velocity`` /
``acceleration``); the encoder and the codebook stay frozen and dead-code restart is off, so every
motion maps to the same tokens as before and the token prior stays valid as it is. The data must be
the checkpoint's (``--set`` the same ``data.*`` it was trained with): its normalization statistics are
checked against the checkpoint's. Writes ``OUT_DIR/model.safetensors`` (the checkpoint with the new
decoder and the loss weights in its recipe) every 200 steps and at the end, and ``OUT_DIR/log.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import torch

from dance_core.checkpoint import load_checkpoint, load_weights, save_checkpoint
from dance_core.recipe import load_recipe
from dance_core.train import Trainer


def main(argv: list[str] | None = None) -> int:
    """Run the fine-tune."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("checkpoint")
    p.add_argument("out", type=Path)
    p.add_argument("--recipe", default="tm2d-small")
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--batch", type=int, default=64)
    p.add_argument("--lr", type=float, default=3e-4)
    p.add_argument("--velocity", type=float, default=0.5)
    p.add_argument("--acceleration", type=float, default=0.5)
    p.add_argument("--set", dest="sets", action="append", default=[])
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    sets = [*args.sets, f"model.head.tokenizer.velocity={args.velocity}",
            f"model.head.tokenizer.acceleration={args.acceleration}"]
    recipe = load_recipe(args.recipe, sets)
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    trainer = Trainer(recipe, args.out, quiet=True)
    ckpt = load_checkpoint(args.checkpoint)
    ours, theirs = trainer.stats.to_arrays(), ckpt.stats.to_arrays()
    if set(ours) != set(theirs) or any(not np.allclose(ours[k], theirs[k], atol=1e-5) for k in ours):
        raise SystemExit(f"{args.checkpoint}: the data's normalization statistics differ from the checkpoint's "
                         "(--set the data it was trained with)")
    model = trainer.model
    load_weights(model, ckpt)
    vq = model.head.tokenizer
    vq.quantizer.restart_after = None  # the codebook stays as the prior knows it
    params = list(vq.decoder.parameters())
    for q in model.parameters():
        q.requires_grad_(False)
    for q in params:
        q.requires_grad_(True)
    stage = next(s for s in trainer.stages if s.name == model.head.config.tokenizer_stage)
    optimizer = torch.optim.Adam(params, lr=args.lr)
    val_motion, _ = trainer.val_sampler.batch(0, trainer.device)
    with torch.no_grad():
        tokens_before = vq.encode(val_motion)
    log = (args.out / "log.jsonl").open("w", encoding="utf-8")

    def val_record(step: int) -> dict:
        model.eval()
        with torch.no_grad():
            out = vq.loss(val_motion, kinematics=trainer.kinematics)
        model.train()
        return {"step": step, "val": {k: float(v) for k, v in out.items() if v.numel() == 1}}

    log.write(json.dumps(val_record(0)) + "\n")
    model.train()
    for step in range(1, args.steps + 1):
        for g in optimizer.param_groups:  # cosine decay to zero
            g["lr"] = args.lr * 0.5 * (1 + math.cos(math.pi * (step - 1) / args.steps))
        motion, streams = trainer.sampler.batch(10_000 + step, trainer.device, args.batch)
        losses = model.training_loss(motion, streams, trainer._context(step, stage))
        optimizer.zero_grad(set_to_none=True)
        losses["loss"].backward()
        torch.nn.utils.clip_grad_norm_(params, 1.0)
        optimizer.step()
        if step % 25 == 0:
            log.write(json.dumps({"step": step, **{k: float(v.detach()) for k, v in losses.items() if v.numel() == 1},
                                  "seconds": round(time.perf_counter() - start, 1)}) + "\n")
            log.flush()
        if step % 200 == 0 or step == args.steps:
            log.write(json.dumps(val_record(step)) + "\n")
            save_checkpoint(args.out / "model.safetensors", model, trainer.stats, recipe, ckpt.motion, ckpt.step + step,
                            ckpt.run)
    with torch.no_grad():
        same = bool(torch.equal(tokens_before, vq.encode(val_motion)))
    log.write(json.dumps({"tokens_unchanged": same, "seconds": round(time.perf_counter() - start, 1)}) + "\n")
    log.close()
    print(f"done: tokens unchanged {same}, {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
