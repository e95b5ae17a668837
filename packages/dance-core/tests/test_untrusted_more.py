"""Issue 28, untrusted input, the classes after the first two files (test_untrusted.py, test_untrusted_data.py):
``dance synth`` with two songs of one name and memory bounded by what is asked, generated dances checked for
sanity before they are written, plugins whose import exits, stale locks, a full disk, valid input that was
refused. Each class is a table of cases."""

from __future__ import annotations

import tracemalloc
import wave

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.formats.wav import write_wav

# ----------------------------------------------------------------------------- dance synth: names, memory


@pytest.mark.parametrize("layout", [
    ["a/song.wav", "b/song.wav"],
    ["a/song.wav", "b/song.flac"],
    ["a/", "b/song.wav"],  # a folder holding song.wav, and another song.wav
    ["a/", "b/"],
    ["x/s.wav", "y/t.wav", "z/s.wav"],
])
def test_synth_refuses_two_songs_of_one_name_before_any_work(tmp_path, capsys, layout):
    for name in ("a/song.wav", "b/song.wav", "b/song.flac", "x/s.wav", "y/t.wav", "z/s.wav"):
        (tmp_path / name).parent.mkdir(exist_ok=True)
        write_wav(tmp_path / name, np.zeros(800, np.float32), 8000)
    out = tmp_path / "out"
    code = main(["synth", "--out", str(out), "--music", *[str(tmp_path / p) for p in layout]])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "has the same name; their dances would overwrite each other" in err[0]
    assert not out.exists()


@pytest.mark.parametrize("seconds, rate, bpm", [(1.0, 8000, 120.0), (3.3, 22050, 400.0), (50.0, 44100, 97.0)])
def test_the_click_track_is_written_piece_by_piece_with_the_same_samples(tmp_path, capsys, seconds, rate, bpm):
    from dance_core.data.synthetic_beats import click_track

    path = tmp_path / "c.wav"
    assert main(["synth", str(path), "--seconds", str(seconds), "--rate", str(rate), "--bpm", str(bpm)]) == 0
    whole = tmp_path / "whole.wav"
    write_wav(whole, click_track(np.arange(0.0, seconds, 60.0 / bpm), seconds, rate, np.random.default_rng(0)), rate)
    assert path.read_bytes() == whole.read_bytes()
    with wave.open(str(path)) as w:
        assert (w.getnframes(), w.getframerate()) == (int(round(seconds * rate)), rate)


def test_an_hour_at_192_khz_takes_the_memory_of_one_piece(tmp_path, capsys):
    """Numpy's arrays are traced by tracemalloc: the whole song at once would peak above 5 GB."""
    path = tmp_path / "long.wav"
    tracemalloc.start()
    try:
        assert main(["synth", str(path), "--seconds", "120", "--rate", "192000"]) == 0
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert path.stat().st_size == 44 + 2 * 120 * 192000
    assert peak < 100 * 2**20, f"peak {peak / 2**20:.0f} MB"  # the whole song at once: about 900 MB


#: sha256 of songs synthesized before the in-place mix-down (numpy 2.x, scipy 1.x as pinned in requirements-dev.txt):
#: the same seed still gives the same song, bit for bit
SONGS = [  # (seed, seconds, rate, bpm, sha256 of Song.audio)
    (0, 8.0, 8000, 120.0, "66e111be6dbfcc73b0c1f7e2e997e349a48c91b77aa141d831d425b71f182f85"),
    (1, 6.0, 22050, 97.0, "afdf7744ebe44d694a4d0d0d2a5ed97810bf33dcc5e883e08f15d5270bc92aed"),
    (7, 5.0, 44100, 150.0, "cfb76c54bab4e9aa52181e273ef328b0d8ba809a8379df702bdba7ac879e9a18"),
    (3, 9.0, 16000, 75.0, "2bb4bafcc28645f6ea8079b53ba3785bca5c03e1f3cf7d4a9036f415f6dad1d4"),
]
#: sha256 of the WAV files of ``dance synth --out D --songs 2 --seconds 7 --rate 11025 --fps 30 --seed 4`` before
DATASET_WAVS = {"synth-0000.wav": "847e5874371565d68d53889cd49473fd3a2e869fdd16321b00c13c62c20351e1",
                "synth-0001.wav": "d24d217f40c0cb909cb9307a09e9b9a378950f540136edbd9486b09d7fd6affe"}


