"""dance live with the bundled model: live features, generation and poses equal offline where they should,
a song piped in at real time comes out covering the song, bad input ends with one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

AUDIO = Path(__file__).resolve().parents[3].parent / "shared" / "fixtures" / "audio"
DANCE = [sys.executable, "-m", "dance_core.cli.main"]


@pytest.fixture(scope="module")
def composer():
    from dance_core.api import Composer
    from dance_core.recipe import load_recipe

    # live starts from the seed as the music starts: compared with compose without its lead-in (a pre-roll
    # of the song's opening, which live cannot have)
    return Composer(load_recipe("default", ["compose.lead_in=false"]))


def _pcm(seconds: float | None = None) -> bytes:
    """sample.wav as raw s16le mono PCM at 22050 Hz."""
    from dance_audio.timing import resample
    from dance_core.data.features import load_audio
    from dance_core.registry import get_registry

    audio = load_audio(AUDIO / "sample.wav", get_registry())
    y = resample(audio.samples, audio.rate, 22050)
    return (np.clip(y, -1, 1) * 32767).astype("<i2").tobytes()


def test_live_features_equal_offline_and_generation_and_poses_too(composer):
    from dance_core.live.features import LiveFeatures
    from dance_core.live.generator import LiveGenerator
    from dance_core.live.pose import PoseDecoder

    song = composer.song(AUDIO / "sample.wav")
    audio = __import__("dance_core.data.features", fromlist=["load_audio"]).load_audio(
        AUDIO / "sample.wav", composer.registry)
    live = LiveFeatures(composer.stack, composer.checkpoint, audio.rate)
    parts = [live.push(audio.samples[lo : lo + 700]) for lo in range(0, len(audio.samples), 700)] + [live.finish()]
    music = np.concatenate([p["music"] for p in parts])
    assert music.shape == song.streams["music"].shape
    assert np.abs(music - song.streams["music"]).max() < 1e-4  # log-mel and onset: the offline maths
    assert 0.04 < live.lookahead < 0.1
    # the model fed the offline features frame by frame gives compose's frames exactly
    offline = composer.generate(song)[0]
    gen, frames = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device), []
    for i in range(song.n_frames):
        gen.add({n: v[i : i + 1] for n, v in song.streams.items()})
        assert gen.ready() <= max(0, i + 2 - composer.model.window.cond_future - len(frames))
        while gen.ready():
            frames.append(gen.step())
    gen.end()
    while gen.ready():
        frames.append(gen.step())
    assert np.array_equal(np.concatenate(frames), offline)
    decoder = PoseDecoder(composer.checkpoint, composer.registry, composer.recipe.fps)
    poses = [decoder(f) for f in offline]
    info = composer.checkpoint.motion  # the offline decoding of the whole dance, before grounding
    whole = info.decode(composer.checkpoint.stats.motion.invert(offline), composer.recipe.fps,
                        composer.registry).skeleton_motion
    assert np.abs(np.stack([p.positions for p in poses]) - whole.positions()).max() < 1e-6


def _feed(proc, data: bytes, speed: float, stop_early: bool = False) -> None:
    """Write PCM to the process at ``speed`` times real time (22050 Hz, 2 bytes a sample)."""
    chunk = 2 * 1024
    for lo in range(0, len(data), chunk):
        proc.stdin.write(data[lo : lo + chunk])
        proc.stdin.flush()
        time.sleep(1024 / 22050 / speed)
    if not stop_early:
        proc.stdin.close()


def _outputs(proc) -> tuple[bytes, bytes]:
    """Standard output to its end, then standard error (the feeder writes standard input meanwhile)."""
    out = proc.stdout.read()
    err = proc.stderr.read()
    proc.wait(timeout=300)
    return out, err


def _live(*args: str) -> subprocess.Popen:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.Popen([*DANCE, "live", "default", *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env)


def test_pcm_piped_at_real_time_yields_frames_covering_the_song():
    data = _pcm()
    proc = _live("--input", "-", "--rate", "22050", "--output", "-", "--json", "--max-lag", "60")
    threading.Thread(target=_feed, args=(proc, data, 8.0), daemon=True).start()
    out, err = _outputs(proc)
    assert proc.returncode == 0, err.decode()
    lines = [json.loads(line) for line in out.decode().splitlines()]
    skeleton, frames = lines[0]["skeleton"], lines[1:]
    assert skeleton["joints"][0] == "Pelvis" and len(skeleton["parents"]) == len(skeleton["offsets"]) == 24
    seconds = len(data) / 2 / 22050
    assert [f["frame"] for f in frames] == list(range(int(np.ceil(seconds * 20))))
    assert frames[0]["t"] == 0 and frames[-1]["t"] == pytest.approx(seconds, abs=0.05)
    assert np.array(frames[-1]["positions"]).shape == (24, 3) and np.array(frames[-1]["rotations"]).shape == (24, 4)
    summary = json.loads(err.decode()[err.decode().index("{"):])
    assert summary["frames"] == len(frames) and summary["dropped_frames"] == 0
    assert summary["latency_ms"]["p50"] > 0 and summary["music_delay_s"] == pytest.approx(0.5564, abs=1e-3)
    # the default recipe grounds and beat-aligns: live, causally; the dance plays behind what was generated
    assert summary["grounded"] is True and 0.3 <= summary["beat_lock"]["lag_s"]["max"] <= 1.6


def test_an_audio_file_on_stdin_and_a_stream_that_stops_end_with_one_line_and_intact_output():
    with open(AUDIO / "sample.wav", "rb") as f:
        wav = f.read()
    proc = _live("--input", "-", "--output", "-")
    out, err = proc.communicate(wav, timeout=300)
    assert proc.returncode == 1 and err.decode().count("\n") == 1
    assert "the stream is a WAV file, not raw s16le mono PCM" in err.decode()
    assert all(json.loads(line) for line in out.decode().splitlines())  # what was written is whole
    data = _pcm()
    proc = _live("--input", "-", "--output", "-", "--idle", "1", "--max-lag", "60")
    _feed(proc, data[: len(data) // 2], 8.0, stop_early=True)
    out, err = _outputs(proc)
    proc.stdin.close()
    assert proc.returncode == 1 and err.decode().strip().endswith("no audio for 1 s; the stream stopped")
    lines = [json.loads(line) for line in out.decode().splitlines()]
    assert "skeleton" in lines[0] and len(lines) > 5 and [f["frame"] for f in lines[1:]] == list(range(len(lines) - 1))


def _live_mic(library: str, **env: str) -> subprocess.Popen:
    """``dance live default --input mic --output - --json`` with ``library`` (a folder of this file's) standing in
    for sounddevice; Ctrl-C (SIGINT) reaches it as from a terminal, even where this test runs as a background job
    (whose children start with SIGINT ignored, and Python then leaves it so)."""
    path = os.pathsep.join(p for p in (str(Path(__file__).parent / library), os.environ.get("PYTHONPATH")) if p)
    run = ("import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
           "sys.argv = ['dance', *sys.argv[1:]]; runpy.run_module('dance_core.cli.main', run_name='__main__')")
    return subprocess.Popen([sys.executable, "-c", run, "live", "default", "--input", "mic", "--output", "-", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=path, **env))


@pytest.mark.parametrize("stop, seconds", [(signal.SIGINT, 4), (signal.SIGTERM, 2)])
def test_the_microphone_dances_as_it_records_until_ctrl_c_or_a_sigterm(stop, seconds):
    """``--input mic`` through sounddevice (a stand-in device recording a 120-BPM click track at real time): frames
    come as it records, the tracker finds the clicks' tempo, and Ctrl-C, or SIGTERM (a service manager stopping
    it), ends the session cleanly: every line written whole, the summary counting the music heard (0 s before: it
    was counted only when a stream ended)."""
    proc = _live_mic("fake_audio_device")
    head = [proc.stdout.readline() for _ in range(1 + 20 * seconds)]  # the skeleton and the frames at 20 fps
    proc.send_signal(stop)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err.decode()
    lines = [json.loads(line) for line in (b"".join(head) + out).decode().splitlines()]
    assert "skeleton" in lines[0] and [f["frame"] for f in lines[1:]] == list(range(len(lines) - 1))
    summary = json.loads(err.decode()[err.decode().index("{"):])
    assert summary["stopped"] == "interrupted" and summary["input"] == "mic" and summary["frames"] == len(lines) - 1
    assert lines[-1]["t"] - 0.1 <= summary["music_seconds"] <= lines[-1]["t"] + 1.5  # the frames reach what was heard
    assert summary["beat_lock"]["tempo_bpm"] == pytest.approx(120.0, abs=3.0)


def test_no_input_device_or_no_audio_library_is_one_line_and_no_output():
    for library, env, why in (("fake_audio_device", {"FAKE_AUDIO_DEVICE": "none"}, "no usable input device"),
                              ("no_audio_library", {}, "no audio input library; install it with pip install")):
        out, err = _live_mic(library, **env).communicate(timeout=120)
        assert out == b"" and err.decode().count("\n") == 1 and f"--input mic: {why}" in err.decode()


def test_a_port_in_use_is_one_line_before_the_model_loads():
    import socket

    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    try:
        proc = _live("--input", str(AUDIO / "sample.wav"), "--output", f"ws://127.0.0.1:{taken.getsockname()[1]}")
        out, err = proc.communicate(timeout=120)
    finally:
        taken.close()
    assert proc.returncode == 1 and "cannot listen: the port is in use" in err.decode() and out == b""


def test_osc_and_websocket_sinks_at_once(composer):
    import socket

    from dance_core.live.osc import OscSink, parse
    from dance_core.live.session import LiveSession
    from dance_core.live.sources import FileSource
    from dance_core.live.websocket import WebSocketSink

    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    listener.bind(("127.0.0.1", 0))
    ws = WebSocketSink("127.0.0.1", 0)
    sinks = [OscSink("127.0.0.1", listener.getsockname()[1]), ws]
    source = FileSource(str(AUDIO / "sample.wav"), composer.registry, composer.recipe.format_options, speed=4.0)
    summary = LiveSession(composer, source, sinks, max_lag=60).run()
    packets = []
    listener.setblocking(False)
    while True:
        try:
            packets.append(parse(listener.recv(65536)))
        except BlockingIOError:
            break
    listener.close()
    assert summary["frames"] == 57 and summary["outputs"]["osc"]["sent"] == 57
    assert 0 < len(packets) <= 57  # UDP on localhost may lose datagrams when the listener's buffer fills
    bones = {args[0] for address, args in packets[-1] if address == "/VMC/Ext/Bone/Pos"}
    assert {"Hips", "Head", "LeftHand", "RightFoot"} <= bones and len(bones) == 22
    assert summary["outputs"]["ws"]["sent"] == 57 and summary["outputs"]["osc"]["dropped"] == 0


@pytest.fixture(scope="module")
def dance_20s(composer):
    """The bundled model's frames for the first 20 s of hungarian_dance_5.ogg, generated as live does."""
    from dance_core.live.generator import LiveGenerator

    song = composer.song(AUDIO / "hungarian_dance_5.ogg", 20.0)
    gen = LiveGenerator(composer.model, composer.recipe, composer.seed(), composer.device)
    gen.add(song.streams)
    gen.end()
    frames = []
    while gen.ready():
        frames.append(gen.step())
    return np.concatenate(frames)


