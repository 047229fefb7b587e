"""Frames to a movie file: an H.264 MP4 or a GIF (both by imageio-ffmpeg's ffmpeg) or a folder of numbered
PNGs.  `isoscope movie` and the window's Record both write through `MovieWriter`, a frame at a time, each
frame handed to ffmpeg as it is drawn (memory stays flat in the frame count: a GIF is not held whole, as
Pillow's writer holds it); the file appears whole or not at all (written beside, then put in its place)."""
from __future__ import annotations

import os
import shutil
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import InputError
from .atomic import write_atomically

MOVIE_SUFFIXES = (".mp4", ".gif")
# ffmpeg's GIF: a palette made from each frame (stats_mode=single) and used for it (new=1), no dithering
GIF_FILTER = "split[a][b];[a]palettegen=stats_mode=single[p];[b][p]paletteuse=new=1:dither=none"


def movie_kind(out, what: str = "--out") -> str:
    """"mp4", "gif" or "folder" by the name `out`; one line (ValueError) for anything else."""
    out = str(out)
    if out.endswith(("/", os.sep)) or Path(out).is_dir():
        return "folder"
    suffix = Path(out).suffix.lower()
    if suffix not in MOVIE_SUFFIXES:
        raise InputError(f"{what} {out}: a movie is .mp4, .gif or a folder (end the name with /); "
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
        if self.kind == "folder":
            self.out.mkdir(parents=True, exist_ok=True)
            return
        folder = self.out.parent if str(self.out.parent) else Path(".")
        handle, self._temporary = tempfile.mkstemp(prefix=f".{self.out.name}.", suffix=f".partial.{self.kind}",
                                                   dir=folder)
        os.close(handle)

    def _start(self, size: tuple[int, int]) -> None:
        """ffmpeg, fed (width, height) RGB frames on its stdin as they come."""
        import imageio_ffmpeg
        if self.kind == "mp4":   # H.264 in yuv420p wants even sides: even_frame repeats an odd row or column
            codec, pixels, params, quality = "libx264", "yuv420p", [], 8
            size = (size[0] + size[0] % 2, size[1] + size[1] % 2)
        else:   # each frame's own palette (a turntable's colours change), no dithering noise; loop forever
            codec, pixels, params, quality = "gif", "pal8", ["-filter_complex", GIF_FILTER, "-loop", "0"], None
        self._writer = imageio_ffmpeg.write_frames(self._temporary, size, pix_fmt_in="rgb24", pix_fmt_out=pixels,
                                                   fps=self.fps, codec=codec, quality=quality, macro_block_size=1,
                                                   output_params=params, ffmpeg_log_level="error")
        self._writer.send(None)

    def append(self, frame: np.ndarray) -> None:
        """Add `frame` (RGB or RGBA uint8) to the movie; the first frame sets the size, and a frame of another size is
        an InputError."""
        frame = np.ascontiguousarray(frame[..., :3], dtype=np.uint8)
        size = (frame.shape[1], frame.shape[0])
        if self.size is None:
            self.size = size
            if self.kind != "folder":
                self._start(size)
        elif size != self.size:
            raise InputError(f"a {size[0]}x{size[1]} frame in a {self.size[0]}x{self.size[1]} movie; "
                             "a movie's frames keep one size")
        if self.kind == "folder":
            from PIL import Image
            path = self.out / f"frame_{self.frames:04d}.png"
            write_atomically(path, lambda target: Image.fromarray(frame).save(target, format="PNG"))
        else:
            self._writer.send(np.ascontiguousarray(even_frame(frame) if self.kind == "mp4" else frame).tobytes())
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and put it at `out` (a folder: already there); its path."""
        if self.kind == "folder":
            return self.out
        try:
            if self.frames == 0:
                raise InputError(f"no frames to write to {self.out}")
            self._writer.close()
            self._writer = None
            with open(self._temporary, "rb") as written:   # copied a megabyte at a time: memory stays flat
                return write_atomically(self.out, lambda target: shutil.copyfileobj(written, target, 1 << 20))
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


def write_movie(frames, out, fps: float, kind: str | None = None, on_frame=None) -> Path:
    """Write the iterable `frames` to `out`; `on_frame(i)` after frame i is written.  The file's path.

    Nothing is left beside `out` when a frame cannot be drawn, the write fails, or SIGINT or SIGTERM
    arrives (SIGTERM then ends the process as it would have, once the partial file is gone); a failure names
    `out`, never the temporary file."""
    with _terminated_as_exception():
        writer = MovieWriter(out, fps, kind)
        try:
            for i, frame in enumerate(frames):
                writer.append(frame)
                if on_frame is not None:
                    on_frame(i)
            return writer.close()
        except OSError as exc:
            temporary = writer._temporary
            writer.abort()
            raise _named(exc, temporary, out) from None
        except BaseException:
            writer.abort()
            raise


@contextmanager
def _terminated_as_exception():
    """On the main thread, where SIGTERM would end the process at once (its default action): SystemExit in
    its place while the block runs (cleaning up as it unwinds), then the process ended by SIGTERM after all
    (exit status 143, as before)."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGTERM) != signal.SIG_DFL:
        yield
        return
    received = []

    def terminate(signum, frame):
        received.append(signum)
        raise SystemExit(128 + signum)
    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    except SystemExit:
        if received:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            signal.raise_signal(signal.SIGTERM)
        raise
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _named(exc: OSError, temporary: str | None, out) -> OSError:
    """`exc` about `out`, the user's path, not the temporary file written beside it; ffmpeg's command line
    (which imageio-ffmpeg puts in its messages) left out."""
    text = str(exc.strerror or exc)
    if "FFMPEG COMMAND" in text:
        text = f"the movie encoder (ffmpeg) stopped: {text.split('FFMPEG COMMAND')[0].strip(' :')}"
    if temporary:
        text = text.replace(temporary, str(out))
    text = " ".join(text.split())
    named = OSError(exc.errno, text if len(text) < 300 else text[:297] + "...")
    named.filename = str(out)
    return named
