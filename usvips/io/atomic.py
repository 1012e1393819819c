"""Writing files so that an error never leaves a partial one behind.

Every output path is checked first (:func:`check_output_path`): it must not be a folder, its folder must
exist and be writable, its name must not be too long. The data then go to a temporary file in the same
folder, which is renamed into place only when complete; on any error the temporary file is removed and
the old file (if any) is untouched. Failures are :class:`OutputFileError` naming the path.

A command never overwrites its own source (:func:`guard_output`, called by every command that writes a
file before it writes): the output may not be one of the command's inputs, the open project, or an
existing file of a kind that holds work (a USVIPS project, a USVIPS calibration), unless the user asks
for replacement (``--force``); then the old file is first copied to ``NAME.bak`` beside it (an older
``NAME.bak`` is replaced) and the new one is written atomically as always. The project a command works
on is never replaced, ``--force`` or not.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from usvips.core.errors import InputFileError, concerning
from usvips.io.file_errors import special_kind

#: The longest file name (one path component, in bytes) most file systems accept.
NAME_MAX = 255


class OutputFileError(InputFileError):
    """A file we were asked to write cannot be written; the message names the path and the reason.
    ``replace_parameter``: the setting with which the user may ask to replace it anyway (``"force"``), or
    None."""

    replace_parameter: str | None = None


def _process_umask() -> int:
    """The process's file-mode mask (read once: setting it to read it back is not safe while other threads
    create files)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


_UMASK = _process_umask()


def give_normal_mode(path: str | Path) -> None:
    """Give a file made by :func:`tempfile.mkstemp` (mode 0600) the mode any new file gets here (0666 less
    the umask), so that a colleague sharing the folder can read what USVIPS wrote."""
    os.chmod(path, 0o666 & ~_UMASK)


def check_output_path(path: str | Path) -> Path:
    """``path`` as a :class:`Path` if a file can be written there; else :class:`OutputFileError`."""
    path = Path(path)
    if not str(path) or path.name in ("", ".", ".."):
        raise OutputFileError(str(path), "not a file name")
    if len(os.fsencode(path.name)) > NAME_MAX:
        raise OutputFileError(f"{str(path)[:60]}…", f"the file name is too long ({len(os.fsencode(path.name))} "
                              f"bytes; at most {NAME_MAX})")
    if path.is_dir():
        raise OutputFileError(str(path), "is a folder; give a file name")
    kind = special_kind(path)
    if kind is not None:  # renaming onto it would replace the device; opening a pipe would wait forever
        raise OutputFileError(str(path), f"is {kind}, not a regular file; give a file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise OutputFileError(str(path), f"the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputFileError(str(path), f"the folder {folder} is not writable")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputFileError(str(path), "the file is read-only")
    return path


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename it into place."""
    with _replaced_atomically(path, "wb") as stream:
        stream.write(data)


def text_atomic(path: str | Path) -> contextlib.AbstractContextManager:
    """A text stream (UTF-8, newlines as written) to a temporary file beside ``path``, renamed into place
    when the block ends without error; on any error the temporary file is removed and ``path`` is
    untouched (for writers that write a large file piece by piece)."""
    return _replaced_atomically(path, "w", encoding="utf-8", newline="")


@contextlib.contextmanager
def _replaced_atomically(path: str | Path, mode: str, **options) -> Iterator:
    """A stream (``open``'s ``mode`` and ``options``) to a temporary file beside ``path`` (checked by
    :func:`check_output_path`), given a normal file's mode and renamed onto ``path`` when the block ends
    without error; on any error the temporary file is removed, ``path`` untouched, and an operating-system
    error is an :class:`OutputFileError` naming ``path``."""
    path = check_output_path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        handle, temporary = tempfile.mkstemp(prefix=".usvips.", suffix=".tmp", dir=str(folder))
    except OSError as error:
        raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
    try:
        with os.fdopen(handle, mode, **options) as stream:
            try:
                yield stream
            except OSError as error:
                raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
        give_normal_mode(temporary)
        os.replace(temporary, path)
    except OSError as error:
        Path(temporary).unlink(missing_ok=True)
        raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically (see :func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_files_atomic(files: dict[Path, str]) -> None:
    """Write a set of text files all or nothing: every text goes to a temporary file beside its target
    first; only when all are written are they renamed into place, and if a rename fails the targets
    already replaced get their old contents back (or are removed when they did not exist)."""
    temporaries: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}
    try:
        for path, text in files.items():
            path = check_output_path(path)
            folder = path.parent if str(path.parent) else Path(".")
            try:
                handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=str(folder))
                temporaries[path] = temporary
                with os.fdopen(handle, "w", encoding="utf-8", newline="") as stream:
                    stream.write(text)
                give_normal_mode(temporary)
            except OSError as error:  # a full disk, say: named by the file it stopped (nothing is in place)
                raise OutputFileError(str(path), f"cannot write: {error.strerror or error}") from None
        for path, temporary in temporaries.items():
            if path.exists():
                handle, backup = tempfile.mkstemp(prefix=f".{path.name}.old.", dir=str(path.parent))
                os.close(handle)
                os.replace(path, backup)
                backups[path] = backup
            else:
                backups[path] = None
            os.replace(temporary, path)
    except BaseException:
        for path, backup in backups.items():
            if backup is not None:
                os.replace(backup, path)
            elif not os.path.exists(temporaries[path]) and path.exists():
                path.unlink()  # it did not exist before and was already put in place
        for temporary in temporaries.values():
            if os.path.exists(temporary):
                os.unlink(temporary)
        raise
    for backup in backups.values():
        if backup is not None and os.path.exists(backup):
            os.unlink(backup)


# ---------------------------------------------------------------------------- never overwrite a source
#: The suffix of the copy an explicitly replaced file is kept as (``cal.json`` → ``cal.json.bak``).
BACKUP_SUFFIX = ".bak"

#: How a file that holds work begins (its first bytes): replaced only when the user asks.
_PRECIOUS_HEADS = ((b"SQLite format 3\x00", "a USVIPS project (SQLite database)"),)
#: Text within the first kilobytes of a USVIPS calibration file.
_CALIBRATION_MARK = b'"usvips-calibration"'


def backup_path(path: str | Path) -> Path:
    """Where :func:`guard_output` keeps the old contents of a file it was allowed to replace."""
    path = Path(path)
    return path.with_name(path.name + BACKUP_SUFFIX)


def precious_kind(path: str | Path) -> str | None:
    """What kind of work an existing file at ``path`` holds ("a USVIPS project …", "a USVIPS calibration"),
    or None for any other file (or none): judged by its first bytes, never by its name."""
    if special_kind(path) is not None:
        return None  # a pipe would block the open; a device holds no one's work
    try:
        with open(path, "rb") as stream:
            head = stream.read(4096)
    except OSError:
        return None
    for magic, kind in _PRECIOUS_HEADS:
        if head.startswith(magic):
            return kind
    if _CALIBRATION_MARK in head:
        return "a USVIPS calibration"
    return None


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file (the same inode when both exist: hard links and symbolic links
    count; otherwise the same resolved path)."""
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError, ValueError):
        return False


