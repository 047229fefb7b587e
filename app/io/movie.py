"""Frames to a movie file: an H.264 MP4 (imageio through imageio-ffmpeg's ffmpeg), a GIF (Pillow) or a folder
of numbered PNGs.  `isoscope movie` and the window's Record both write through `MovieWriter`, a frame at a
time; the file appears whole or not at all (written beside, then put in its place)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .atomic import write_atomically

MOVIE_SUFFIXES = (".mp4", ".gif")


def movie_kind(out, what: str = "--out") -> str:
    """"mp4", "gif" or "folder" by the name `out`; one line (ValueError) for anything else."""
    out = str(out)
    if out.endswith(("/", os.sep)) or Path(out).is_dir():
        return "folder"
    suffix = Path(out).suffix.lower()
    if suffix not in MOVIE_SUFFIXES:
        raise ValueError(f"{what} {out}: a movie is .mp4, .gif or a folder (end the name with /); "
                         f"not {suffix or 'a name without an extension'}")
    return suffix[1:]


def even_frame(frame: np.ndarray) -> np.ndarray:
    """H.264 in yuv420p needs even sizes: an odd row or column is repeated."""
    h, w = frame.shape[:2]
    return np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") if (h | w) & 1 else frame


class MovieWriter:
    """Frames (H, W, 3) uint8, top row first, appended one at a time to the movie `out` at `fps`; `close`
    puts the whole file in its place, `abort` (or a failed write) leaves no file behind."""

    def __init__(self, out, fps: float, kind: str | None = None):
        self.out = Path(out)
        self.kind = kind or movie_kind(out)
        self.fps = float(fps)
        self.frames = 0
        self.size: tuple[int, int] | None = None   # (width, height) of the first frame: every frame's
        self._temporary: str | None = None
        self._writer = None
        self._images: list = []
        if self.kind == "folder":
            self.out.mkdir(parents=True, exist_ok=True)
            return
        folder = self.out.parent if str(self.out.parent) else Path(".")
        handle, self._temporary = tempfile.mkstemp(prefix=f".{self.out.name}.", suffix=f".partial.{self.kind}",
                                                   dir=folder)
        os.close(handle)
        if self.kind == "mp4":
            import imageio.v2 as imageio
            try:
                self._writer = imageio.get_writer(self._temporary, format="FFMPEG", mode="I", fps=self.fps,
                                                  codec="libx264", quality=8, macro_block_size=2,
                                                  ffmpeg_log_level="error")
            except BaseException:
                self.abort()
                raise

    def append(self, frame: np.ndarray) -> None:
        frame = np.ascontiguousarray(frame[..., :3], dtype=np.uint8)
        size = (frame.shape[1], frame.shape[0])
        if self.size is None:
            self.size = size
        elif size != self.size:
            raise ValueError(f"a {size[0]}x{size[1]} frame in a {self.size[0]}x{self.size[1]} movie; "
                             "a movie's frames keep one size")
        if self.kind == "folder":
            from PIL import Image
            path = self.out / f"frame_{self.frames:04d}.png"
            write_atomically(path, lambda target: Image.fromarray(frame).save(target, format="PNG"))
        elif self.kind == "mp4":
            self._writer.append_data(even_frame(frame))
        else:
            from PIL import Image
            self._images.append(Image.fromarray(frame))
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and put it at `out` (a folder: already there); its path."""
        if self.kind == "folder":
            return self.out
        try:
            if self.frames == 0:
                raise ValueError(f"no frames to write to {self.out}")
            if self.kind == "mp4":
                self._writer.close()
                self._writer = None
            else:
                self._images[0].save(self._temporary, format="GIF", save_all=True, append_images=self._images[1:],
                                     duration=round(1000 / self.fps), loop=0)
                self._images = []
            data = Path(self._temporary).read_bytes()
            return write_atomically(self.out, lambda target: target.write(data))
        finally:
            self.abort()

    def abort(self) -> None:
        """Stop, leaving no partial file (a folder keeps the frames written)."""
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:   # noqa: BLE001 - the file is being thrown away
                pass
            self._writer = None
        if self._temporary is not None:
            Path(self._temporary).unlink(missing_ok=True)
            self._temporary = None
        self._images = []


def write_movie(frames, out, fps: float, kind: str | None = None, on_frame=None) -> Path:
    """Write the iterable `frames` to `out`; `on_frame(i)` after frame i is written.  The file's path."""
    writer = MovieWriter(out, fps, kind)
    try:
        for i, frame in enumerate(frames):
            writer.append(frame)
            if on_frame is not None:
                on_frame(i)
    except BaseException:
        writer.abort()
        raise
    return writer.close()
