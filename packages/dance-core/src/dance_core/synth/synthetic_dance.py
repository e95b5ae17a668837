"""The ``synthetic-dance`` dataset and the files ``dance synth`` writes: songs with a beat-locked dancer
(on ``dance24``), procedural or chained from real moves (``mocap``).

Deterministic from the seed: song ``i`` draws its music from ``(seed, i)``, the order of its dancers
from ``(seed, i, 2)`` and dance ``k`` of it its moves and style from ``(seed, i, 1, k)``, so the same
music comes with several dances, by different dancers when ``dancers`` names several
(:data:`~dance_core.synth.dancer.DANCERS`; the default, the classic dancer alone, gives the dances
of before the profiles existed, bit for bit). ``homogeneous`` is the control set: one dancer, one style,
one fixed routine. ``dance synth --music`` choreographs the classic dancer to real songs instead
(:mod:`dance_core.synth.choreograph`).
"""

from __future__ import annotations

import zlib
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from dance_core.data.sources import ClipSource
from dance_core.media import Audio
from dance_core.protocols import MotionData
from dance_core.synth.beat_grid import BeatGrid
from dance_core.synth.dancer import CLASSIC, dancer_names, perform_dance
from dance_core.synth.motion_graph import MotionGraph, real_dance
from dance_core.synth.music import synthesize

#: the ``dancer`` of dances chained from real moves
REAL = "real moves"

#: what ``write_clip`` writes beside each clip's song, in order
CLIP_SUFFIXES = (".bvh", ".beats", ".texts", ".sections")


def make_clip(index: int, *, seed: int, seconds: float, bpm: tuple[float, float], rate: int, fps: float,
              dances_per_song: int = 1, tracker: str | None = None, dancers: list[str] | None = (CLASSIC,),
              homogeneous: bool = False, graph: MotionGraph | None = None) -> ClipSource:
    """Clip ``index``: song ``index // dances_per_song`` with dance ``index % dances_per_song``.

    The dancer follows the song's true beats, or with ``tracker`` the beats that tracker hears (what a
    model reading that tracker's beat features will hear in real songs: the same tempo octave). Dance
    ``k`` of a song is danced by ``dancers`` (names of :data:`~dance_core.synth.dancer.DANCERS`,
    ``None``: all) in an order drawn per song, so the dances of one song have different dancers as far as
    there are dancers; ``homogeneous``: every dance by the first dancer in its one style and fixed
    routine (the control set: dances of one song are then the same). With a ``graph`` the dance is
    chained from its real moves instead (:mod:`dance_core.synth.motion_graph`; no move labels); with
    ``homogeneous`` too, every dance walks the graph with one draw of its own (the same for every song and
    dance: one routine), so the dances of one song are the same (give it one take for one dancer).
    """
    song_i, dance_i = divmod(index, dances_per_song)
    names = dancer_names(None if dancers is None else list(dancers))
    if homogeneous:
        dancer = names[0]
    else:
        order = np.random.default_rng([seed, song_i, 2]).permutation(len(names)) if len(names) > 1 else [0]
        dancer = names[order[dance_i % len(names)]]
    music_rng = np.random.default_rng([seed, song_i, 0])
    song = synthesize(seconds, float(music_rng.uniform(*bpm)), rate, music_rng)
    audio = Audio(song.audio, rate)
    if tracker is None:
        grid = BeatGrid(song.beats, song.beats_per_bar, 0)
    else:
        from dance_core.registry import get_registry
        from dance_core.synth.choreograph import track_grid

        grid = track_grid(audio, get_registry(), tracker)
    bar_beats = grid.beats_per_bar
    bar_of = lambda t: int(round(float(grid.beat_at(t)) / bar_beats))  # noqa: E731
    sections = [(name, bar_of(a), bar_of(b)) for name, a, b in song.sections]
    sections = [(n, max(a, 0), b) for n, a, b in sections if b > max(a, 0)] or [("verse", 0, grid.bars(seconds))]
    dance_rng = np.random.default_rng([seed, song_i, 1, dance_i])
    if graph is not None and homogeneous:  # one routine: the walk's draws depend on neither song nor dance
        dance_rng = np.random.default_rng([seed, 1])
    if graph is not None:
        dancer, texts = REAL, ()
        motion = real_dance(graph, grid.times, seconds, fps, dance_rng, grid.downbeats(),
                            section_times(grid, sections))
    else:
        motion, texts = perform_dance(dancer, grid, sections, seconds, fps, dance_rng, homogeneous)
    name = f"synth-{song_i:04d}" + (f"-{dance_i}" if dances_per_song > 1 else "")
    meta = {**_grid_meta(grid, song.sections, song.style), "dancer": dancer}
    return ClipSource(name, _motion_data(motion, meta), audio, texts=texts, meta=meta)