def guard_output(path: str | Path, inputs: Iterable[str | Path | None] = (), project: str | Path | None = None,
                 replace: bool = False, parameter: str = "out", replaceable: bool = True) -> bool:
    """Check ``path`` for writing (:func:`check_output_path`) and as not a source of the command; returns
    whether an existing file there is to be kept as a backup when it is replaced (see :func:`replacing`).

    Refused (:class:`OutputFileError`, one line naming the file and what it is, concerning the setting
    ``parameter`` that named the output) when ``path`` is one of ``inputs`` or an existing USVIPS project
    or calibration (:func:`precious_kind`) — unless ``replace`` (the user asked for it; the error's
    ``replace_parameter`` is ``"force"`` when the user may ask, i.e. when ``replaceable``) — and always
    when it is the ``project`` the command works on (a project open while its file is replaced would be
    lost, backup or not)."""
    path = check_output_path(path)
    if not (path.exists() or path.is_symlink()):
        return False
    if project is not None and same_file(path, project):
        raise concerning(OutputFileError(str(path), "the output is the project this command works on; writing "
                                         "there would destroy it: give another file"), parameter)
    what = None
    for source in inputs:
        if source is not None and str(source) and same_file(path, source):
            what = "an input of this command"
            break
    kind = precious_kind(path)
    if what is None and kind is None:
        return False
    if not replace:
        described = what + (f", {kind}" if kind else "") if what else kind
        how = f", or replace it on purpose: the old one is kept as {backup_path(path).name}" if replaceable else ""
        error = concerning(OutputFileError(str(path), f"the output is {described}; writing there would destroy it "
                                                      f"(give another file{how})"), parameter)
        error.replace_parameter = "force" if replaceable else None
        raise error
    return True


@contextlib.contextmanager
def replacing(paths: str | Path | Iterable[str | Path], inputs: Iterable[str | Path | None] = (),
              project: str | Path | None = None, replace: bool = False, parameter: str = "out",
              replaceable: bool = True) -> Iterator[None]:
    """Around a command's writing of ``paths`` (one or several files): each checked by
    :func:`guard_output` on entry (so a refusal comes before any work); a file that may be replaced only
    because the user asked is copied aside on entry and the copy becomes ``NAME.bak`` when the block
    ends without error (on an error the copy is dropped: the old file is untouched anyway, as every
    writer here writes atomically)."""
    targets = [Path(paths)] if isinstance(paths, (str, Path)) else [Path(p) for p in paths]
    inputs = list(inputs)
    kept: dict[Path, str] = {}
    try:
        for target in targets:
            if guard_output(target, inputs, project, replace, parameter, replaceable):
                try:
                    handle, temporary = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".bak.tmp",
                                                         dir=str(target.parent))
                    os.close(handle)
                    kept[target] = temporary
                    shutil.copy2(target, temporary)
                except OSError as error:
                    raise OutputFileError(str(target), f"cannot keep the old file as {backup_path(target).name}: "
                                          f"{error.strerror or error}; nothing was written") from None
        yield
        for target, temporary in kept.items():
            os.replace(temporary, backup_path(target))
    finally:
        for temporary in kept.values():
            Path(temporary).unlink(missing_ok=True)