def test_live_poses_are_grounded_causally(composer, dance_20s):
    from dance_core.live.pose import LivePoses, PoseDecoder
    from dance_core.motion.grounding import GroundingOptions, find_feet, foot_contacts, foot_speeds, soles
    from dance_core.motion.motion import Motion

    fps = composer.recipe.fps
    raw_decoder, decoder = (PoseDecoder(composer.checkpoint, composer.registry, fps) for _ in range(2))
    grounding = LivePoses(decoder, ground=True)
    raw = [raw_decoder(f) for f in dance_20s]
    live = [grounding(i, f) for i, f in enumerate(dance_20s)]
    skeleton = decoder.skeleton
    motions = [Motion(skeleton, fps, np.stack([p.root for p in ps]), np.stack([p.rotations for p in ps]))
               for ps in (raw, live)]
    np.testing.assert_allclose(np.stack([p.positions for p in live]), motions[1].positions(), atol=1e-9)
    feet = find_feet(skeleton)
    on_floor = [float(np.mean(np.abs(soles(m).min(1)) < 0.03)) for m in motions]
    assert on_floor[1] >= 0.9 and on_floor[1] > on_floor[0]  # raw: 0.90, live: 0.98
    # skating: horizontal speed of the feet where the raw dance's own contacts are
    contacts = foot_contacts(soles(motions[0]), foot_speeds(motions[0].positions(), feet, fps, vertical=True), fps,
                             GroundingOptions())
    skating = [foot_speeds(m.positions(), feet, fps)[contacts].mean() for m in motions]
    assert contacts.mean() > 0.3 and skating[1] < 0.5 * skating[0]  # raw 30 cm/s, live 8 cm/s


