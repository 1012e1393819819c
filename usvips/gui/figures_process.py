"""Objects' figures computed in a child process, so that the window's thread never waits on them for the GIL.

Why a process and not only a worker thread: the window's thread calls into Python hundreds of times per
repaint (a model's ``data``, an item's ``paint``), and each call first takes the interpreter's lock. While a
worker *thread* computes figures in Python, each of those calls waits up to the interpreter's switch
interval (5 ms): during *Detect* a repaint of a few dozen calls froze the window for 0.15–0.27 s while the
window's own work was 0.04 s (docs/benchmarks.md, "The window's freezes while a worker runs Python"). A
child process has an interpreter of its own; the worker thread that asks it waits on a pipe, without the
lock.

:func:`figures_of` is the one function that turns measurement inputs into the calculator's results; the
child runs it, and so does the asking thread whenever the child cannot (not started yet, gone, or a bug in
the computation: then the same exception is raised where it is asked, with its real traceback). The
results are the same either way.

The child is ``python -m usvips.gui.figures_child``, one per window process, started when figures are first
asked of it and ended when the window's process ends (or when its stdin closes). Requests and answers are
pickled frames on its stdin and stdout — an 8-byte little-endian length, then the pickle — between this
process and the child it started, nothing else. The child lowers its own scheduling priority (as bulk
workers do) so the window's thread gets a core first.
"""

from __future__ import annotations

import atexit
import importlib.util
import itertools
import os
import pickle
import struct
import subprocess
import sys
import threading
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import BinaryIO

from usvips.app.project_figures import MeasurementInput, evaluate_many
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules
from usvips.core.stereo_calibration import StereoCalibration
from usvips.gui.calculator import Result, result_of

#: the module the child runs (``python -m``): one of its own, so that the requests are served by this module
#: imported under its name — run as ``-m`` itself, this file would be ``__main__``, whose classes are not the
#: ones the requests' pickles name (every batch then failed in the child and was computed in the asker)
CHILD_MODULE = "usvips.gui.figures_child"
#: the child's scheduling niceness (as ``usvips.gui.qt.worker.BACKGROUND_NICE``; no Qt is imported here)
CHILD_NICE = 10
#: after this many failed children in one process, figures stay in the asking thread
MAX_STARTS = 3
#: how long (s) a request waits for a starting child before it is computed in the asking thread
READY_WAIT_S = 20.0
#: calibrations the child holds at most before it is told to forget them (a window opens a few per project)
MAX_CALIBRATIONS = 64
_READY = b"usvips-figures-ready"
_HEADER = struct.Struct("<Q")


def figures_of(sources: Sequence[MeasurementInput], rules: QualityRules | None) -> list[Result]:
    """Each source's figures (``project_figures.evaluate_many``) as the calculator shows them; a source that
    cannot be measured gives a result with no figures and the reason. Pure: any thread or process."""
    return [Result((), (), str(measured)) if isinstance(measured, UsvipsError) else result_of(measured)
            for measured in evaluate_many(sources, rules)]


def write_frame(stream: BinaryIO, payload: object) -> None:
    """One pickled frame: its length (8 bytes, little-endian), then the pickle."""
    data = pickle.dumps(payload, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)))
    stream.write(data)
    stream.flush()


def read_frame(stream: BinaryIO) -> object:
    """The next frame's object; EOFError when the stream ends (a whole frame or none)."""
    header = _read_exactly(stream, _HEADER.size)
    return pickle.loads(_read_exactly(stream, _HEADER.unpack(header)[0]))


def _read_exactly(stream: BinaryIO, size: int) -> bytes:
    chunks, left = [], size
    while left:
        chunk = stream.read(left)
        if not chunk:
            raise EOFError("the figures process closed its pipe")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


