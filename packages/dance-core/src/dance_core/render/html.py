"""A self-contained HTML player: motion and music embedded, orbit camera, play/pause/scrub, audio-driven clock.

The camera follows the dancer: its view centre is the root's ground position smoothed over time
(computed here and embedded), its distance is set by the body's size, not by the room danced in.
No CDN, no third-party script, no network reference: the page opens offline from a single file.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import re
import wave
from pathlib import Path

import numpy as np
from scipy.signal import filtfilt

from dance_core.atomic import write_text
from dance_core.checks import nonfinite_reason
from dance_core.errors import DataError
from dance_core.render.frames import bone_colors

#: seconds of music embedded past the dance's last frame
AUDIO_MARGIN_S = 1.0
#: highest sample rate of embedded cut music (a preview player's speaker, not a master)
PREVIEW_RATE = 22050

AUDIO_TYPES = {".wav": "audio/wav", ".wave": "audio/wav", ".ogg": "audio/ogg", ".oga": "audio/ogg",
               ".mp3": "audio/mpeg", ".flac": "audio/flac", ".m4a": "audio/mp4", ".opus": "audio/ogg"}

_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>__TITLE__</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body{margin:0;font:14px system-ui,sans-serif;background:#fafafa;color:#222}
#wrap{max-width:720px;margin:12px auto;padding:0 8px}
canvas{width:100%;background:#fff;border:1px solid #ddd;border-radius:6px;cursor:grab;touch-action:none}
#bar{display:flex;gap:8px;align-items:center;margin-top:6px}
#scrub{flex:1}button{min-width:64px}
</style></head><body><div id="wrap">
<h3 id="title"></h3>
<canvas id="view" width="720" height="540"></canvas>
<div id="bar"><button id="play">Play</button><input id="scrub" type="range" min="0" value="0" step="1">
<span id="clock">0.00 s</span></div>
<p style="color:#777">Drag to orbit, wheel to zoom, space to play or pause.</p>
__AUDIO__
</div>
<script type="application/json" id="motion">__DATA__</script>
<script>
(function(){
"use strict";
const D = JSON.parse(document.getElementById("motion").textContent);
const J = D.parents.length, T = D.frames, fps = D.fps;
const P = D.positions;  // flat: frame-major, joint, xyz
const F = D.follow;     // flat: frame-major, smoothed root x, z (the view centre)
const cv = document.getElementById("view"), g = cv.getContext("2d");
const scrub = document.getElementById("scrub"), playBtn = document.getElementById("play");
const clock = document.getElementById("clock"), audio = document.getElementById("music");
document.getElementById("title").textContent = D.title;
scrub.max = T - 1;
let az = 0.6, el = 0.25, zoom = 1.0, playing = false, frame = 0, t0 = 0, f0 = 0;
const H = Math.max(D.body, 1e-6), floor = D.floor, cy = floor + D.stature / 2, step = H / 2;
let cam = null;
function camera(f) {  // basis and eye for frame f: looks at the followed root from a body-sized distance
  const ce = Math.cos(el), se = Math.sin(el);
  const fx = -Math.sin(az)*ce, fy = -se, fz = -Math.cos(az)*ce;
  const rn = Math.hypot(fz, fx), rx = -fz/rn, rz = fx/rn;
  const ux = -rz*fy, uy = rz*fx - rx*fz, uz = rx*fy;
  const dist = (1.7*H + 1.5*D.wander) * zoom;
  const cx = F[2*f], cz = F[2*f+1];
  return {cx, cz, fx, fy, fz, rx, rz, ux, uy, uz, ex: cx - fx*dist, ey: cy - fy*dist, ez: cz - fz*dist,
          near: 0.05 * H, s: 1.7 * cv.height / 2};
}
function toCam(x, y, z) {
  const c = cam, dx = x-c.ex, dy = y-c.ey, dz = z-c.ez;
  return [dx*c.rx + dz*c.rz, dx*c.ux + dy*c.uy + dz*c.uz, dx*c.fx + dy*c.fy + dz*c.fz];
}
function toPix(q) { const d = Math.max(q[2], cam.near), s = cam.s / d;
  return [cv.width/2 + q[0]*s, cv.height/2 - q[1]*s]; }
function project(x, y, z) { return toPix(toCam(x, y, z)); }
function line(a, b) {  // a world segment, clipped to the near plane
  let p = toCam(a[0], a[1], a[2]), q = toCam(b[0], b[1], b[2]); const n = cam.near;
  if (p[2] < n && q[2] < n) return;
  if (p[2] < n || q[2] < n) { const k = (n - p[2]) / (q[2] - p[2]), m = [0, 1, 2].map(i => p[i] + k*(q[i]-p[i]));
    if (p[2] < n) p = m; else q = m; }
  const u = toPix(p), v = toPix(q);
  g.beginPath(); g.moveTo(u[0], u[1]); g.lineTo(v[0], v[1]); g.stroke();
}
const view = {frame: 0, bbox: [0, 0, 0, 0], width: cv.width, height: cv.height};
function draw() {
  cam = camera(frame);
  g.clearRect(0, 0, cv.width, cv.height);
  const n = 12, gx = Math.round(cam.cx / step) * step, gz = Math.round(cam.cz / step) * step;
  g.strokeStyle = "#e2e2e2"; g.lineWidth = 1;
  for (let k = -n; k <= n; k++) {  // floor lines fixed in the world, around the view centre
    line([gx + k*step, floor, gz - n*step], [gx + k*step, floor, gz + n*step]);
    line([gx - n*step, floor, gz + k*step], [gx + n*step, floor, gz + k*step]);
  }
  g.strokeStyle = "#8bc34a"; g.lineWidth = 2;
  for (let t = Math.max(0, frame - 3*fps|0); t < frame; t++)
    line([P[t*J*3], floor, P[t*J*3+2]], [P[(t+1)*J*3], floor, P[(t+1)*J*3+2]]);
  const o = frame*J*3, pts = [];
  for (let j = 0; j < J; j++) pts.push(project(P[o+3*j], P[o+3*j+1], P[o+3*j+2]));
  g.lineCap = "round"; g.lineWidth = 5;
  for (let j = 0; j < J; j++) { const p = D.parents[j]; if (p < 0) continue;
    g.strokeStyle = D.colors[j]; g.beginPath(); g.moveTo(pts[p][0], pts[p][1]);
    g.lineTo(pts[j][0], pts[j][1]); g.stroke(); }
  g.fillStyle = "#222"; for (const q of pts) { g.beginPath(); g.arc(q[0], q[1], 2.5, 0, 6.283); g.fill(); }
  scrub.value = frame; clock.textContent = (frame / fps).toFixed(2) + " s";
  view.frame = frame;
  const xs = pts.map(q => q[0]), ys = pts.map(q => q[1]);
  view.bbox = [Math.min(...xs), Math.min(...ys), Math.max(...xs), Math.max(...ys)];
}
function now() { return audio ? audio.currentTime : f0 / fps + (performance.now() - t0) / 1000; }
function tick() {
  if (!playing) return;
  frame = Math.min(T - 1, Math.floor(now() * fps + 1e-6));
  draw();
  if (frame >= T - 1 || (audio && audio.ended)) { pause(); return; }
  requestAnimationFrame(tick);
}
function play() {
  if (frame >= T - 1) seek(0);
  playing = true; playBtn.textContent = "Pause"; t0 = performance.now(); f0 = frame;
  if (audio) { audio.currentTime = frame / fps; audio.play(); }
  requestAnimationFrame(tick);
}
function pause() { playing = false; playBtn.textContent = "Play"; if (audio) audio.pause(); }
function seek(f) { frame = Math.max(0, Math.min(T - 1, f|0)); f0 = frame; t0 = performance.now();
  if (audio) audio.currentTime = frame / fps; draw(); }
playBtn.onclick = () => playing ? pause() : play();
scrub.oninput = () => seek(+scrub.value);
document.addEventListener("keydown", e => {
  if (e.code === "Space") { e.preventDefault(); playing ? pause() : play(); } });
let drag = null;
cv.onpointerdown = e => { drag = [e.clientX, e.clientY, az, el]; cv.setPointerCapture(e.pointerId); };
cv.onpointermove = e => { if (!drag) return; az = drag[2] - (e.clientX - drag[0]) * 0.01;
  el = Math.max(-0.2, Math.min(1.4, drag[3] + (e.clientY - drag[1]) * 0.01)); draw(); };
cv.onpointerup = () => { drag = null; };
cv.onwheel = e => { e.preventDefault(); zoom = Math.max(0.3, Math.min(4, zoom * Math.exp(e.deltaY * 0.001))); draw(); };
// For tests and embedding pages: the shown frame, the figure's projected box (canvas pixels) and the controls.
globalThis.dancePlayer = Object.assign(view, {play, pause, seek, playing: () => playing});
draw();
})();
</script></body></html>
"""


