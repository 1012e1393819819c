"""Your own footage from the command line: an empty project, image pairs from folders, a stereo video
(chaptered, with a lag we choose), synchronisation by flash and by sound, a frame pair exported exactly,
and bad input named in one line with nothing stored."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from usvips.cli import main
from usvips.core.synth.frame_numbers import frame_number, numbered_frame
from usvips.io.images import read_image, write_image
from usvips.io.video_writer import encode_video
from usvips.store import Project

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"
FPS = 25


def _stereo(folder: Path, lag: int, frames: int = 80, flash_at: int | None = None, sound: bool = False,
            chapters: int = 1, size=(160, 120)) -> tuple[list[Path], list[Path]]:
    """Left frame i shows instant i; right frame j shows instant j − lag (frame numbers = instants, offset
    by 1000 on the right so the two are told apart). A light goes on at instant ``flash_at``; the
    soundtrack is noise heard by both with the same lag."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(lag + 17)
    rate = 8000
    scene = rng.normal(0, 0.3, rate * (frames // FPS + 4))
    paths = {}
    for side, shift in (("left", 0), ("right", lag)):
        instants = [j - shift for j in range(frames)]
        pictures = [numbered_frame(1000 + t if side == "right" else t, *size, seed=1,
                                   brightness=60.0 if flash_at is not None and t >= flash_at else 0.0)
                    if t >= 0 else numbered_frame(2000 - t, *size, seed=1) for t in instants]
        audio = None
        if sound:
            start = 2 * rate - round(shift * rate / FPS)
            audio = (scene[start:start + frames * rate // FPS], rate)
        bounds = np.linspace(0, frames, chapters + 1).astype(int)
        paths[side] = []
        for c in range(chapters):
            path = folder / f"{side}_GX0{c + 1}0042.mp4"
            encode_video(path, pictures[bounds[c]:bounds[c + 1]], FPS, "h264", gop=40, audio=audio if chapters == 1
                         else None)
            paths[side].append(path)
    return paths["left"], paths["right"]


def _run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("lag, chapters", [(4, 1), (-3, 2), (0, 3)])
def test_a_stereo_video_is_added_synchronised_by_its_flash_and_exported_exactly(tmp_path, capsys, lag, chapters):
    project = tmp_path / "mine.usvips"
    assert _run(capsys, "project", "new", project)[0] == 0
    left, right = _stereo(tmp_path / "media", lag, flash_at=30, chapters=chapters)
    code, out, err = _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right,
                          "--label", "dive1")
    assert code == 0, err
    assert "left 80 frames, right 80 frames at 25 fps" in out and "warning" not in out
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "dive1", "--method", "flash", "--json")
    assert code == 0, err
    estimate = json.loads(out)
    assert {"offset_frames", "offset_s", "method", "confidence"} <= estimate.keys()
    assert estimate["offset_frames_used"] == lag and estimate["method"] == "flash" and estimate["stored"]
    # each is printed rounded (frames to 1e-3, seconds to 1e-6): they agree at that precision
    assert estimate["offset_s"] == pytest.approx(estimate["offset_frames"] / FPS, abs=0.5e-3 / FPS + 0.5e-6)
    code, out, _ = _run(capsys, "project", "info", project)
    assert f"video dive1: 80 frames at 25 fps, offset {lag:+d} frames" in out
    assert ", 0 image pairs, 1 video, " in out  # the video's own pair is not counted as an image pair
    code, out, err = _run(capsys, "video", "take-pair", project, "--pair", "dive1", "--frame", 33, "--medium", "air")
    assert code == 0, err
    with Project.open(project) as p:
        taken = next(q for q in p.pairs() if q.label == "dive1-33")
        assert taken.medium == "air" and taken.left == "frames/dive1-33/left.png"
        assert frame_number(read_image(p.media_path(taken.right))) == 1033
    for frame in (40, 10, 55):
        assert _run(capsys, "video", "export-frame", project, "--pair", "dive1", "--frame", frame,
                    "--out", tmp_path / "out")[0] == 0
        assert frame_number(read_image(tmp_path / "out" / "left.png")) == frame
        assert frame_number(read_image(tmp_path / "out" / "right.png")) == 1000 + frame  # the same instant


def test_sync_by_sound_dry_run_stores_nothing_and_set_offset_by_hand(tmp_path, capsys):
    project = tmp_path / "mine.usvips"
    main(["project", "new", str(project)])
    left, right = _stereo(tmp_path / "media", 7, sound=True)
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "v", "--json", "--dry-run")
    assert code == 0, err
    estimate = json.loads(out)
    assert estimate["method"] == "audio" and estimate["offset_frames_used"] == 7 and not estimate["stored"]
    assert estimate["confidence"] > 0.5
    with Project.open(project) as p:
        assert p.video("v").offset_frames == 0
    assert _run(capsys, "video", "set-offset", project, "--pair", "v", "5")[0] == 0
    with Project.open(project) as p:
        assert p.video("v").offset_frames == 5 and p.video("v").offset_estimate == {"method": "by hand"}
    code, out, _ = _run(capsys, "video", "sync", project, "--pair", "v")
    assert "offset +7.00 frames (+0.2800 s) by audio" in out and "stored" in out
    assert _run(capsys, "video", "period", project, "--pair", "v", "--add", "descent", "0", "20")[0] == 0
    code, out, _ = _run(capsys, "video", "period", project, "--pair", "v")
    assert out == "descent: frames 0 to 20\n"
    code, _, err = _run(capsys, "video", "period", project, "--pair", "v", "--add", "late", "70", "90")
    assert code == 2 and "not an interval within the video (0 to 79)" in err


def test_an_estimate_of_little_confidence_is_not_stored_unless_forced(tmp_path, capsys):
    """No flash in the videos: the flash method's best offset hardly beats the others. It is printed, not
    stored over the offset there is, and stored with --force."""
    project = tmp_path / "mine.usvips"
    main(["project", "new", str(project)])
    left, right = _stereo(tmp_path / "media", 2)
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    assert _run(capsys, "video", "set-offset", project, "--pair", "v", "2")[0] == 0
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "v", "--method", "flash", "--json")
    assert code == 0, err
    estimate = json.loads(out)
    assert estimate["confidence"] < 0.5 and not estimate["stored"] and "--force" in estimate["not_stored"]
    with Project.open(project) as p:
        assert p.video("v").offset_frames == 2 and p.video("v").offset_estimate == {"method": "by hand"}
    code, out, _ = _run(capsys, "video", "sync", project, "--pair", "v", "--method", "flash", "--force")
    assert code == 0 and out.rstrip().endswith("; stored")
    with Project.open(project) as p:
        assert p.video("v").offset_estimate["method"] == "flash"