def test_beat_locked_poses_are_grounded_with_a_look_ahead_inside_the_lag(composer, dance_20s):
    """With the beat lock, each pose is grounded with the frames after it (BufferedGrounding): the lock never
    plays a frame whose grounding is not done, so the look-ahead costs no latency, and the figure stays on the
    floor, no foot below it by more than 1 cm (the causal grounding here: 2.1 cm below), and both soles more
    than 5 cm up in under 2 % of frames (1.0 % with the weights of 2 Dec 2026 12:40, which float 1-2 % offline;
    the weights before: 0-0.3 %). The grounded frames keep every sole on or above the floor; between them the
    lock's interpolation (root linear, rotations slerped) can take a foot the knee-keeping drop holds on the
    floor 5 mm below it."""
    from dance_core.live.beat_lock import MAX_LAG, BeatClock
    from dance_core.live.pose import LivePoses, PoseDecoder
    from dance_core.motion.buffered_grounding import BufferedGrounding
    from dance_core.motion.grounding import soles
    from dance_core.motion.motion import Motion

    fps = composer.recipe.fps
    clock = BeatClock(fps)
    poses = LivePoses(PoseDecoder(composer.checkpoint, composer.registry, fps), True, clock, lookahead=0.25)
    assert isinstance(poses.grounding, BufferedGrounding) and poses.lookahead == 0.25
    delay = poses.grounding.delay
    out = []
    for i, f in enumerate(dance_20s):
        phase = (i / fps / 0.5) % 1.0  # a 120 BPM clock
        clock.update(i, float(np.sin(2 * np.pi * phase)), float(np.cos(2 * np.pi * phase)))
        out.append(poses(i, f))
        assert poses.lock.source <= i - delay + 1e-9  # never a frame whose grounding waits for later frames
        assert i < delay or poses.lock.newest == i - delay
    lags = np.asarray(poses.lock.lags)
    assert lags.min() >= delay / fps - 1e-9 and lags.max() <= MAX_LAG + 1e-9
    motion = Motion(poses.decoder.skeleton, fps, np.stack([p.root for p in out]), np.stack([p.rotations for p in out]))
    h = soles(motion)
    assert np.mean(h.min(1) > 0.05) < 0.02 and h.min() > -0.01


