"""The output guard: a command's output never replaces its input, its project or a file holding work
unless asked; asked, the old file is kept as NAME.bak only when the writing succeeds."""

import sqlite3

import numpy as np
import pytest

from usvips.io.atomic import OutputFileError, backup_path, guard_output, precious_kind, replacing, write_text_atomic


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def test_precious_files_are_known_by_their_contents_not_their_names(tmp_path):
    database = tmp_path / "survey.csv"
    sqlite3.connect(database).execute("CREATE TABLE t (x)").connection.close()
    calibration = tmp_path / "notes.txt"
    calibration.write_text('{"format": "usvips-calibration", "version": 1}')
    plain = tmp_path / "old.usvips"
    plain.write_text("id,X\n")
    assert "project" in precious_kind(database) and "calibration" in precious_kind(calibration)
    assert precious_kind(plain) is None and precious_kind(tmp_path / "absent") is None
    for path in (database, calibration):
        with pytest.raises(OutputFileError, match="destroy"):
            guard_output(path)
    assert guard_output(plain) is False  # an ordinary old output is simply replaced


def test_many_random_aliases_of_an_input_are_all_refused(tmp_path):
    rng = np.random.default_rng(5)
    source = tmp_path / "data.csv"
    source.write_text("id,X\n1,2\n")
    (tmp_path / "a" / "b").mkdir(parents=True)
    for n in range(40):
        depth = int(rng.integers(0, 3))
        spelled = tmp_path.joinpath(*["a", "b"][:depth], *[".."] * depth, "data.csv")
        alias = spelled
        if rng.random() < 0.5:
            alias = tmp_path / f"link{n}.csv"
            (alias.symlink_to if rng.random() < 0.5 else alias.hardlink_to)(source)
        with pytest.raises(OutputFileError, match="an input of this command"):
            guard_output(alias, [tmp_path / "other.csv", spelled])
        assert guard_output(alias, [source], replace=True) is True


def test_the_project_is_never_replaced_even_when_forced(tmp_path):
    project = tmp_path / "p.usvips"
    sqlite3.connect(project).execute("CREATE TABLE t (x)").connection.close()
    with pytest.raises(OutputFileError, match="the project this command works on"):
        guard_output(project, project=project, replace=True)


def test_a_forced_replacement_keeps_a_backup_only_when_the_writing_succeeds(tmp_path):
    target = tmp_path / "cal.json"
    target.write_text('{"format": "usvips-calibration"}')
    with pytest.raises(RuntimeError), replacing(target, replace=True):
        raise RuntimeError("the calibration could not be read")
    assert _files(tmp_path) == ["cal.json"]
    with replacing(target, replace=True):
        write_text_atomic(target, "new")
    assert backup_path(target).read_text() == '{"format": "usvips-calibration"}' and target.read_text() == "new"
    assert _files(tmp_path) == ["cal.json", "cal.json.bak"]
    with pytest.raises(OutputFileError):  # refused before anything happens
        with replacing(target, [target]):
            raise AssertionError("the block must not run")


def test_a_pipe_or_a_device_is_never_written_over_nor_waited_on(tmp_path):
    """A named pipe as the output would block opening it (to see whether it holds a project); a device
    would be replaced by a regular file by the rename. Both are refused, before anything is opened; as an
    input, each is named for what it is (not "no such file")."""
    import os

    from usvips.io.file_errors import not_a_file

    pipe = tmp_path / "pipe.csv"
    os.mkfifo(pipe)
    for output in (pipe, "/dev/null"):
        with pytest.raises(OutputFileError, match="not a regular file; give a file name"):
            write_text_atomic(output, "x")
        with pytest.raises(OutputFileError, match="not a regular file"):
            guard_output(output)
    assert precious_kind(pipe) is None  # answered without opening it (an open would wait for a writer)
    assert pipe.exists() and not pipe.is_file()
    assert str(not_a_file(pipe)) == f"{pipe}: is a named pipe, not a regular file: save it to a file first"
    assert str(not_a_file("/dev/null")).endswith("is a device, not a regular file: save it to a file first")
    assert str(not_a_file(tmp_path / "missing.csv")).endswith("no such file")


def test_a_set_of_files_stopped_by_a_full_disk_is_named_by_the_file_and_leaves_nothing(tmp_path, monkeypatch):
    import errno
    import os

    from usvips.io import atomic
    from usvips.io.atomic import write_files_atomic

    (tmp_path / "a.txt").write_text("old a")
    opened = os.fdopen
    calls = []

    def full_on_second(handle, *args, **kwargs):
        calls.append(handle)
        stream = opened(handle, *args, **kwargs)
        if len(calls) == 2:
            def full(text):
                raise OSError(errno.ENOSPC, "No space left on device")
            stream.write = full
        return stream

    monkeypatch.setattr(atomic.os, "fdopen", full_on_second)
    with pytest.raises(OutputFileError, match=r"b\.txt: cannot write: No space left on device"):
        write_files_atomic({tmp_path / "a.txt": "new a", tmp_path / "b.txt": "new b"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"] and (tmp_path / "a.txt").read_text() == "old a"