def test_an_offset_at_the_edge_of_its_window_is_never_stored_and_a_bad_window_is_one_line(tmp_path, capsys):
    """The lag (20 frames) outside the window searched: the best of the window lies at its edge; it is
    printed and named, and not stored, not even with --force. A window that is no window is refused."""
    project = tmp_path / "mine.usvips"
    main(["project", "new", str(project)])
    left, right = _stereo(tmp_path / "media", 20, flash_at=40)
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    assert _run(capsys, "video", "set-offset", project, "--pair", "v", "20")[0] == 0
    for force in ((), ("--force",)):
        code, out, err = _run(capsys, "video", "sync", project, "--pair", "v", "--method", "flash", "--max-offset",
                              "14", "--json", *force)
        assert code == 0, err
        estimate = json.loads(out)
        assert estimate["at_edge"] and not estimate["stored"] and "search window" in estimate["not_stored"]
    with Project.open(project) as p:
        assert p.video("v").offset_frames == 20 and p.video("v").offset_estimate == {"method": "by hand"}
    for window in ("-5", "-1", "0", "3", "nan", "1e8", "2.5", "x", "100000000"):
        code, _, err = _run(capsys, "video", "sync", project, "--pair", "v", "--method", "flash", "--max-offset",
                            window)
        assert code == 2 and err.count("\n") == 1 and "--max-offset" in err and "Traceback" not in err, (window, err)
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "v", "--method", "flash", "--max-offset", "26")
    assert code == 0 and "; stored" in out, (out, err)