def _grid_meta(grid: BeatGrid, sections: list, style: str) -> dict:
    """What ``write_clip`` writes beside a dance: tempo, beats, meter, sections and style."""
    return {"bpm": grid.bpm, "beats": grid.times.tolist(), "downbeats": grid.downbeats().tolist(),
            "beats_per_bar": grid.beats_per_bar, "first_downbeat": grid.first_downbeat, "sections": sections,
            "style": style}


def _motion_data(motion, meta: dict) -> MotionData:
    """Joint positions of a skeletal motion, with the motion itself attached."""
    positions = motion.positions().reshape(motion.n_frames, -1).astype(np.float32)
    channels = [f"{j}.{a}" for j in motion.skeleton.names for a in "xyz"]
    return MotionData(positions, motion.fps, channels, meta, motion)


def section_times(grid: BeatGrid, sections: list) -> np.ndarray:
    """Start times (s) of sections given as ``(name, first bar, end bar)``."""
    downbeats = grid.downbeats()
    return np.asarray([downbeats[a] for _, a, _ in sections if 0 <= a < len(downbeats)], np.float64)


def music_clips(path: str, registry, *, dances: int, seed: int, fps: float, tracker: str,
                graph: MotionGraph | None = None) -> list[ClipSource]:
    """``dances`` dances of the synthetic dancer (or, with a ``graph``, of real moves) to one real song
    (beats from the registered tracker)."""
    from dance_core.data.features import load_audio
    from dance_core.synth.choreograph import choreograph, track_grid

    audio = load_audio(path, registry)
    grid = track_grid(audio, registry, tracker)
    out = []
    song_key = zlib.crc32(Path(path).name.encode())  # another song, other dances, whatever the order
    for k in range(dances):
        rng = np.random.default_rng([seed, song_key, k])
        motion, texts, sections = choreograph(audio, grid, fps, rng)
        if graph is not None:  # the same song structure, danced with real moves
            texts = ()
            motion = real_dance(graph, grid.times, audio.duration, fps, np.random.default_rng([seed, song_key, k, 1]),
                                grid.downbeats(), np.asarray([a for _, a, _ in sections], np.float64))
        meta = _grid_meta(grid, sections, f"tracked ({tracker})")
        name = Path(path).stem + (f"-{k}" if dances > 1 else "")
        out.append(ClipSource(name, _motion_data(motion, meta), audio, audio_path=str(path), texts=texts, meta=meta))
    return out


class SyntheticDance:
    """The ``synthetic-dance`` dataset."""

    def __init__(self, config: Any, fps: float, root: str = "."):
        self.config = config
        self.fps = config.motion_fps or fps
        self.root = root
        self._graph: MotionGraph | None = None

    def graph(self) -> MotionGraph | None:
        """The motion graph of the ``mocap`` takes (built on first use), or None."""
        c = self.config
        if c.mocap is not None and self._graph is None:
            self._graph = takes_graph(str(Path(self.root) / Path(c.mocap).expanduser()), self.fps,
                                      tuple(c.mocap_files or ()), tuple(c.mocap_exclude))
        return self._graph

    def clip(self, index: int) -> ClipSource:
        """One clip."""
        c = self.config
        return make_clip(index, seed=c.seed, seconds=c.seconds, bpm=tuple(c.bpm), rate=c.sample_rate,
                         fps=self.fps, dances_per_song=c.dances_per_song, tracker=c.dance_to_tracker,
                         dancers=c.dancers, homogeneous=c.homogeneous, graph=self.graph())

    def clips(self) -> list[ClipSource]:
        """Every song times every dance."""
        return [self.clip(i) for i in range(self.config.songs * self.config.dances_per_song)]


def build(config: Any, *, fps: float, root: str = ".", **_: Any) -> SyntheticDance:
    """Build the ``synthetic-dance`` dataset."""
    return SyntheticDance(config, fps, root)


@lru_cache(maxsize=4)
def takes_graph(folder: str, fps: float, files: tuple[str, ...] = (), exclude: tuple[str, ...] = ()) -> MotionGraph:
    """The motion graph of a folder's takes, retargeted onto dance24 at ``fps`` (the ``mocap`` dataset's
    cache), built once per process."""
    from dance_core.data.dataset_configs import MocapDatasetConfig
    from dance_core.data.mocap import MocapDataset

    config = MocapDatasetConfig(path=folder, files=list(files) or None, exclude=list(exclude))
    clips = MocapDataset(config, fps).clips()
    return MotionGraph([c.motion.skeleton_motion for c in clips], [c.name for c in clips])


