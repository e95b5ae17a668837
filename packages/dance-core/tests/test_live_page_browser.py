"""dance live's page in a real browser: headless Chromium connects to the WebSocket output, receives the
skeleton and the frames as they are sent, and draws the figure as it moves (the Chromium helper of
test_html_preview_browser; skipped without Chromium)."""

import sys
import time
from pathlib import Path

import numpy as np
import pytest

from dance_core.live.pose import Pose
from dance_core.live.session import frame_message
from dance_core.live.websocket import WebSocketSink
from dance_core.motion.motion import Motion
from dance_core.motion.rotations import expmap_to_quat
from dance_core.motion.skeletons import dance24

sys.path.insert(0, str(Path(__file__).parent))
from test_html_preview_browser import BROWSER, Chromium  # noqa: E402

pytestmark = pytest.mark.skipif(BROWSER is None, reason="needs Chromium: `apt-get install chromium`")

FPS = 20.0
BLUE = np.array([0x25, 0x63, 0xEB])  # the page's stroke colour
L_SHOULDER, R_SHOULDER = 16, 17


def poses(n: int, arms_up: bool) -> list[Pose]:
    """A dance24 figure standing (arms down, or raised over its head), swaying a little, ``n`` frames."""
    rot = np.zeros((n, 24, 3))
    angle = 1.2 if arms_up else -1.2
    rot[:, L_SHOULDER, 2], rot[:, R_SHOULDER, 2] = angle, -angle
    rot[:, 0, 1] = 0.05 * np.sin(np.arange(n))
    m = Motion(dance24(), FPS, np.tile([0.0, 0.93, 0.0], (n, 1)), expmap_to_quat(rot))
    return [Pose(m.root[i], m.rotations[i], p) for i, p in enumerate(m.positions())]


def wait_for(browser: Chromium, expression: str, timeout: float = 30.0):
    """Poll the page until ``expression`` is truthy; its value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = browser.js(expression)
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"the page never had {expression}; its status: {browser.js(STATUS)}")


STATUS = "(document.getElementById('status') || {}).textContent"  # null-safe while the page loads


def figure(browser: Chromium) -> tuple[int, int, int, int]:
    """The bounding box (x0, y0, x1, y1) of the figure's strokes in the canvas."""
    img = browser.screenshot("#view").astype(int)
    ys, xs = np.nonzero(np.abs(img - BLUE).sum(-1) < 60)
    assert len(xs) > 200, "no figure drawn"
    return xs.min(), ys.min(), xs.max(), ys.max()


def test_the_live_page_receives_the_frames_and_draws_the_figure_as_it_moves(tmp_path):
    skeleton = dance24()
    sink = WebSocketSink("127.0.0.1", 0, "dance live test")
    sink.start({"skeleton": {"name": skeleton.name, "joints": list(skeleton.names),
                             "parents": [int(p) for p in skeleton.parents],
                             "offsets": skeleton.offsets.round(6).tolist(), "fps": FPS}})
    browser = Chromium(tmp_path / "profile", resolve="MAP * ~NOTFOUND, EXCLUDE 127.0.0.1")  # our server only
    try:
        browser.send("Page.navigate", browser.session, url=sink.url)
        wait_for(browser, f"{STATUS} === 'connected'")
        while not sink.clients:  # registered once its handshake is done
            time.sleep(0.01)
        sent = 0
        for arms_up in (False, True):
            for pose in poses(20, arms_up):
                sink.send(frame_message(sent, FPS, pose))
                sent += 1
                time.sleep(1 / FPS)  # as the model makes them
            wait_for(browser, f"window.danceLive.frames() === {sent}")
            wait_for(browser, f"window.danceLive.drawn > 0 && {STATUS}.endsWith('{sent} frames')")
            time.sleep(0.2)  # the next animation frames draw the newest pose
            box = figure(browser)
            if not arms_up:
                down = box
        assert browser.js(STATUS) == f"music time {(sent - 1) / FPS:.2f} s, {sent} frames"
        up = box
        # the hands went over the head: the figure's top rose by about half its arm span's drop (pixels, y down)
        assert up[1] < down[1] - 30, (down, up)
        assert 0 < up[0] < up[2] < 720 and 0 < up[1] < up[3] < 540  # inside the canvas
        sink.close()
        wait_for(browser, f"{STATUS}.startsWith('the dance has ended ({sent} frames)')")
        assert not browser.errors()
    finally:
        sink.shutdown()
        browser.close()
    assert sink.stats()["sent"] == sent and sink.stats()["dropped"] == 0
