"""Issue 16, the data / run-folder / output-set / determinism half: bad values stop before work with one
line naming the file, run folders are locked and resumed only from a matching pair, output sets are
all-or-nothing (SIGTERM included), the same song composes the same dance, checkpoints are byte-identical
and 0644, previews embed only the music the dance covers. The fault tests kill real subprocesses."""

from __future__ import annotations

import base64
import hashlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import wave
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from dance_core import hookimpl
from dance_core.atomic import OutputSet, atomic_path, output_mode, sweep_stale_temps
from dance_core.checkpoint import load_checkpoint
from dance_core.compose import compose
from dance_core.data.synthetic_beats import click_track
from dance_core.errors import CheckpointError, DanceError, DataError
from dance_core.formats.npz import NpzFormat
from dance_core.formats.wav import write_wav
from dance_core.protocols import MotionData
from dance_core.testing import registered_plugin
from dance_core.train import LOCK_FILE, run_lock, train

sys.path.insert(0, str(Path(__file__).parent))
from compose_helpers import NoisyPlugin  # noqa: E402

TINY = [
    "data.dataset.songs=4",
    "data.dataset.seconds=6",
    "training.steps=40",
    "training.batch_size=16",
    "training.val_every=20",
    "training.checkpoint_every=20",
    "training.log_every=10",
]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def temps(folder: Path) -> list[str]:
    """Hidden temporary files of ours left in a folder."""
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith(".") and ".dance-" in p.name)


