"""A user's own media in a project: image pairs from folders or lists, stereo videos (frame-exact,
synchronised), and the synchronised frame pair written out.

Sits above io and store like :mod:`usvips.app.samples` (it joins files read by io to the project written by
store); the command line and the workstation both go through here.

Convention: a video pair's offset ``k`` (frames) means left frame ``i`` and right frame ``i + k`` show the
same instant; frame numbers and times of a vertex are the left stream's frame ``i``, the right's ``i + k``
and the left frame's presentation time (s).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.app.calibration_size import check_for, check_size
from usvips.app.calibrations import make_active, read_calibration
from usvips.core import synchronisation, validation
from usvips.core.errors import InputFileError, InvalidParameterError, UsvipsError, concerning
from usvips.core.synchronisation import SyncEstimate
from usvips.io import video_proxy
from usvips.io.atomic import guard_output
from usvips.io.images import read_image, write_image
from usvips.io.pairing import IMAGE_SUFFIXES, VIDEO_SUFFIXES, check_chapters, expand, pair_images, shared_stem
from usvips.io.video_stream import Chapter, VideoStream
from usvips.store.interface import ProjectStore
from usvips.store.records import Video

#: left and right frame rates further apart than this (relative) are not one stereo video
FPS_TOLERANCE = 1e-3


class VideoError(UsvipsError):
    """A stereo video that cannot be used as asked; the message names the file or pair."""


@dataclass(frozen=True)
class AddedVideo:
    """What :func:`add_video` stored: its label, frames, frame rate (fps), and the problems found in the
    streams (one line each; empty when both are clean)."""

    label: str
    frame_count: int
    fps: float
    warnings: tuple[str, ...]
    #: the right camera's frames (``frame_count`` is the left's)
    right_frame_count: int = 0

    @property
    def summary(self) -> str:
        """``video 'x': left 1200 frames, right 1198 frames at 25 fps``: both cameras' counts, always."""
        return (f"video {self.label!r}: left {_frames(self.frame_count)}, right {_frames(self.right_frame_count)} "
                f"at {self.fps:.6g} fps")


# ---------------------------------------------------------------------------- image pairs
def plan_image_pairs(left: Sequence[str | Path], right: Sequence[str | Path], label_prefix: str = "",
                     by: str = "auto", max_dt: float = 1.0) -> tuple[list[tuple[str, Path, Path]], str]:
    """The (label, left, right) pairs that :func:`add_image_pairs` would add, and the rule used (for a
    person to confirm). Labels: prefix + the shared stem (or the pair's number when paired by order)."""
    label_prefix = validation.name("label_prefix", label_prefix, allow_empty=True) if label_prefix else ""
    label_prefix = validation.folder_name("label_prefix", label_prefix) if label_prefix else ""  # (a tab: refused
    # by name above, which allows a prefix of white space only; folder_name does not)
    max_dt = validation.finite("max_dt", max_dt)
    if max_dt <= 0:
        raise InvalidParameterError("max_dt", f"must be > 0 seconds, got {max_dt:g}",
                                    label="the time between partners' capture")
    left_files = expand(left, IMAGE_SUFFIXES, "left")
    right_files = expand(right, IMAGE_SUFFIXES, "right")
    _refuse_repeated_files({"left": left_files, "right": right_files}, "image")
    pairs, rule = pair_images(left_files, right_files, by, max_dt)
    labels = [f"{label_prefix}{shared_stem(a) if rule == 'stem' else f'{n + 1:03d}'}" for n, (a, _) in enumerate(pairs)]
    for label, (a, _) in zip(labels, pairs, strict=True):
        validation.folder_name(f"pair label (from {a.name})", label)
    return [(label, a, b) for label, (a, b) in zip(labels, pairs, strict=True)], rule


