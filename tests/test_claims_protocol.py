"""The claims benchmark's protocol (benchmarks/claims_protocol.py, claims_curriculum.py): training stops on
a validation plateau and keeps the best checkpoint, results are cached and skipped on a re-run, the seed
span is cut before scoring, and the curriculum rates make q grow to its target over the run."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from dance_core.protocols import JointClip
from dance_core.recipe import load_recipe

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture
def claims(monkeypatch):
    """The benchmark modules, importable from benchmarks/."""
    monkeypatch.syspath_prepend(str(BENCH))
    import claims_curriculum
    import claims_protocol

    yield claims_protocol, claims_curriculum
    for name in ("claims_protocol", "claims_curriculum", "claims_runs", "readme_section"):
        sys.modules.pop(name, None)


TINY = ["data.dataset.songs=4", "data.dataset.seconds=6", "training.batch_size=16", "training.log_every=5"]


def test_training_stops_on_a_plateau_and_keeps_the_best_checkpoint(claims, tmp_path):
    protocol_mod, _ = claims
    protocol = protocol_mod.Protocol(steps=60, val_every=5, patience=2, cache=tmp_path)
    still = load_recipe("core-synthetic", [*TINY, "training.steps=60", "training.optimizer.lr=1e-12"])
    run = protocol_mod.train_to_plateau(still, tmp_path / "still", protocol)
    # nothing learns at lr 1e-12: the first check is the best, two more without improvement stop it
    assert run["best_step"] == 5 and run["stopped"] == 15 and len(run["val"]) == 3
    learning = load_recipe("core-synthetic", [*TINY, "training.steps=60"])
    run = protocol_mod.train_to_plateau(learning, tmp_path / "learns", protocol)
    vals = dict((int(k), v) for k, v in run["val"])
    best = run["best_step"]
    assert vals[best] <= min(vals.values()) * 1.0101  # the best check, within the 1 % tolerance
    assert run["stopped"] == min(best + 2 * 5, 60)  # two checks without a 1 % improvement, or the budget
    assert all(vals[k] > vals[best] * 0.99 for k in vals if k > best)
    assert Path(run["checkpoint"]).name == "best.safetensors" and Path(run["checkpoint"]).exists()


def test_results_are_cached_and_a_cached_only_report_runs_nothing(claims, tmp_path):
    protocol_mod, _ = claims
    protocol = protocol_mod.Protocol(cache=tmp_path)
    calls = []
    first = protocol_mod.cached(protocol, "run-a", lambda: calls.append(1) or {"FMD": 0.5})
    again = protocol_mod.cached(protocol, "run-a", lambda: calls.append(1) or {"FMD": 9.0})
    assert first == again == {"FMD": 0.5} and len(calls) == 1
    protocol_mod.CACHED_ONLY = True
    try:
        assert protocol_mod.cached(protocol, "run-b", lambda: calls.append(1) or {}) is None and len(calls) == 1
    finally:
        protocol_mod.CACHED_ONLY = False
    assert protocol_mod.pm([1.0, 3.0]) == "2 ± 1" and protocol_mod.pm([None]) == "n/a"


def test_a_run_another_live_process_claimed_is_left_to_it_and_a_dead_ones_claim_is_taken_over(claims, tmp_path):
    import subprocess
    import sys

    protocol_mod, _ = claims
    protocol = protocol_mod.Protocol(cache=tmp_path)
    marker = tmp_path / "results" / "run-c.running"
    marker.parent.mkdir(parents=True)
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        marker.write_text(str(other.pid))
        calls = []
        assert protocol_mod.cached(protocol, "run-c", lambda: calls.append(1) or {"FMD": 1.0}) is None
        assert calls == [] and marker.exists()  # left to the live process
    finally:
        other.kill()
        other.wait()
    # the holder has ended: its claim is taken over, the run made, the marker removed
    assert protocol_mod.cached(protocol, "run-c", lambda: {"FMD": 2.0}) == {"FMD": 2.0}
    assert not marker.exists() and (tmp_path / "results" / "run-c.json").exists()
    # a run that fails leaves no claim behind
    with pytest.raises(RuntimeError):
        protocol_mod.cached(protocol, "run-d", lambda: (_ for _ in ()).throw(RuntimeError("boom")))
    assert not (tmp_path / "results" / "run-d.running").exists()


def test_the_seed_span_is_cut_and_the_beats_move_with_it(claims):
    protocol_mod, _ = claims
    positions = np.arange(100 * 2 * 3, dtype=float).reshape(100, 2, 3)
    clip = JointClip("song-0", positions, 20.0, ["a", "b"], np.array([0.5, 1.5, 2.5, 4.0]))
    cut = protocol_mod.trimmed(clip, 2.0)
    assert len(cut.positions) == 60 and np.array_equal(cut.positions[0], positions[40])
    assert np.allclose(cut.music_beats, [0.5, 2.0])


def test_every_curriculum_reaches_its_q_in_the_last_epoch_and_starts_lower(claims):
    from dance_core.registry import get_registry

    _, curriculum = claims
    registry = get_registry()
    finals = {}
    for label, override in curriculum.schedules():
        spec = load_recipe("dancerevolution-small", [override]).training.schedules["auto_condition"]
        fn = registry.create("schedule", spec.plugin, spec.options())
        first, last = fn(0, 0, 100), fn(99, curriculum.EPOCHS - 1, 100)
        finals[label] = last
        if label not in ("teacher forcing", "const (q=10)"):
            assert first < 10 <= last
    assert finals["teacher forcing"] == 0 and finals["const (q=10)"] == 10
    assert finals["linear"] == finals["quadratic"] == curriculum.Q_END
    assert curriculum.Q_END - 2 <= finals["exponential"] <= curriculum.Q_END


def test_verdict_line_is_read_from_its_source_not_from_the_claims_quote(claims, tmp_path):
    from readme_section import verdict_line

    readme = tmp_path / "README.md"
    readme.write_text("<!-- claims:start -->\n- **TM2D** (text) old verdict\n  old continuation\n"
                      "<!-- claims:end -->\n\n"
                      "text\n\n- **TM2D** (text) new verdict\n  new continuation\nafter\n", encoding="utf-8")
    assert verdict_line("- **TM2D** (text", readme) == "- **TM2D** (text) new verdict\n  new continuation"
    assert verdict_line("- **Other**", readme) is None


def test_the_long_test_songs_are_different_songs(claims, tmp_path):
    from dataclasses import replace

    protocol_mod, curriculum = claims
    protocol = replace(protocol_mod.Protocol(cache=tmp_path), long_seconds=6.0, long_songs=2)
    test = curriculum.long_songs(protocol)
    assert [s.name for s in test.sources] == ["synth-0012-0", "synth-0013-0"]
    assert [p.stem for p in test.songs] == ["synth-0012", "synth-0013"] == sorted(test.beats)
    first, second = (p.read_bytes() for p in test.songs)
    assert first != second  # two WAVs, not one listed twice
    assert not np.array_equal(test.real[0].positions, test.real[1].positions)
    with pytest.raises(ValueError, match="repeat a song"):
        protocol_mod.distinct_songs([test.sources[0], test.sources[0]])


def test_the_temperature_is_chosen_on_selection_songs_and_the_test_songs_see_one(claims, tmp_path):
    protocol_mod, _ = claims
    calls = []
    select_fmd = {0.5: 2.0, 0.75: 1.0, 1.0: 3.0}
    test_fmd = {0.5: 0.1, 0.75: 5.0, 1.0: 0.2}  # the test songs would prefer 0.5: they are never asked
    out = protocol_mod.choose_then_score(
        (0.5, 0.75, 1.0), lambda t: calls.append(("select", t)) or {"FMD": select_fmd[t]},
        lambda t: calls.append(("test", t)) or {"FMD": test_fmd[t]})
    assert out["chosen"] == 0.75 and out["temperatures"] == {"0.75": {"FMD": 5.0}}
    assert [c for c in calls if c[0] == "test"] == [("test", 0.75)] and calls[-1] == ("test", 0.75)
    assert protocol_mod.scored(out) == {"FMD": 5.0}
    assert protocol_mod.scored({"temperatures": {"1": {"a": 1}}}) == {"a": 1}
    single = protocol_mod.choose_then_score((1.0,), lambda t: calls.append("never"), lambda t: {"FMD": 1.0})
    assert single["chosen"] == 1.0 and "never" not in calls
    from claims_runs import run_family

    with pytest.raises(ValueError, match="selection songs"):
        run_family(protocol_mod.Protocol(cache=tmp_path), "k", "transflower-small", [], 0, None, [], (0.5, 1.0))


def test_selection_songs_follow_the_test_songs(claims, tmp_path):
    from dataclasses import replace

    protocol_mod, _ = claims
    protocol = replace(protocol_mod.Protocol(cache=tmp_path), test_songs=2, select_songs=1)
    test = protocol_mod.TestSet(protocol, 6.0, protocol.test_songs, dances=1)
    select = protocol_mod.selection_set(protocol, test)
    assert [p.stem for p in test.songs] == ["synth-0012", "synth-0013"]
    assert [p.stem for p in select.songs] == ["synth-0014"] and len(select.real) == 3


def test_bootstrap_intervals_are_seeded_and_cover_the_difference(claims):
    protocol_mod, _ = claims
    a, b = [3.0, 3.2, 2.9, 3.1, 3.0], [1.0, 1.1, 0.9, 1.2, 1.0]
    est, low, high = protocol_mod.difference(a, b)
    assert est == pytest.approx(np.mean(a) - np.mean(b)) and low < est < high
    assert low > 1.8 and high < 2.3 and protocol_mod.decide((est, low, high)) == "above"
    assert protocol_mod.difference(a, b) == (est, low, high)  # the same draws every time
    assert protocol_mod.decide(protocol_mod.difference(b, a)) == "below"
    overlap = protocol_mod.difference([1.0, 2.0, 3.0], [1.5, 2.5, 2.0])
    assert protocol_mod.decide(overlap) == "straddles"
    assert protocol_mod.difference([None], [1.0]) == (None, None, None)
    assert protocol_mod.decide((None, None, None)) == "n/a"
    assert protocol_mod.ci((0.5, 0.25, 0.75)) == "+0.5 [+0.25, +0.75]"


def run(fmd, div, chosen=0.75):
    t = f"{chosen:g}"
    return {"chosen": chosen, "temperatures": {t: {"FMD": fmd, "Div_sample_pose": div}}}


def test_transflower_rule_judges_diversity_against_the_real_dances(claims, monkeypatch):
    protocol_mod, _ = claims
    import claims_transflower as tf

    def result(flow_div, control_regression=1.7):
        jitter = [0.0, 0.02, -0.02, 0.01, -0.01]
        return {
            "multimodal": {"gt": {"Div_sample_pose": 0.25},
                           "flow": [run(1.5 + j, flow_div + j) for j in jitter],
                           "regression": [run(3.2 + j, 0.0, 1.0) for j in jitter]},
            "control": {"gt": {}, "flow": [run(1.6 + j, 0.3) for j in jitter],
                        "regression": [run(control_regression + j, 0.0, 1.0) for j in jitter]}}

    protocol = protocol_mod.Protocol()
    assert "**holds**" in tf.verdict(result(0.30), protocol)
    # ten times the real dances' diversity is farther from them than the regression head's zero
    line = tf.verdict(result(2.5), protocol)
    assert "does not hold (diversity nearer the real dances' goes the other way)" in line and "Rule:" in line
    # the gap widens on the control
    assert "gap closes on the control goes the other way" in tf.verdict(result(0.3, 5.0), protocol)


def test_curriculum_rule_on_bootstrap_intervals(claims):
    protocol_mod, curriculum = claims

    def runs(pff, fid):
        return [{"minutes": [{"PFF_rel": pff + j, "FID_k": fid + j}, {"PFF_rel": pff + j, "FID_k": fid + 5 + j}]}
                for j in (0.0, 0.1, -0.1, 0.2, -0.2)]

    protocol = protocol_mod.Protocol()
    labels = [label for label, _ in curriculum.schedules()]
    better = {label: runs(10.0, 100.0) if label == "teacher forcing" else runs(1.0, 50.0) for label in labels}
    line = curriculum.verdict(better, protocol)
    assert "**holds**" in line and "linear: PFF_rel gain +9 [" in line and "Rule:" in line
    worse = {label: runs(1.0, 50.0) if label == "teacher forcing" else runs(10.0, 100.0) for label in labels}
    assert "**does not hold**" in curriculum.verdict(worse, protocol)
    still = {label: runs(0.0, 50.0 if label == "teacher forcing" else 40.0) for label in labels}
    for r in still.values():
        for x in r:
            for m in x["minutes"]:
                m["PFF_rel"] = 0.0
    assert "inconclusive (no model froze" in curriculum.verdict(still, protocol)


def test_verdicts_say_how_many_runs_the_plateau_rule_ended(claims):
    protocol_mod, curriculum = claims
    runs = [{"stopped": 950}, {"stopped": 1000}, {"stopped": 425}, None]
    assert protocol_mod.plateau_ends(runs, 1000) == "2 of 3 runs ended by the plateau rule within the 1000-step budget"
    protocol = protocol_mod.Protocol()
    assert protocol.tf_steps > protocol.steps  # the Transflower experiment trains to its plateau, not 200 steps
    labels = [label for label, _ in curriculum.schedules()]
    capped = {label: [{"stopped": protocol.dr_steps, "minutes": [{"PFF_rel": 0.0, "FID_k": 50.0 + j}]}
                      for j in range(5)] for label in labels}
    assert f"0 of {5 * len(labels)} runs ended by the plateau rule" in curriculum.verdict(capped, protocol)


MOCAP = Path(__file__).resolve().parents[1] / ".." / "shared" / "mocap" / "cmu-dance"
needs_mocap = pytest.mark.skipif(not MOCAP.is_dir(), reason="../shared/mocap not available")


def test_without_real_moves_the_protocol_is_the_procedural_one(claims):
    protocol_mod, _ = claims
    protocol = protocol_mod.Protocol()
    assert protocol.dataset() == ("data.dataset={plugin: synthetic-dance, songs: 12, seconds: 24, dances_per_song: 3, "
                                  "dancers: null, homogeneous: false, bpm: [80, 140], dance_to_tracker: librosa}")
    assert protocol.graph() is None and protocol.metrics() == protocol_mod.METRICS
    assert "move-validity" in protocol.metrics()


@needs_mocap
def test_real_moves_train_and_test_on_one_pool_of_takes(claims):
    from fnmatch import fnmatch

    from dance_core.contexts import DatasetContext
    from dance_core.registry import get_registry

    protocol_mod, _ = claims
    protocol = protocol_mod.Protocol(train_seconds=6.0, mocap=MOCAP.resolve())
    assert "move-validity" not in protocol.metrics()  # no move labels on real moves: the column is n/a
    names = protocol.graph().names
    held_out = [n for n in names if any(fnmatch(f"{n}.bvh", p) for p in protocol_mod.MOCAP_EXCLUDE)]
    assert len(names) == 22 and not held_out and "modern_05_09" in names and "salsa_61_07" in names
    assert protocol.graph(homogeneous=True).names == ["salsa_60_01"]
    for homogeneous in (False, True):  # the training set's dances are the protocol's own (source)
        recipe = load_recipe("transflower-small", protocol.common(homogeneous))
        spec = recipe.data.dataset
        data = get_registry().create("dataset", spec.plugin, spec.options(),
                                     DatasetContext(fps=recipe.fps, seed=recipe.seed, root=recipe.folder))
        clip = data.clip(4)
        ours = protocol_mod.source(4, 6.0, homogeneous, protocol.graph(homogeneous))
        assert clip.meta["dancer"] == ours.meta["dancer"] == "real moves"
        np.testing.assert_array_equal(clip.motion.skeleton_motion.positions(), ours.motion.skeleton_motion.positions())
    # the control: one take, one routine, so a song's dances are the same; the multimodal set's differ
    control = [protocol_mod.source(i, 6.0, True, protocol.graph(True)).motion.skeleton_motion for i in (3, 4)]
    np.testing.assert_array_equal(control[0].positions(), control[1].positions())
    multi = [protocol_mod.source(i, 6.0, False, protocol.graph()).motion.skeleton_motion for i in (3, 4)]
    assert np.abs(multi[0].positions() - multi[1].positions()).max() > 0.05


def test_real_moves_without_the_takes_is_one_clear_error(tmp_path):
    import os
    import subprocess

    missing = tmp_path / "no-takes"
    done = subprocess.run([sys.executable, str(BENCH / "claims.py"), "--quick", "--real-moves", str(missing),
                           "--cache", str(tmp_path / "cache")], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert done.returncode == 2 and f"--real-moves: no folder of takes at {missing}" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "cache").exists()
