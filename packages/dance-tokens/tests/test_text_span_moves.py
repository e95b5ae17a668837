"""A text span makes the bundled tm2d-small perform the prompted move there, and the dance returns to
music after it: judged by kinematic move detectors that share no code with the model or the dancer."""

import numpy as np

from dance_core.cli.main import main
from dance_core.data.files import read_motion_file
from dance_core.data.synthetic_beats import click_track
from dance_core.evaluation.loading import joint_positions
from dance_core.evaluation.move_detect import detect, move_share
from dance_core.formats.wav import write_wav
from dance_core.registry import get_registry

SECONDS, START, END = 20.0, 6.0, 14.0  # the span; its ramps take 20 % at either end


def dances(folder, song, extra):
    """Three samples of the bundled model on ``song`` as joint positions (Y up, m)."""
    assert main(["-q", "compose", "tm2d-small", "--music", str(song), "-o", str(folder), "--format", "bvh",
                 "--set", "compose.samples=3", *extra]) == 0
    out = []
    for k in range(3):
        path = folder / f"song-{k}.bvh"
        positions, names, up = joint_positions(read_motion_file(path, get_registry()), str(path))
        assert up == "y" and names[0].lower() == "pelvis" and positions.shape[1] == 24
        out.append(positions)
    return out


def test_a_text_span_brings_its_move_and_the_dance_returns_to_music_after_it(tmp_path, monkeypatch):
    move, text = "jump", "a person jumps on the beat"
    rate = 16000
    song = tmp_path / "song.wav"
    write_wav(song, click_track(np.arange(0.25, SECONDS, 0.5), SECONDS, rate, np.random.default_rng(3)), rate)
    monkeypatch.chdir(tmp_path)
    plain = dances(tmp_path / "plain", song, [])
    steered = dances(tmp_path / "text", song, ["--text", f"{START:g}-{END:g}: {text}"])

    def share(positions, start, end):
        return move_share(detect(move, positions, 30.0), 30.0, start, end)

    inside = np.mean([share(p, START, END) for p in steered])
    music_inside = np.mean([share(p, START, END) for p in plain])
    before = np.mean([share(p, 0.0, START) for p in steered])
    after = np.mean([share(p, END + 1.0, SECONDS) for p in steered])  # a second for the decoder's reach
    music_after = np.mean([share(p, END + 1.0, SECONDS) for p in plain])
    assert inside >= 0.5, (inside, music_inside)  # the move is there most seconds of its span...
    assert inside - music_inside >= 0.3  # ...where the same noise without text does not make it
    assert inside - before >= 0.3 and inside - after >= 0.3  # and not before or after the span
    assert after <= music_after + 0.25  # after the span: back to the music-only dance's rate of the move