def _refuse_repeated_files(sides: dict[str, Sequence[Path]], what: str) -> None:
    """One file given twice — in one camera's list (the same chapter twice) or as both cameras (the same
    video as left and right) — by the same name or another name of it (a link): one line naming both
    mentions. (Identical copies are not compared: synthetic test footage may be byte-identical.)"""
    mentions = []
    for side, files in sides.items():
        for path in files:
            try:
                stat = path.stat()
            except OSError:
                continue  # named missing where it is read
            mentions.append((side, path, (stat.st_dev, stat.st_ino)))
    for j, (side, path, inode) in enumerate(mentions):
        for first_side, first, first_inode in mentions[:j]:
            if inode != first_inode:
                continue
            where = f"for both the {first_side} and the {side} camera" if first_side != side else \
                f"twice for the {side} camera"
            why = ""
            if what == "video":
                why = " (the same video as both cameras)" if first_side != side else " (the same chapter twice)"
            raise concerning(InputFileError(str(path), f"the same file as {first} is given {where}{why}"), side)


def add_image_pairs(project: ProjectStore, plan: Sequence[tuple[str, Path, Path]], medium: str = "water") -> list[int]:
    """Add planned pairs (all or none); left and right must be readable images of one size, none of them
    already an image of one of the project's pairs (one image in two pairs)."""
    taken = {}
    for pair in project.pairs():
        for side in ("left", "right"):
            if getattr(pair, side):
                taken[project.media_location(getattr(pair, side))] = pair.label
    for label, left, right in plan:
        for path in (left, right):
            if Path(path).resolve() in taken:
                raise InputFileError(str(path), f"is already an image of pair {taken[Path(path).resolve()]!r}; "
                                     f"pair {label!r} cannot have it too (one image in two pairs)")
    sizes = []
    for label, left, right in plan:
        a, b = read_image(left, strict=True), read_image(right, strict=True)
        if a.shape[:2] != b.shape[:2]:
            raise InputFileError(str(right), f"pair {label!r}: {b.shape[1]} × {b.shape[0]} px, but the left image "
                                 f"{left.name} is {a.shape[1]} × {a.shape[0]} px")
        sizes.append((a.shape[1], a.shape[0]))
    return project.add_image_pairs(plan, medium, sizes)


# ---------------------------------------------------------------------------- videos
@dataclass(frozen=True)
class VideoPlan:
    """A stereo video read and checked, ready to store (:func:`store_video`): its label, each camera's
    files as (path, frames, fps), the pair's fps, frame count and size (px), and the problems found."""

    label: str
    left: tuple[tuple[Path, int, float], ...]
    right: tuple[tuple[Path, int, float], ...]
    fps: float
    frame_count: int
    size: tuple[int, int]
    warnings: tuple[str, ...]
    #: the right camera's frames (``frame_count`` is the left's)
    right_frame_count: int = 0


def _frames(count: int) -> str:
    return f"{count} frame" + ("" if count == 1 else "s")


#: how a player turns a picture, by its clockwise display rotation in degrees
TURN_WORDS = {90: "90° clockwise", 180: "upside down (180°)", 270: "90° counter-clockwise"}


