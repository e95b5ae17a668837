"""Transflower's claim as its own experiment: a flow head beats a deterministic (regression) head of the
same encoder on FMD and sample diversity on the multimodal set (3 dancers per song), and the gap closes
on the homogeneous control (one dancer, one routine). Both heads sit on transflower-small's encoder with
its augmentation; the flow is sampled at every temperature of the sweep, the regression head at 1."""

from __future__ import annotations

from claims_protocol import Protocol, TestSet, pm, reference_clips, spread
from claims_runs import ground_truth, run_family

FLOW = ("flow", "transflower-small", [])
REGRESSION = ("regression", "transflower-small",
              ["model.head={plugin: regression, frames: 3, keep: 1, loss: l2, hidden: 64}"])
SETS = (("multimodal", False), ("control", True))


def run(protocol: Protocol) -> dict:
    """Every (set, head, seed) run; ``{set: {"gt": metrics, "flow": [runs], "regression": [runs]}}``."""
    out = {}
    for name, homogeneous in SETS:
        test = TestSet(protocol, protocol.test_seconds, protocol.test_songs, homogeneous)
        reference = reference_clips(protocol, homogeneous)
        out[name] = {"gt": ground_truth(protocol, test, reference, f"gt-{name}")}
        for head, recipe, extra in (FLOW, REGRESSION):
            temps = protocol.temperatures if head == "flow" else (1.0,)
            if head == "flow" and homogeneous and out["multimodal"]["flow"]:  # the control: the claim's T only
                temps = (best_temperature(out["multimodal"]["flow"], protocol.temperatures),)
            runs = [run_family(protocol, f"tf-{name}-{head}", recipe, extra, seed, test, reference, temps, homogeneous)
                    for seed in range(protocol.seeds)]
            out[name][head] = [r for r in runs if r]
            print(f"done: transflower {name} {head}", flush=True)
    return out


def values(runs: list[dict], temperature: float, key: str) -> list:
    """One metric over the seeds at one temperature."""
    return [r["temperatures"].get(f"{temperature:g}", {}).get(key) for r in runs]


def best_temperature(runs: list[dict], temperatures) -> float:
    """The flow's temperature with the lowest mean FMD on the multimodal set (the one the claim uses)."""
    return min(temperatures, key=lambda t: spread(values(runs, t, "FMD"))[0] or float("inf"))


COLS = [("FMD", "FMD ↓"), ("FID_k", "FID_k ↓"), ("Div_sample_pose", "sample div. (m)"),
        ("Div_k", "Div_k"), ("beat_locking", "beat lock ↑"), ("move_validity", "move valid ↑"),
        ("PFF_rel", "PFF_rel % ↓"), ("mpd_20", "MPD_20 (m) ↓"), ("mpd_speed", "its speed (m/s)")]


def table(result: dict, protocol: Protocol) -> list[str]:
    """Per set: ground truth, the flow at each temperature, the regression head (mean ± sd over seeds)."""
    lines = ["| set | model | T | " + " | ".join(c for _, c in COLS) + " | NLL (nats/frame) | best step |",
             "|" + "---|" * (len(COLS) + 5)]
    for name, _ in SETS:
        r = result[name]
        real = " | ".join(pm([r["gt"].get(k)]) for k, _ in COLS)
        lines.append(f"| {name} | real dances | — | {real} | — | — |")
        for head in ("flow", "regression"):
            temps = [t for t in protocol.temperatures if any(f"{t:g}" in x["temperatures"] for x in r[head])]
            temps = temps if head == "flow" else (1.0,)
            nll = pm([x["nll"] for x in r[head]])
            steps = pm([x["best_step"] for x in r[head]])
            for t in temps:
                cells = " | ".join(pm(values(r[head], t, k)) for k, _ in COLS)
                lines.append(f"| {name} | {head} | {t:g} | {cells} | {nll} | {steps} |")
    return lines


def _gap(result: dict, name: str, t: float, key: str):
    f, _ = spread(values(result[name]["flow"], t, key))
    g, _ = spread(values(result[name]["regression"], 1.0, key))
    return f, g


def _separated(a: list, b: list) -> bool:
    """Means differ by more than the sum of the spreads."""
    (ma, sa), (mb, sb) = spread(a), spread(b)
    return None not in (ma, mb) and abs(ma - mb) > (sa or 0) + (sb or 0)


def verdict(result: dict, protocol: Protocol) -> str:
    """The Transflower verdict line."""
    t = best_temperature(result["multimodal"]["flow"], protocol.temperatures)
    fm, gm = _gap(result, "multimodal", t, "FMD")
    fc, gc = _gap(result, "control", t, "FMD")
    dm, dg = _gap(result, "multimodal", t, "Div_sample_pose")
    if None in (fm, gm, fc, gc, dm, dg):
        return "- **Transflower** (flow vs regression head, same encoder): inconclusive — a run did not finish."
    mm = result["multimodal"]
    fmd_sep = _separated(values(mm["flow"], t, "FMD"), values(mm["regression"], 1.0, "FMD"))
    beats = fm < gm and fmd_sep
    diverse = dm > dg
    closes = (gc - fc) < (gm - fm)
    numbers = (f"multimodal FMD flow (T={t:g}) {fm:.3g} vs regression {gm:.3g}, sample diversity {dm:.3g} vs "
               f"{dg:.3g} m; control FMD {fc:.3g} vs {gc:.3g} (gap {gm - fm:+.3g} → {gc - fc:+.3g}); "
               f"{protocol.seeds} seeds × {protocol.samples} samples")
    if beats and diverse and closes:
        word = "holds"
    elif not fmd_sep and diverse:
        word = "inconclusive (the FMD difference on the multimodal set is within the seeds' spread)"
    else:
        missing = [w for w, ok in (("flow better FMD", beats), ("more diverse", diverse), ("gap closes", closes))
                   if not ok]
        word = "does not hold (" + ", ".join(missing) + " fails)"
    return f"- **Transflower** (a flow head beats a regression head of the same encoder on FMD and diversity on " \
           f"the multimodal set; the gap closes on the homogeneous control): {numbers}: {word}."
