"""GIF and MP4 writers for stick-figure previews; MP4 gets the music muxed in by ffmpeg."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dance_core.atomic import atomic_path
from dance_core.errors import DanceError, DataError
from dance_core.render.frames import render_frames


def preview_fps(fps: float, wanted: float | None, gif: bool = False, cap: float = 30.0) -> float:
    """The preview's frame rate: ``wanted``, else the motion's up to ``cap``. GIF stores frame times in
    hundredths of a second, so a GIF gets the nearest rate at or below it of the form ``100 / k``."""
    rate = float(wanted) if wanted else min(float(fps), cap)
    return 100.0 / math.ceil(100.0 / rate - 1e-9) if gif else rate


def write_gif(path: str | Path, positions: np.ndarray, parents: list[int], names: list[str], fps: float,
              width: int = 480, height: int = 480, trail: bool = True, title: str = "",
              progress: Callable[[int, int], None] | None = None) -> int:
    """An animated GIF, one frame per motion frame (frame times rounded to 10 ms); returns the frame count.
    ``progress(done, total)`` is called after each frame."""
    rendered = render_frames(positions, parents, names, fps, width, height, trail, title)  # checks matplotlib
    from PIL import Image  # Pillow comes with matplotlib

    frames = []
    for f in rendered:
        frames.append(Image.fromarray(f).quantize(colors=64, method=Image.Quantize.FASTOCTREE))
        if progress:
            progress(len(frames), len(positions))
    with atomic_path(path) as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], loop=0,
                       duration=10 * round(100 / fps), disposal=1, optimize=False)
    return len(frames)


def ffmpeg_exe() -> str:
    """The ffmpeg binary from the ``imageio-ffmpeg`` wheel."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise DanceError("MP4 previews need ffmpeg: pip install 'dance-core[render]' (imageio-ffmpeg)") from None
    return imageio_ffmpeg.get_ffmpeg_exe()


def write_mp4(path: str | Path, positions: np.ndarray, parents: list[int], names: list[str], fps: float,
              music: str | Path | None = None, width: int = 480, height: int = 480, trail: bool = True,
              title: str = "", progress: Callable[[int, int], None] | None = None) -> int:
    """An H.264 MP4 with the music (AAC) muxed in when given; returns the frame count.
    ``progress(done, total)`` is called after each frame."""
    width, height = width - width % 2, height - height % 2
    path = Path(path)
    cmd = [ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
           "-s", f"{width}x{height}", "-r", f"{fps:g}", "-i", "-"]
    if music is not None:
        if not Path(music).exists():
            raise DataError(f"{music}: music file not found")
        cmd += ["-i", str(music), "-map", "0:v", "-map", "1:a", "-c:a", "aac", "-b:a", "160k",
                "-t", f"{len(positions) / fps:.4f}"]
    n = 0
    with atomic_path(path) as tmp:
        cmd += ["-c:v", "libx264", "-pix_fmt", "yuv420p", "-preset", "veryfast", "-crf", "23",
                "-movflags", "+faststart", "-f", "mp4", str(tmp)]
        proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            for frame in render_frames(positions, parents, names, fps, width, height, trail, title):
                proc.stdin.write(np.ascontiguousarray(frame).tobytes())
                n += 1
                if progress:
                    progress(n, len(positions))
            proc.stdin.close()
        except BrokenPipeError:
            pass
        err = proc.stderr.read().decode(errors="replace").strip()
        if proc.wait() != 0:
            raise DanceError(f"{path}: ffmpeg failed: {err.splitlines()[-1] if err else 'unknown error'}")
    return n