def follow_track(root_xz: np.ndarray, fps: float, seconds: float = 0.35) -> np.ndarray:
    """The view centre ``(T, 2)``: ``root_xz`` through a critically damped follow (two exponential
    stages of time constant ``seconds``) run forwards then backwards, so it lags neither way; the
    ends are extended by reflection (as the walk would go on), so the start and end do not lag."""
    x = np.asarray(root_xz, np.float64)
    if len(x) < 2:
        return x.copy()
    a = 1.0 - np.exp(-1.0 / (max(float(fps), 1e-6) * seconds))
    stage = np.array([1.0, a - 1.0])
    pad = min(len(x) - 1, int(np.ceil(8 * seconds * fps)))
    return filtfilt([a * a], np.convolve(stage, stage), x, axis=0, padtype="odd", padlen=pad)


def framing(positions: np.ndarray, fps: float) -> dict:
    """What the player's camera needs: the followed centre, the floor height, the figure's stature
    and size (its typical extent, not the room's) and how far the root strays from the centre."""
    pos = np.asarray(positions, np.float64).reshape(len(positions), -1, 3)
    if pos.size == 0:
        return {"follow": [], "floor": 0.0, "stature": 1.0, "body": 1.0, "wander": 0.0}
    follow = follow_track(pos[:, 0, [0, 2]], fps)
    floor = float(pos[..., 1].min())
    stature = float(np.percentile(pos[..., 1].max(axis=1), 90) - floor)
    extent = float(np.percentile(np.ptp(pos, axis=1).max(axis=1), 90))
    wander = float(np.percentile(np.linalg.norm(pos[:, 0, [0, 2]] - follow, axis=-1), 95))
    return {"follow": np.round(follow.reshape(-1), 3).tolist(), "floor": floor,
            "stature": max(stature, 1e-6), "body": max(stature, extent, 1e-6), "wander": wander}