def inspect_video(left: Sequence[str | Path], right: Sequence[str | Path], label: str | None = None,
                  scan_pictures: bool = False) -> VideoPlan:
    """Read a stereo video's files (each camera's files in order: chapters of one recording). Refuses
    left and right of different picture sizes or frame rates; reports variable frame rate, duplicated
    and dropped frames (``scan_pictures`` decodes every frame to find repeated pictures too). Touches no
    project (may run in a worker thread)."""
    left_files = expand(left, VIDEO_SUFFIXES, "left")
    right_files = expand(right, VIDEO_SUFFIXES, "right")
    _refuse_repeated_files({"left": left_files, "right": right_files}, "video")
    check_chapters(left_files, "left")
    check_chapters(right_files, "right")
    label = validation.name("label", label) if label is not None else \
        validation.name("label (from the file name)", shared_stem(left_files[0]) or left_files[0].stem)
    with VideoStream(left_files) as a, VideoStream(right_files) as b:
        if a.size != b.size:
            raise VideoError(f"{right_files[0]}: {b.width} × {b.height} px, but the left video {left_files[0].name} "
                             f"is {a.width} × {a.height} px")
        for stream, files in ((a, left_files), (b, right_files)):  # blame the file at fault
            if not np.isfinite(stream.fps):
                raise VideoError(f"{files[0]}: a video needs at least two frames to have a frame rate "
                                 f"(it has {stream.frame_count})")
        if abs(a.fps - b.fps) > FPS_TOLERANCE * a.fps:
            raise VideoError(f"{right_files[0]}: {b.fps:.6g} fps, but the left video {left_files[0].name} runs at "
                             f"{a.fps:.6g} fps: frames cannot be paired by number")
        warnings = []
        for side, stream, files in (("left", a, left_files), ("right", b, right_files)):
            for chapter in stream.chapters:  # damage found now, not as a decoding error while measuring
                for index in {chapter.first, chapter.first + chapter.count - 1}:
                    try:
                        stream.frame(index, grey=True)
                    except UsvipsError as error:
                        raise VideoError(f"{chapter.path} ({side}) is damaged: "
                                         f"{str(error).removeprefix(str(chapter.path) + ': ')}") from None
            turned = stream.picture(0).display_rotation
            if turned:
                how = TURN_WORDS.get(turned, f"{turned}° clockwise")
                warnings.append(f"{files[0]} ({side}): players show this video turned {how} (its "
                                "display matrix); USVIPS measures the pictures as recorded, unturned, and so must its "
                                "calibration have been made")
            report = stream.scan_pictures() if scan_pictures else stream.report
            if not report.clean:
                warnings.append(f"{files[0]} ({side}): {report.summary()}")
        files = {side: tuple((p, c.count, chapter_fps(c, s.fps)) for p, c in zip(s.paths, s.chapters, strict=True))
                 for side, s in (("left", a), ("right", b))}
        if a.frame_count != b.frame_count:  # both counts, at add time (the offset pairs them; say it)
            warnings.append(f"the cameras' frame counts differ: left {_frames(a.frame_count)}, right "
                            f"{_frames(b.frame_count)} (a file cut short, or the cameras started and stopped "
                            "apart: synchronise, then frames past the shorter end have no partner)")
        return VideoPlan(label, files["left"], files["right"], a.fps, a.frame_count, a.size, tuple(warnings),
                         b.frame_count)


def store_video(project: ProjectStore, plan: VideoPlan, medium: str = "water") -> AddedVideo:
    """Store the inspected video ``plan``; ``medium`` "air" or "water" (what the cameras looked through)."""
    project.add_video(plan.label, plan.left, plan.right, plan.fps, plan.frame_count, plan.size,
                      "\n".join(plan.warnings), medium)
    return AddedVideo(plan.label, plan.frame_count, plan.fps, plan.warnings, plan.right_frame_count)


def add_video(project: ProjectStore, left: Sequence[str | Path], right: Sequence[str | Path], label: str | None = None,
              scan_pictures: bool = False, medium: str = "water") -> AddedVideo:
    """:func:`inspect_video` then :func:`store_video` (``medium`` "air" or "water")."""
    return store_video(project, inspect_video(left, right, label, scan_pictures), medium)


def chapter_fps(chapter: Chapter, stream_fps: float) -> float:
    """A chapter file's frame rate as recorded with a video (frames per second): from the median step of its
    presentation timestamps, the stream's rate for a one-frame chapter."""
    if chapter.count > 1:
        return 1.0 / float(np.median(np.diff(chapter.pts)) * chapter.time_base)
    return stream_fps


def open_streams(project: ProjectStore, label: str) -> tuple[Video, VideoStream, VideoStream]:
    """The stored video (as :meth:`Project.video`) and its two streams, opened (seeking through their
    proxies where :func:`build_proxies` made them); close them after use."""
    video = project.video(label)
    left = VideoStream([project.media_path(p) for p in video.paths("left")])
    try:
        right = VideoStream([project.media_path(p) for p in video.paths("right")])
    except BaseException:
        left.close()
        raise
    for stream in (left, right):
        video_proxy.attach_proxy(stream, proxy_folder(project))
    return video, left, right


