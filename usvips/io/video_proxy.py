"""Seek proxies: a camera's recording re-encoded losslessly with every frame a key frame, so that a random
seek decodes one frame instead of everything since the preceding key frame.

A long-GOP H.264/HEVC file (one key frame a second or more) cannot be seeked frame-exactly faster than
decoding half a GOP on average; editors answer with proxies, and so do we, but exact ones: the decoder's
own pictures (YUV planes) are encoded losslessly, every frame on its own, so a proxy frame decodes to the
very same planes, and with the same colour range and matrix to the same RGB, as the original frame of
that index. The codec is Ut Video (a lossless intra codec made for editing: at 1080p about 7 ms of one
core to decode a frame, against 19 ms for H.264's lossless mode and 15–50 ms a frame for the half GOP an
exact seek in the original decodes), in a NUT container; pictures in full ("JPEG") range, which Ut Video
cannot flag, go to H.264's lossless mode (``qp 0``, all intra), which can (:func:`encoding_for`).
Frame ``i`` of the proxy is frame ``i`` of the recording (all chapters, in order); times stay
the original's. Disk: about 1.3–2.5 MB a 1080p frame (a minute at 30 fps ≈ 2.5–4.5 GB per camera).

Life cycle: a proxy is written to a temporary file beside its place, checked (frame count, every frame a
key frame at regular timestamps, and frames at random indices decoded from proxy and original compared
pixel for pixel) and only then moved into place, its stamp (``<proxy>.json``) written last: a cancelled,
failed or half-written build never leaves a proxy that is used. The stamp holds the proxy format
(:data:`PROXY_FORMAT`), the recording it was made from (each chapter's name, size in bytes, frame count,
and a digest of all its coded packets, which the stream's index reads anyway: a re-encoded, trimmed or
swapped file changes it even when its size does not) and the proxy's own index (frame count and
timestamps), so that opening a proxy reads no packets (a proxy of a long recording is gigabytes).
:func:`proxy_state` tells ``fresh``, ``missing`` or ``stale`` (and why); a stale proxy is never
attached and is replaced by the next build.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError
from usvips.io.atomic import give_normal_mode
from usvips.io.lazy_import import lazy_module
from usvips.io.video_stream import VideoStream

av = lazy_module("av")  # PyAV loaded when a video is first read (see usvips.io.lazy_import)

#: pixel formats a proxy stores exactly (8-bit YUV; "j" = full range)
EXACT_FORMATS = ("yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p")
#: the lossless intra encodings of a proxy: (codec, encoder options); :func:`encoding_for` chooses
ENCODINGS = {
    "utvideo": ("utvideo", {}),
    "h264 lossless": ("libx264", {"qp": "0", "preset": "ultrafast", "tune": "fastdecode"}),
}
#: a seek uses the proxy when the original would decode more than this many frames to reach its target
#: (measured at 1080p: a Ut Video frame decodes in about 2.5 H.264 frames' time; through the proxy from 2
#: frames on, a random seek a pair took 44 ms against 50 ms from 4 frames on, at load 9)
PROXY_AFTER = 1
SUFFIX = ".proxy.nut"
#: proxy files of every format, the current one first (format 1 was H.264 lossless in Matroska, unstamped)
SUFFIXES = (SUFFIX, ".proxy.mkv")
#: version of the proxy's encoding; a proxy stamped with another (or none: format 1 had no stamp) is stale.
#: 2: Ut Video in NUT (format 1: H.264 lossless in Matroska, 2.7 × the decoding time)
PROXY_FORMAT = 2
#: frames at random indices compared pixel for pixel against the original before a proxy is used
VERIFY_FRAMES = 6
STAMP_SUFFIX = ".json"


def recording_stamp(stream: VideoStream) -> dict:
    """What a proxy was made from and how: the proxy format, and per chapter its file name, size (bytes),
    frame count and a digest of its coded packets (from the stream's index; no decoding)."""
    chapters = []
    for chapter in stream.chapters:
        digest = hashlib.blake2b("".join(chapter.digests).encode(), digest_size=8).hexdigest()
        chapters.append([chapter.path.name, chapter.path.stat().st_size, chapter.count, digest])
    return {"size": list(stream.size), "chapters": chapters}


def proxy_path(folder: str | Path, stream: VideoStream) -> Path:
    """Where the proxy of ``stream`` lives in ``folder`` (:func:`proxy_path_for` its files)."""
    return proxy_path_for(folder, stream.paths)


def proxy_path_for(folder: str | Path, paths: Sequence[str | Path]) -> Path:
    """Where the proxy of the recording made of ``paths`` (its chapters in order) lives in ``folder``:
    named for its first file and a digest of its files' absolute paths (two cameras' files of the same
    name in different folders get different proxies; a changed recording's proxy is found, and found
    stale by :func:`proxy_state`); needs no decoding or indexing."""
    names = [str(Path(p).resolve()) for p in paths]
    key = hashlib.blake2b(json.dumps(names).encode(), digest_size=6).hexdigest()
    return Path(folder) / f"{Path(paths[0]).stem}.{key}{SUFFIX}"


def related_proxies(folder: str | Path, stream: VideoStream | Sequence[str | Path]) -> list[Path]:
    """The proxy files in ``folder`` of a recording (a stream, or its files): its current proxy (fresh or
    stale) and those of older proxy formats (named for the recording's first file)."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    paths = stream.paths if isinstance(stream, VideoStream) else stream
    stem = Path(paths[0]).stem
    current = proxy_path_for(folder, paths)
    legacy = [p for suffix in SUFFIXES[1:] for p in folder.glob(f"{glob_escape(stem)}.*{suffix}")
              if p.name[len(stem) + 1:-len(suffix)].isalnum()]
    found = [p for p in (current, stamp_path(current)) if p.is_file()]
    return found + sorted(legacy)


def stamp_path(proxy: str | Path) -> Path:
    """The stamp file beside a proxy (:func:`read_stamp`)."""
    return Path(f"{proxy}{STAMP_SUFFIX}")


def glob_escape(text: str) -> str:
    return "".join(f"[{c}]" if c in "*?[]" else c for c in text)


@dataclass(frozen=True)
class ProxyState:
    """``state`` is "fresh" (the proxy may be used), "missing" or "stale"; ``reason`` says why it is stale;
    ``path`` is where the proxy is (or would be) and ``bytes`` its size on disk (0 when missing)."""

    state: str
    path: Path
    reason: str = ""
    bytes: int = 0


def read_stamp(path: str | Path) -> dict | None:
    """The stamp of the proxy at ``path`` (see the module's docstring), or None (no stamp: a proxy of
    format 1, or one whose build did not finish; or an unreadable stamp)."""
    try:
        stamp = json.loads(stamp_path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return stamp if isinstance(stamp, dict) else None


def proxy_state(folder: str | Path, stream: VideoStream) -> ProxyState:
    """Whether ``stream``'s proxy in ``folder`` exists and was made, in this proxy format, from these very
    files (:func:`recording_stamp`)."""
    path = proxy_path(folder, stream)
    if not path.is_file():
        return ProxyState("missing", path)
    size = path.stat().st_size + (stamp_path(path).stat().st_size if stamp_path(path).is_file() else 0)
    stamp = read_stamp(path)
    if stamp is None:
        return ProxyState("stale", path, "no proxy stamp (an older proxy format, or a damaged file)", size)
    if stamp.get("format") != PROXY_FORMAT:
        return ProxyState("stale", path, f"proxy format {stamp.get('format')}, this version writes {PROXY_FORMAT}",
                          size)
    if stamp.get("bytes") != path.stat().st_size:
        return ProxyState("stale", path, f"the proxy file is damaged ({path.stat().st_size} bytes, built with "
                          f"{stamp.get('bytes')})", size)
    if stamp.get("recording") != recording_stamp(stream):
        return ProxyState("stale", path, "the recording changed since the proxy was built (files, sizes, frames "
                          "or content)", size)
    return ProxyState("fresh", path, "", size)


def build_proxy(stream: VideoStream, out: str | Path, progress: Callable[[int, int], None] | None = None,
                cancelled: Callable[[], bool] | None = None) -> Path:
    """Encode every frame of ``stream`` (in order, all chapters) into the lossless all-intra proxy ``out``,
    check it (:func:`verify_proxy`) and move it into place, replacing a stale one and removing proxies of
    older formats of the same recording. ``progress(done, total)`` every 25 frames; ``cancelled()`` → stop
    and raise :class:`InterruptedError`. On any failure (cancelled, disk full, folder not writable, a
    damaged recording) the partial file is removed and ``out`` is left as it was."""
    out = Path(out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".nut", dir=str(out.parent))
        os.close(handle)
    except OSError as error:
        raise InputFileError(str(out.parent), f"cannot write a seek proxy here: {_os_reason(error)}") from None
    stamp_temporary = None
    try:
        _encode(stream, temporary, progress, cancelled)
        index = verify_proxy(stream, temporary)
        stamp = {"format": PROXY_FORMAT, "recording": recording_stamp(stream), "index": index,
                 "bytes": os.path.getsize(temporary)}
        handle, stamp_temporary = tempfile.mkstemp(prefix=f".{out.name}.", suffix=STAMP_SUFFIX, dir=str(out.parent))
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            json.dump(stamp, file)
        for old in related_proxies(out.parent, stream):
            old.unlink(missing_ok=True)  # the stamp first: a proxy without its stamp is never used
        give_normal_mode(temporary)
        give_normal_mode(stamp_temporary)
        os.replace(temporary, out)
        os.replace(stamp_temporary, stamp_path(out))
    except InterruptedError:
        raise  # cancelled (an OSError too, but not a failure to write)
    except av.error.FFmpegError as error:
        raise InputFileError(str(out), f"cannot write the seek proxy: {_ffmpeg_reason(error)}") from None
    except OSError as error:
        raise InputFileError(str(out), f"cannot write the seek proxy: {_os_reason(error)}") from None
    finally:
        for path in (temporary, stamp_temporary):
            if path is not None and os.path.exists(path):
                os.unlink(path)
    return out


def _os_reason(error: OSError) -> str:
    if error.errno == errno.ENOSPC:
        return "the disk is full (no space left on the device); the partial proxy was removed"
    if error.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "the folder is read-only"
    return error.strerror or str(error)


def _ffmpeg_reason(error: av.error.FFmpegError) -> str:
    if getattr(error, "errno", None) == errno.ENOSPC:
        return "the disk is full (no space left on the device); the partial proxy was removed"
    return str(error)


def _encode(stream: VideoStream, temporary: str, progress, cancelled) -> None:
    done = 0
    with av.open(temporary, "w", format="nut") as container:
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


def encoding_for(pixel_format: str, color_range: int) -> str:
    """The :data:`ENCODINGS` key that keeps pictures of this pixel format and colour range (FFmpeg's
    ``AVColorRange``: 2 = full) exactly: Ut Video, unless the range is full (it cannot flag that)."""
    if pixel_format not in EXACT_FORMATS:
        raise ValueError(pixel_format)
    full = pixel_format.startswith("yuvj") or int(color_range) == 2
    return "h264 lossless" if full else "utvideo"


def _open_target(container, frame: av.VideoFrame, stream: VideoStream, path: Path):
    if frame.format.name not in EXACT_FORMATS:
        raise InputFileError(str(path), f"pixel format {frame.format.name} cannot be kept exactly in a proxy "
                             f"(exact: {', '.join(EXACT_FORMATS)})")
    codec, options = ENCODINGS[encoding_for(frame.format.name, frame.color_range)]
    rate = Fraction(stream.fps).limit_denominator(1001) if stream.fps > 0 else Fraction(30)
    target = container.add_stream(codec, rate=rate)
    target.width, target.height = frame.width, frame.height
    target.pix_fmt = frame.format.name
    context = target.codec_context
    context.gop_size = 1
    context.max_b_frames = 0
    for name in ("color_range", "colorspace", "color_primaries", "color_trc"):
        setattr(context, name, getattr(frame, name))
    target.options = dict(options)
    return target, 1 / rate


def verify_proxy(stream: VideoStream, path: str | Path, frames: int = VERIFY_FRAMES, seed: int = 0) -> dict:
    """Raise :class:`InputFileError` unless the proxy at ``path`` has the recording's frame count and size,
    every frame a key frame at regular timestamps, and decodes at the first, the last and ``frames``
    random indices (visited in random order: forwards and backwards) to exactly the original's pixels.
    Returns the proxy's index for its stamp (``count``, ``size``, ``codec``, ``pts_first``, ``pts_step``,
    ``time_base`` as [numerator, denominator]), read from every packet of the file."""
    with VideoStream(path) as proxy, VideoStream(stream.paths) as original:
        if proxy.frame_count != original.frame_count or proxy.size != original.size:
            raise InputFileError(str(path), f"the proxy has {proxy.frame_count} frames of {proxy.size}, the "
                                 f"recording {original.frame_count} of {original.size}: not its proxy")
        chapter = proxy.chapters[0]
        step = int(chapter.pts[1] - chapter.pts[0]) if chapter.count > 1 else 1
        regular = chapter.pts[0] + step * np.arange(chapter.count)
        if not chapter.keyframe.all() or not np.array_equal(chapter.pts, regular):
            raise InputFileError(str(path), "the proxy's frames are not all key frames at regular timestamps")
        rng = np.random.default_rng(seed)
        count = original.frame_count
        indices = [0, count - 1] + [int(i) for i in rng.permutation(count)[:frames]]
        for index in indices:
            if not np.array_equal(proxy.picture(index).array(), original.picture(index).array()):
                raise InputFileError(str(path), f"frame {index} of the proxy differs from the recording's: "
                                     "the proxy is not used")
        with av.open(str(path)) as container:
            time_base = container.streams.video[0].time_base
        return {"count": int(chapter.count), "size": list(proxy.size), "codec": proxy.codec,
                "pts_first": int(chapter.pts[0]), "pts_step": step,
                "time_base": [time_base.numerator, time_base.denominator]}


def needs_proxy(stream: VideoStream) -> bool:
    """Whether a seek in ``stream`` can decode more than :data:`PROXY_AFTER` frames (a key frame further
    back than that): long-GOP H.264/HEVC does, all-intra recordings (Motion-JPEG, FFV1) do not."""
    for chapter in stream.chapters:
        keys = np.flatnonzero(chapter.keyframe)
        gaps = np.diff(np.append(keys, chapter.count))
        if gaps.size and int(gaps.max()) - 1 > PROXY_AFTER:
            return True
    return False


def attach_proxy(stream: VideoStream, folder: str | Path) -> bool:
    """Let ``stream`` seek through its proxy in ``folder`` when a fresh one exists (:func:`proxy_state`);
    returns whether it did. A stale or unreadable proxy is never used."""
    state = proxy_state(folder, stream)
    if state.state != "fresh":
        return False
    index = read_stamp(state.path)["index"]
    try:
        proxy = VideoStream.from_index(state.path, index["count"], tuple(index["size"]), index["codec"],
                                       index["pts_first"], index["pts_step"], Fraction(*index["time_base"]))
    except (InputFileError, KeyError, TypeError, ValueError, ZeroDivisionError):
        return False
    if proxy.frame_count != stream.frame_count or proxy.size != stream.size:
        proxy.close()
        return False
    proxy.thread_type = "SLICE"  # frame threading would decode a pipeline's worth of frames after each seek
    stream.attach_proxy(proxy, PROXY_AFTER)
    return True


def delete_proxy(folder: str | Path, stream: VideoStream | Sequence[str | Path]) -> int:
    """Remove the proxy of a recording (a stream, or its files) and those of older formats from
    ``folder``; returns the bytes freed."""
    freed = 0
    for path in related_proxies(folder, stream):
        freed += path.stat().st_size
        path.unlink(missing_ok=True)
    return freed
