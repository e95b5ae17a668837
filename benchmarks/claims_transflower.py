"""Transflower's claim as its own experiment: a flow head beats a deterministic (regression) head of the
same encoder on FMD, with a sample diversity nearer the real dances', on the multimodal set (3 dancers per
song), and the gap closes on the homogeneous control (one dancer, one routine). Both heads sit on
transflower-small's encoder with its augmentation. Each flow run chooses its temperature on the
selection songs (``claims_protocol.selection_set``; never the test songs) and is scored on the test
songs at that temperature only.

The rule, stated before the run (``RULE``), on 95 % percentile-bootstrap intervals over the training
seeds (``claims_protocol.bootstrap``): (1) FMD(regression) − FMD(flow) on the multimodal set; (2) the
regression head's distance from the real dances' sample diversity minus the flow's,
``|div_reg − div_real| − |div_flow − div_real|`` (too much diversity is as wrong as too little);
(3) the FMD gap on the multimodal set minus the gap on the control. It holds when all three intervals
lie above 0, does not hold when any lies wholly below 0, and is inconclusive otherwise.
"""

from __future__ import annotations

from claims_protocol import (
    Protocol,
    TestSet,
    bootstrap,
    ci,
    decide,
    difference,
    plateau_ends,
    pm,
    reference_clips,
    scored,
    selection_set,
)
from claims_runs import ground_truth, run_family

FLOW = ("flow", "transflower-small", [])
REGRESSION = ("regression", "transflower-small",
              ["model.head={plugin: regression, frames: 3, keep: 1, loss: l2, hidden: 64}"])
SETS = (("multimodal", False), ("control", True))
RULE = ("holds when the 95 % bootstrap intervals over seeds of (1) FMD(regression) − FMD(flow) on the multimodal "
        "set, (2) |div(regression) − div(real)| − |div(flow) − div(real)| (sample diversity, the real dances' as "
        "the target) and (3) the FMD gap on the multimodal set minus that on the control all lie above 0; does not "
        "hold when any lies wholly below 0; inconclusive otherwise; the flow's temperature chosen per run on "
        "selection songs")


def run(protocol: Protocol) -> dict:
    """Every (set, head, seed) run; ``{set: {"gt": metrics, "flow": [runs], "regression": [runs]}}``."""
    out = {}
    for name, homogeneous in SETS:
        test = TestSet(protocol, protocol.test_seconds, protocol.test_songs, homogeneous)
        select = selection_set(protocol, test)
        reference = reference_clips(protocol, homogeneous)
        out[name] = {"gt": ground_truth(protocol, test, reference, f"gt-{name}")}
        for head, recipe, extra in (FLOW, REGRESSION):
            temps = protocol.temperatures if head == "flow" else (1.0,)
            runs = [run_family(protocol, f"tf2-{name}-{head}", recipe, extra, seed, test, reference, temps,
                               homogeneous, select=select)
                    for seed in range(protocol.seeds)]
            out[name][head] = [r for r in runs if r]
            print(f"done: transflower {name} {head}", flush=True)
    return out


def values(runs: list[dict], key: str) -> list:
    """One metric over the seeds, each at the temperature its run chose on the selection songs."""
    return [scored(r).get(key) for r in runs]


COLS = [("FMD", "FMD ↓"), ("FID_k", "FID_k ↓"), ("Div_sample_pose", "sample div. (m)"),
        ("Div_k", "Div_k"), ("beat_locking", "beat lock ↑"), ("move_validity", "move valid ↑"),
        ("PFF_rel", "PFF_rel % ↓"), ("mpd_20", "MPD_20 (m) ↓"), ("mpd_speed", "its speed (m/s)")]


def chosen(runs: list[dict]) -> str:
    """The temperatures the runs chose (one per seed)."""
    return ", ".join(f"{r.get('chosen', 1.0):g}" for r in runs) or "—"