def dead_pid() -> int:
    """The pid of a process that has exited (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def song(path: Path, seconds: float = 3.0, rate: int = 16000) -> str:
    beats = np.arange(0.0, seconds, 0.5)
    write_wav(path, click_track(beats, seconds, rate, np.random.default_rng(0)), rate)
    return str(path)


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    from dance_core.recipe import load_recipe

    run = tmp_path_factory.mktemp("run")
    return train(load_recipe("core-synthetic", [*TINY, "training.steps=20"]), out=str(run), quiet=True).checkpoint


# ---------------------------------------------------------------------------------------------- bad values in data


def poisoned_sources(recipe, field: str = "motion"):
    """The recipe's dataset with NaN in the second clip's motion, as if read from ``bad.npz``."""
    from dance_core.data.prepare import dataset_sources

    sources = dataset_sources(recipe)
    bad = sources[1]
    values = bad.motion.values.copy()
    values[7, 2] = np.nan
    motion = replace(bad.motion, values=values, meta={**bad.motion.meta, "path": "data/bad.npz"})
    sources[1] = replace(bad, motion=motion)
    return sources


def test_nan_motion_stops_before_training_naming_the_file(tiny_recipe, tmp_path, monkeypatch):
    import dance_core.data.prepare as P  # training's data-preparation step lists the dataset here

    recipe = tiny_recipe()
    poisoned = poisoned_sources(recipe)
    monkeypatch.setattr(P, "dataset_sources", lambda r: poisoned)
    run = tmp_path / "run"
    with pytest.raises(DataError) as err:
        train(recipe, out=str(run), quiet=True)
    message = str(err.value)
    assert message.startswith("data/bad.npz: motion holds NaN values") and "frame 7" in message
    assert "\n" not in message and "learning rate" not in message and "lr" not in message
    assert not run.exists()  # the folder this call made is gone again: no run began


def test_nan_feature_stream_names_the_music_file_and_stream(tiny_recipe):
    from dance_core.data.features import FeatureStack
    from dance_core.data.prepare import dataset_sources, to_clip
    from dance_core.registry import get_registry

    recipe = tiny_recipe()
    stack = FeatureStack(recipe)
    source = replace(dataset_sources(recipe)[0], audio_path="music/song.wav")
    real = stack.extract_spans

    def poisoned(n, audio=None, texts=()):
        streams, spans = real(n, audio, texts)
        streams["music"][3, 0] = np.inf
        return streams, spans

    stack.extract_spans = poisoned
    with pytest.raises(DataError, match=r"^music/song\.wav: feature stream 'music' holds infinite values .*frame 3"):
        to_clip(source, stack, get_registry())


BVH = """HIERARCHY
ROOT hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT knee
\t{
\t\tOFFSET 0 -1 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 -1 0
\t\t}
\t}
}
MOTION
Frames: 3
Frame Time: 0.033333
0 1 0 0 0 0 0 0 0
0 1 0 0 5 0 0 0 0
0 1 0 0 10 0 0 0 0
"""


@pytest.mark.parametrize("old, new, match", [
    ("0 1 0 0 5 0 0 0 0", "0 1 0 0 nan 0 0 0 0", r":20: BVH MOTION: frame 1 holds 'nan'"),
    ("0 1 0 0 10 0 0 0 0", "0 1 0 0 10 0 inf 0 0", r":21: BVH MOTION: frame 2 holds 'inf'"),
    ("0 1 0 0 5 0 0 0 0", "0 1 0 0 5 0 zero 0 0", r":20: BVH MOTION: 'zero' is not a number"),
    ("0 1 0 0 5 0 0 0 0", "0 1 0 0 5 0 0 0", r":20: BVH MOTION: frame 1 has 8 values"),
    ("\t\tOFFSET 0 -1 0\n\t\tCHANNELS", "\t\tOFFSET 0 nan 0\n\t\tCHANNELS",
     r":8: BVH HIERARCHY: 'nan' is not a finite"),
    ("\t\tCHANNELS 3 Z", "\t\tCHANNELS three Z", r":9: BVH HIERARCHY: CHANNELS count"),
    ("Frame Time: 0.033333", "Frame Time: fast", r":18: BVH MOTION: Frame Time 'fast' is not a number"),
    ("0 1 0 0 10 0 0 0 0\n", "", r"3 frames of 9 channels declared, found 2"),
])
def test_bvh_errors_name_the_file_and_line(tmp_path, old, new, match):
    from dance_core.formats.bvh import BvhFormat

    good = tmp_path / "good.bvh"
    good.write_text(BVH)
    assert BvhFormat().read(good).values.shape == (3, 9)
    bad = tmp_path / "bad.bvh"
    assert old in BVH
    bad.write_text(BVH.replace(old, new, 1))
    with pytest.raises(DataError, match=match) as err:
        BvhFormat().read(bad)
    assert str(err.value).startswith(f"{bad}:") and "\n" not in str(err.value)


@pytest.fixture(scope="module")
def eval_sets(tmp_path_factory):
    """Three reference clips, and generated copies of them: one with NaN, and an all-NaN set."""
    root = tmp_path_factory.mktemp("eval")
    rng = np.random.default_rng(0)
    channels = [f"j{j}.{a}" for j in range(4) for a in "xyz"]
    fmt = NpzFormat()
    for sub in ("reference", "generated", "all-nan"):
        (root / sub).mkdir()
    for k in range(3):
        walk = np.cumsum(rng.normal(0, 0.01, (80, 12)), axis=0).astype(np.float32) + np.tile([0, 1, 0], 4)
        fmt.write(MotionData(walk, 20.0, channels), root / "reference" / f"c{k}.npz")
        gen = walk[::-1].copy()
        if k == 1:
            gen[10, 4] = np.nan
        fmt.write(MotionData(gen, 20.0, channels), root / "generated" / f"c{k}.npz")
        gen[:, 0] = np.inf
        fmt.write(MotionData(gen, 20.0, channels), root / "all-nan" / f"c{k}.npz")
    return root


def evaluate_cli(root: Path, generated: str, capsys, *extra: str) -> tuple[int, dict, str]:
    from dance_core.cli.main import main

    out = root / f"{generated}.json"
    rc = main(["-q", "evaluate", "--generated", str(root / generated), "--reference", str(root / "reference"),
               "--metrics", "freezing", "fid-k", "--no-plots", "-o", str(out), *extra])
    err = capsys.readouterr().err
    return rc, json.loads(out.read_text()) if out.exists() else {}, err


def test_evaluate_leaves_out_nan_clips_and_names_them(eval_sets, capsys):
    rc, report, _ = evaluate_cli(eval_sets, "generated", capsys)
    assert rc == 0
    assert list(report["unusable_clips"]) == ["generated/c1"]
    assert "NaN at frame 10, joint 'j1'" in report["unusable_clips"]["generated/c1"]
    assert set(report["metrics"]["freezing"]["per_clip"]) == {"c0", "c2"}
    assert any("c1.npz left out" in n for n in report["notes"])


def test_evaluate_exits_non_zero_when_it_could_score_nothing(eval_sets, capsys):
    from dance_core.evaluation.report import Report, check_scored

    rc, report, err = evaluate_cli(eval_sets, "all-nan", capsys)
    assert rc == 1
    assert sorted(report["unusable_clips"]) == ["generated/c0", "generated/c1", "generated/c2"]
    lines = [ln for ln in err.splitlines() if ln.startswith("dance: error:")]
    assert len(lines) == 1 and "c0, c1, c2" in lines[0] and "NaN or inf" in lines[0]
    with pytest.raises(DanceError, match="could score nothing"):
        check_scored(Report())


# ------------------------------------------------------------------------------------------------- run folders


def test_a_locked_run_folder_refuses_a_second_trainer(tiny_recipe, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        (run / LOCK_FILE).write_text(f"{holder.pid}\n")
        with pytest.raises(DanceError) as err:
            train(tiny_recipe(), out=str(run), quiet=True)
        assert f"pid {holder.pid}" in str(err.value) and "in use" in str(err.value)
        assert "\n" not in str(err.value) and not (run / "model.safetensors").exists()
        assert (run / LOCK_FILE).read_text().strip() == str(holder.pid)  # the holder's lock is untouched
    finally:
        holder.kill()
        holder.wait()


def test_a_stale_lock_is_taken_over_with_a_warning_and_released(tiny_recipe, tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    pid = dead_pid()
    (run / LOCK_FILE).write_text(f"{pid}\n")
    result = train(tiny_recipe("training.steps=5"), out=str(run), quiet=True)
    assert result.steps == 5 and load_checkpoint(result.checkpoint).step == 5
    assert f"stale lock (pid {pid}, no longer running)" in capsys.readouterr().err
    assert not (run / LOCK_FILE).exists()


def test_run_lock_is_exclusive_atomic_and_reentrant(tmp_path):
    with run_lock(tmp_path) as lock:
        assert lock.read_text().split()[0] == str(os.getpid())  # the pid, then its start time
        with run_lock(tmp_path):  # the same process, nested (train() around Trainer.run)
            pass
        assert lock.exists()
        child = subprocess.run(
            [sys.executable, "-c", f"from dance_core.train import run_lock\nwith run_lock({str(tmp_path)!r}): pass"],
            capture_output=True, text=True, env=ENV,
        )
        assert child.returncode != 0 and f"in use by another dance train (pid {os.getpid()}" in child.stderr
    assert not lock.exists()
    (tmp_path / "file").write_text("x")
    with pytest.raises(DataError, match="is a file, not a run folder"), run_lock(tmp_path / "file"):
        pass


@pytest.mark.parametrize("stop_at, match", [(0, "positive"), (-3, "positive"), (41, "beyond the run's last step")])
def test_stop_at_out_of_range_is_refused_before_any_work(tiny_recipe, tmp_path, stop_at, match):
    with pytest.raises(DanceError, match=match):
        train(tiny_recipe(), out=str(tmp_path / "run"), quiet=True, stop_at=stop_at)
    assert not (tmp_path / "run").exists()


def test_resume_refuses_a_model_and_state_that_do_not_belong_together(tiny_recipe, tmp_path):
    run, other = tmp_path / "run", tmp_path / "other"
    train(tiny_recipe(), out=str(run), quiet=True, stop_at=20)
    shutil.copy(run / "state.safetensors", tmp_path / "state-20.safetensors")
    train(tiny_recipe(), out=str(run), quiet=True, resume=True)
    shutil.copy(tmp_path / "state-20.safetensors", run / "state.safetensors")  # model at 40, state at 20
    with pytest.raises(CheckpointError, match="model checkpoint is at step 40 but the training state at step 20"):
        train(tiny_recipe(), out=str(run), quiet=True, resume=True)
    # the same step, another run (another learning rate): the run ids differ
    train(tiny_recipe("training.optimizer.lr=0.001"), out=str(other), quiet=True, stop_at=20)
    train(tiny_recipe(), out=str(run), quiet=True, stop_at=20, overwrite=True)
    shutil.copy(other / "state.safetensors", run / "state.safetensors")
    with pytest.raises(CheckpointError, match="come from different runs") as err:
        train(tiny_recipe(), out=str(run), quiet=True, resume=True)
    assert "\n" not in str(err.value)
    with pytest.raises(DanceError, match="not after the step the run resumes from"):
        shutil.copy(tmp_path / "state-20.safetensors", run / "state.safetensors")
        train(tiny_recipe(), out=str(run), quiet=True, resume=True, stop_at=20)


# ------------------------------------------------------------------------------------------------ output sets


class FailingFormat:
    """A motion format whose every write fails (a full disk, a bug in a preview)."""

    def read(self, path):
        raise DataError(f"{path}: write-only")

    def write(self, motion, path):
        Path(path).write_bytes(b"half")  # something reached the disk before the failure
        raise OSError(28, "No space left on device")


class FailingPlugin:
    @hookimpl
    def register_motion_formats(self, register):
        register("failing", None, lambda config=None, **_: FailingFormat(), "always fails", suffixes=(".fail",))


def test_compose_output_set_is_all_or_nothing(tiny_recipe, checkpoint, tmp_path):
    a, b = song(tmp_path / "a.wav"), song(tmp_path / "b.wav", 2.0)
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.npz").write_bytes(b"the previous dance")
    with registered_plugin(FailingPlugin(), "failing-format"), pytest.raises(OSError, match="No space left"):
        compose(tiny_recipe("compose.formats=[npz, failing]"), music=[a, b], checkpoint=str(checkpoint),
                out_dir=str(out), quiet=True)
    assert sorted(p.name for p in out.iterdir()) == ["a.npz"]  # no b.npz, no temp file
    assert (out / "a.npz").read_bytes() == b"the previous dance"  # the old set is left whole


def test_output_set_commits_together_sweeps_stale_temps_and_uses_the_umask(tmp_path):
    stale = tmp_path / f".x.npz.dance-{dead_pid()}-abcdefgh.npz"
    live = tmp_path / f".x.npz.dance-{os.getpid()}-abcdefgh.npz"
    nested = tmp_path / f"..x.npz.dance-{dead_pid()}-abcdefgh.npz.dance-1-ijklmnop.npz"
    for p in (stale, live, nested):
        p.write_bytes(b"")
    with OutputSet() as files:
        files.path(tmp_path / "x.npz").write_bytes(b"x")
        files.path(tmp_path / "y.bvh").write_bytes(b"y")
        assert not (tmp_path / "x.npz").exists()
    assert (tmp_path / "x.npz").read_bytes() == b"x" and (tmp_path / "y.bvh").read_bytes() == b"y"
    assert not stale.exists() and not nested.exists() and live.exists()  # a running writer's file stays
    live.unlink()
    assert temps(tmp_path) == []
    for name in ("x.npz", "y.bvh"):
        assert (tmp_path / name).stat().st_mode & 0o777 == output_mode()
    assert sweep_stale_temps(tmp_path, ["x.npz"]) == []


# The children wait in short sleeps, never one long one: a signal whose C handler runs after the
# interpreter's last check but before ``time.sleep`` enters the kernel is only acted on when that sleep
# ends (CPython checks for signals after the system call, not before). A 60-s sleep made that window a
# 60-s hang on a loaded machine; 0.05-s sleeps bound it.
WAIT = "for _ in range(1200): time.sleep(0.05)"

SLOW_WRITER = f"""
import sys, time
from pathlib import Path
from dance_core.atomic import OutputSet, atomic_path
out = Path(sys.argv[1])
if sys.argv[2] == "atomic":
    with atomic_path(out / "song.bvh") as tmp:
        tmp.write_bytes(b"")
        print("ready", flush=True)
        {WAIT}