def wav_bytes(samples: np.ndarray, rate: int) -> bytes:
    """Mono 16-bit PCM WAV of ``samples`` in [-1, 1]."""
    pcm = np.clip(np.round(np.asarray(samples, np.float64) * 32768.0), -32768, 32767).astype("<i2")
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(int(rate))
        w.writeframes(pcm.tobytes())
    return buf.getvalue()


def cut_music(samples: np.ndarray, rate: int, seconds: float) -> tuple[np.ndarray, int]:
    """The first ``seconds`` of mono ``samples``, brought down to at most ``PREVIEW_RATE`` Hz."""
    from scipy.signal import resample_poly

    samples = np.asarray(samples, np.float32)[: max(1, math.ceil(seconds * rate))]
    if rate > PREVIEW_RATE:
        g = math.gcd(PREVIEW_RATE, int(rate))
        samples = resample_poly(samples, PREVIEW_RATE // g, int(rate) // g).astype(np.float32)
        rate = PREVIEW_RATE
    return samples, int(rate)


def embedded_audio(music: str | Path, seconds: float) -> tuple[str, bytes]:
    """The MIME type and bytes the player embeds for a dance lasting ``seconds``: the music file
    itself when it is no larger than its cut would be, else its first ``seconds`` +
    ``AUDIO_MARGIN_S`` decoded and written as mono 16-bit WAV (at most ``PREVIEW_RATE`` Hz). A format
    browsers do not play (AIFF, any other an audio reader reads) is always decoded and embedded as WAV."""
    music = Path(music)
    kind = AUDIO_TYPES.get(music.suffix.lower())
    if not music.is_file():
        raise DataError(f"{music}: music file not found" if not music.exists() else f"{music}: not a music file")
    keep = max(float(seconds), 0.0) + AUDIO_MARGIN_S
    if kind is None:  # no browser plays it: our reader decodes it (an unreadable suffix is one line naming it)
        return "audio/wav", _cut_wav(music, keep)
    bound = 44 + 2 * math.ceil(keep * PREVIEW_RATE)  # the largest cut WAV
    if music.stat().st_size <= bound:
        return kind, music.read_bytes()
    try:  # only the part embedded is decoded
        cut = _cut_wav(music, keep)
    except DataError as exc:
        from dance_core.plugins import warn

        warn(f"{music}: cannot cut the music to the dance, embedding the whole file ({exc})")
        return kind, music.read_bytes()
    if len(cut) >= music.stat().st_size:
        return kind, music.read_bytes()
    return "audio/wav", cut


def _cut_wav(music: Path, keep: float) -> bytes:
    """The first ``keep`` seconds of ``music``, decoded (only that part) as mono 16-bit WAV bytes."""
    from dance_core.data.features import audio_reader_for, check_audio, read_audio
    from dance_core.registry import get_registry

    audio = check_audio(read_audio(audio_reader_for(music, get_registry()), music, keep), music)
    return wav_bytes(*cut_music(audio.samples, audio.rate, keep))


#: characters escaped in JSON embedded in a script block: none can end the block, open a comment or a
#: tag, or end a line of script where JSON allows it (U+2028, U+2029)
_SCRIPT_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028", "\u2029": "\\u2029"}


def script_json(data: object) -> str:
    """``data`` as JSON that is inert inside an HTML ``<script>`` block: ``<``, ``>``, ``&``, U+2028 and
    U+2029 escaped wherever they are (they can only be inside strings), NaN and infinities refused
    (``ValueError``), so the page parses as the data, whatever strings it holds."""
    text = json.dumps(data, separators=(",", ":"), allow_nan=False)
    return re.sub("[<>&\u2028\u2029]", lambda m: _SCRIPT_ESCAPES[m.group(0)], text)


def fill_page(page: str, fields: dict[str, str]) -> str:
    """``page`` with each ``__KEY__`` replaced by ``fields[KEY]`` in one pass, so no value's text is
    ever searched for another placeholder."""
    return re.sub("__([A-Z]+)__", lambda m: fields.get(m.group(1), m.group(0)), page)


def shown(text: object) -> str:
    """``text`` as it can be written as UTF-8: the undecodable bytes of a file name (surrogate escapes, as
    Python reads names under ``LANG=C``) and any lone surrogate become U+FFFD."""
    text = str(text)
    try:
        return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    except UnicodeEncodeError:
        return text.encode("utf-8", "replace").decode("utf-8")


def player_html(positions: np.ndarray, parents: list[int], names: list[str], fps: float,
                music: str | Path | None = None, title: str = "dance", source: str | Path = "motion") -> str:
    """The page's text: positions rounded to 1e-3 of the units, music as a base64 data URI holding
    only the part the dance covers (see :func:`embedded_audio`). Every user string (title, joint
    names) is escaped for where it goes; non-finite positions are one line naming ``source``."""
    positions = np.asarray(positions, np.float64)
    title, names = shown(title), [shown(n) for n in names]
    reason = nonfinite_reason(positions.reshape(len(positions), -1, 3), list(names))
    if reason is not None or not math.isfinite(float(fps)):
        raise DataError(f"{source}: cannot preview a motion that holds {reason or f'fps {fps}'}; nothing written")
    data = {
        "title": title, "fps": float(fps), "frames": int(len(positions)), "names": names,
        "parents": [int(p) for p in parents], "colors": bone_colors(list(names), list(parents)),
        "positions": np.round(positions.reshape(-1), 3).tolist(),
        **framing(positions, fps),
    }
    audio = ""
    if music is not None:
        kind, raw = embedded_audio(music, len(positions) / float(fps))
        payload = base64.b64encode(raw).decode("ascii")
        audio = f'<audio id="music" preload="auto" src="data:{html.escape(kind)};base64,{payload}"></audio>'
    try:
        blob = script_json(data)
    except ValueError as exc:  # a non-finite number computed from finite positions (a degenerate framing)
        raise DataError(f"{source}: cannot preview this motion ({exc}); nothing written") from None
    return fill_page(_PAGE, {"TITLE": html.escape(title, quote=True), "AUDIO": audio, "DATA": blob})


def write_html(path: str | Path, positions: np.ndarray, parents: list[int], names: list[str], fps: float,
               music: str | Path | None = None, title: str = "dance") -> int:
    """Write the player atomically; returns the frame count."""
    write_text(path, player_html(positions, parents, names, fps, music, title, source=path))
    return len(positions)
