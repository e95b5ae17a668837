"""Stick-figure frames drawn with matplotlib (Agg): bones, a floor grid and the root's trail.

matplotlib is an optional dependency (``dance-core[plots]``): it is imported only when a frame or a
figure is drawn, and :func:`require_matplotlib` turns its absence into one line naming the extra.
"""

from __future__ import annotations

from collections.abc import Iterator
from types import ModuleType

import numpy as np

from dance_core.errors import PluginError
from dance_core.render.camera import Camera, frame_camera

LEFT, RIGHT, CENTER = "#e4572e", "#2e86ab", "#333333"
PLOTS_HINT = "GIF/MP4 previews and plots need matplotlib: pip install 'dance-core[plots]'"


def require_matplotlib(hint: str = PLOTS_HINT) -> ModuleType:
    """matplotlib, switched to the Agg backend; a PluginError saying ``hint`` when it is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise PluginError(hint) from None
    matplotlib.use("Agg", force=False)
    return matplotlib


def bone_colors(names: list[str], parents: list[int]) -> list[str]:
    """Left limbs orange, right limbs blue (joints with a mirror counterpart), the rest dark."""
    from dance_core.motion.skeleton import side_of

    colors = {"left": LEFT, "right": RIGHT, None: CENTER}
    return [colors[side_of(n, names)] for n in names]


def floor_lines(positions: np.ndarray, spacing: float) -> list[np.ndarray]:
    """Grid lines ``(2, 3)`` on the floor under the whole motion."""
    lo = positions[..., [0, 2]].reshape(-1, 2).min(0) - 2 * spacing
    hi = positions[..., [0, 2]].reshape(-1, 2).max(0) + 2 * spacing
    y = positions[..., 1].min()
    xs = np.arange(np.floor(lo[0] / spacing), np.ceil(hi[0] / spacing) + 1) * spacing
    zs = np.arange(np.floor(lo[1] / spacing), np.ceil(hi[1] / spacing) + 1) * spacing
    lines = [np.array([[x, y, zs[0]], [x, y, zs[-1]]]) for x in xs]
    lines += [np.array([[xs[0], y, z], [xs[-1], y, z]]) for z in zs]
    return lines


def render_frames(
    positions: np.ndarray, parents: list[int], names: list[str], fps: float, width: int = 480, height: int = 480,
    trail: bool = True, title: str = "", camera: Camera | None = None,
) -> Iterator[np.ndarray]:
    """RGB frames ``(height, width, 3)`` uint8, one per motion frame.

    matplotlib is checked when this is called, so that a missing one fails before any work starts.
    """
    require_matplotlib()
    return _frames(positions, parents, names, fps, width, height, trail, title, camera)


def _frames(
    positions: np.ndarray, parents: list[int], names: list[str], fps: float, width: int, height: int,
    trail: bool, title: str, camera: Camera | None,
) -> Iterator[np.ndarray]:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    cam = camera or frame_camera(positions, fps)
    body = float(np.ptp(positions[0, :, 1]) or 1.0)
    fig = Figure(figsize=(width / 100, height / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_axis_off()
    from matplotlib.collections import LineCollection

    grid_pts = np.stack(floor_lines(positions, body / 2))  # (L, 2, 3)
    grid = ax.add_collection(LineCollection([], colors="#cccccc", linewidths=0.8))
    colors = bone_colors(names, parents)
    bones = np.array([(p, j) for j, p in enumerate(parents) if p >= 0])
    lines = ax.add_collection(LineCollection([], colors=[colors[j] for _, j in bones], linewidths=3,
                                             capstyle="round"))
    joints = ax.plot([], [], "o", color="#222222", ms=2.5)[0]
    path = ax.plot([], [], color="#8bc34a", lw=1.5, alpha=0.8)[0]
    label = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9, color="#555555")
    ground_y = positions[..., 1].min()
    trail_len = int(3 * fps)
    for t in range(len(positions)):
        grid.set_segments(cam.project(grid_pts, t))
        xy = cam.project(positions[t], t)
        lines.set_segments(xy[bones])
        joints.set_data(xy[:, 0], xy[:, 1])
        if trail:
            tr = positions[max(0, t - trail_len) : t + 1, 0].copy()
            tr[:, 1] = ground_y
            txy = cam.project(tr, t)
            path.set_data(txy[:, 0], txy[:, 1])
        label.set_text(f"{title}  {t / fps:5.2f} s".strip())
        canvas.draw()
        yield np.asarray(canvas.buffer_rgba())[..., :3].copy()
