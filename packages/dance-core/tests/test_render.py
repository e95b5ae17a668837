import base64
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from dance_core.cli.main import main
from dance_core.errors import DataError
from dance_core.formats.bvh import BvhFormat
from dance_core.formats.wav import write_wav
from dance_core.render.preview import render
from dance_core.synth.synthetic_dance import make_clip


@pytest.fixture(scope="module")
def dance(tmp_path_factory):
    """A 3-second synthetic dance at 30 fps, its song as WAV, and the dance as BVH."""
    root = tmp_path_factory.mktemp("render")
    clip = make_clip(0, seed=11, seconds=3.0, bpm=(110.0, 110.0), rate=16000, fps=30.0)
    write_wav(root / "song.wav", clip.audio.samples, clip.audio.rate)
    BvhFormat().write_motion(clip.motion.skeleton_motion, root / "dance.bvh")
    return clip.motion.skeleton_motion, root / "song.wav", root / "dance.bvh"


def test_gif_has_one_frame_per_motion_frame_and_the_right_duration(dance, tmp_path):
    from PIL import Image

    motion, _, _ = dance
    n = render(motion, tmp_path / "d.gif", width=200, height=160)
    with Image.open(tmp_path / "d.gif") as im:
        assert im.n_frames == n == 75 and im.size == (200, 160)  # 30 fps shown at 25 (4 cs per frame)
        durations = []
        for i in range(im.n_frames):
            im.seek(i)
            durations.append(im.info["duration"])
        assert set(durations) == {40} and sum(durations) == 3000
        im.seek(0)
        first = np.asarray(im.convert("RGB"))
        im.seek(45)
        middle = np.asarray(im.convert("RGB"))
    assert (first < 200).any() and np.abs(first.astype(int) - middle).sum() > 0  # something drawn, and it moves


def ffprobe(path):
    from dance_core.render.video import ffmpeg_exe

    return subprocess.run([ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True, text=True).stderr


def test_mp4_has_the_frames_the_duration_and_the_music(dance, tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    import imageio_ffmpeg

    motion, song, _ = dance
    n = render(motion, tmp_path / "d.mp4", song, width=160, height=120)
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "d.mp4"))
    assert frames == n == 90 and seconds == pytest.approx(3.0, abs=0.05)
    info = ffprobe(tmp_path / "d.mp4")
    assert "Video: h264" in info and "Audio: aac" in info
    assert re.search(r"Duration: 00:00:0(2\.9|3\.0)", info)


def test_html_player_is_self_contained_and_carries_motion_and_music(dance, tmp_path):
    motion, song, _ = dance
    n = render(motion, tmp_path / "d.html", song)
    html = (tmp_path / "d.html").read_text()
    assert n == motion.n_frames
    for ref in ("http://", "https://", "//cdn", "<link", "src=\"http", "import(", "fetch("):
        assert ref not in html
    assert not re.search(r"<script[^>]*\ssrc=", html)
    blob = re.search(r'<script type="application/json" id="motion">(.*?)</script>', html, re.S).group(1)
    data = json.loads(blob)
    assert data["frames"] == 90 and data["fps"] == 30.0 and len(data["parents"]) == 24
    np.testing.assert_allclose(np.reshape(data["positions"], (90, 24, 3)), motion.positions(), atol=6e-4)
    audio = re.search(r'src="data:audio/wav;base64,([A-Za-z0-9+/=]+)"', html).group(1)
    assert base64.b64decode(audio) == song.read_bytes()


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node to run the player's script")
def test_html_player_script_runs_plays_and_draws(dance, tmp_path):
    motion, _, _ = dance
    render(motion, tmp_path / "p.html")
    html = (tmp_path / "p.html").read_text()
    blob = re.search(r'<script type="application/json" id="motion">(.*?)</script>', html, re.S).group(1)
    script = re.findall(r"<script>(.*?)</script>", html, re.S)[0]
    harness = """
const calls = {lineTo: 0, arc: 0, bad: 0};
const ctx = new Proxy({}, {get: (t, k) => k in t ? t[k] : (...a) => {
  if (k in calls) calls[k]++; for (const v of a) if (typeof v === "number" && !isFinite(v)) calls.bad++; }});
const els = {};
function el(id) { return els[id] || (els[id] = {id, textContent: "", value: 0, width: 720, height: 540,
  getContext: () => ctx, setPointerCapture() {}, style: {}}); }
els.motion = {textContent: BLOB};
els.music = null;
global.document = {getElementById: id => id === "music" ? null : el(id), addEventListener() {}};
global.performance = {now: () => Date.now()};
let frames = 0;
global.requestAnimationFrame = f => { if (frames++ < 5) setTimeout(f, 40); };
SCRIPT
els.play.onclick();
setTimeout(() => {
  els.scrub.value = 60; els.scrub.oninput();
  console.log(JSON.stringify({calls, label: els.clock.textContent, button: els.play.textContent}));
}, 400);
""".replace("BLOB", json.dumps(blob)).replace("SCRIPT", script)
    (tmp_path / "run.js").write_text(harness)
    out = subprocess.run(["node", str(tmp_path / "run.js")], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["calls"]["bad"] == 0 and result["calls"]["lineTo"] > 100 and result["calls"]["arc"] >= 24
    assert result["label"] == "2.00 s" and result["button"] == "Pause"


def test_dance_render_cli_writes_all_three(dance, tmp_path, capsys):
    _, song, bvh = dance
    outs = [tmp_path / "a.gif", tmp_path / "a.mp4", tmp_path / "a.html"]
    args = ["render", str(bvh), "--music", str(song), "--size", "160", "120", "--seconds", "1"]
    assert main([*args, *[x for o in outs for x in ("-o", str(o))]]) == 0
    assert all(o.stat().st_size > 1000 for o in outs)
    assert "a.gif (25 frames)" in capsys.readouterr().out


def test_render_errors_are_one_line(dance, tmp_path, capsys):
    motion, _, bvh = dance
    with pytest.raises(DataError, match="cannot render '.png'"):
        render(motion, tmp_path / "x.png")
    assert main(["render", str(bvh), "--music", str(tmp_path / "nope.wav"), "-o", str(tmp_path / "x.html")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nope.wav: music file not found" in err
