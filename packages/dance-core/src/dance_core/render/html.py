"""A self-contained HTML player: motion and music embedded, orbit camera, play/pause/scrub, audio-driven clock.

No CDN, no third-party script, no network reference: the page opens offline from a single file.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from dance_core.atomic import write_text
from dance_core.errors import DataError
from dance_core.render.frames import bone_colors

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
const cv = document.getElementById("view"), g = cv.getContext("2d");
const scrub = document.getElementById("scrub"), playBtn = document.getElementById("play");
const clock = document.getElementById("clock"), audio = document.getElementById("music");
document.getElementById("title").textContent = D.title;
scrub.max = T - 1;
let az = 0.6, el = 0.25, zoom = 1.0, playing = false, frame = 0, t0 = 0, f0 = 0;
let minY = Infinity, maxY = -Infinity, cx = 0, cz = 0, far = 0;
for (let i = 0; i < P.length; i += 3) { minY = Math.min(minY, P[i+1]); maxY = Math.max(maxY, P[i+1]); }
for (let t = 0; t < T; t++) { cx += P[t*J*3] / T; cz += P[t*J*3+2] / T; }
for (let t = 0; t < T; t++) { far = Math.max(far, Math.hypot(P[t*J*3]-cx, P[t*J*3+2]-cz)); }
const H = Math.max(maxY - minY, 1e-6), cy = minY + H / 2;
function project(x, y, z) {
  const ce = Math.cos(el), se = Math.sin(el);
  const fx = -Math.sin(az)*ce, fy = -se, fz = -Math.cos(az)*ce;
  let rx = fy*0 - fz*1, ry = 0, rz = fx*1 - fy*0; const rn = Math.hypot(rx, rz); rx /= rn; rz /= rn;
  const ux = ry*fz - rz*fy, uy = rz*fx - rx*fz, uz = rx*fy - ry*fx;
  const dist = (2.2*H + 2*far) * zoom;
  const ex = cx - fx*dist, ey = cy - fy*dist, ez = cz - fz*dist;
  const dx = x-ex, dy = y-ey, dz = z-ez, depth = Math.max(dx*fx+dy*fy+dz*fz, 1e-3);
  const s = 1.7 / depth * cv.height / 2;
  return [cv.width/2 + (dx*rx+dy*ry+dz*rz)*s, cv.height/2 - (dx*ux+dy*uy+dz*uz)*s];
}
function draw() {
  g.clearRect(0, 0, cv.width, cv.height);
  const step = H / 2, n = Math.ceil((far + H) / step) + 1;
  g.strokeStyle = "#e2e2e2"; g.lineWidth = 1;
  for (let k = -n; k <= n; k++) {
    let a = project(cx + k*step, minY, cz - n*step), b = project(cx + k*step, minY, cz + n*step);
    g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke();
    a = project(cx - n*step, minY, cz + k*step); b = project(cx + n*step, minY, cz + k*step);
    g.beginPath(); g.moveTo(a[0], a[1]); g.lineTo(b[0], b[1]); g.stroke();
  }
  g.strokeStyle = "#8bc34a"; g.lineWidth = 2; g.beginPath();
  for (let t = Math.max(0, frame - 3*fps|0); t <= frame; t++) {
    const q = project(P[t*J*3], minY, P[t*J*3+2]);
    if (t === Math.max(0, frame - 3*fps|0)) g.moveTo(q[0], q[1]); else g.lineTo(q[0], q[1]);
  }
  g.stroke();
  const o = frame*J*3, pts = [];
  for (let j = 0; j < J; j++) pts.push(project(P[o+3*j], P[o+3*j+1], P[o+3*j+2]));
  g.lineCap = "round"; g.lineWidth = 5;
  for (let j = 0; j < J; j++) { const p = D.parents[j]; if (p < 0) continue;
    g.strokeStyle = D.colors[j]; g.beginPath(); g.moveTo(pts[p][0], pts[p][1]);
    g.lineTo(pts[j][0], pts[j][1]); g.stroke(); }
  g.fillStyle = "#222"; for (const q of pts) { g.beginPath(); g.arc(q[0], q[1], 2.5, 0, 6.283); g.fill(); }
  scrub.value = frame; clock.textContent = (frame / fps).toFixed(2) + " s";
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
draw();
})();
</script></body></html>
"""


def player_html(positions: np.ndarray, parents: list[int], names: list[str], fps: float,
                music: str | Path | None = None, title: str = "dance") -> str:
    """The page's text: positions rounded to 1e-3 of the units, music as a base64 data URI."""
    data = {
        "title": title, "fps": float(fps), "frames": int(len(positions)), "names": list(names),
        "parents": [int(p) for p in parents], "colors": bone_colors(list(names), list(parents)),
        "positions": np.round(np.asarray(positions, np.float64).reshape(-1), 3).tolist(),
    }
    audio = ""
    if music is not None:
        music = Path(music)
        kind = AUDIO_TYPES.get(music.suffix.lower())
        if kind is None:
            raise DataError(f"{music}: cannot embed {music.suffix!r} audio (use {', '.join(sorted(AUDIO_TYPES))})")
        try:
            payload = base64.b64encode(music.read_bytes()).decode("ascii")
        except FileNotFoundError:
            raise DataError(f"{music}: music file not found") from None
        audio = f'<audio id="music" preload="auto" src="data:{kind};base64,{payload}"></audio>'
    blob = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    safe_title = title.replace("&", "&amp;").replace("<", "&lt;")
    return _PAGE.replace("__TITLE__", safe_title).replace("__AUDIO__", audio).replace("__DATA__", blob)


def write_html(path: str | Path, positions: np.ndarray, parents: list[int], names: list[str], fps: float,
               music: str | Path | None = None, title: str = "dance") -> int:
    """Write the player atomically; returns the frame count."""
    write_text(path, player_html(positions, parents, names, fps, music, title))
    return len(positions)
