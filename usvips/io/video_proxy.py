"""Seek proxies: a camera's recording re-encoded losslessly with every frame a key frame, so that a random
seek decodes one frame instead of everything since the preceding key frame.

A long-GOP H.264/HEVC file (one key frame a second or more) cannot be seeked frame-exactly faster than
decoding half a GOP on average (at 1080p on this class of machine 0.2–0.4 s a frame pair); editors
answer with proxies, and so do we, but exact ones: the decoder's own pictures (YUV planes) are
encoded with H.264 in its lossless mode (``qp 0``, all intra), so a proxy frame decodes to the very same
planes, and with the same colour range and matrix to the same RGB, as the original frame of that index.
Frame ``i`` of the proxy is frame ``i`` of the recording (all chapters, in order); times stay the
original's. Disk: about 1–2.5 MB a 1080p frame (a minute at 30 fps ≈ 2–4.5 GB per camera).

Built on demand (``usvips video proxy``, the Video dock's *Seek proxy* button) in the background, written
to a temporary file and moved into place; a proxy whose recording changed (names, sizes, frame count)
is not used.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path

import av

from usvips.core.errors import InputFileError
from usvips.io.video_stream import VideoStream

#: pixel formats H.264's lossless mode stores exactly (8-bit YUV; "j" = full range)
EXACT_FORMATS = ("yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p")
#: a seek uses the proxy when the original would decode more than this many frames to reach its target
PROXY_AFTER = 3
SUFFIX = ".proxy.mkv"


def recording_key(stream: VideoStream) -> str:
    """A short digest of what the proxy was made from: each chapter's name, size (bytes) and frame count."""
    parts = [(c.path.name, c.path.stat().st_size, c.count) for c in stream.chapters]
    return hashlib.blake2b(json.dumps(parts).encode(), digest_size=6).hexdigest()


def proxy_path(folder: str | Path, stream: VideoStream) -> Path:
    """Where the proxy of ``stream`` lives in ``folder``: named for its first file and :func:`recording_key`."""
    return Path(folder) / f"{stream.chapters[0].path.stem}.{recording_key(stream)}{SUFFIX}"


def build_proxy(stream: VideoStream, out: str | Path, progress: Callable[[int, int], None] | None = None,
                cancelled: Callable[[], bool] | None = None) -> Path:
    """Encode every frame of ``stream`` (in order, all chapters) into the lossless all-intra proxy ``out``.
    ``progress(done, total)`` every 25 frames; ``cancelled()`` → stop, leaving nothing behind (returns
    ``out`` unchanged then raises :class:`InterruptedError`)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".mkv", dir=str(out.parent))
    os.close(handle)
    done = 0
    try:
        with av.open(temporary, "w", format="matroska") as container:
            target = None
            for chapter in stream.chapters:
                with av.open(str(chapter.path)) as source:
                    video = source.streams.video[0]
                    video.thread_type = "AUTO"
                    for frame in source.decode(video):
                        if target is None:
                            target, frame_time = _open_target(container, frame, stream, chapter.path)
                        if frame.format.name != target.pix_fmt:
                            raise InputFileError(str(chapter.path), f"frame {done} is {frame.format.name}, the "
                                                 f"recording began in {target.pix_fmt}: not one recording")
                        frame.pts = done
                        frame.time_base = frame_time
                        frame.pict_type = av.video.frame.PictureType.NONE
                        container.mux(target.encode(frame))
                        done += 1
                        if progress is not None and done % 25 == 0:
                            progress(done, stream.frame_count)
                        if cancelled is not None and cancelled():
                            raise InterruptedError("proxy cancelled")
            if target is not None:
                container.mux(target.encode(None))
        if done != stream.frame_count:
            raise InputFileError(str(stream.paths[0]), f"decoded {done} frames but the index holds "
                                 f"{stream.frame_count}: the file is damaged")
        os.replace(temporary, out)
    except av.error.FFmpegError as error:
        raise InputFileError(str(out), f"cannot write the proxy: {error}") from None
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return out


def _open_target(container, frame: av.VideoFrame, stream: VideoStream, path: Path):
    if frame.format.name not in EXACT_FORMATS:
        raise InputFileError(str(path), f"pixel format {frame.format.name} cannot be kept exactly in a proxy "
                             f"(exact: {', '.join(EXACT_FORMATS)})")
    rate = Fraction(stream.fps).limit_denominator(1001) if stream.fps > 0 else Fraction(30)
    target = container.add_stream("libx264", rate=rate)
    target.width, target.height = frame.width, frame.height
    target.pix_fmt = frame.format.name
    context = target.codec_context
    context.gop_size = 1
    context.max_b_frames = 0
    for name in ("color_range", "colorspace", "color_primaries", "color_trc"):
        setattr(context, name, getattr(frame, name))
    target.options = {"qp": "0", "preset": "ultrafast", "tune": "fastdecode"}
    return target, 1 / rate


def attach_proxy(stream: VideoStream, folder: str | Path) -> bool:
    """Let ``stream`` seek through its proxy in ``folder`` when one was built for this recording (same
    files, sizes and frame count); returns whether it did."""
    path = proxy_path(folder, stream)
    if not path.is_file():
        return False
    try:
        proxy = VideoStream(path)
    except InputFileError:
        return False
    if proxy.frame_count != stream.frame_count or proxy.size != stream.size:
        proxy.close()
        return False
    proxy.thread_type = "SLICE"  # frame threading would decode a pipeline's worth of frames after each seek
    stream.attach_proxy(proxy, PROXY_AFTER)
    return True