def test_the_sample_project_opens_on_its_video_and_finds_its_lag(tmp_path, capsys):
    project = tmp_path / "rov.usvips"
    assert _run(capsys, "project", "new", project, "--from", SAMPLE)[0] == 0
    assert "video video: 30 frames at 10 fps, offset +3 frames" in _run(capsys, "project", "info", project)[1]
    assert _run(capsys, "video", "set-offset", project, "--pair", "video", "0")[0] == 0
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "video", "--method", "image", "--json")
    assert code == 0, err
    estimate = json.loads(out)
    assert estimate["offset_frames_used"] == 3
    # the sigma holds the calibration's own error (its curves' sigma0), which every feature shares
    assert abs(estimate["offset_frames"] - 3) < 3 * estimate["offset_sigma_frames"]
    assert _run(capsys, "video", "export-frame", project, "--pair", "video", "--frame", 12, "--out", tmp_path)[0] == 0
    truth = json.loads((SAMPLE / "truth.json").read_text())["video"]
    from usvips.io.video_stream import VideoStream

    with VideoStream(SAMPLE / "video_right.avi") as right:
        assert np.array_equal(read_image(tmp_path / "right.png"), right.frame(15))
    assert truth["right"][15]["time_s"] == pytest.approx(truth["left"][12]["time_s"])


def test_bad_videos_are_refused_in_one_line_and_nothing_is_stored(tmp_path, capsys):
    project = tmp_path / "mine.usvips"
    main(["project", "new", str(project)])
    left, right = _stereo(tmp_path / "a", 0, frames=30)
    small, _ = _stereo(tmp_path / "b", 0, frames=30, size=(128, 96))
    slow = tmp_path / "slow.mp4"
    encode_video(slow, [numbered_frame(i) for i in range(30)], 30, "h264")
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00garbage" * 100)
    cases = [
        ((left, small), "128 × 96 px, but the left video"),
        ((left, [slow]), "30 fps, but the left video"),
        ((left, [junk]), "junk.mp4: not a video"),
        (([left[0], tmp_path / "a" / "gone.mp4"], right), "gone.mp4: the left camera's files: no such file or folder "
                                                     "(set it with --left)"),
    ]
    for (a, b), message in cases:
        code, out, err = _run(capsys, "project", "add-video", project, "--left", *a, "--right", *b)
        assert code == 2 and message in err and err.count("\n") == 1 and "Traceback" not in err
    with Project.open(project) as p:
        assert p.videos() == []
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    for argv, message in [
        (("video", "export-frame", project, "--pair", "v", "--frame", 30, "--out", tmp_path / "x"), "frame 30 is out"),
        (("video", "set-offset", project, "--pair", "v", "-30"), "offset -30 frames"),
        (("video", "sync", project, "--pair", "w"), "no video pair 'w'"),
        (("video", "sync", project, "--pair", "v", "--method", "audio"), "carry no soundtrack"),
    ]:
        code, _, err = _run(capsys, *argv)
        assert code == 2 and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "x").exists()
    # a moved file is named when the video is used
    shutil.move(left[0], tmp_path / "moved.mp4")
    code, _, err = _run(capsys, "video", "export-frame", project, "--pair", "v", "--frame", 1, "--out", tmp_path / "y")
    assert code == 2 and "a/left_GX010042.mp4 is missing" in err
    code, out, err = _run(capsys, "project", "info", project)  # a read-only command still shows the project
    assert code == 0 and "media a/left_GX010042.mp4: missing" in out
    assert f"recorded at {tmp_path / 'a' / 'left_GX010042.mp4'}" in out
    # another recording copied over a file of the video: named, refused, until accepted or relocated
    shutil.copy(right[0], tmp_path / "a" / "left_GX010042.mp4")
    for argv in (("video", "export-frame", project, "--pair", "v", "--frame", 1, "--out", tmp_path / "y"),
                 ("video", "take-pair", project, "--pair", "v", "--frame", 1),
                 ("video", "sync", project, "--pair", "v")):
        code, _, err = _run(capsys, *argv)
        assert code == 2 and "a/left_GX010042.mp4 is not the file that was added" in err and err.count("\n") == 1
    assert _run(capsys, "project", "relocate-media", project, "a/left_GX010042.mp4", tmp_path / "moved.mp4")[0] == 0
    assert _run(capsys, "video", "export-frame", project, "--pair", "v", "--frame", 1, "--out", tmp_path / "y")[0] == 0


