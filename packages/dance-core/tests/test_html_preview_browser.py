"""The HTML player in a real browser: headless Chromium, offline, on a figure that walks 5 m away.

Chromium is the system's (Debian's package ``chromium``; ``make install`` installs it when run as
root). It is driven over its DevTools pipe, in real time: under ``--virtual-time-budget`` headless
Chromium hardly runs ``requestAnimationFrame``, so a page dumped that way never shows playback.
"""

import base64
import contextlib
import fcntl
import io
import json
import os
import select
import shutil
import subprocess
import time

import numpy as np
import pytest

from dance_core.formats.wav import write_wav
from dance_core.motion.skeletons import dance24
from dance_core.render.frames import CENTER, LEFT, RIGHT
from dance_core.render.html import write_html

BROWSER = next((shutil.which(n) for n in ("chromium", "chromium-browser") if shutil.which(n)), None)
pytestmark = pytest.mark.skipif(BROWSER is None, reason="needs Chromium: `apt-get install chromium` "
                                "(`make install` does it when run as root)")

W, H = 720, 540  # the player's canvas
FPS, SECONDS = 30.0, 4.0
LAST = int(FPS * SECONDS) - 1


class Chromium:
    """Headless Chromium with one page, spoken to over ``--remote-debugging-pipe`` (fds 3 and 4)."""

    def __init__(self, profile, timeout: float = 60.0, resolve: str = "MAP * ~NOTFOUND"):
        """``resolve``: the host resolver rules (by default no name resolves: the page is offline)."""
        to_browser, from_browser = os.pipe(), os.pipe()  # four fds: 3 and 4 are surely open here

        def place_pipes():  # in the child: its ends at 3 and 4 (dup2 onto another fd drops close-on-exec)
            high = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10) for fd in (to_browser[0], from_browser[1])]
            os.dup2(high[0], 3)
            os.dup2(high[1], 4)

        self.log = open(f"{profile}.log", "wb")  # noqa: SIM115 (closed in close())
        self.proc = subprocess.Popen(
            [BROWSER, "--headless", "--disable-gpu", "--no-sandbox", "--no-first-run", "--mute-audio",
             "--remote-debugging-pipe", f"--user-data-dir={profile}", "--disable-background-networking",
             "--disable-component-update", f"--host-resolver-rules={resolve}", "--proxy-server=127.0.0.1:9",
             "--autoplay-policy=no-user-gesture-required", f"--window-size={W + 100},{H + 300}", "about:blank"],
            pass_fds=(3, 4), preexec_fn=place_pipes, stdout=subprocess.DEVNULL, stderr=self.log)
        os.close(to_browser[0])
        os.close(from_browser[1])
        self.out, self.inp, self.buf, self.next_id, self.timeout = to_browser[1], from_browser[0], b"", 0, timeout
        self.events: list[dict] = []
        try:
            page = next(t for t in self.send("Target.getTargets")["targetInfos"] if t["type"] == "page")
            self.session = self.send("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
            self.send("Runtime.enable", self.session)
            self.send("Page.enable", self.session)
        except BaseException:
            self.close()
            raise

    def send(self, method: str, session: str | None = None, **params) -> dict:
        """One DevTools command; its result. Events that arrive meanwhile go to ``events``."""
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        os.write(self.out, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            while b"\0" not in self.buf:
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([self.inp], [], [], left)[0]:
                    raise TimeoutError(f"Chromium did not answer {method}{self.tail()}")
                chunk = os.read(self.inp, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"Chromium exited during {method}{self.tail()}")
                self.buf += chunk
            raw, self.buf = self.buf.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") != self.next_id:
                self.events.append(reply)
            elif "error" in reply:
                raise RuntimeError(f"{method}: {reply['error']}")
            else:
                return reply["result"]

    def tail(self) -> str:
        """The end of Chromium's log, for error messages."""
        self.log.flush()
        with open(self.log.name, errors="replace") as f:
            return "; Chromium's log ends: " + f.read()[-1500:]

    def js(self, expression: str):
        """Evaluate in the page (promises awaited); the value, or the page's exception raised here."""
        r = self.send("Runtime.evaluate", self.session, expression=expression, awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in r:
            raise AssertionError(r["exceptionDetails"])
        return r["result"].get("value")

    def open(self, path) -> None:
        """Navigate to a file and wait until it has loaded."""
        self.send("Page.navigate", self.session, url=path.as_uri())
        self.js("new Promise(r => { const ok = () => document.readyState === 'complete' ? r() : setTimeout(ok, 20);"
                " ok(); })")

    def errors(self) -> list:
        """Uncaught exceptions and console errors seen so far."""
        return [e["params"] for e in self.events if e.get("method") == "Runtime.exceptionThrown"
                or (e.get("method") == "Runtime.consoleAPICalled" and e["params"]["type"] == "error")]

    def screenshot(self, selector: str) -> np.ndarray:
        """The element's pixels, RGB ``(h, w, 3)``."""
        from PIL import Image

        x, y, w, h = self.js(f"(() => {{ const b = document.querySelector('{selector}').getBoundingClientRect();"
                             " return [b.x, b.y, b.width, b.height]; })()")
        clip = {"x": x, "y": y, "width": w, "height": h, "scale": 1}
        png = base64.b64decode(self.send("Page.captureScreenshot", self.session, format="png", clip=clip)["data"])
        with Image.open(io.BytesIO(png)) as im:
            return np.asarray(im.convert("RGB"))

    def close(self) -> None:
        """Close the browser and the pipes."""
        with contextlib.suppress(RuntimeError, TimeoutError, OSError):
            self.send("Browser.close")
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self.out)
        os.close(self.inp)
        self.log.close()


def walker() -> tuple[np.ndarray, list[int], list[str]]:
    """SMPL's rest pose walking 5 m (4 m along x, 3 m along z) in 4 s, swinging its legs and arms."""
    skel = dance24()
    t = np.arange(LAST + 1) / FPS
    heading = np.array([0.8, 0.0, 0.6])
    pos = np.repeat(skel.rest_positions()[None], len(t), 0) + (t / SECONDS)[:, None, None] * 5.0 * heading
    swing = 0.3 * np.sin(2 * np.pi * 1.8 * t)[:, None]
    for j, name in enumerate(skel.names):
        side = 1.0 if name.startswith("L_") else -1.0 if name.startswith("R_") else 0.0
        leg = any(k in name for k in ("Knee", "Ankle", "Foot"))
        arm = any(k in name for k in ("Elbow", "Wrist", "Hand"))
        pos[:, j] += (side * (1.0 if leg else -0.5 if arm else 0.0)) * swing * heading
    pos[..., 1] += 0.03 * np.abs(np.sin(2 * np.pi * 1.8 * t))[:, None]
    return pos, skel.parents, skel.names


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The walker's preview without and with music, written by the player's own writer."""
    root = tmp_path_factory.mktemp("browser")
    pos, parents, names = walker()
    t = np.arange(int(16000 * SECONDS)) / 16000
    write_wav(root / "song.wav", (0.2 * np.sin(2 * np.pi * 220 * t)).astype(np.float32), 16000)
    write_html(root / "walk.html", pos, parents, names, FPS, title="walk")
    write_html(root / "music.html", pos, parents, names, FPS, music=root / "song.wav", title="walk")
    return root


@pytest.fixture()
def browser(tmp_path):
    """A fresh headless Chromium, closed after the test."""
    b = Chromium(tmp_path / "profile")
    yield b
    b.close()


STATE = "({frame: dancePlayer.frame, clock: document.getElementById('clock').textContent, " \
        "button: document.getElementById('play').textContent, bbox: dancePlayer.bbox})"


def scrub_to(browser: Chromium, frame: int) -> dict:
    """Move the scrub bar as a user would; the player's state after it."""
    return browser.js(f"(() => {{ const s = document.getElementById('scrub'); s.value = {frame};"
                      f" s.dispatchEvent(new Event('input')); return {STATE}; }})()")


def assert_framed(box: list[float]) -> None:
    """The figure lies wholly inside the canvas, near its middle, and is body-sized (not a speck)."""
    x0, y0, x1, y1 = box
    assert 0 < x0 < x1 < W and 0 < y0 < y1 < H, box
    assert 0.3 * H < y1 - y0 < 0.9 * H, box
    assert abs((x0 + x1) / 2 - W / 2) < 0.25 * W and abs((y0 + y1) / 2 - H / 2) < 0.25 * H, box


@pytest.mark.parametrize("name", ["walk.html", "music.html"])
def test_player_loads_plays_and_scrubs_without_errors(pages, browser, name):
    browser.open(pages / name)
    start = browser.js(STATE)
    assert start["frame"] == 0 and start["clock"] == "0.00 s" and start["button"] == "Play"
    browser.js("document.getElementById('play').click()")
    played = browser.js(f"new Promise(r => setTimeout(() => r({STATE}), 1200))")
    assert played["button"] == "Pause" and played["frame"] >= 10, played  # the clock runs (audio's, if any)
    assert played["clock"] == f"{played['frame'] / FPS:.2f} s"
    browser.js("document.getElementById('play').click()")
    assert browser.js(STATE)["button"] == "Play"
    mid = scrub_to(browser, LAST // 2)
    assert mid["frame"] == LAST // 2 and mid["clock"] == f"{LAST // 2 / FPS:.2f} s"
    assert browser.errors() == []


def test_camera_follows_the_walker_and_fits_its_body(pages, browser):
    browser.open(pages / "walk.html")
    for frame in (0, LAST // 2, LAST):  # 0 m, 2.5 m and 5 m from the start: always framed alike
        state = scrub_to(browser, frame)
        assert state["frame"] == frame
        assert_framed(state["bbox"])
    tall = state["bbox"][3] - state["bbox"][1]
    browser.js("document.getElementById('view')"
               ".dispatchEvent(new WheelEvent('wheel', {deltaY: 500, cancelable: true}))")
    zoomed = browser.js(STATE)["bbox"]
    assert zoomed[3] - zoomed[1] < 0.8 * tall  # the wheel still zooms out
    x, y = browser.js("(() => { const b = document.getElementById('view').getBoundingClientRect();"
                      " return [b.x + b.width / 2, b.y + b.height / 2]; })()")
    for kind, dx in (("mousePressed", 0), ("mouseMoved", 60), ("mouseMoved", 120), ("mouseReleased", 120)):
        browser.send("Input.dispatchMouseEvent", browser.session, type=kind, x=x + dx, y=y, button="left",
                      buttons=0 if kind == "mouseReleased" else 1, clickCount=1)
    turned = browser.js(STATE)["bbox"]
    assert abs((turned[2] - turned[0]) - (zoomed[2] - zoomed[0])) > 5  # a drag still orbits
    assert browser.errors() == []


def figure_mask(rgb: np.ndarray) -> np.ndarray:
    """Pixels near a bone colour or the joints' dark grey (not the floor grid, the trail or the background)."""
    ref = np.array([[int(c[i:i + 2], 16) for i in (1, 3, 5)] for c in (LEFT, RIGHT, CENTER, "#222222")], float)
    return np.abs(rgb[..., None, :].astype(float) - ref).max(-1).min(-1) < 40


def test_screenshot_shows_the_walker_large_and_inside_the_canvas_5m_away(pages, browser, tmp_path):
    from PIL import Image

    browser.open(pages / "walk.html")
    assert scrub_to(browser, LAST)["frame"] == LAST
    rgb = browser.screenshot("#view")
    Image.fromarray(rgb).save(tmp_path / "last-frame.png")  # to look at: pytest --basetemp=DIR
    inner = rgb[2:-2, 2:-2]  # inside the canvas's border
    ys, xs = np.nonzero(figure_mask(inner))
    h, w = inner.shape[:2]
    assert len(xs) > 0.005 * w * h, "the figure is missing or tiny"
    assert xs.min() > 0 and xs.max() < w - 1 and ys.min() > 0 and ys.max() < h - 1  # not cut by an edge
    assert ys.max() - ys.min() > 0.3 * h  # framed to the body, not to the room walked in
    assert (inner.reshape(-1, 3) == 255).all(-1).mean() > 0.5  # mostly the canvas's white
    assert browser.errors() == []