def test_the_figure_stands_at_rest_while_the_music_is_silent_and_dances_when_it_plays(composer, tmp_path):
    """Four seconds of silence, then music: the figure comes to rest standing at ease (the model dances on beneath) and
    dances with the music; with ``silence=None`` (``--silence off``) it dances through the silence."""
    import io

    import soundfile as sf

    from dance_core.data.features import load_audio
    from dance_core.live.session import LiveSession
    from dance_core.live.silence import AHEAD, EASE_IN, FLOOR_DB, HOLD
    from dance_core.live.sinks import JsonLinesSink
    from dance_core.live.sources import FileSource

    music = load_audio(AUDIO / "hungarian_dance_5.ogg", composer.registry)
    song = np.concatenate([np.zeros(4 * music.rate, np.float32), music.samples[: 4 * music.rate]])
    path = tmp_path / "pause.wav"
    sf.write(path, song, music.rate)
    speeds, summaries = [], []
    for silence in (FLOOR_DB, None):
        out = io.BytesIO()
        out.close = lambda: None  # read after the session
        source = FileSource(str(path), composer.registry, composer.recipe.format_options, speed=6.0)
        summaries.append(LiveSession(composer, source, [JsonLinesSink(out)], max_lag=60, silence=silence).run())
        frames = [json.loads(line) for line in out.getvalue().decode().splitlines()[1:]]
        p = np.array([f["positions"] for f in frames])
        speeds.append(np.linalg.norm(np.diff(p, axis=0), axis=2).max(1) * composer.recipe.fps)
    fps = composer.recipe.fps
    pause, playing = slice(int((HOLD + EASE_IN) * fps), int((4.0 - AHEAD) * fps) - 1), slice(int(4.2 * fps), None)
    assert 1e-4 < speeds[0][pause].max() < 0.08 and summaries[0]["silence"]["rested_s"] > 2.0  # at ease, not dancing
    assert speeds[1][pause].mean() > 0.1 and summaries[1]["silence"] is None  # off: it dances on
    assert speeds[0][playing].mean() > 0.3  # and dances when the music plays