@pytest.mark.parametrize("seed, seconds, rate, bpm, digest", SONGS)
def test_a_seed_still_synthesizes_the_same_song_bit_for_bit(seed, seconds, rate, bpm, digest):
    import hashlib

    from dance_core.synth.music import synthesize

    song = synthesize(seconds, bpm, rate, np.random.default_rng(seed))
    assert hashlib.sha256(song.audio.tobytes()).hexdigest() == digest, "the song changed (or numpy/scipy did)"


def test_a_dataset_seed_still_writes_the_same_wav_files(tmp_path, capsys):
    import hashlib

    assert main(["-q", "synth", "--out", str(tmp_path), "--songs", "2", "--seconds", "7", "--rate", "11025",
                 "--fps", "30", "--seed", "4"]) == 0
    assert {n: hashlib.sha256((tmp_path / n).read_bytes()).hexdigest() for n in DATASET_WAVS} == DATASET_WAVS


@pytest.mark.parametrize("n, seed", [(16, 0), (1000, 1), (65536, 2), (65537, 3), (200_001, 4)])
def test_the_in_place_mix_down_sums_what_the_whole_arrays_summed(n, seed):
    """The mix-down, the room and the background noise as they were written over whole arrays, bit for bit."""
    from scipy.signal import lfilter, oaconvolve

    from dance_core.synth import instruments as ins
    from dance_core.synth.music import _mixdown

    rng = np.random.default_rng(seed)
    buses = {k: rng.standard_normal(n) * rng.uniform(0.1, 2) for k in ("drums", "bass", "pad", "keys", "lead")}
    levels = {k: float(rng.uniform(0.2, 1.3)) for k in buses}
    dry = sum(levels[k] * buses[k] for k in levels)
    send = buses["pad"] + buses["keys"] + buses["lead"] + 0.3 * buses["drums"]
    got_dry, got_send = _mixdown({k: v.copy() for k, v in buses.items()}, levels)
    assert np.array_equal(got_dry, dry) and np.array_equal(got_send, send)
    for rate in (8000, 11025, 44100):
        x = rng.standard_normal(n)
        q, room = max(1, rate // 5500), ins.reverb(x, rate, np.random.default_rng(seed), 0.5)
        low = x[: n // q * q].reshape(-1, q).mean(axis=1) if q > 1 else x
        t = np.arange(max(1, int(0.5 * rate // q))) / (rate // q)
        ir = np.random.default_rng(seed).standard_normal(len(t)) * np.exp(-6.9 * t / 0.5) * np.minimum(1.0, t / 0.01)
        wet = oaconvolve(low, ir / np.sqrt((ir**2).sum()))[: len(low)]
        assert np.array_equal(room, np.interp(np.arange(n), np.arange(len(low)) * q + (q - 1) / 2, wet))
        white = np.random.default_rng(seed).standard_normal(n)
        pink = np.zeros(n)
        for fc in (20.0, 200.0, 2000.0):
            p = np.exp(-2 * np.pi * fc / rate)
            pink += lfilter([1 - p], [1, -p], white) / np.sqrt(fc)
        noise = pink / max(1e-12, pink.std()) + 0.2 * white
        assert np.array_equal(ins.background(n, rate, np.random.default_rng(seed), 0.2),
                              noise / max(1e-12, noise.std()))


def test_a_dataset_song_takes_the_memory_its_estimate_says():
    """Numpy's arrays are traced by tracemalloc: a song synthesized whole took 108 bytes a sample; mixed down in
    place it takes its five buses and a little more, under what ``dance synth`` refuses by (SONG_BYTES)."""
    from dance_core.synth.command import SONG_BYTES
    from dance_core.synth.music import synthesize

    n = 40 * 16000
    tracemalloc.start()
    try:
        synthesize(40.0, 110.0, 16000, np.random.default_rng(0))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert 40 < peak / n < SONG_BYTES, f"{peak / n:.1f} bytes a sample"


@pytest.mark.parametrize("argv", [
    ["--songs", "1", "--seconds", "3600", "--rate", "192000"],
    ["--songs", "4", "--seconds", "600", "--rate", "96000", "--jobs", "4"],
])
def test_a_dataset_larger_than_memory_is_refused_before_any_work(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.setattr("dance_core.checks.available_memory", lambda: 8 * 2**30)
    code = main(["synth", "--out", str(tmp_path / "out"), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "GB of memory, more than the 8.0 GB free" in err[0], err
    assert "--rate" in err[0] and not (tmp_path / "out").exists()


# ------------------------------------------------------------------------- generated dances, checked sane


def _walk(frames: int = 60, fps: float = 30.0, speed: float = 1.0) -> np.ndarray:
    root = np.zeros((frames, 3))
    root[:, 0] = np.arange(frames) * speed / fps
    root[:, 1] = 1.0
    return root


ROOTS = [  # (how the root path is broken, the words of the error)
    (lambda r: r + [[47.0, 0.0, 0.0]], None),  # 47-49 m from the origin, walking: still a dance
    (lambda r: r * 19.0, None),  # 19 m/s: fast, but a body could
    (lambda r: r + [[0.0, 0.0, 51.0]], "m from the origin at frame 0"),
    (lambda r: r + [[1e4, 0.0, 0.0]], "10000.0 m from the origin"),
    (lambda r: r * 21.0, "m/s between frames 0 and 1"),
    (lambda r: np.where(np.arange(60)[:, None] == 30, r + 5.0, r), "m/s between frames 29 and 30"),
    (lambda r: np.where(np.arange(60)[:, None] == 7, np.nan, r), "NaN at frame 7"),
    (lambda r: np.where(np.arange(60)[:, None] == 0, np.inf, r), "inf at frame 0"),
    (lambda r: np.where(np.arange(60)[:, None] == 59, -np.inf, r), "inf at frame 59, joint 'root'"),
]


@pytest.mark.parametrize("mangle, words", ROOTS)
def test_a_root_path_a_body_could_not_take_is_named(mangle, words):
    from dance_core.checks import implausible_root

    reason = implausible_root(mangle(_walk()), 30.0)
    assert (reason is None) if words is None else (words in reason), reason


@pytest.fixture(scope="module")
def dance_run(tmp_path_factory):
    from dance_core.recipe import load_recipe
    from dance_core.train import train

    tiny = ["data.dataset.songs=3", "data.dataset.seconds=8", "training.steps=4", "training.batch_size=8",
            "training.val_every=4", "training.checkpoint_every=4", "training.log_every=2"]
    out = tmp_path_factory.mktemp("dance-run")
    train(load_recipe("core-dance", tiny), out=str(out), quiet=True)
    song = out / "songs" / "song.wav"
    song.parent.mkdir()
    write_wav(song, np.random.default_rng(0).uniform(-0.5, 0.5, 4 * 8000).astype(np.float32), 8000)
    return out / "model.safetensors", song


@pytest.mark.parametrize("broken, words", [
    (None, None),
    ("huge", "m from the origin"),
    ("nan", "its frames hold NaN or inf from frame 3"),
])
def test_compose_refuses_a_generated_dance_that_flies_off_naming_the_recipe_and_the_song(
        dance_run, tmp_path, capsys, monkeypatch, broken, words):
    import dance_core.compose.loop as loop

    generate = loop.generate_song

    def flying(*args, **kwargs):
        motion = generate(*args, **kwargs)
        if broken == "huge":
            motion[:, :, 0] = 1e5  # the root's forward step, normalized: kilometres a frame
        elif broken == "nan":
            motion[:, 3:, 5] = np.nan
        return motion

    monkeypatch.setattr(loop, "generate_song", flying)
    checkpoint, song = dance_run
    out = tmp_path / "out"
    code = main(["-q", "compose", "core-dance", "--checkpoint", str(checkpoint), "--music", str(song),
                 "-o", str(out), "--set", "compose.formats=[bvh, npz]"])
    err = capsys.readouterr().err.strip().splitlines()
    if broken is None:
        assert code == 0 and (out / "song.bvh").is_file()
        return
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith(f"dance: error: {song}: the dance generated by recipe ") and "core-dance" in err[0]
    assert words in err[0] and "nothing is written for this song" in err[0]
    assert not out.exists() or not [p for p in out.iterdir() if not p.name.startswith(".")]


# --------------------------------------------------------------------- plugins whose import or hook exits

IMPORTS = [  # (the module's body, its words in the warning)
    "raise SystemExit(0)", "raise SystemExit(3)", "import sys; sys.exit('bye')", "raise SystemExit",
    "raise GeneratorExit", "raise BaseException('odd')", "class Odd(BaseException): pass\nraise Odd()",
    "raise RuntimeError('boom')", "raise MemoryError", "1 / 0", "import no_such_module_anywhere",
]
HOOKS = [  # a hook that exits
    "raise SystemExit(0)", "raise BaseException('odd')", "raise RecursionError('deep')",
]


def _hostile_plugin(monkeypatch, tmp_path, body: str, hook: str | None = None, name: str = "evil"):
    import importlib.metadata
    import sys

    from dance_core import plugins, registry

    module = f"{name}_{abs(hash((body, hook))) % 10**8}"
    text = body if hook is None else (
        f"from dance_core import hookimpl\n\n@hookimpl\ndef {hook}(**kwargs):\n    " + body.replace("\n", "\n    "))
    (tmp_path / f"{module}.py").write_text(text + "\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, module, raising=False)
    ep = importlib.metadata.EntryPoint(name, module, plugins.GROUP)
    real = importlib.metadata.entry_points
    monkeypatch.setattr(plugins, "entry_points",
                        lambda group=None, **kw: [*real(group=group, **kw), *([ep] if group == plugins.GROUP else [])])
    monkeypatch.delenv("DANCE_STRICT_PLUGINS", raising=False)
    monkeypatch.delenv("DANCE_LOAD_PLUGINS", raising=False)
    plugins.get_plugin_manager.cache_clear()
    registry.reset()
    return module


@pytest.fixture
def clean_plugins():
    from dance_core import plugins, registry

    yield
    plugins.get_plugin_manager.cache_clear()
    registry.reset()


@pytest.mark.parametrize("body", IMPORTS)
def test_a_plugin_whose_import_exits_is_one_line_and_dance_carries_on(tmp_path, monkeypatch, capsys, clean_plugins,
                                                                     body):
    module = _hostile_plugin(monkeypatch, tmp_path, body)
    assert main(["plugins"]) == 0
    out, err = capsys.readouterr()
    lines = [w for w in err.splitlines() if "evil" in w]
    assert len(lines) == 1 and f"plugin 'evil' from evil is broken and was skipped: cannot import {module}" in lines[0]
    assert "Traceback" not in err and "BROKEN" in out and "regression" in out  # the others still load
    if "SystemExit" in body or "sys.exit" in body:
        assert "it tried to end dance" in lines[0]


@pytest.mark.parametrize("body", IMPORTS[:4])
def test_strict_makes_an_exiting_plugin_an_error_never_a_silent_exit(tmp_path, monkeypatch, capsys, clean_plugins,
                                                                   body):
    _hostile_plugin(monkeypatch, tmp_path, body)
    monkeypatch.setenv("DANCE_STRICT_PLUGINS", "0")  # main sets it to 1; restored after
    assert main(["--strict", "plugins"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("dance: error: plugin 'evil'") and "end dance" in err[0]


@pytest.mark.parametrize("body", ["raise KeyboardInterrupt", "raise KeyboardInterrupt('typed')",
                                  "from dance_core.atomic import Terminated\nraise Terminated()"])
def test_a_plugin_interrupted_on_import_stops_dance_naming_it(tmp_path, monkeypatch, capsys, clean_plugins, body):
    module = _hostile_plugin(monkeypatch, tmp_path, body)
    code = main(["plugins"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == (143 if "Terminated" in body else 130) and len(err) == 1, err
    assert f"plugin 'evil' from evil (entry point {module}): interrupted" in err[0]


@pytest.mark.parametrize("body", HOOKS)
@pytest.mark.parametrize("hook", ["register_heads", "register_commands"])
def test_a_plugin_hook_that_exits_is_skipped_in_one_line(tmp_path, monkeypatch, capsys, clean_plugins, body, hook):
    _hostile_plugin(monkeypatch, tmp_path, body, hook)
    assert main(["plugins"]) == 0
    out, err = capsys.readouterr()
    lines = [w for w in err.splitlines() if "evil" in w]
    assert len(lines) == 1 and f"failed in {hook}" in lines[0] and "Traceback" not in err, err


# --------------------------------------------------------------------- stale locks: a pid reused by another


@pytest.fixture
def other_process():
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    yield proc.pid
    proc.kill()
    proc.wait()


@pytest.mark.skipif(not __import__("os").path.exists("/proc/self/stat"), reason="start times read from /proc")
@pytest.mark.parametrize("content, taken", [
    ("{pid} {start}\n", False),  # the holder itself, still running: in use
    ("{pid}\n", False),  # a lock written before start times: the pid alone decides, as before
    ("{pid} {boot}:1\n", True),  # the pid is another process now (it started later): stale
    ("{pid} 00000000:{ticks}\n", True),  # same ticks, another boot
    ("{pid} garbage\n", True),
    ("{dead} {start}\n", True),  # no such process
    ("{self} 00000000:1\n", True),  # our own pid, reused: a trainer that died before us
])
def test_a_lock_whose_pid_was_reused_is_taken_over(tmp_path, capsys, other_process, content, taken):
    import os

    from dance_core.atomic import process_start
    from dance_core.train import LOCK_FILE, run_lock

    start = process_start(other_process)
    boot, ticks = start.split(":")
    lock = tmp_path / "run" / LOCK_FILE
    lock.parent.mkdir()
    lock.write_text(content.format(pid=other_process, start=start, boot=boot, ticks=ticks, dead=2**22 + 7,
                                   self=os.getpid()))
    if not taken:
        from dance_core.errors import DanceError

        with pytest.raises(DanceError, match=f"in use by another dance train \\(pid {other_process}"), \
                run_lock(tmp_path / "run"):
            pass
        assert lock.read_text() == content.format(pid=other_process, start=start)  # left as it was
        return
    with run_lock(tmp_path / "run"):
        assert lock.read_text().split() == [str(os.getpid()), process_start(os.getpid())]
    assert "taking over a stale lock" in capsys.readouterr().err and not lock.exists()


# ------------------------------------------------------------------------------- a full disk while training

TINY_SETS = [arg for s in ("data.dataset.songs=4", "data.dataset.seconds=6", "training.steps=40",
                           "training.batch_size=16", "training.val_every=20", "training.checkpoint_every=20",
                           "training.log_every=10") for arg in ("--set", s)]


def _fill_disk_in(monkeypatch, where: str, after: int) -> None:
    """Make the ``after``-th call of one writer run out of space, part of its bytes written first."""
    import errno
    import os

    import dance_core.train.run_folder as run_folder

    calls = {"n": 0}

    def full(path):
        calls["n"] += 1
        if calls["n"] == after:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    if where == "log":
        real = run_folder._write_all

        def write(fd, data):
            if calls["n"] + 1 == after:
                os.write(fd, data[: len(data) // 2])  # half a record reached the disk
            full("log.jsonl")
            real(fd, data)

        monkeypatch.setattr(run_folder, "_write_all", write)
        return
    real = getattr(run_folder, where)

    def save(path, *args, **kwargs):
        real(path, *args, **kwargs)  # the file is written, then the disk is full (as for a flush that fails)
        full(path)

    monkeypatch.setattr(run_folder, where, save)


@pytest.mark.parametrize("where, after, words", [
    ("save_checkpoint", 2, "saving the checkpoint of step 40"),
    ("save_train_state", 2, "saving the checkpoint of step 40"),
    ("log", 4, "appending step 30 to log.jsonl"),  # 10, 20, 20 (val), then 30
    ("save_checkpoint", 1, "no checkpoint was written yet"),
])
def test_a_full_disk_while_training_keeps_the_last_good_checkpoint_and_says_so(tmp_path, capsys, monkeypatch, where,
                                                                               after, words):
    import json

    from dance_core.checkpoint import load_checkpoint, train_state_info

    run = tmp_path / "run"
    _fill_disk_in(monkeypatch, where, after)
    code = main(["-q", "train", "core-synthetic", *TINY_SETS, "-o", str(run)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "disk full (No space left on device)" in err[0] and words in err[0], err
    assert sorted(p.name for p in run.iterdir() if p.name.startswith(".")) == []  # no temporary left
    for line in (run / "log.jsonl").read_text().splitlines():
        json.loads(line)  # never half a record
    if after == 1 and where != "log":
        assert not (run / "model.safetensors").exists()
        return
    assert "last good checkpoint (step 20)" in err[0]
    assert load_checkpoint(run / "model.safetensors").step == 20
    assert train_state_info(run / "state.safetensors")[0] == 20
    monkeypatch.undo()
    assert main(["-q", "train", "core-synthetic", *TINY_SETS, "-o", str(run), "--resume"]) == 0
    assert load_checkpoint(run / "model.safetensors").step == 40


# ------------------------------------------------------------- valid input once refused: AIFF, names, LANG=C


def _dance_bvh(path) -> None:
    from dance_core.formats.bvh import BvhFormat
    from dance_core.synth.synthetic_dance import make_clip

    clip = make_clip(0, seed=1, seconds=3.0, bpm=(100, 100), rate=8000, fps=30.0)
    BvhFormat().write_motion(clip.motion.skeleton_motion, path)


@pytest.mark.parametrize("suffix, fmt", [(".aiff", "AIFF"), (".aif", "AIFF"), (".AIFF", "AIFF")])
def test_an_aiff_song_is_embedded_in_the_preview_as_wav(tmp_path, capsys, suffix, fmt):
    sf = pytest.importorskip("soundfile")
    from dance_core.registry import get_registry

    if suffix.lower() not in get_registry().suffixes("audio-reader"):
        pytest.skip("no installed audio reader reads AIFF (dance-audio does)")
    import base64
    import io
    import re

    song = tmp_path / f"song{suffix}"
    samples = (0.3 * np.sin(np.arange(8000 * 6) / 5.0)).astype(np.float32)
    sf.write(song, samples, 8000, format=fmt, subtype="PCM_16")
    _dance_bvh(tmp_path / "d.bvh")
    assert main(["render", str(tmp_path / "d.bvh"), "--music", str(song), "-o", str(tmp_path / "d.html")]) == 0
    page = (tmp_path / "d.html").read_text()
    raw = base64.b64decode(re.search(r'src="data:audio/wav;base64,([^"]+)"', page).group(1))
    with wave.open(io.BytesIO(raw)) as w:  # the dance's 3 s and the margin, never the whole 6 s
        played = np.frombuffer(w.readframes(w.getnframes()), "<i2") / 32768.0
        assert w.getframerate() == 8000 and 3 * 8000 <= len(played) < 6 * 8000
    np.testing.assert_allclose(played, samples[: len(played)], atol=2e-4)


NAMES = ["sång é", b"\xe9t\xe9 latin-1", "日本語 \u2028 ダンス"]
LOCALES = [{"LANG": "C", "LC_ALL": "C"}, {"LANG": "C", "LC_ALL": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}]


@pytest.mark.parametrize("name", NAMES, ids=["accents", "undecodable", "cjk"])
@pytest.mark.parametrize("env", LOCALES, ids=["C", "C-no-utf8-mode"])
def test_non_ascii_file_names_work_under_lang_c(tmp_path, name, env):
    import os
    import subprocess
    import sys
    from pathlib import Path

    from dance_core.render.html import shown

    stem = os.fsencode(name) if isinstance(name, str) else name
    folder = os.fsencode(tmp_path) + b"/" + stem
    os.mkdir(folder)
    _dance_bvh(os.fsdecode(folder + b"/" + stem + b".bvh"))
    run_env = {**{k: v for k, v in os.environ.items() if not k.startswith(("LC_", "LANG", "PYTHONUTF8"))}, **env}
    dance = [sys.executable, "-m", "dance_core.cli.main"]
    song, page = folder + b"/" + stem + b".wav", folder + b"/" + stem + b".html"
    for argv in (["synth", song, "--seconds", "2", "--rate", "8000"],
                 ["render", folder + b"/" + stem + b".bvh", "--music", song, "-o", page]):
        done = subprocess.run([*dance, *argv], env=run_env, capture_output=True, timeout=120)
        assert done.returncode == 0, done.stderr.decode("utf-8", "replace")
    title = shown(Path(os.fsdecode(page)).stem)
    text = Path(os.fsdecode(page)).read_text(encoding="utf-8")
    assert os.path.getsize(song) == 44 + 2 * 16000 and f"<title>{title}</title>" in text.replace("&#x27;", "'")
