"""The claims benchmark's one protocol: data split, features, representation, training to a validation
plateau, generation of several samples per test song, seed frames cut, scoring, and a result cache.

Every family gets the same: ``synthetic-dance`` songs 0-11 for training (3 dances per song by different
dancers, or the homogeneous control), songs 12+ for testing (a split by song), mirroring, the music
features mel + onset (stream ``music``) and librosa-tracker beats (stream ``beat``), the motion
representation root deltas + exponential maps at 20 fps, AdamW with a cosine schedule, and training to
a validation plateau: validation every ``val_every`` steps, stop after ``patience`` checks without a 1 %
improvement, keep the best checkpoint, never past the step budget. The first ``SEED_SECONDS`` of every
dance (generated or real) are cut before scoring: that is where the rest-pose seed sits. With
``Protocol.mocap`` (``claims.py --real-moves``) every dance of every split is chained from the real moves of
one pool of takes (``MOCAP_EXCLUDE`` left out, as the bundled recipes leave them out), the control from one
take (``CONTROL_TAKE``) in one routine, and move validity is not scored (real moves have no move labels).

Choices (the flow's temperature) are made on **selection songs** (``SelectionSet``: songs after the
test songs, never scored for a claim) before the test songs are composed, at the chosen value only
(``choose_then_score``). Differences between arms are judged by percentile-bootstrap intervals over the
training seeds (``bootstrap``, numpy, fixed seed) against a rule written down before the run
(``decide``).

Each finished run writes one JSON file into the cache folder, so a re-run skips it.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FPS = 20.0
SEED_SECONDS = 2.0
TRAIN_SONGS = 12
DANCES = 3
BPM = (80.0, 140.0)
FEATURES = ("features={music: [{plugin: mel}, {plugin: onset}], "
            "beat: [{plugin: beats, tracker: librosa}]}")
METRICS = ["fid-k", "div-k", "fmd", "freezing", "beat-locking", "sample-diversity", "move-validity", "mpd"]
#: real moves (``Protocol.mocap``): the takes the bundled real-moves recipes hold out (transflower-small,
#: dancerevolution-real), left out of every dance here, training and test alike (one pool of takes)
MOCAP_EXCLUDE = ("salsa_6?_09.bvh", "salsa_6?_10.bvh", "modern_05_1?.bvh")
#: the homogeneous control on real moves (one dancer, one style, one routine): one take of the pool, the
#: longest (37 s), walked with one draw for every song and dance (``make_clip``)
CONTROL_TAKE = "salsa_60_01.bvh"


@dataclass
class Protocol:
    """The sizes of one run of the protocol (``quick()`` for the smoke path)."""

    seeds: int = 5
    samples: int = 5
    test_songs: int = 4
    select_songs: int = 2
    train_seconds: float = 24.0
    test_seconds: float = 20.0
    long_seconds: float = 300.0
    long_songs: int = 2
    steps: int = 200
    dr_steps: int = 120
    #: the Transflower experiment's budget: large enough that the plateau rule, not the budget, ends its runs
    #: (at 1000 steps 4 of 20 flow and regression runs were still improving at the end); its own cache folder
    tf_steps: int = 2000
    val_every: int = 25
    patience: int = 3
    batch_size: int = 32
    temperatures: tuple[float, ...] = (0.5, 0.75, 1.0)
    cache: Path = field(default_factory=lambda: Path("runs/claims-cache"))
    #: a folder of motion-capture takes: every dance (training, test, selection, reference) chained from its
    #: real moves (less ``MOCAP_EXCLUDE``) instead of the procedural dancers; None: the procedural dancers
    mocap: Path | None = None

    @classmethod
    def quick(cls, cache: Path) -> Protocol:
        """CI sizes: one seed, two samples, two short test songs, a few steps."""
        return cls(seeds=1, samples=2, test_songs=2, select_songs=1, train_seconds=12.0, test_seconds=8.0,
                   long_seconds=16.0, long_songs=1, steps=6, dr_steps=6, tf_steps=6, val_every=3, patience=1,
                   batch_size=8, temperatures=(0.75, 1.0), cache=cache)

    @classmethod
    def reduced(cls, cache: Path) -> Protocol:
        """A run that fits about ten minutes of one CPU thread for one experiment: 3 seeds, 40 steps, two 8-s
        test songs, one selection song, 3 samples, two temperatures. Its verdicts say they are reduced."""
        return cls(seeds=3, samples=3, test_songs=2, select_songs=1, train_seconds=12.0, test_seconds=8.0,
                   long_seconds=60.0, long_songs=1, steps=40, dr_steps=40, tf_steps=40, val_every=20, patience=2,
                   batch_size=16, temperatures=(0.75, 1.0), cache=cache)

    def dataset(self, homogeneous: bool = False) -> str:
        """The training set override: 12 songs, 3 dances each (all dancers, or the homogeneous control)."""
        moves = ""
        if self.mocap is not None:
            files, exclude = self.takes(homogeneous)
            quoted = lambda names: "[" + ", ".join(f"'{n}'" for n in names) + "]"  # noqa: E731
            moves = (f", mocap: '{self.mocap}', mocap_exclude: {quoted(exclude)}"
                     + (f", mocap_files: {quoted(files)}" if files else ""))
        return (f"data.dataset={{plugin: synthetic-dance, songs: {TRAIN_SONGS}, seconds: {self.train_seconds:g}, "
                f"dances_per_song: {DANCES}, dancers: null, homogeneous: {str(homogeneous).lower()}, "
                f"bpm: [{BPM[0]:g}, {BPM[1]:g}], dance_to_tracker: librosa{moves}}}")

    def takes(self, homogeneous: bool = False) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """Real moves: (file patterns taken, patterns left out) of the takes; all but the held-out ones, the
        control one take."""
        return ((CONTROL_TAKE,) if homogeneous else ()), MOCAP_EXCLUDE

    def graph(self, homogeneous: bool = False):
        """The motion graph of the real-moves takes (the training set's, built once per process), or None."""
        if self.mocap is None:
            return None
        from dance_core.synth import takes_graph

        return takes_graph(str(self.mocap), FPS, *self.takes(homogeneous))

    def metrics(self) -> list[str]:
        """The metrics scored: all of ``METRICS``, less move validity on real moves (no move labels: n/a)."""
        return [m for m in METRICS if self.mocap is None or m != "move-validity"]

    def common(self, homogeneous: bool = False) -> list[str]:
        """Overrides every family gets."""
        return [
            FEATURES,
            "motion={plugin: rotations, rotation: expmap, root: deltas}",
            self.dataset(homogeneous),
            "fps=20",
            "data.mirror=true",
            "data.val_fraction=0.15",
            "training.optimizer.lr=1.0e-3",
            "training.optimizer.weight_decay=0.0",
            "training.lr_schedule={plugin: cosine, warmup: 30}",
            "training.grad_clip=1.0",
            "training.threads=1",
            "training.val_batches=4",
            f"training.batch_size={self.batch_size}",
            f"training.steps={self.steps}",
            f"training.val_every={self.steps}",
            f"training.checkpoint_every={self.steps}",
            "compose.seed_motion=rest",
            "compose.threads=1",
        ]


# ---------------------------------------------------------------- data


def source(index: int, seconds: float, homogeneous: bool = False, graph=None):
    """Clip ``index`` (song ``index // 3``, dance ``index % 3``) of the protocol's generator (real moves from
    ``graph``: ``Protocol.graph``)."""
    from dance_core.synth import make_clip

    return make_clip(index, seed=0, seconds=seconds, bpm=BPM, rate=22050, fps=FPS, dances_per_song=DANCES,
                     tracker="librosa", dancers=None, homogeneous=homogeneous, graph=graph)


def joint_clip(src, name: str | None = None, cut: float = SEED_SECONDS):
    """A source's dance as a ``JointClip`` with its beats, the first ``cut`` seconds removed."""
    from dance_core import JointClip

    motion = src.motion.skeleton_motion
    return trimmed(JointClip(name or src.name, motion.positions(), motion.fps, list(motion.skeleton.names),
                             np.asarray(src.meta["beats"])), cut)


def trimmed(clip, cut: float = SEED_SECONDS):
    """The clip without its first ``cut`` seconds (beats shifted with it)."""
    from dataclasses import replace

    n = int(round(cut * clip.fps))
    beats = None if clip.music_beats is None else np.asarray(clip.music_beats) - cut
    kept = None if beats is None else beats[beats >= 0]
    return replace(clip, positions=np.asarray(clip.positions)[n:], music_beats=kept)


class TestSet:
    """Test songs (WAV files written once into the cache) with their real dances and beats."""

    def __init__(self, protocol: Protocol, seconds: float, songs: int, homogeneous: bool = False, tag: str = "test",
                 dances: int = DANCES, first_song: int = TRAIN_SONGS):
        from dance_core.synth import write_clip

        self.seconds, self.homogeneous = seconds, homogeneous
        first = first_song * DANCES
        self.sources = [source(first + s * DANCES + d, seconds, homogeneous, protocol.graph(homogeneous))
                        for s in range(songs) for d in range(dances)]
        distinct_songs(self.sources[::dances])
        folder = protocol.cache / "songs" / f"{tag}-{'homo' if homogeneous else 'multi'}-{seconds:g}s"
        self.songs, self.beats = [], {}
        for src in self.sources[::dances]:
            song = folder / f"{src.name.rsplit('-', 1)[0]}.wav"
            if not song.exists():
                written = write_clip(folder, src)
                song = next(p for p in written if p.suffix == ".wav")
                song = song.rename(folder / f"{src.name.rsplit('-', 1)[0]}.wav")
            self.songs.append(song)
            self.beats[song.stem] = np.asarray(src.meta["beats"])
        self.real = [joint_clip(s) for s in self.sources]


def selection_set(protocol: Protocol, test: TestSet) -> TestSet:
    """The selection songs: ``select_songs`` songs after the test songs (never a test or training song), with
    their real dances; where temperatures (and any other choice) are chosen."""
    select = TestSet(protocol, test.seconds, protocol.select_songs, test.homogeneous, tag="select",
                     first_song=TRAIN_SONGS + protocol.test_songs)
    shared = {p.stem for p in select.songs} & {p.stem for p in test.songs}
    if shared:
        raise ValueError(f"claims: selection songs {sorted(shared)} are test songs")
    return select


def distinct_songs(sources) -> None:
    """Refuse a test set that lists one song twice (its dances would count twice)."""
    names = [src.name.rsplit("-", 1)[0] for src in sources]
    if len(set(names)) != len(names):
        raise ValueError(f"claims: the test songs {names} repeat a song; each must be a different song")


def reference_clips(protocol: Protocol, homogeneous: bool = False):
    """The real dances of the training songs, seed span cut (the reference set of FID/FMD/MPD)."""
    graph = protocol.graph(homogeneous)
    return [joint_clip(source(i, protocol.train_seconds, homogeneous, graph)) for i in range(TRAIN_SONGS * DANCES)]


# ---------------------------------------------------------------- training


class _MemoData:
    """Data prepared once for every run of the process with the same dataset, motion and features."""

    def __init__(self):
        self.on, self.prepared = False, {}

    def install(self):
        """Share prepared data between the runs of this process from now on."""
        self.on = True

    def data(self, recipe):
        """The recipe's prepared data (``dance_core.api.prepare_data``), shared; None when not installed."""
        if not self.on:
            return None
        from dance_core.api import prepare_data

        key = json.dumps([recipe.data.dataset.model_dump(mode="json"), recipe.data.mirror, recipe.fps,
                          recipe.motion.model_dump(mode="json") if recipe.motion else None,
                          {k: [s.model_dump(mode="json") for s in v] for k, v in recipe.features.items()}],
                         sort_keys=True)
        if key not in self.prepared:
            self.prepared[key] = prepare_data(recipe)
        return self.prepared[key]


MEMO = _MemoData()


def trainer_class():
    """``Trainer`` with a fixed validation context (every schedule at ``val_values``: a curriculum head is
    validated teacher-forced, so its validation loss compares across steps) and a settable epoch length."""
    from dance_core.api import Trainer

    class PlateauTrainer(Trainer):
        val_values: dict = {}

        def validate(self, step, stage):
            saved = self.schedules
            self.schedules = {n: (lambda s, e, t, v=v: v) for n, v in self.val_values.items()} or saved
            try:
                return super().validate(step, stage)
            finally:
                self.schedules = saved

    return PlateauTrainer


def plateau_ends(runs, budget: int) -> str:
    """How many of the runs the plateau rule ended before the step ``budget`` (the rest ran into it)."""
    runs = [r for r in runs if r]
    ended = sum(1 for r in runs if r.get("stopped", budget) < budget)
    return f"{ended} of {len(runs)} runs ended by the plateau rule within the {budget}-step budget"


def train_to_plateau(recipe, out: Path, protocol: Protocol, epoch_steps: int | None = None,
                     val_values: dict | None = None) -> dict:
    """Train in chunks of ``val_every`` steps, keep the best validation checkpoint, stop on a plateau.

    Returns ``{"checkpoint", "best_step", "stopped", "val", "train_s"}``."""
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    t0 = time.perf_counter()
    trainer = trainer_class()(recipe, out, quiet=True, data=MEMO.data(recipe))
    trainer.val_values = dict(val_values or {})
    if epoch_steps:
        trainer.steps_per_epoch = epoch_steps
    best, best_step, waited, history, stopped = float("inf"), 0, 0, [], protocol.steps
    best_path = out / "best.safetensors"
    for k in range(protocol.val_every, protocol.steps + protocol.val_every, protocol.val_every):
        k = min(k, protocol.steps)
        result = trainer.run(resume=k > protocol.val_every, stop_at=k)
        val = float(result.val_loss)
        history.append([k, val])
        if val < best - 0.01 * abs(best) or not np.isfinite(best):
            best, best_step, waited = val, k, 0
            shutil.copyfile(result.checkpoint, best_path)
        else:
            waited += 1
        stopped = k
        if waited >= protocol.patience or k >= protocol.steps:
            break
    return {"checkpoint": str(best_path), "best_step": best_step, "stopped": stopped, "val": history,
            "train_s": time.perf_counter() - t0}


# ---------------------------------------------------------------- generation and scoring


def generate(recipe, checkpoint: str, songs: list[Path], beats: dict, samples: int, temperature: float = 1.0,
             seconds: float | None = None, resample_to: float | None = FPS):
    """``samples`` dances per song (``SONG-k``), as ``JointClip``s at ``resample_to`` fps with the songs'
    beats, seed span cut; and the frames generated per second."""
    from dance_core import JointClip
    from dance_core.api import Composer

    recipe = recipe.model_copy(update={"compose": recipe.compose.model_copy(
        update={"samples": samples, "temperature": temperature, "threads": 1})})
    composer = Composer(recipe, checkpoint, device="cpu")
    seed = composer.seed("rest")
    clips, frames, t0 = [], 0, time.perf_counter()
    for path in songs:
        song = song_inputs(path, composer)
        motion = composer.generate(song, seed)
        frames += motion.shape[0] * song.n_frames
        for k, data in enumerate(composer.dances(song, motion, ground=True)):
            sm = data.skeleton_motion
            if resample_to and abs(sm.fps - resample_to) > 1e-6:
                sm = sm.resample(resample_to)
            clip = JointClip(f"{path.stem}-{k}", sm.positions(), sm.fps, list(sm.skeleton.names), beats[path.stem])
            clips.append(trimmed(clip))
    return clips, frames / max(time.perf_counter() - t0, 1e-9)


_RAW: dict = {}


def song_inputs(path: Path, composer):
    """``Composer.song`` with the raw features kept for the process (every model composes the same
    songs with the same features; only the standardization differs)."""
    from dance_core import load_audio
    from dance_core.api import Song

    stack, ckpt = composer.stack, composer.checkpoint
    key = (str(path), json.dumps(stack.signature, sort_keys=True, default=str), stack.fps)
    if key not in _RAW:
        audio = load_audio(str(path), composer.registry)
        _RAW[key] = stack.extract(audio.n_frames(stack.fps), audio, ())
    raw = _RAW[key]
    streams = {name: ckpt.stats.streams[name].apply(values) for name, values in raw.items()}
    return Song(Path(path).stem, streams, len(next(iter(raw.values()))), str(path), ())


def score(generated, reference, metrics=METRICS) -> dict:
    """The metrics' values as a flat dict of floats (skipped metrics absent)."""
    from dance_core.api import EvaluateOptions, evaluate

    report = evaluate(generated, reference, EvaluateOptions(metrics=metrics))
    return {k: float(v) for k, v in report.values().items() if v is not None}


# ---------------------------------------------------------------- cache and summaries


#: set by ``claims.py --cached-only``: report what the cache holds, run nothing new
CACHED_ONLY = False


def cached(protocol: Protocol, key: str, fn) -> dict | None:
    """``fn()``'s JSON result, from ``cache/results/key.json`` when a previous run finished it (None when
    it did not and ``CACHED_ONLY`` is set, or while another live process runs it: several processes share
    one cache, each running what no other has claimed; ``--cached-only`` then reports them together)."""
    from dance_core import write_text

    path = protocol.cache / "results" / f"{key}.json"
    if path.exists():
        return json.loads(path.read_text())
    if CACHED_ONLY or not claim(path.with_suffix(".running")):
        return None
    try:
        result = fn()
        write_text(path, json.dumps(result, indent=1, default=float))
    finally:
        path.with_suffix(".running").unlink(missing_ok=True)
    return result


def claim(marker: Path) -> bool:
    """Claim a run for this process by creating ``marker`` (holding its PID); False when a live process
    holds it. A marker left by a process that has ended is taken over."""
    from dance_core import pid_alive

    marker.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(2):
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            try:
                holder, age = int(marker.read_text() or 0), time.time() - marker.stat().st_mtime
            except (OSError, ValueError):
                holder, age = 0, 0.0
            if holder != os.getpid() and (pid_alive(holder) if holder else age < 10.0):  # empty: being written
                return False
            marker.unlink(missing_ok=True)
            continue
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        return True
    return False


def spread(values) -> tuple[float | None, float | None]:
    """Mean and standard deviation (over seeds) of the values that are not None."""
    v = [float(x) for x in values if x is not None and np.isfinite(x)]
    if not v:
        return None, None
    return float(np.mean(v)), float(np.std(v))


def pm(values, digits: int = 3) -> str:
    """``mean ± sd`` for a table cell (``n/a`` when nothing was measured)."""
    m, s = spread(values)
    if m is None:
        return "n/a"
    return f"{m:.{digits}g} ± {s:.1g}" if len(values) > 1 else f"{m:.{digits}g}"


# ---------------------------------------------------------------- choices and statistics


def choose_then_score(temperatures, on_selection, on_test, key: str = "FMD") -> dict:
    """Choose the temperature with the lowest ``key`` on the selection songs, then score the test songs at
    that one temperature only: ``{"selection": {T: metrics}, "chosen": T, "temperatures": {T: metrics}}``.
    ``on_selection(t)`` composes and scores the selection songs, ``on_test(t)`` the test songs; the test
    songs are never composed at a temperature that was not chosen, so no choice can see them."""
    temperatures = list(temperatures)
    picked = {f"{t:g}": on_selection(t) for t in temperatures} if len(temperatures) > 1 else {}
    chosen = min(temperatures, key=lambda t: picked[f"{t:g}"].get(key, float("inf"))) if picked else temperatures[0]
    return {"selection": picked, "chosen": chosen, "temperatures": {f"{chosen:g}": on_test(chosen)}}


def scored(run: dict) -> dict:
    """A run's test-song metrics at the temperature it chose (1 for runs without a choice)."""
    return run["temperatures"].get(f"{run.get('chosen', 1.0):g}", {})


#: percentile-bootstrap draws and interval
DRAWS, LEVEL, STATS_SEED = 4000, 0.95, 0


def bootstrap(statistic, *arms, draws: int = DRAWS, level: float = LEVEL, seed: int = STATS_SEED):
    """``statistic(*means)`` over the arms' means, and its percentile-bootstrap interval: every draw
    resamples each arm (its seeds' values) with replacement, independently. ``(estimate, low, high)``;
    ``(None, None, None)`` when an arm has no finite value."""
    arms = [np.asarray([float(x) for x in a if x is not None and np.isfinite(x)]) for a in arms]
    if any(len(a) == 0 for a in arms):
        return None, None, None
    rng = np.random.default_rng(seed)
    means = [a[rng.integers(0, len(a), (draws, len(a)))].mean(axis=1) for a in arms]
    values = np.asarray(statistic(*means), dtype=float)
    tail = 100 * (1 - level) / 2
    estimate = float(statistic(*[np.array([a.mean()]) for a in arms])[0])
    return estimate, float(np.percentile(values, tail)), float(np.percentile(values, 100 - tail))


def difference(a, b, **kw):
    """``mean(a) - mean(b)`` with its bootstrap interval (independent arms: different training runs)."""
    return bootstrap(lambda x, y: x - y, a, b, **kw)


def decide(interval) -> str:
    """``above`` when the whole interval is above 0, ``below`` when wholly below, else ``straddles`` (and
    ``n/a`` for no interval): the one reading every verdict rule uses."""
    _, low, high = interval
    if low is None:
        return "n/a"
    return "above" if low > 0 else "below" if high < 0 else "straddles"


def ci(interval, digits: int = 3) -> str:
    """``estimate [low, high]`` for a verdict line."""
    est, low, high = interval
    return "n/a" if est is None else f"{est:+.{digits}g} [{low:+.{digits}g}, {high:+.{digits}g}]"
