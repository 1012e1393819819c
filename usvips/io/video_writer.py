"""Writing videos through FFmpeg (PyAV): H.264 MP4 (the codec of most cameras), MPEG-4, Motion-JPEG,
FFV1 (lossless), optionally with explicit presentation times (variable frame rate) and a soundtrack.

Used for the H.264 version of a sample and for test videos. Written to a temporary file first and moved
into place: a failure never leaves a partial video behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError
from usvips.io.atomic import give_normal_mode
from usvips.io.lazy_import import lazy_module
from usvips.io.video_stream import VideoStream

av = lazy_module("av")  # PyAV loaded when a video is first read (see usvips.io.lazy_import)

#: codec → (FFmpeg encoder, pixel format, containers it may go in)
CODECS: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "h264": ("libx264", "yuv420p", (".mp4", ".mkv", ".mov")),
    "mpeg4": ("mpeg4", "yuv420p", (".mp4", ".avi", ".mkv")),
    "mjpeg": ("mjpeg", "yuvj420p", (".avi", ".mkv")),
    "ffv1": ("ffv1", "yuv444p", (".mkv", ".avi")),
}


def encoders_available() -> list[str]:
    """The codecs of :data:`CODECS` this FFmpeg build can encode."""
    return [name for name, (encoder, _, _) in CODECS.items() if encoder in av.codecs_available]


def encode_video(path: str | Path, frames: Iterable[np.ndarray], fps: float, codec: str = "h264",
                 times_s: Sequence[float] | None = None, gop: int = 250, bframes: int = 2,
                 audio: tuple[np.ndarray, int] | None = None, quality: int = 18) -> int:
    """Encode RGB (H, W, 3) uint8 frames; returns the frame count.

    ``fps`` is the nominal rate (frames per second, any positive rational); ``times_s`` (seconds, one per
    frame, increasing) makes a variable-frame-rate file. ``gop`` is the key-frame interval in frames,
    ``bframes`` the B-frames between references (H.264, MPEG-4); ``quality`` the H.264 CRF.
    ``audio``: (samples (N,) float in [-1, 1], sample rate Hz), stored as AAC (MP4) or PCM (MKV, AVI)."""
    path = Path(path)
    if codec not in CODECS:
        raise InputFileError(str(path), f"codec {codec!r}: choose one of {', '.join(CODECS)}")
    encoder, pixel_format, suffixes = CODECS[codec]
    if encoder not in av.codecs_available:
        raise InputFileError(str(path), f"this FFmpeg build has no {encoder} encoder")
    if path.suffix.lower() not in suffixes:
        raise InputFileError(str(path), f"{codec} videos go in {', '.join(suffixes)} files")
    if not (np.isfinite(fps) and fps > 0):
        raise InputFileError(str(path), f"fps must be a positive number of frames per second, got {fps!r}")
    rate = Fraction(fps).limit_denominator(1001)
    time_base = Fraction(1, 1000) if times_s is not None else 1 / rate
    handle, temporary = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=str(path.parent))
    os.close(handle)
    count = 0
    try:
        with av.open(temporary, "w") as container:
            stream = container.add_stream(encoder, rate=rate)
            stream.pix_fmt = pixel_format
            stream.time_base = time_base
            stream.codec_context.time_base = time_base
            if codec in ("h264", "mpeg4"):
                stream.codec_context.gop_size = gop
                stream.codec_context.max_b_frames = bframes
            if codec == "h264":
                stream.options = {"crf": str(quality), "preset": "veryfast", "threads": "1"}
            elif codec in ("mjpeg", "mpeg4"):
                stream.options = {"qmin": "2", "qmax": "3"}  # constant quality, not a starving bit rate
            sound = None
            if audio is not None:
                samples, sample_rate = audio
                sound = container.add_stream("aac" if path.suffix.lower() in (".mp4", ".mov") else "pcm_s16le",
                                             rate=int(sample_rate))
                sound.layout = "mono"
            for index, frame in enumerate(frames):
                frame = np.asarray(frame)
                if frame.dtype != np.uint8 or frame.ndim != 3 or frame.shape[2] != 3:
                    raise InputFileError(str(path), f"frame {index}: expected uint8 RGB (H, W, 3), got "
                                         f"{frame.dtype} {frame.shape}")
                if index == 0:
                    stream.height, stream.width = frame.shape[:2]
                elif frame.shape[:2] != (stream.height, stream.width):
                    raise InputFileError(str(path), f"frame {index}: {frame.shape[1]} × {frame.shape[0]} px, but "
                                         f"the video is {stream.width} × {stream.height} px")
                picture = av.VideoFrame.from_ndarray(frame, format="rgb24")
                if times_s is not None:
                    picture.pts = round(times_s[index] * 1000)
                else:
                    picture.pts = index
                picture.time_base = time_base
                container.mux(stream.encode(picture))
                count += 1
            if count == 0:
                raise InputFileError(str(path), "no frames to write")
            container.mux(stream.encode(None))
            if sound is not None:
                _write_audio(container, sound, *audio)
        give_normal_mode(temporary)
        os.replace(temporary, path)
    except av.error.FFmpegError as error:
        raise InputFileError(str(path), f"FFmpeg cannot write the video: {error}") from None
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return count


def transcode_h264(source: str | Path, target: str | Path, gop: int = 10, quality: int = 20) -> bool:
    """Write ``source``'s frames (decoded exactly) as an H.264 MP4 at its frame rate (GOP ``gop`` with
    B-frames, CRF ``quality``); False, writing nothing, when this FFmpeg has no H.264 encoder. Used for
    the samples' H.264 versions (deterministic for one FFmpeg build: one encoder thread)."""
    if "libx264" not in av.codecs_available:
        return False
    with VideoStream(source) as video:
        frames = [video.frame(i) for i in range(video.frame_count)]
        fps = video.fps
    encode_video(target, frames, round(fps, 6), "h264", gop=gop, bframes=2, quality=quality)
    return True


def _write_audio(container, stream, samples: np.ndarray, rate: int) -> None:
    samples = np.clip(np.asarray(samples, float), -1, 1)
    pcm = (samples * 32767).astype(np.int16).reshape(1, -1)
    frame = av.AudioFrame.from_ndarray(pcm, format="s16", layout="mono")
    frame.sample_rate = int(rate)
    frame.pts = 0
    frame.time_base = Fraction(1, int(rate))
    resampler = av.AudioResampler(format=stream.codec_context.format.name, layout="mono", rate=int(rate))
    frame_size = stream.codec_context.frame_size or 1024
    fifo = av.AudioFifo()
    for out in resampler.resample(frame):
        fifo.write(out)
    while fifo.samples:
        chunk = fifo.read(min(frame_size, fifo.samples))
        container.mux(stream.encode(chunk))
    container.mux(stream.encode(None))