class _Blocks:
    """A source giving a song in blocks of ``block`` samples, ``pause`` seconds apart (0: as fast as read)."""

    def __init__(self, samples: np.ndarray, rate: int, block: int, pause: float):
        self.samples, self.rate, self.block, self.pause, self.name = samples, rate, block, pause, "blocks"

    def blocks(self):
        """The blocks, in order."""
        for lo in range(0, len(self.samples), self.block):
            time.sleep(self.pause)
            yield self.samples[lo : lo + self.block]

    def close(self) -> None:
        """Nothing to release."""


def test_the_same_song_gives_the_same_live_dance_however_its_audio_arrives(composer):
    """The same blocks arriving far ahead of the model or at its pace give the same frames, to the byte (the
    beat lock hears the tracker up to the music each frame waited for, the rest gate likewise); before, the
    lock heard whatever had arrived, and at real time the dance differed from the same blocks read at once by
    1.5 cm within 10 s. Blocks of other sizes
    differ only in float32's last bit of the log-mel (the mel product's BLAS blocking), well under 1 mm."""
    import io

    from dance_core.data.features import load_audio
    from dance_core.live.session import LiveSession
    from dance_core.live.sinks import JsonLinesSink

    music = load_audio(AUDIO / "vibe_ace.ogg", composer.registry)
    y = music.samples[: 10 * music.rate]
    outputs = []
    for block, pause in ((4410, 0.0), (4410, 0.2), (512, 0.0)):  # all at once; at real time; other blocks
        out = io.BytesIO()
        out.close = lambda: None
        source = _Blocks(y, music.rate, block, pause)
        summary = LiveSession(composer, source, [JsonLinesSink(out)], max_lag=60).run()
        assert summary["dropped_frames"] == 0 and summary["beat_lock"]["accents"] > 5
        outputs.append(out.getvalue())
    assert len(outputs[0].splitlines()) == 1 + 10 * composer.recipe.fps
    assert outputs[0] == outputs[1]
    p = [np.array([json.loads(line)["positions"] for line in o.decode().splitlines()[1:]]) for o in outputs]
    assert np.abs(p[2] - p[0]).max() < 1e-3