def proxy_folder(project: ProjectStore) -> Path:
    """Where a project's seek proxies live: ``proxies/`` in the store's derived-media folder (beside the
    project file of a file project)."""
    return project.derived_media_folder() / "proxies"


ProxyStates = Sequence[tuple[list[Path], video_proxy.ProxyState]]


def plan_proxies(project: ProjectStore, label: str, states: ProxyStates | None = None) -> list[tuple[list[Path], Path]]:
    """The proxies :func:`build_proxies` would write for the video pair: (the camera's files, proxy path)
    for each camera that has no fresh one (none yet, or a stale one: see :func:`proxy_states`); pass
    ``states`` from :func:`proxy_states` not to index the recordings again."""
    states = proxy_states(project, label) if states is None else states
    return [(files, state.path) for files, state in states if state.state != "fresh"]


def proxy_states(project: ProjectStore, label: str) -> list[tuple[list[Path], video_proxy.ProxyState]]:
    """Each camera's files and its seek proxy's state: fresh (used), missing, or stale with its reason
    (never used; rebuilt by :func:`build_proxies`), with its size on disk. Indexes both recordings (reads
    their packets)."""
    video = project.video(label)
    states = []
    for side in ("left", "right"):
        files = [project.media_path(p) for p in video.paths(side)]
        with VideoStream(files) as stream:
            states.append((files, video_proxy.proxy_state(proxy_folder(project), stream)))
    return states


def proxy_files(project: ProjectStore, label: str) -> list[Path]:
    """The seek-proxy files on disk for the video pair (current and older formats; fresh or stale), found
    by name alone (no decoding): what :func:`delete_proxies` removes and ``project info`` adds up."""
    video = project.video(label)
    folder = proxy_folder(project)
    # where the files were recorded, whether or not they are there now (a missing file's proxies still count)
    return [path for side in ("left", "right")
            for path in video_proxy.related_proxies(folder, [project.media_location(p) for p in video.paths(side)])]


def proxy_bytes(project: ProjectStore, label: str) -> int:
    """Bytes the video pair's seek proxies take on disk (0 when it has none)."""
    return sum(path.stat().st_size for path in proxy_files(project, label))


def delete_proxies(project: ProjectStore, label: str) -> int:
    """Remove the video pair's seek proxies (every format); returns the bytes freed. Seeks then decode the
    original again (exact, slower). Called when a video is removed from a project, by ``usvips video proxy
    --delete`` and by the window's *Delete seek proxy*."""
    freed = 0
    for path in proxy_files(project, label):
        try:
            size = path.stat().st_size
            path.unlink()
        except FileNotFoundError:
            continue
        except OSError as error:
            raise VideoError(f"{path}: cannot delete the seek proxy: {error.strerror or error}") from None
        freed += size
    return freed


def build_proxies(plan: Sequence[tuple[Sequence[Path], Path]], progress: Callable[[int, int], None] | None = None,
                  cancelled: Callable[[], bool] | None = None) -> list[Path]:
    """Build the planned seek proxies (:mod:`usvips.io.video_proxy`); reads and writes files only (no
    project), so the window runs it in a worker. ``progress(done, total)`` over all frames."""
    streams = [VideoStream(files) for files, _ in plan]
    try:
        total = sum(s.frame_count for s in streams) or 1
        done_before = 0
        written = []
        for stream, (_, path) in zip(streams, plan, strict=True):
            def report(done: int, _: int, before: int = done_before) -> None:
                if progress is not None:
                    progress(before + done, total)
            written.append(video_proxy.build_proxy(stream, path, report, cancelled))
            done_before += stream.frame_count
        return written
    finally:
        for stream in streams:
            stream.close()


def partner_frame(video: Video, frame: int, right_count: int | None = None) -> int:
    """The right frame showing left frame ``frame``'s instant; named error when outside either video."""
    count = video.frame_count
    right_count = count if right_count is None else right_count
    partner = int(frame) + int(video.offset_frames)
    if not 0 <= int(frame) < count:
        raise VideoError(f"video {video.label!r}: frame {frame} is out of range (0 to {count - 1})")
    if not 0 <= partner < right_count:
        raise VideoError(f"video {video.label!r}: left frame {frame} has no right partner (right frame {partner} "
                         f"with offset {video.offset_frames}; the right video has frames 0 to {right_count - 1})")
    return partner