def table(result: dict, protocol: Protocol) -> list[str]:
    """Per set: ground truth, the flow and the regression head on the test songs (each flow run at its chosen
    temperature), and the flow's selection-song FMD per temperature (mean ± sd over seeds)."""
    lines = ["| set | model | T (per seed) | " + " | ".join(c for _, c in COLS) + " | NLL (nats/frame) | best step |",
             "|" + "---|" * (len(COLS) + 5)]
    for name, _ in SETS:
        r = result[name]
        real = " | ".join(pm([r["gt"].get(k)]) for k, _ in COLS)
        lines.append(f"| {name} | real dances | — | {real} | — | — |")
        for head in ("flow", "regression"):
            cells = " | ".join(pm(values(r[head], k)) for k, _ in COLS)
            nll, steps = pm([x["nll"] for x in r[head]]), pm([x["best_step"] for x in r[head]])
            lines.append(f"| {name} | {head} | {chosen(r[head])} | {cells} | {nll} | {steps} |")
    sweep = [f"{t:g}: " + pm([x.get("selection", {}).get(f"{t:g}", {}).get("FMD") for x in result[name]["flow"]])
             for name, _ in SETS for t in protocol.temperatures]
    lines += ["", "Flow FMD on the selection songs per temperature (multimodal, then control): " + "; ".join(sweep)]
    return lines


def intervals(result: dict) -> dict:
    """The three bootstrap intervals of the rule."""
    mm, co = result["multimodal"], result["control"]
    real_div = mm["gt"].get("Div_sample_pose")
    fmd = difference(values(mm["regression"], "FMD"), values(mm["flow"], "FMD"))
    div = (None, None, None) if real_div is None else bootstrap(
        lambda reg, flow: abs(reg - real_div) - abs(flow - real_div),
        values(mm["regression"], "Div_sample_pose"), values(mm["flow"], "Div_sample_pose"))
    closes = bootstrap(lambda rm, fm, rc, fc: (rm - fm) - (rc - fc),
                       values(mm["regression"], "FMD"), values(mm["flow"], "FMD"),
                       values(co["regression"], "FMD"), values(co["flow"], "FMD"))
    return {"flow better FMD": fmd, "diversity nearer the real dances'": div, "gap closes on the control": closes}


def verdict(result: dict, protocol: Protocol, reduced: str = "") -> str:
    """The Transflower verdict line: the deciding numbers, their intervals and the rule."""
    parts = intervals(result)
    readings = {k: decide(v) for k, v in parts.items()}
    mm = result["multimodal"]
    seeds = min(len(mm["flow"]), len(mm["regression"]))
    if "n/a" in readings.values():
        word = "inconclusive (a run did not finish)"
    elif all(r == "above" for r in readings.values()):
        word = "holds"
    elif any(r == "below" for r in readings.values()):
        word = "does not hold (" + ", ".join(k for k, r in readings.items() if r == "below") + " goes the other way)"
    else:
        word = "inconclusive (" + ", ".join(k for k, r in readings.items() if r == "straddles") + ": interval spans 0)"
    div = [pm(values(mm[h], "Div_sample_pose")) for h in ("flow", "regression")]
    numbers = (f"multimodal FMD flow {pm(values(mm['flow'], 'FMD'))} vs regression "
               f"{pm(values(mm['regression'], 'FMD'))}; sample diversity flow {div[0]}, regression {div[1]}, real "
               f"{pm([mm['gt'].get('Div_sample_pose')])} m; control FMD flow "
               f"{pm(values(result['control']['flow'], 'FMD'))} vs regression "
               f"{pm(values(result['control']['regression'], 'FMD'))}; intervals: "
               + "; ".join(f"{k} {ci(v)}" for k, v in parts.items())
               + f"; {seeds} seeds × {protocol.samples} samples, T chosen on selection songs ({chosen(mm['flow'])}); "
               + plateau_ends([r for part in result.values() for h in ("flow", "regression") for r in part[h]],
                              protocol.steps))
    return (f"- **Transflower** (a flow head beats a regression head of the same encoder on FMD and diversity on "
            f"the multimodal set; the gap closes on the homogeneous control): {numbers}: **{word}**{reduced}. "
            f"Rule: {RULE}.")