def test_image_pairs_from_folders_by_stem_or_order_stored_relative_and_checked(tmp_path, capsys):
    project = tmp_path / "survey.usvips"
    main(["project", "new", str(project)])
    for side, mark in (("left", "L"), ("right", "R")):
        (tmp_path / side).mkdir()
        for n in (2, 10, 1):
            write_image(tmp_path / side / f"IMG_{n}_{mark}.png", numbered_frame(n if side == "left" else 100 + n))
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "left", "--right",
                          tmp_path / "right", "--label-prefix", "st1-", "--dry-run")
    assert code == 0 and "3 pairs by shared stem" in out and "st1-img_10:" in out
    with Project.open(project) as p:
        assert p.pairs() == []
    assert _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "left", "--right",
                tmp_path / "right", "--label-prefix", "st1-")[0] == 0
    with Project.open(project) as p:
        pairs = {q.label: q for q in p.pairs()}
        assert list(pairs) == ["st1-img_1", "st1-img_2", "st1-img_10"]
        assert pairs["st1-img_10"].left == "left/IMG_10_L.png" and pairs["st1-img_10"].width == 160
        for label, pair in pairs.items():
            n = int(label.rsplit("_", 1)[1])
            assert frame_number(read_image(p.media_path(pair.left))) == n
            assert frame_number(read_image(p.media_path(pair.right))) == 100 + n
        assert p.media_problems() == []
    # swapped and moved files are detected; a relocated file must be the same file
    a, b = tmp_path / "left" / "IMG_1_L.png", tmp_path / "left" / "IMG_2_L.png"
    a.rename(tmp_path / "t.png")
    b.rename(a)
    (tmp_path / "t.png").rename(b)
    (tmp_path / "right" / "IMG_10_R.png").rename(tmp_path / "IMG_10_R.png")
    with Project.open(project) as p:
        problems = dict(p.media_problems())
        assert problems["left/IMG_1_L.png"] == "holds what left/IMG_2_L.png held when added (swapped?)"
        assert problems["right/IMG_10_R.png"] == "missing (moved or deleted?)"
        from usvips.store.project import ProjectError

        with pytest.raises(ProjectError, match="not the file that was added"):
            p.relocate_media("right/IMG_10_R.png", tmp_path / "right" / "IMG_2_R.png")
        assert p.relocate_media("right/IMG_10_R.png", tmp_path / "IMG_10_R.png") == "IMG_10_R.png"
        assert pairs["st1-img_10"].label in {q.label for q in p.pairs() if q.right == "IMG_10_R.png"}
    # by order when the stems do not match; unequal counts refused
    (tmp_path / "l2").mkdir()
    (tmp_path / "r2").mkdir()
    for n in range(3):
        write_image(tmp_path / "l2" / f"a{n}.png", numbered_frame(n))
        write_image(tmp_path / "r2" / f"b{n}.png", numbered_frame(n))
    code, out, _ = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "l2", "--right", tmp_path / "r2")
    assert code == 0 and "3 pairs by name order" in out and "001:" in out
    (tmp_path / "r2" / "b2.png").unlink()
    code, _, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "l2", "--right", tmp_path / "r2")
    assert code == 2 and "3 left and 2 right files" in err