def write_clip(out: Path, clip: ClipSource) -> list[Path]:
    """Write ``name.wav``, ``name.bvh``, ``name.beats`` (time, beat in bar), ``name.texts`` (start, end,
    sentence) and ``name.sections`` (start, end, section; tempo, style and any dancer but the classic one
    in a comment) into ``out``."""
    from dance_core.atomic import write_text
    from dance_core.formats.bvh import BvhFormat
    from dance_core.formats.wav import write_wav

    out.mkdir(parents=True, exist_ok=True)
    base = out / clip.name
    if clip.audio_path:  # a real song: linked (or copied) beside its dance under the dance's name
        song = base.with_suffix(Path(clip.audio_path).suffix.lower())
        _link_or_copy(Path(clip.audio_path), song)
    else:
        song = base.with_suffix(".wav")
        write_wav(song, clip.audio.samples, clip.audio.rate)
    BvhFormat(precision=5).write_motion(clip.motion.skeleton_motion, base.with_suffix(".bvh"))
    beats, per_bar = clip.meta["beats"], clip.meta["beats_per_bar"]
    first = clip.meta.get("first_downbeat", 0)
    write_text(base.with_suffix(".beats"),
               "".join(f"{b:.4f}\t{(i - first) % per_bar + 1}\n" for i, b in enumerate(beats)))
    write_text(base.with_suffix(".texts"), "".join(f"{t.start:.4f}\t{t.end:.4f}\t{t.text}\n" for t in clip.texts))
    dancer = clip.meta.get("dancer", CLASSIC)
    head = f"# bpm {clip.meta['bpm']:.4f} style {clip.meta['style']}"
    if dancer != CLASSIC:  # the files of the classic dancer stay as they were before dancer profiles
        head += f" dancer {dancer}"
    head += "\n"
    rows = "".join(f"{a:.4f}\t{b:.4f}\t{n}\n" for n, a, b in clip.meta["sections"])
    write_text(base.with_suffix(".sections"), head + rows)
    return [song] + [base.with_suffix(s) for s in CLIP_SUFFIXES]


def _link_or_copy(src: Path, dst: Path) -> None:
    """A hard link to ``src`` at ``dst`` (a copy across file systems); an existing ``dst`` is replaced."""
    import os
    import shutil

    tmp = dst.with_name(f".{dst.name}.tmp")
    tmp.unlink(missing_ok=True)
    try:
        os.link(src, tmp)
    except OSError:
        shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def _write_one(args: tuple) -> str:
    out, index, kwargs = args
    kwargs = dict(kwargs)  # shared by every clip of a one-process run: popping from it lost --mocap after clip 0
    mocap = kwargs.pop("mocap", None)
    graph = takes_graph(mocap[0], kwargs["fps"], (), mocap[1]) if mocap else None
    clip = make_clip(index, **kwargs, graph=graph)
    write_clip(Path(out), clip)
    return clip.name


def write_dataset(out: str | Path, songs: int, seed: int = 0, seconds: float = 60.0, fps: float = 60.0,
                  bpm: tuple[float, float] = (80.0, 140.0), rate: int = 22050, dances_per_song: int = 1,
                  jobs: int = 1, dancers: list[str] | None = (CLASSIC,), homogeneous: bool = False,
                  mocap: str | None = None, mocap_exclude: tuple[str, ...] = ()) -> list[str]:
    """Write a whole synthetic dataset (in ``jobs`` processes; dancers as in :func:`make_clip`, or real
    moves from the takes in ``mocap`` less ``mocap_exclude``); returns the clip names."""
    kwargs = {"seed": seed, "seconds": seconds, "bpm": bpm, "rate": rate, "fps": fps,
              "dances_per_song": dances_per_song, "dancers": dancers, "homogeneous": homogeneous,
              "mocap": (str(mocap), tuple(mocap_exclude)) if mocap else None}
    work = [(str(out), i, kwargs) for i in range(songs * dances_per_song)]
    if jobs <= 1:
        return [_write_one(w) for w in work]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(jobs) as pool:
        return list(pool.map(_write_one, work, chunksize=4))


def music_files(paths: list[str], registry) -> list[Path]:
    """The audio files named, and those inside named folders (sorted), checked before any work."""
    from dance_core.errors import DataError

    readable = set(registry.suffixes("audio-reader"))
    out: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in readable)
            if not found:
                raise DataError(f"{p}: --music: no audio file ({', '.join(sorted(readable))}) in this folder")
            out += found
        elif p.is_file():
            out.append(p)
        else:
            raise DataError(f"{p}: --music: no such file or folder")
    return out


def write_music_dances(out: str | Path, music: list[str], dances: int, seed: int, fps: float,
                       tracker: str, mocap: str | None = None, mocap_exclude: tuple[str, ...] = ()) -> list[str]:
    """Choreograph ``dances`` dances to every song in ``music`` (with real moves from ``mocap`` when
    given) and write them like a synthetic dataset."""
    from dance_core.registry import get_registry

    registry = get_registry()
    graph = takes_graph(str(mocap), fps, (), tuple(mocap_exclude)) if mocap else None
    names = []
    for path in music_files(music, registry):
        for clip in music_clips(str(path), registry, dances=dances, seed=seed, fps=fps, tracker=tracker,
                                graph=graph):
            write_clip(Path(out), clip)
            names.append(clip.name)
    return names

