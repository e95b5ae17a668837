"""Rendering a skeletal motion to a preview file, chosen by suffix; also registered as motion formats."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from dance_core.atomic import target_of
from dance_core.errors import DataError
from dance_core.motion.motion import Motion
from dance_core.protocols import MotionData

SUFFIXES = (".gif", ".mp4", ".html")


def render(motion: Motion, path: str | Path, music: str | Path | None = None, width: int = 480,
           height: int = 480, fps: float | None = None, trail: bool = True, title: str | None = None,
           progress: Callable[[int, int], None] | None = None) -> int:
    """Write a GIF, an MP4 (with ``music`` muxed in) or an HTML player; returns the frame count.
    ``progress(done, total)`` is called as GIF/MP4 frames are drawn."""
    from dance_core.render.video import preview_fps, write_gif, write_mp4

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise DataError(f"{path}: cannot render {suffix or 'a file without suffix'!r}; use {', '.join(SUFFIXES)}")
    title = target_of(path).stem if title is None else title  # the output's name, never a temporary one
    skel = motion.skeleton
    if suffix == ".html":
        from dance_core.render.html import write_html

        return write_html(path, motion.positions(), skel.parents, skel.names, motion.fps, music, title)
    out_fps = preview_fps(motion.fps, fps, gif=suffix == ".gif")
    shown = motion.resample(out_fps) if abs(out_fps - motion.fps) > 1e-9 else motion
    args = (shown.positions(), skel.parents, skel.names, out_fps)
    common = {"width": width, "height": height, "trail": trail, "title": title, "progress": progress}
    if suffix == ".gif":
        return write_gif(path, *args, **common)
    return write_mp4(path, *args, music=music, **common)


class PreviewFormat:
    """A write-only motion format that renders previews (``formats: [bvh, gif]`` in ``compose:``)."""

    def __init__(self, config: Any = None):
        self.config = config

    def read(self, path: str | Path) -> MotionData:
        """Previews cannot be read back."""
        raise DataError(f"{path}: previews are write-only; read the BVH or NPZ written next to them")

    def write(self, motion: MotionData, path: str | Path) -> None:
        """Render the skeletal motion behind ``motion`` with its song (``meta['audio_path']``), titled
        ``meta['title']`` (else the file's name)."""
        if motion.skeleton_motion is None:
            raise DataError(f"{path}: a preview needs a skeletal motion (set a `motion:` representation in the recipe)")
        c = self.config
        music = motion.meta.get("audio_path") or None
        render(motion.skeleton_motion, path, music, getattr(c, "width", 480), getattr(c, "height", 480),
               getattr(c, "fps", None), getattr(c, "trail", True), title=motion.meta.get("title"))


def build(config: Any = None, **_: Any) -> PreviewFormat:
    """Build the ``html`` preview format (no optional dependency)."""
    return PreviewFormat(config)


def build_gif(config: Any = None, **_: Any) -> PreviewFormat:
    """Build the ``gif`` preview format; without matplotlib one line naming the extra, before any work."""
    from dance_core.render.frames import require_matplotlib

    require_matplotlib()
    return PreviewFormat(config)


def build_mp4(config: Any = None, **_: Any) -> PreviewFormat:
    """Build the ``mp4`` preview format; without matplotlib or ffmpeg one line naming the extra, before any work."""
    from dance_core.render.frames import require_matplotlib
    from dance_core.render.video import ffmpeg_exe

    require_matplotlib("MP4 previews need matplotlib and ffmpeg: pip install 'dance-core[render]'")
    ffmpeg_exe()
    return PreviewFormat(config)