def test_the_samples_h264_version_is_the_same_video_and_synchronises_alike(tmp_path, capsys):
    """video_left.mp4 / video_right.mp4: the sample's AVI frames encoded as H.264 (GOP 10, B-frames)."""
    from usvips.io.video_stream import VideoStream

    assert (SAMPLE / "video_left.mp4").stat().st_size + (SAMPLE / "video_right.mp4").stat().st_size < 2 * 2**20
    for side in ("left", "right"):
        with VideoStream(SAMPLE / f"video_{side}.avi") as avi, VideoStream(SAMPLE / f"video_{side}.mp4") as mp4:
            assert (mp4.frame_count, mp4.fps, mp4.size, mp4.codec) == (30, pytest.approx(10), (640, 480), "h264")
            for i in (29, 0, 13, 14, 7):
                assert np.abs(mp4.frame(i).astype(int) - avi.frame(i)).mean() < 3.0
    project = tmp_path / "rov.usvips"
    main(["project", "new", str(project), "--from", str(SAMPLE)])
    assert _run(capsys, "project", "add-video", project, "--left", SAMPLE / "video_left.mp4", "--right",
                SAMPLE / "video_right.mp4", "--label", "h264")[0] == 0
    with Project.open(project) as p:
        p.activate_calibration("h264", p.active_calibration("video"))
    code, out, err = _run(capsys, "video", "sync", project, "--pair", "h264", "--json")
    assert code == 0, err
    assert json.loads(out)["offset_frames_used"] == 3 and json.loads(out)["method"] == "image"


def test_jpeg_pairs_by_exif_capture_time(tmp_path, capsys):
    """Two cameras' JPEGs named by their own counters, paired by the capture time in their EXIF."""
    from datetime import datetime, timedelta

    import cv2

    from usvips.io.exif import capture_time, exif_jpeg

    start = datetime(2026, 5, 1, 9, 30, 0)
    rng = np.random.default_rng(4)
    shots = sorted(rng.uniform(0, 600, 6))
    for side, first in (("left", 100), ("right", 7000)):
        (tmp_path / side).mkdir()
        order = rng.permutation(6) if side == "right" else np.arange(6)  # counters unrelated to time order
        for k, shot in enumerate(shots):
            when = start + timedelta(seconds=float(shot) + (rng.uniform(-0.2, 0.2) if side == "right" else 0))
            ok, jpeg = cv2.imencode(".jpg", numbered_frame(k + (1000 if side == "right" else 0))[:, :, ::-1])
            (tmp_path / side / f"DSC{first + int(order[k]):05d}.JPG").write_bytes(exif_jpeg(jpeg.tobytes(), when))
            assert abs((capture_time(tmp_path / side / f"DSC{first + int(order[k]):05d}.JPG") - when)
                       .total_seconds()) < 1e-3
    project = tmp_path / "p.usvips"
    main(["project", "new", str(project)])
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "left", "--right",
                          tmp_path / "right")
    assert code == 0 and "6 pairs by capture time" in out, err
    with Project.open(project) as p:
        for pair in p.pairs():
            assert frame_number(read_image(p.media_path(pair.right))) == \
                1000 + frame_number(read_image(p.media_path(pair.left)))
    code, _, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "left", "--right",
                        tmp_path / "right", "--pair-by", "time", "--max-dt", "0.01", "--dry-run")
    assert code == 2 and "no right image captured within 0.01 s" in err


