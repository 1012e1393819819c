"""Media are who they say they are: random damages to recorded media files (another recording of the
same or another size, cut short, grown, a byte changed where the fast check samples or anywhere, moved
away) are named by the fast check (size and sampled hash) or, for a byte changed between the samples, by
the full SHA-256; their use is refused until the file is relocated or accepted; a missing file does not
stop the project from opening."""

import shutil

import numpy as np
import pytest

from usvips.store import Project, ProjectError
from usvips.store.project import SAMPLE_BLOCK_BYTES, SAMPLE_BLOCKS

DAMAGES = ("other recording, same size", "other recording", "cut short", "grown", "byte in a sample",
           "byte anywhere", "moved away", "none")


def _sampled_offsets(size: int) -> np.ndarray:
    if size <= SAMPLE_BLOCKS * SAMPLE_BLOCK_BYTES:
        return np.arange(size)
    starts = np.linspace(0, size - SAMPLE_BLOCK_BYTES, SAMPLE_BLOCKS).astype(np.int64)
    return (starts[:, None] + np.arange(SAMPLE_BLOCK_BYTES)).ravel()


def _damage(path, kind: str, rng: np.random.Generator) -> None:
    data = bytearray(path.read_bytes())
    if kind == "other recording, same size":
        data = bytearray(rng.integers(0, 256, len(data), dtype=np.uint8).tobytes())
    elif kind == "other recording":
        data = bytearray(rng.integers(0, 256, int(rng.integers(1, 3 << 20)), dtype=np.uint8).tobytes())
    elif kind == "cut short":
        data = data[: int(rng.integers(0, len(data)))]
    elif kind == "grown":
        data += rng.integers(0, 256, int(rng.integers(1, 5000)), dtype=np.uint8).tobytes()
    elif kind == "byte in a sample":
        data[int(rng.choice(_sampled_offsets(len(data))))] ^= int(rng.integers(1, 256))
    elif kind == "byte anywhere":
        data[int(rng.integers(0, len(data)))] ^= int(rng.integers(1, 256))
    elif kind == "moved away":
        shutil.move(path, path.with_name("elsewhere.bin"))
        return
    path.write_bytes(bytes(data))


def test_random_damages_to_media_are_named_and_their_use_refused_until_accepted(tmp_path):
    rng = np.random.default_rng(28)
    project_path = tmp_path / "p.usvips"
    Project.create(project_path).close()
    seen = set()
    for trial in range(60):
        folder = tmp_path / f"t{trial}"
        folder.mkdir()
        size = int(rng.choice([100, 5000, 900_000, 1_100_000, 3_000_000]))
        files = [folder / f"{side}.mp4" for side in ("left", "right")]
        for path in files:
            path.write_bytes(rng.integers(0, 256, size, dtype=np.uint8).tobytes())
        label = f"v{trial}"
        with Project.open(project_path) as project:
            project.add_video(label, [(files[0], 10, 25.0)], [(files[1], 10, 25.0)], 25.0, 10, (64, 48))
            stored = project.video(label).left[0].path
        kind = str(rng.choice(DAMAGES))
        seen.add(kind)
        _damage(files[0], kind, rng)
        with Project.open(project_path, read_only=True) as project:  # opens whatever the media's state
            fast, full = project.media_identity(stored), project.media_identity(stored, full=True)
            problems = dict(project.media_problems(check_hash=True))
        if kind == "none":
            assert fast is None and full is None and stored not in problems
            continue
        assert full is not None and stored in problems, kind  # the whole hash names every damage
        sampled = kind != "byte anywhere" or size <= SAMPLE_BLOCKS * SAMPLE_BLOCK_BYTES
        if sampled:
            assert fast is not None, kind
            with Project.open(project_path) as project, pytest.raises(ProjectError, match=stored):
                project.media_path(stored)
        if kind == "moved away":
            assert "missing" in fast
            with Project.open(project_path) as project:
                project.relocate_media(stored, files[0].with_name("elsewhere.bin"))
                assert project.media_identity(project.video(label).left[0].path, full=True) is None
        else:
            with Project.open(project_path) as project:
                project.accept_media(stored)
                assert project.media_identity(stored, full=True) is None and project.media_path(stored) == files[0]
    assert seen == set(DAMAGES)


def test_a_project_from_before_sampled_hashes_checks_the_whole_file_once(tmp_path):
    media = tmp_path / "left.mp4"
    media.write_bytes(bytes(range(256)) * 5000)
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_video("v", [(media, 10, 25.0)], [(media, 10, 25.0)], 25.0, 10, (64, 48))
        project._edit("DELETE FROM meta WHERE key LIKE 'media-sample:%'")  # as an older USVIPS left it
        assert project.media_identity("left.mp4") is None  # the full hash compared, the sample recorded
        assert project._query("SELECT count(*) FROM meta WHERE key LIKE 'media-sample:%'") == [(1,)]
        data = bytearray(media.read_bytes())
        data[0] ^= 1
        media.write_bytes(bytes(data))
        assert "sampled hash" in project.media_identity("left.mp4")


def test_a_copy_in_another_folder_finds_its_media_as_they_were(tmp_path):
    rng = np.random.default_rng(3)
    media = tmp_path / "media"
    media.mkdir()
    files = []
    for side in ("left", "right"):
        files.append(media / f"{side}.mp4")
        files[-1].write_bytes(rng.integers(0, 256, 2_000_000, dtype=np.uint8).tobytes())
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_video("v", [(files[0], 10, 25.0)], [(files[1], 10, 25.0)], 25.0, 10, (64, 48))
        (tmp_path / "elsewhere").mkdir()
        copy = project.copy_to(tmp_path / "elsewhere" / "copy.usvips")
    with Project.open(copy) as other:
        video = other.video("v")
        assert video.paths("left") == [str(files[0].resolve())] and other.media_problems() == []  # outside: absolute
        assert [other.media_path(p) for p in video.paths("left") + video.paths("right")] == [f.resolve() for f in files]
        assert other._query("SELECT count(*) FROM meta WHERE key LIKE 'media-sample:/%'") == [(2,)]