def left_frame_time(left: VideoStream, frame: int) -> float:
    """The time (s) of a stereo video's left frame ``frame``, as every vertex measured on that frame stores
    it: the frame's presentation time in the left stream (seconds from its first frame) — on a
    variable-frame-rate video not ``frame / fps``. The window (the frame it shows), :func:`frame_pair` and
    tracking (:mod:`usvips.app.tracking`) all take it from here."""
    return left.time_of(int(frame))


def left_frame_times(project: ProjectStore, label: str, frames: Sequence[int]) -> np.ndarray:
    """:func:`left_frame_time` of each of ``frames`` of video ``label`` (s), the left stream opened for it
    (its packets indexed, nothing decoded)."""
    video = project.video(label)
    with VideoStream([project.media_path(p) for p in video.paths("left")]) as left:
        return np.array([left_frame_time(left, f) for f in frames], float)


def frame_pair(project: ProjectStore, label: str, frame: int) -> tuple[np.ndarray, np.ndarray, int, float]:
    """Left frame ``frame`` and its synchronised right frame, decoded exactly; the right frame's number
    and the left frame's time (s, :func:`left_frame_time`)."""
    video, left, right = open_streams(project, label)
    with left, right:
        partner = partner_frame(video, frame, right.frame_count)
        return left.frame(frame), right.frame(partner), partner, left_frame_time(left, frame)


def write_frame_pair(left: np.ndarray, right: np.ndarray, out: str | Path) -> tuple[Path, Path]:
    """Write a synchronised frame pair as ``out/left.png`` and ``out/right.png`` (lossless; each file
    written whole under a temporary name and then moved into place)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputFileError(str(out), "not a folder")
    out.mkdir(parents=True, exist_ok=True)
    paths = out / "left.png", out / "right.png"
    for path, image in zip(paths, (left, right), strict=True):
        temporary = path.with_name(f".{path.name}.partial.png")
        write_image(temporary, image)
        temporary.replace(path)
    return paths


def export_frame(project: ProjectStore, label: str, frame: int, out: str | Path) -> tuple[Path, Path]:
    """``out/left.png`` (left frame ``frame``) and ``out/right.png`` (right frame ``frame + offset``)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputFileError(str(out), "not a folder")
    sources = media_files(project)
    for target in (out / "left.png", out / "right.png"):  # never over a picture the project measures on
        if target.exists():
            guard_output(target, sources, project.path, parameter="out", replaceable=False)
    left, right, _, _ = frame_pair(project, label, frame)
    return write_frame_pair(left, right, out)


class Cancelled(UsvipsError):
    """A long check stopped because the user cancelled it."""


def verify_media(records: Sequence[tuple[str, Path, int, str]], progress: Callable[[int, int], None] | None = None,
                 cancelled: Callable[[], bool] | None = None, chunk: int = 1 << 22) -> list[tuple[str, str]]:
    """The full check of media files, away from the project (a worker thread may run it): each file of
    ``records`` (:meth:`Project.media_records`) read whole and its SHA-256 compared with the one recorded;
    (stored path, problem) for each that is missing, resized or changed. ``progress(bytes done, bytes in
    all)`` after every ``chunk`` bytes; ``cancelled()`` is asked as often and stops the reading at once
    (:class:`Cancelled`)."""
    read = ByteProgress(sum(size for _, _, size, _ in records), progress)
    problems = []
    for stored, path, size, sha in records:
        if not path.is_file():
            problems.append((stored, "missing (moved or deleted?)"))
            read.skip(size)
            continue
        now = path.stat().st_size
        if now != size:
            problems.append((stored, f"{now} bytes, but {size} when it was added"))
            read.skip(size)
            continue
        if file_sha256(path, read, cancelled, chunk) != sha:
            problems.append((stored, "its contents differ from the file added (SHA-256; same size)"))
    return problems


