"""``dance evaluate`` end to end on the synthetic choreography written to disk."""

import json
from pathlib import Path

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.data.dataset_configs import SyntheticBeatsConfig
from dance_core.data.synthetic_beats import SyntheticBeats
from dance_core.formats.npz import NpzFormat
from dance_core.formats.wav import write_wav
from dance_core.protocols import MotionData


@pytest.fixture(scope="module")
def synthetic_set(tmp_path_factory):
    """Four synthetic songs: reference motion, generated (= reference shifted and one frozen), music."""
    root = tmp_path_factory.mktemp("synthetic")
    data = SyntheticBeats(SyntheticBeatsConfig(songs=4, seconds=8.0, sample_rate=8000), fps=20.0)
    fmt = NpzFormat()
    for sub in ("reference", "generated", "music", "beats"):
        (root / sub).mkdir()
    for k, clip in enumerate(data.clips()):
        fmt.write(clip.motion, root / "reference" / f"{clip.name}.npz")
        values = clip.motion.values.copy()
        if k == 0:
            values[:] = values[0]  # a frozen dance
        fmt.write(MotionData(values, 20.0, clip.motion.channels), root / "generated" / f"{clip.name}-0.npz")
        write_wav(root / "music" / f"{clip.name}.wav", clip.audio.samples, clip.audio.rate)
        beats = "\n".join(f"{b:.6f}" for b in clip.meta["beats"])
        (root / "beats" / f"{clip.name}.beats").write_text(beats + "\n")
    return root


def test_evaluate_writes_report_table_and_plots(synthetic_set, capsys):
    out = synthetic_set / "out" / "report.json"
    rc = main(
        [
            "evaluate",  # not -q: the table is shown
            "--generated",
            str(synthetic_set / "generated"),
            "--reference",
            str(synthetic_set / "reference"),
            "--music",
            str(synthetic_set / "beats"),
            "-o",
            str(out),
        ]
    )
    assert rc == 0
    report = json.loads(out.read_text())
    values = report["values"]
    assert report["clips"] == {"generated": 4, "reference": 4} and report["fps"] == 20.0
    # one of four dances is frozen for its whole 8 s: PFF is 25 %
    assert values["PFF"] == pytest.approx(25.0)
    assert report["metrics"]["freezing"]["per_clip"]["synthetic-000-0"]["PFF"] == pytest.approx(100.0)
    assert values["FID_k"] > 0 and values["FMD"] > 0
    # the synthetic dancer has 6 unnamed joints: the SMPL-only metrics say why they did not run
    assert "24 SMPL joints" in report["skipped"]["fid-g"] and "ankle and toe" in report["skipped"]["pfc"]
    assert 0.0 <= values["BAS_bailando"] <= 1.0 and values["beat_offset_mean"] >= 0
    assert "music beats from beat annotation files (4 song(s))" in report["notes"]
    plots = report["plots"]
    assert any(p.endswith("freezing.png") for p in plots) and len(plots) == 5
    for p in plots:
        assert Path(p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    shown = capsys.readouterr().out
    assert "FID_k" in shown and "PFF" in shown


def test_evaluate_reference_against_itself_and_audio_beats(synthetic_set):
    out = synthetic_set / "self.json"
    rc = main(
        [
            "-q",
            "evaluate",
            "--generated",
            str(synthetic_set / "reference"),
            "--reference",
            str(synthetic_set / "reference"),
            "--music",
            str(synthetic_set / "music"),
            "--metrics",
            "fid-k",
            "fmd",
            "bas-bailando",
            "-o",
            str(out),
            "--no-plots",
        ]
    )
    assert rc == 0
    report = json.loads(out.read_text())
    assert report["values"]["FID_k"] == pytest.approx(0.0, abs=1e-6)
    assert report["values"]["FMD"] == pytest.approx(0.0, abs=1e-6)
    assert any("from energy onset peaks" in n or "flux tracker" in n for n in report["notes"])
    # beats found in the click tracks score like the annotated beats
    annotated = synthetic_set / "annotated.json"
    assert (
        main(
            [
                "-q",
                "evaluate",
                "--generated",
                str(synthetic_set / "reference"),
                "--no-plots",
                "--reference",
                str(synthetic_set / "reference"),
                "--music",
                str(synthetic_set / "beats"),
                "--metrics",
                "bas-bailando",
                "-o",
                str(annotated),
            ]
        )
        == 0
    )
    expected = json.loads(annotated.read_text())["values"]["BAS_bailando"]
    assert report["values"]["BAS_bailando"] == pytest.approx(expected, abs=0.03)


def test_onset_fallback_finds_click_track_beats():
    from dance_core.data.synthetic_beats import click_track
    from dance_core.evaluation.music import onset_envelope, onset_peaks
    from dance_core.media import Audio

    beats = np.arange(0.3, 9.5, 0.5)
    audio = Audio(click_track(beats, 10.0, 16000, np.random.default_rng(0)), 16000)
    found = onset_peaks(onset_envelope(audio), 100.0)
    assert len(found) == len(beats)
    np.testing.assert_allclose(found, beats, atol=0.02)


def test_evaluate_errors_are_one_line(synthetic_set, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    rc = main(["-q", "evaluate", "--generated", str(empty), "--reference", str(synthetic_set / "reference")])
    err = capsys.readouterr().err
    assert rc == 1 and "no motion files" in err and len(err.strip().splitlines()) == 1
    rc = main(
        [
            "-q",
            "evaluate",
            "--generated",
            str(synthetic_set / "generated"),
            "--reference",
            str(synthetic_set / "reference"),
            "--metrics",
            "fid-x",
        ]
    )
    assert rc == 1 and "unknown metric 'fid-x'" in capsys.readouterr().err
    rc = main(
        [
            "-q",
            "evaluate",
            "--generated",
            str(synthetic_set / "generated"),
            "--no-plots",
            "--reference",
            str(synthetic_set / "reference"),
            "--metrics",
            "bas-fact",
            "-o",
            str(tmp_path / "r.json"),
        ]
    )
    assert rc == 1 and "needs music beats" in capsys.readouterr().err


def test_evaluate_reads_only_the_suffixes_asked_for(synthetic_set, tmp_path, capsys):
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for p in (synthetic_set / "reference").iterdir():
        (mixed / p.name).write_bytes(p.read_bytes())
        (mixed / f"{p.stem}.json").write_text("{}")  # metadata next to the dances, as dance synth writes
    args = ["-q", "evaluate", "--generated", str(mixed), "--reference", str(synthetic_set / "reference")]
    args += ["--metrics", "fid-k", "--no-plots", "-o", str(tmp_path / "r.json")]
    assert main(args) == 1 and ".json" in capsys.readouterr().err
    assert main([*args, "--suffix", ".npz"]) == 0
    assert json.loads((tmp_path / "r.json").read_text())["values"]["FID_k"] == pytest.approx(0.0, abs=1e-6)
    assert main([*args, "--suffix", ".xyz"]) == 1
    assert "no motion format reads .xyz" in capsys.readouterr().err