class FiguresProcess:
    """The child that computes figures, started on first use; :meth:`figures` is safe from any thread (one
    request at a time; a second asker waits on a lock, without the GIL)."""

    def __init__(self, command: Sequence[str] | None = None) -> None:
        self._command = list(command) if command is not None else [sys.executable, "-m", CHILD_MODULE]
        self._lock = threading.Lock()
        self._child: subprocess.Popen | None = None
        self._settled = threading.Event()  # the child said it is ready, or ended before it did
        self._ready = False
        self._starts = 0
        # the calibrations the child holds, by the parent's object: id → (token, calibration); kept so that the
        # child's copy keeps what it caches between requests (its derivative cameras: a fresh copy a batch
        # took 35-40 ms against 20 ms for 32 fish)
        self._sent: dict[int, tuple[int, StereoCalibration]] = {}
        self._tokens = itertools.count(1)
        #: why the last child is gone ("" while none failed): shown by the bench and the tests
        self.failure = ""

    @property
    def running(self) -> bool:
        """A child is started and has said it is ready."""
        return self._child is not None and self._ready and self._child.poll() is None

    def figures(self, sources: Sequence[MeasurementInput], rules: QualityRules | None) -> list[Result]:
        """:func:`figures_of` in the child (started now if it is not; waited for while it starts, up to
        :data:`READY_WAIT_S`), else — the child could not start, or failed — in the calling thread."""
        with self._lock:
            self._start_locked()
            child = self._child
            if child is not None and self._settled.wait(READY_WAIT_S) and self._ready and child is self._child:
                forget = len(self._sent) >= MAX_CALIBRATIONS
                held = {} if forget else self._sent
                new: dict[int, tuple[int, StereoCalibration]] = {}
                try:
                    packed = [self._packed(source, held, new) for source in sources]
                except Exception:  # noqa: BLE001 — not a measurement input: computed here, where it raises
                    packed = None
                if packed is not None:
                    try:
                        write_frame(child.stdin, (packed, {t: c for t, c in new.values()}, forget, rules))
                        answer = read_frame(child.stdout)
                    except Exception as error:  # noqa: BLE001 — a broken pipe, a refused pickle: computed here
                        self._stop(f"the figures process failed: {type(error).__name__}: {error}")
                    else:
                        self._sent = {**held, **new}
                        if isinstance(answer, list):
                            return answer
                        # the computation raised in the child: computed here, the same error raised with its trace
            elif child is not None and child is self._child:
                self._stop(self.failure if self._settled.is_set()
                           else f"the figures process was not ready within {READY_WAIT_S:g} s")
        return figures_of(sources, rules)

    def warm(self) -> None:
        """Start the child now, if none runs and no request holds it (returns at once, never waiting: safe on
        the window's thread), so that the figures asked for soon do not wait for its imports."""
        if self._lock.acquire(blocking=False):
            try:
                self._start_locked()
            finally:
                self._lock.release()

    def _packed(self, source: MeasurementInput, held: dict[int, tuple[int, StereoCalibration]],
                new: dict[int, tuple[int, StereoCalibration]]) -> MeasurementInput:
        """``source`` (and its instants) with each calibration as the token the child knows it by (``held``:
        those it holds, by the parent's object id); one it does not hold yet gets a token in ``new``."""
        calibration = source.calibration
        if calibration is not None and not isinstance(calibration, SentCalibration):
            sent = held.get(id(calibration))
            if sent is None or sent[1] is not calibration:
                sent = new.get(id(calibration)) or (next(self._tokens), calibration)
                new[id(calibration)] = sent
            calibration = SentCalibration(sent[0])
        instants = tuple(self._packed(i, held, new) for i in source.instants)
        return replace(source, calibration=calibration, instants=instants)

    def close(self) -> None:
        """End the child (its stdin closed, then killed if it has not gone within a second)."""
        with self._lock:
            self._stop("")

    def _start_locked(self) -> None:
        if self._child is not None or self._starts >= MAX_STARTS:
            return
        self._starts += 1
        self._settled.clear()
        self._ready = False
        package_root = _package_root()  # the child imports this very usvips
        environment = dict(os.environ, PYTHONPATH=os.pathsep.join(
            p for p in (package_root, os.environ.get("PYTHONPATH", "")) if p))
        try:
            child = subprocess.Popen(self._command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, env=environment)
        except OSError as error:
            self.failure = f"the figures process did not start: {error}"
            return
        self._child = child
        self._sent.clear()  # a new child holds none
        threading.Thread(target=self._await_ready, args=(child,), name="figures-process-ready",
                         daemon=True).start()

    def _await_ready(self, child: subprocess.Popen) -> None:
        try:
            said = read_frame(child.stdout)
        except Exception:  # noqa: BLE001 — the child ended, or wrote something else: not ready
            said = None
        if child is self._child:
            self._ready = said == _READY
            if not self._ready:
                self.failure = "the figures process ended before it was ready"
            self._settled.set()

    def _stop(self, why: str) -> None:
        child, self._child = self._child, None
        self._ready = False
        if why:
            self.failure = why
        if child is None:
            return
        try:
            child.stdin.close()
            child.wait(timeout=1.0)
        except (OSError, subprocess.TimeoutExpired):
            child.kill()
            child.wait()
        finally:
            child.stdout.close()


def _package_root() -> str:
    """The folder the import system found the ``usvips`` package in (for the child's ``PYTHONPATH``)."""
    spec = importlib.util.find_spec("usvips")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    return os.path.dirname(os.path.abspath(locations[0])) if locations else ""


_PROCESS: FiguresProcess | None = None
_PROCESS_LOCK = threading.Lock()


def shared_process() -> FiguresProcess:
    """The window process's one figures child (made on first call, ended at exit)."""
    global _PROCESS
    with _PROCESS_LOCK:
        if _PROCESS is None:
            _PROCESS = FiguresProcess()
            atexit.register(_PROCESS.close)
        return _PROCESS


@dataclass(frozen=True)
class SentCalibration:
    """A calibration the child was sent before, by its token (in a request's measurement inputs)."""

    token: int


def _unpacked(source: MeasurementInput, calibrations: dict[int, StereoCalibration]) -> MeasurementInput:
    calibration = source.calibration
    if isinstance(calibration, SentCalibration):
        calibration = calibrations[calibration.token]
    return replace(source, calibration=calibration, instants=tuple(_unpacked(i, calibrations) for i in source.instants))


def serve(requests: BinaryIO, answers: BinaryIO) -> None:
    """The child's loop: say ready, then answer each request — ``(sources, new calibrations by token, whether to
    forget those held first, rules)`` — with :func:`figures_of`'s list (or, when it raises, the error's text:
    the asker computes again itself) until ``requests`` ends."""
    write_frame(answers, _READY)
    calibrations: dict[int, StereoCalibration] = {}
    while True:
        try:
            packed, new, forget, rules = read_frame(requests)
        except EOFError:
            return
        if forget:
            calibrations.clear()
        calibrations.update(new)
        try:
            answer: object = figures_of([_unpacked(s, calibrations) for s in packed], rules)
        except Exception as error:  # noqa: BLE001 — reported to the asker, which raises it again
            answer = f"{type(error).__name__}: {error}"
        write_frame(answers, answer)


def serve_stdio() -> None:
    """The child's whole life (:mod:`usvips.gui.figures_child` runs it): lower its priority, keep its stdout for
    the frames, and :func:`serve` stdin until it ends."""
    try:
        os.nice(CHILD_NICE)
    except (AttributeError, OSError):
        pass
    answers = os.fdopen(os.dup(sys.stdout.fileno()), "wb")  # the frames only: a stray print goes to stderr
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    serve(sys.stdin.buffer, answers)