def test_a_damaged_capture_time_is_named_not_paired_around_and_an_unset_clock_pairs_by_order(tmp_path, capsys):
    """Automatic pairing of JPEGs by capture time: one left image's EXIF time unreadable is refused by its
    name (pairing by order instead would pair captures by chance), with the way to pair by order anyway; a
    camera whose clock was never set (0000:00:00 00:00:00) has no time, and its images pair by order."""
    from datetime import datetime

    import cv2

    from usvips.io.exif import exif_jpeg

    when = datetime(2026, 5, 1, 9, 30, 0)
    stamp = when.strftime("%Y:%m:%d %H:%M:%S").encode()
    for case, bad in (("damaged", b"2026:13:45 99:00:00"), ("unset", b"0000:00:00 00:00:00")):
        for side in ("left", "right"):
            (tmp_path / case / side).mkdir(parents=True)
            for k in range(2):
                jpeg = exif_jpeg(cv2.imencode(".jpg", numbered_frame(k)[:, :, ::-1])[1].tobytes(), when)
                if side == "left" or case == "unset":
                    jpeg = jpeg.replace(stamp, bad)
                (tmp_path / case / side / f"{'DSC' if side == 'left' else 'IMG'}{k + 40}.jpg").write_bytes(jpeg)
    project = tmp_path / "p.usvips"
    main(["project", "new", str(project)])
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "damaged" / "left", "--right",
                          tmp_path / "damaged" / "right", "--dry-run")
    assert code == 2 and "DSC40.jpg: damaged EXIF" in err and "by order" in err and "--pair-by" in err
    assert len(err.splitlines()) == 1
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "damaged" / "left", "--right",
                          tmp_path / "damaged" / "right", "--pair-by", "order", "--dry-run")
    assert code == 0 and "2 pairs by name order" in out, err
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", tmp_path / "unset" / "left", "--right",
                          tmp_path / "unset" / "right", "--dry-run")
    assert code == 0 and "2 pairs by name order" in out, err
    code, out, err = _run(capsys, "project", "add-pairs", project, "--left", "", "--right",
                          tmp_path / "unset" / "right", "--dry-run")  # an empty value is not the working folder
    assert code == 2 and "--left: the left camera's files: an empty path" in err


