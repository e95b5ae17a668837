"""Optional extras stay optional: `dance compose default` (BVH + HTML) needs none of matplotlib,
librosa or madmom and reads no madmom file; without matplotlib, plots and GIF/MP4 previews fail with
one line naming the extra, before any work."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dance_core.errors import PluginError

COMPOSE = textwrap.dedent(
    """
    import importlib.util, sys
    from pathlib import Path

    spec = importlib.util.find_spec("madmom")
    madmom_dir = str(Path(spec.origin).parent) + "/" if spec and spec.origin else None  # its models/ inside
    read = []

    def audit(event, args):
        if event == "open" and madmom_dir and isinstance(args[0], str) and args[0].startswith(madmom_dir):
            read.append(args[0])

    sys.addaudithook(audit)
    from dance_core.cli.main import main

    assert main(["synth", "song.wav", "--seconds", "4", "--bpm", "124"]) == 0
    assert main(["-q", "compose", "default", "--music", "song.wav", "-o", "out"]) == 0
    assert Path("out/song.bvh").is_file() and Path("out/song.html").is_file(), sorted(Path("out").iterdir())
    heavy = ("matplotlib", "PIL", "librosa", "madmom", "imageio_ffmpeg")
    print(sorted(m for m in heavy if m in sys.modules), read)
    """
)


def test_compose_default_imports_no_optional_extra_and_reads_no_madmom_file(tmp_path):
    result = subprocess.run(
        [sys.executable, "-c", COMPOSE], capture_output=True, text=True, timeout=600, cwd=tmp_path, check=False,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.strip().splitlines()[-1] == "[] []"


@pytest.fixture
def no_matplotlib(monkeypatch):
    """As if matplotlib (and so Pillow, which comes with it) were not installed."""
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "PIL", None)


def _motion():
    positions = np.zeros((3, 2, 3))
    positions[:, 1, 1] = 1.0
    return positions, [-1, 0], ["Hips", "Head"]


def _one_line(exc: Exception, extra: str) -> None:
    message = str(exc)
    assert f"pip install '{extra}'" in message and "matplotlib" in message and "\n" not in message


def test_previews_without_matplotlib_are_one_line(no_matplotlib, tmp_path):
    from dance_core.render.frames import render_frames
    from dance_core.render.video import write_gif

    positions, parents, names = _motion()
    with pytest.raises(PluginError) as info:
        render_frames(positions, parents, names, 20.0)  # at the call, not at the first frame
    _one_line(info.value, "dance-core[plots]")
    with pytest.raises(PluginError) as info:
        write_gif(tmp_path / "a.gif", positions, parents, names, 20.0)
    _one_line(info.value, "dance-core[plots]")
    assert not (tmp_path / "a.gif").exists()


def test_evaluation_plots_without_matplotlib_are_one_line(no_matplotlib, tmp_path):
    from dance_core.evaluation.plots import plot_freezing

    with pytest.raises(PluginError) as info:
        plot_freezing([], tmp_path / "freezing.png")
    _one_line(info.value, "dance-core[plots]")


def test_dance_features_plot_without_matplotlib_is_one_line_before_any_work(no_matplotlib, tmp_path, capsys):
    from dance_core.cli.main import main

    song, out = tmp_path / "song.wav", tmp_path / "f.npz"
    assert main(["synth", str(song), "--seconds", "2"]) == 0
    capsys.readouterr()
    code = main(["features", str(song), "-x", "onset", "-o", str(out), "--plot", str(tmp_path / "f.png")])
    err = capsys.readouterr().err.strip()
    assert code != 0 and len(err.splitlines()) == 1 and "pip install 'dance-audio[plots]'" in err
    assert not out.exists()