else:
    with OutputSet() as files:
        files.path(out / "song.bvh").write_bytes(b"motion")
        files.path(out / "song.html")
        print("ready", flush=True)
        {WAIT}
"""


@pytest.mark.parametrize("how", ["atomic", "set"])
def test_sigterm_during_a_write_leaves_no_temp_file(tmp_path, how):
    proc = subprocess.Popen([sys.executable, "-c", SLOW_WRITER, str(tmp_path), how], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout.readline().strip() == "ready"
    assert temps(tmp_path)  # the 0-byte temporary file exists while the write is under way
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=30)
    assert proc.returncode != 0
    assert list(tmp_path.iterdir()) == []  # neither the temporary file nor a half-written target


# ------------------------------------------------------------------------------------------------ determinism


def test_a_song_composes_the_same_dance_whatever_else_is_in_the_call(tiny_recipe, tmp_path):
    a, b = song(tmp_path / "a.wav", 3.0), song(tmp_path / "b.wav", 4.5, rate=22050)
    with registered_plugin(NoisyPlugin(), "noisy-plugin"):
        recipe = tiny_recipe("model.head.plugin=noisy-head", "training.steps=10", "compose.samples=2",
                             "compose.temperature=1.0")
        ckpt = str(train(recipe, out=str(tmp_path / "run"), quiet=True).checkpoint)
        alone = compose(recipe, music=[a], checkpoint=ckpt, out_dir=str(tmp_path / "alone"), quiet=True)
        both = compose(recipe, music=[b, a], checkpoint=ckpt, out_dir=str(tmp_path / "both"), quiet=True)
    assert [p.name for p in alone] == ["a-0.npz", "a-1.npz"]
    assert [p.name for p in both] == ["b-0.npz", "b-1.npz", "a-0.npz", "a-1.npz"]
    for name in ("a-0.npz", "a-1.npz"):
        assert (tmp_path / "alone" / name).read_bytes() == (tmp_path / "both" / name).read_bytes()
    with np.load(tmp_path / "both" / "a-0.npz") as f0, np.load(tmp_path / "both" / "a-1.npz") as f1:
        assert not np.array_equal(f0["values"], f1["values"])  # the samples are random draws


def test_two_songs_with_one_name_are_refused_before_generating(tiny_recipe, checkpoint, tmp_path):
    (tmp_path / "x").mkdir()
    a, b = song(tmp_path / "a.wav"), song(tmp_path / "x" / "a.wav")
    with pytest.raises(DataError, match="has the same name"):
        compose(tiny_recipe(), music=[a, b], checkpoint=str(checkpoint), out_dir=str(tmp_path / "o"), quiet=True)


def test_same_run_same_checkpoint_bytes_and_mode_0644(tiny_recipe, tmp_path):
    a = train(tiny_recipe(), out=str(tmp_path / "a"), quiet=True)
    b = train(tiny_recipe(), out=str(tmp_path / "b"), quiet=True, stop_at=20)
    b = train(tiny_recipe(), out=str(tmp_path / "b"), quiet=True, resume=True)
    for name in ("model.safetensors", "state.safetensors"):
        assert sha(tmp_path / "a" / name) == sha(tmp_path / "b" / name)
        assert (tmp_path / "a" / name).stat().st_mode & 0o777 == output_mode()
    assert load_checkpoint(a.checkpoint).run == load_checkpoint(b.checkpoint).run is not None
    header = a.checkpoint.read_bytes()
    meta = json.loads(header[8 : 8 + int.from_bytes(header[:8], "little")])["__metadata__"]
    assert list(meta) == sorted(meta) and str(tmp_path) not in json.dumps(meta)


def test_deterministic_safetensors_round_trip_every_dtype(tmp_path):
    from safetensors.torch import load_file

    from dance_core.checkpoint import write_safetensors

    tensors = {
        "f64": torch.randn(3, dtype=torch.float64), "bf16": torch.randn(2, 5).to(torch.bfloat16),
        "f16": torch.randn(7).half(), "i64": torch.arange(5), "u8": torch.tensor([1, 2, 3], dtype=torch.uint8),
        "bool": torch.tensor([True, False, True]), "scalar": torch.tensor(2.5), "empty": torch.zeros(0, 4),
    }
    write_safetensors(tmp_path / "a.safetensors", tensors, {"z": "1", "a": "2"})
    write_safetensors(tmp_path / "b.safetensors", dict(reversed(list(tensors.items()))), {"a": "2", "z": "1"})
    assert sha(tmp_path / "a.safetensors") == sha(tmp_path / "b.safetensors")
    back = load_file(str(tmp_path / "a.safetensors"))
    assert set(back) == set(tensors)
    for k, v in tensors.items():
        assert back[k].dtype == v.dtype and torch.equal(back[k], v)


# ---------------------------------------------------------------------------------------------------- previews


def test_html_preview_embeds_only_the_music_the_dance_covers(tmp_path):
    from dance_core.render.html import AUDIO_MARGIN_S, PREVIEW_RATE, player_html

    rate, seconds = 44100, 60.0
    t = np.arange(int(rate * seconds)) / rate
    long_song = tmp_path / "long.wav"
    write_wav(long_song, 0.3 * np.sin(2 * np.pi * 440 * t), rate)
    positions = np.zeros((100, 2, 3))  # 5 s at 20 fps
    positions[:, 1, 1] = 1.0
    html = player_html(positions, [-1, 0], ["root", "head"], 20.0, long_song)
    kind, payload = re.search(r'src="data:(audio/[a-z]+);base64,([A-Za-z0-9+/=]+)"', html).groups()
    raw = base64.b64decode(payload)
    bound = 44 + 2 * int(np.ceil((5.0 + AUDIO_MARGIN_S) * PREVIEW_RATE))
    assert kind == "audio/wav" and len(raw) <= bound < long_song.stat().st_size / 10
    with wave.open(io.BytesIO(raw)) as w:
        assert w.getframerate() == PREVIEW_RATE
        assert w.getnframes() / w.getframerate() == pytest.approx(5.0 + AUDIO_MARGIN_S, abs=0.01)
    short = tmp_path / "short.wav"
    write_wav(short, 0.3 * np.sin(2 * np.pi * 440 * t[: rate * 2]), 16000)
    html = player_html(positions, [-1, 0], ["root", "head"], 20.0, short)
    assert base64.b64decode(re.search(r"base64,([A-Za-z0-9+/=]+)", html).group(1)) == short.read_bytes()


# ------------------------------------------------------------------------------------------------ fault tests


def dance(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dance_core.cli.main", "-q", *args], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


@pytest.mark.slow
def test_sigkill_during_train_then_resume_equals_an_uninterrupted_run(tmp_path):
    sets = [*TINY, "training.steps=200", "training.checkpoint_every=10", "training.val_every=50"]
    args = [a for s in sets for a in ("--set", s)]
    run = tmp_path / "killed"
    proc = dance("train", "core-synthetic", "--out", str(run), *args)
    deadline = time.monotonic() + 120
    while not (run / "model.safetensors").exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)
    proc.kill()
    proc.wait()
    assert (run / LOCK_FILE).exists()  # SIGKILL left the lock behind
    step = load_checkpoint(run / "model.safetensors").step
    assert 10 <= step < 200, "the kill landed after the run ended; lower the sleep"
    resumed = dance("train", "core-synthetic", "--out", str(run), "--resume", *args)
    _, err = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, err
    assert "stale lock" in err and temps(run) == [] and not (run / LOCK_FILE).exists()
    from dance_core.recipe import load_recipe

    straight = train(load_recipe("core-synthetic", sets), out=str(tmp_path / "straight"), quiet=True)
    assert load_checkpoint(run / "model.safetensors").step == 200
    assert sha(run / "model.safetensors") == sha(straight.checkpoint)


@pytest.mark.slow
def test_sigkill_during_compose_then_a_retry_writes_the_whole_set(tiny_recipe, checkpoint, tmp_path):
    songs = [song(tmp_path / f"s{k}.wav", 20.0) for k in range(3)]
    out = tmp_path / "out"
    args = ["compose", "core-synthetic", "--checkpoint", str(checkpoint), "--music", *songs, "-o", str(out),
            "--samples", "2", *[a for s in TINY for a in ("--set", s)]]
    proc = dance(*args)
    time.sleep(4.0)  # in generation or writing, whichever it has reached
    proc.kill()
    proc.wait()
    out.mkdir(exist_ok=True)
    finals = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    for k in range(3):  # at the kill: each song's set whole or absent (a song's files are one output set)
        assert len([f for f in finals if f.startswith(f"s{k}-")]) in (0, 2), finals
    stale = out / f".s0-0.npz.dance-{dead_pid()}-abcdefgh.npz"  # what a kill inside the write pass leaves
    stale.write_bytes(b"")
    retry = dance(*args)
    _, err = retry.communicate(timeout=300)
    assert retry.returncode == 0, err
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"s{k}-{i}.npz" for k in range(3) for i in range(2)] + [f".s{k}.outputs.json" for k in range(3)])
    with np.load(out / "s2-1.npz") as f:
        assert f["values"].shape == (400, 18)


def test_install_sigterm_handler_turns_sigterm_into_an_interrupt(tmp_path):
    script = textwrap.dedent(f"""
        import time
        from dance_core.atomic import install_sigterm_handler
        install_sigterm_handler()
        try:
            print("ready", flush=True)
            {WAIT}
        except KeyboardInterrupt as exc:
            print(type(exc).__name__, exc)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout.readline().strip() == "ready"
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=30)
    assert out.strip() == "Terminated terminated (SIGTERM)"


def test_atomic_path_refuses_a_folder_target_and_cleans_up_after_errors(tmp_path):
    (tmp_path / "dir.bvh").mkdir()
    with pytest.raises(DataError, match="is a folder"), atomic_path(tmp_path / "dir.bvh"):
        pass
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "x.txt") as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.bvh"]