def test_seek_proxies_are_built_listed_by_project_info_rebuilt_when_stale_and_deleted(tmp_path, capsys):
    left, right = _stereo(tmp_path / "media", lag=2, frames=40)
    project = tmp_path / "p.usvips"
    assert _run(capsys, "project", "new", project)[0] == 0
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    assert "seek proxies" not in _run(capsys, "project", "info", project)[1]
    code, out, _ = _run(capsys, "video", "proxy", project, "--pair", "v")
    assert code == 0 and out.count("wrote ") == 2
    proxies = sorted((tmp_path / "proxies").iterdir())
    total = sum(p.stat().st_size for p in proxies)
    assert len(proxies) == 4  # two proxies and their stamps
    assert f"seek proxies {total / 2**20:.1f} MiB" in _run(capsys, "project", "info", project)[1]
    assert "already built" in _run(capsys, "video", "proxy", project, "--pair", "v")[1]
    # the left recording replaced by other pictures of the same length: named and refused until accepted;
    # then its proxy is stale and rebuilt
    encode_video(left[0], (numbered_frame(3000 + i, 160, 120, seed=1) for i in range(40)), FPS, "h264", gop=40)
    code, _, err = _run(capsys, "video", "proxy", project, "--pair", "v")
    assert code == 2 and "media/left_GX010042.mp4 is not the file that was added" in err
    assert _run(capsys, "project", "accept-media", project, "media/left_GX010042.mp4")[0] == 0
    code, out, _ = _run(capsys, "video", "proxy", project, "--pair", "v")
    assert code == 0 and "stale" in out and out.count("wrote ") == 1
    code, out, _ = _run(capsys, "video", "proxy", project, "--pair", "v", "--delete")
    assert code == 0 and "MiB freed" in out and not any((tmp_path / "proxies").iterdir())
    assert "seek proxies" not in _run(capsys, "project", "info", project)[1]
    assert "no seek proxies" in _run(capsys, "video", "proxy", project, "--pair", "v", "--delete")[1]
    code, out, err = _run(capsys, "video", "proxy", project, "--pair", "nope", "--delete")
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_a_replacement_is_accepted_only_with_the_recordings_frames_rate_and_size(tmp_path, capsys):
    """``project accept-media`` takes a changed file for the recorded one only when the stored picks can
    still point into it: a video chapter with the recorded frame count, frame rate and size; an image of
    the pair's size. Anything else is refused in one line naming the file and what differs, and the
    project keeps what it had recorded."""
    left, right = _stereo(tmp_path / "media", lag=0, frames=30)
    project = tmp_path / "p.usvips"
    assert _run(capsys, "project", "new", project)[0] == 0
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "v")[0] == 0
    stored = "media/left_GX010042.mp4"
    def record(path=stored):
        with Project.open(project) as p:
            return next(r for r in p.media_records() if r[0] == path)

    recorded = record()
    replacements = {
        "not a video": lambda: left[0].write_text("not a video\n"),
        "10 frames, but the left chapter of video v had 30": lambda: encode_video(
            left[0], (numbered_frame(i, 160, 120, seed=2) for i in range(10)), FPS, "h264"),
        "is 320 × 240 px, but the left chapter of video v was 160 × 120 px": lambda: encode_video(
            left[0], (numbered_frame(i, 320, 240, seed=2) for i in range(30)), FPS, "h264"),
        "runs at 30 fps, but the left chapter of video v ran at 25": lambda: encode_video(
            left[0], (numbered_frame(i, 160, 120, seed=2) for i in range(30)), 30, "h264"),
    }
    for expected, replace in replacements.items():
        replace()
        code, out, err = _run(capsys, "project", "accept-media", project, stored)
        assert code == 2 and len(err.strip().splitlines()) == 1 and "left_GX010042.mp4" in err, err
        assert expected in err, err
        assert record() == recorded  # nothing recorded anew
    encode_video(left[0], (numbered_frame(i, 160, 120, seed=2) for i in range(30)), FPS, "h264")
    right_record = record("media/right_GX010042.mp4")
    right[0].write_text("not a video\n")  # one of two refused: neither is accepted
    code, _, err = _run(capsys, "project", "accept-media", project, stored, "media/right_GX010042.mp4")
    assert code == 2 and "right_GX010042.mp4" in err and record() == recorded, err
    assert record("media/right_GX010042.mp4") == right_record
    assert _run(capsys, "project", "accept-media", project, stored)[0] == 0  # a re-export of the same shape
    assert record() != recorded
    accepted = record()
    left_bytes = left[0].read_bytes()
    encode_video(right[0], (numbered_frame(i, 160, 120, seed=5) for i in range(30)), FPS, "h264")
    assert _run(capsys, "project", "accept-media", project, "media/right_GX010042.mp4")[0] == 0
    right[0].write_bytes(left_bytes)  # the left recording copied over the right: same frames, rate and size
    code, _, err = _run(capsys, "project", "accept-media", project, "media/right_GX010042.mp4")
    assert code == 2 and "holds what media/left_GX010042.mp4 held when it was added (swapped?)" in err, err
    assert record() == accepted

    images = tmp_path / "images"
    images.mkdir()
    picture = numbered_frame(1, 160, 120, seed=3)
    write_image(images / "left.png", picture)
    write_image(images / "right.png", picture)
    code, _, err = _run(capsys, "project", "add-pairs", project, "--left", images / "left.png", "--right",
                        images / "right.png", "--pair-by", "order")
    assert code == 0, err
    with Project.open(project) as p:
        pair = next(q for q in p.pairs() if q.left is not None)
    where = p.media_location(pair.left)
    write_image(where, numbered_frame(1, 200, 100, seed=3))
    code, _, err = _run(capsys, "project", "accept-media", project, pair.left)
    assert code == 2 and "is 200 × 100 px, but the left image of pair" in err and "160 × 120 px" in err, err
    write_image(where, numbered_frame(2, 160, 120, seed=3))
    assert _run(capsys, "project", "accept-media", project, pair.left)[0] == 0