class ByteProgress:
    """Bytes read so far out of ``total``: called with each block's byte count, it reports
    ``progress(bytes done, bytes in all)`` (the total at least 1); :meth:`skip` counts bytes not read."""

    def __init__(self, total: int, progress: Callable[[int, int], None] | None) -> None:
        self.total, self.done, self.progress = max(int(total), 1), 0, progress

    def __call__(self, count: int) -> None:
        self.done += count
        if self.progress is not None:
            self.progress(min(self.done, self.total), self.total)

    def skip(self, count: int) -> None:
        self.done += count


def file_sha256(path: Path, read: Callable[[int], None] | None = None, cancelled: Callable[[], bool] | None = None,
                chunk: int = 1 << 22) -> str:
    """The SHA-256 (hex) of the whole file at ``path``, read ``chunk`` bytes at a time: ``read(bytes)`` after
    each block; ``cancelled()`` asked before each stops the reading at once (:class:`Cancelled`)."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        while block := stream.read(chunk):
            if cancelled is not None and cancelled():
                raise Cancelled("the check of the media files was cancelled")
            digest.update(block)
            if read is not None:
                read(len(block))
    return digest.hexdigest()


def media_files(project: ProjectStore) -> list[Path]:
    """Where every media file the project records (image pairs' images, videos' files) should be, absolute
    (whether or not it is there)."""
    stored = [getattr(p, side) for p in project.pairs() for side in ("left", "right") if getattr(p, side)]
    stored += [path for v in project.videos() for side in ("left", "right") for path in v.paths(side)]
    return [project.media_location(path) for path in stored]


def plan_taken_pair(project: ProjectStore, label: str, frame: int, pair_label: str | None = None) -> tuple[str, Path]:
    """The label (default ``VIDEO-FRAME``) and folder (``frames/LABEL`` beside the project) of the image
    pair :func:`take_pair` makes of left frame ``frame``; refuses a label already used before anything
    is written (so no stored pair's images are overwritten)."""
    pair_label = validation.folder_name("label", f"{label}-{frame}" if pair_label is None else pair_label)
    if pair_label in {p.label for p in project.pairs()}:
        raise VideoError(f"{project.path}: pair label {pair_label!r} is already used; choose another")
    active = project.active_calibration(label)
    if active is not None:  # the video's frames were measured with it: it must fit them
        check_for(project, read_calibration(project, active), [label], f"its calibration {active}")
    return pair_label, project.derived_media_folder() / "frames" / pair_label


def add_taken_pair(project: ProjectStore, pair_label: str, paths: tuple[Path, Path], medium: str = "water") -> str:
    """Add frames written by :func:`write_frame_pair` as the image pair ``pair_label``."""
    add_image_pairs(project, [(pair_label, *paths)], medium)
    return pair_label


def take_pair(project: ProjectStore, label: str, frame: int, pair_label: str | None = None,
              medium: str = "water") -> str:
    """Make the synchronised frames of left frame ``frame`` an image pair of the project (e.g. the
    calibration frame filmed in air and underwater): written as PNG beside the project under
    ``frames/`` and added like any pair. Returns the pair's label. The window does the same steps with
    the decoding and writing in a worker (:func:`plan_taken_pair`, :func:`write_frame_pair`,
    :func:`add_taken_pair`)."""
    pair_label, folder = plan_taken_pair(project, label, frame, pair_label)
    left, right, _, _ = frame_pair(project, label, frame)
    return add_taken_pair(project, pair_label, write_frame_pair(left, right, folder), medium)


# ---------------------------------------------------------------------------- synchronisation
def _brightness(stream: VideoStream, limit: int | None, progress: Callable[[int, int], None] | None) -> np.ndarray:
    count = stream.frame_count if limit is None else min(limit, stream.frame_count)
    values = np.empty(count)
    for i in range(count):
        values[i] = float(stream.frame(i, grey=True).mean())
        if progress is not None and i % 50 == 0:
            progress(i, count)
    return values


def _calibration_for(project: ProjectStore, calibration_id: int | None, label: str):
    if calibration_id is None:
        calibration_id = project.active_calibration(label)
    if calibration_id is None:
        stored = project.calibrations()
        if not stored:
            raise VideoError(f"{project.path}: image synchronisation needs a calibration of the rig; the project "
                             "has none (import one, or synchronise by a flash or the audio)")
        water = [c for c in stored if c.phase not in ("air", "phase1")]
        calibration_id = (water or stored)[-1].id
    return read_calibration(project, calibration_id)


@dataclass(frozen=True)
class SyncJob:
    """What estimating a video pair's offset needs, read from the project (on its thread): each camera's
    files, and the rig (for the image method) or why there is none."""

    label: str
    left: tuple[Path, ...]
    right: tuple[Path, ...]
    rig: object | None
    no_rig: str = ""
    #: the calibration's pointing precision (px): how far its epipolar curves may lie off
    pointing_sigma_px: float = 0.0


def plan_sync(project: ProjectStore, label: str, calibration_id: int | None = None) -> SyncJob:
    """Read what :func:`run_sync` needs from the project (so the estimate can run in a worker)."""
    video = project.video(label)
    rig, why, sigma0 = None, "", 0.0
    try:
        calibration = _calibration_for(project, calibration_id, label)
        check_size(calibration, (video.width, video.height), f"video {label!r}")
        rig, sigma0 = calibration.rig(0, "rig"), float(calibration.sigma0_px)
    except UsvipsError as error:
        why = str(error)
    return SyncJob(label, tuple(project.media_path(p) for p in video.paths("left")),
                   tuple(project.media_path(p) for p in video.paths("right")), rig, why, sigma0)


#: an estimate is stored without asking only from this confidence up (0 … 1: how clearly the best offset
#: beats the runner-up); below it the user decides (``--force``, or the window's question). A clean flash
#: in busy footage scores about 0.45 (the scene's own brightness changes make the runner-up), a video with
#: no flash about 0.1; image estimates below it were off by most of a frame in our trials.
STORE_CONFIDENCE = 0.3


def doubt_about(estimate: SyncEstimate) -> str | None:
    """Why ``estimate`` should not replace a stored offset unasked (found at the edge of its search window,
    or its confidence below :data:`STORE_CONFIDENCE`), or None."""
    edge = estimate.edge_problem()
    if edge is not None:
        return edge
    if estimate.confidence >= STORE_CONFIDENCE:
        return None
    return (f"confidence {estimate.confidence:.2f} is below {STORE_CONFIDENCE}: the best offset hardly beats the "
            "others")


def store_refusal(estimate: SyncEstimate, force: bool = False) -> str | None:
    """Why ``estimate`` is not stored: an offset at the edge of its search window never is (it is no
    estimate; ``force`` does not change that), one of low confidence only with ``force``; None to store."""
    edge = estimate.edge_problem()
    if edge is not None or force:
        return edge
    return doubt_about(estimate)


def estimate_offset(project: ProjectStore, label: str, method: str | None = None, max_offset: int | None = None,
                    calibration_id: int | None = None, frame_limit: int | None = 3000,
                    progress: Callable[[int, int], None] | None = None) -> SyncEstimate:
    """Estimate the video pair's offset by ``method`` (flash, audio or image; default: audio when both files
    carry sound, otherwise a flash when one is clear, otherwise the images). ``max_offset``: frames
    searched either way (default: a third of the video, at most 300); ``frame_limit``: frames read for
    flash and image estimation. A window that cannot hold a plausible lag, or is negative, is refused
    (:func:`usvips.core.synchronisation.search_window`)."""
    if method is not None and method not in synchronisation.METHODS:
        raise InvalidParameterError("method", f"{method!r}: choose one of {', '.join(synchronisation.METHODS)}",
                                    label="synchronisation method")
    return run_sync(plan_sync(project, label, calibration_id), method, max_offset, frame_limit, progress)


def run_sync(job: SyncJob, method: str | None = None, max_offset: int | None = None, frame_limit: int | None = 3000,
             progress: Callable[[int, int], None] | None = None) -> SyncEstimate:
    """:func:`estimate_offset` on what :func:`plan_sync` read: files only, no project."""
    if method is not None and method not in synchronisation.METHODS:
        raise InvalidParameterError("method", f"{method!r}: choose one of {', '.join(synchronisation.METHODS)}",
                                    label="synchronisation method")
    label = job.label
    left = VideoStream(job.left)
    try:
        right = VideoStream(job.right)
    except BaseException:
        left.close()
        raise
    with left, right:
        count = min(left.frame_count, right.frame_count)
        fps = left.fps
        limit = synchronisation.search_window(max_offset, fps, count)
        if method in (None, "audio"):
            a, b = left.audio(), right.audio()
            if a is not None and b is not None and a[1] == b[1]:
                return synchronisation.audio_offset(a[0], b[0], a[1], fps, limit / fps)
            if method == "audio":
                raise VideoError(f"video {label!r}: " + ("the two soundtracks have different sample rates"
                                 if a is not None and b is not None else "the files carry no soundtrack"))
        if method in (None, "flash"):
            try:
                estimate = synchronisation.flash_offset(_brightness(left, frame_limit, progress),
                                                        _brightness(right, frame_limit, progress), fps, limit)
                if method == "flash" or (estimate.confidence >= 0.5 and not estimate.at_edge):
                    return estimate
            except UsvipsError:
                if method == "flash":
                    raise
        if job.rig is None:
            raise VideoError(job.no_rig)
        rig = job.rig
        n = min(count, frame_limit or count, 200)
        step = max(1, n // 15)
        left_frames = [left.frame(i) for i in range(n)]
        right_frames = [right.frame(i) for i in range(min(right.frame_count, n + limit))]
        return synchronisation.image_offset(left_frames, right_frames, rig.left, rig.right, fps,
                                            range(-limit, limit + 1), step=step,
                                            epipolar_sigma_px=job.pointing_sigma_px)


def eventmeasure_frame_columns(project: ProjectStore, vertex) -> tuple[str, str, str, str, str, str, str] | None:
    """EventMeasure's FilenameLeft, FrameLeft, FilenameRight, FrameRight, Time, Period, PeriodTime of a
    vertex measured on a video (None otherwise): the chapter file holding each frame and the frame's
    number within it, the time in minutes from the first frame of the recording, the period holding the
    left frame and the minutes since it began.

    The convention is EventMeasure's, checked on its exports that CheckEM ships (e.g. a 2020 stereo-BRUV
    Lengths.txt: 62 frames further on, Time grows by 0.01724 = 62 / 59.94 fps / 60, so minutes; in the
    next GoPro chapter FrameLeft starts again near 0 while Time continues from the recording's start;
    PeriodTime = Time − the period's start time), written with 5 decimals as EventMeasure does."""
    if vertex.video is None:
        return None
    video = project.video(vertex.video)

    def locate(camera: str, frame: int) -> tuple[str, str]:
        first = 0
        for file in video.files(camera):
            if frame < first + file.frame_count:
                return Path(file.path).name, str(frame - first)
            first += file.frame_count
        return "", str(frame)

    (file_left, frame_left), (file_right, frame_right) = locate("left", vertex.frame_left), locate(
        "right", vertex.frame_right)
    period, period_time = "", ""
    for name, start, end in project.periods(vertex.video):
        if start <= vertex.frame_left <= end:
            period, period_time = name, f"{(vertex.time_s - start / video.fps) / 60:.5f}"
    return file_left, frame_left, file_right, frame_right, f"{vertex.time_s / 60:.5f}", period, period_time


def add_sample_video(project: ProjectStore, left: Path, right: Path, offset: int, label: str = "video") -> None:
    """A sample's stereo video with its known offset (used when a sample directory becomes a project),
    measured with the calibration that is active for most of the sample's underwater pairs."""
    add_video(project, [left], [right], label)
    project.set_video_offset(label, offset, {"method": "sample truth"})
    active = [project.active_calibration(p.label) for p in project.pairs() if p.medium == "water"]
    active = [a for a in active if a is not None]
    if active:
        make_active(project, label, max(set(active), key=active.count))
