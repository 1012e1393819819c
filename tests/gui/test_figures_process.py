"""The figures child process (usvips.gui.figures_process): the same figures as computed in the asking thread,
over random surveys; and when the child cannot help — it never starts, ends before it is ready, dies
between requests, or the computation raises — the figures are still computed, and the reason is kept."""

import io
import os
import signal
import sys
from dataclasses import replace

import numpy as np
import pytest

from usvips.gui import figures_process
from usvips.gui.figures_process import FiguresProcess, figures_of, read_frame, write_frame
from usvips.gui.workspace import Workspace
from usvips.store.opening import open_project


@pytest.fixture(scope="module")
def surveys(tmp_path_factory):
    """Three random surveys of 40 random fish each on the ROV sample's pair, their measurement inputs varied:
    a third with right picks moved up to 25 px (rays that miss: rules broken, or no figure), a fifth with
    no calibration and no stored X, Y, Z (no figure, a reason), a sixth measured on further instants
    (combined figures); and the quality rules in use."""
    from usvips.gui.qt.bench import survey_project

    made = []
    for seed in (3, 11, 29):
        path = survey_project(tmp_path_factory.mktemp(f"survey{seed}"), 40, seed)
        project = open_project(path)
        ws = Workspace()
        ws.open_project(project)
        cache = ws.cache
        sources = [cache.input(cache.get(i)) for i in cache.ids()]
        rng = np.random.default_rng(seed)
        varied = []
        for index, source in enumerate(sources):
            if index % 3 == 1:
                source = replace(source, right=source.right + rng.uniform(-25.0, 25.0, source.right.shape))
            if index % 5 == 2:
                source = replace(source, calibration=None, xyz=np.full_like(source.xyz, np.nan))
            if index % 6 == 0:
                source = replace(source, instants=(replace(sources[index - 1], id=f"{source.id}b"),))
            varied.append(source)
        made.append((varied, ws.rules))
        ws.close_project()
    return made


@pytest.fixture
def computed_here(monkeypatch):
    """The batches this process computed itself (the child's fallback): a list of their sizes."""
    sizes = []
    computing = figures_process.figures_of

    def counted(sources, rules):
        sizes.append(len(sources))
        return computing(sources, rules)

    monkeypatch.setattr(figures_process, "figures_of", counted)
    return sizes


def _same(first, second) -> None:
    assert len(first) == len(second)
    for a, b in zip(first, second, strict=True):
        assert a.reason == b.reason and a.failures == b.failures
        assert [f.name for f in a.figures] == [f.name for f in b.figures]
        for fa, fb in zip(a.figures, b.figures, strict=True):
            assert fa.value == pytest.approx(fb.value, rel=1e-12, abs=1e-15)
            assert fa.sigma == pytest.approx(fb.sigma, rel=1e-12, abs=1e-15)


def test_the_child_computes_what_the_thread_computes(surveys, computed_here):
    process = FiguresProcess()
    try:
        for sources, rules in surveys:
            assert len(sources) == 40
            rng = np.random.default_rng(len(sources))
            batch = [sources[i] for i in rng.permutation(len(sources))]
            _same(process.figures(batch, rules), figures_of(batch, rules))
            computed = figures_of(batch, rules)
            assert any(r.figures for r in computed) and any(r.reason for r in computed)
            assert any(r.failures for r in computed)
        assert process.running and process.failure == "" and computed_here == []  # all in the child
    finally:
        process.close()
    assert not process.running


def test_a_child_that_never_starts_leaves_the_figures_to_the_thread(surveys):
    sources, rules = surveys[0]
    process = FiguresProcess(["/nonexistent/usvips-python"])
    _same(process.figures(sources[:10], rules), figures_of(sources[:10], rules))
    assert not process.running and "did not start" in process.failure


def test_a_child_that_ends_before_it_is_ready(surveys):
    sources, rules = surveys[0]
    process = FiguresProcess([sys.executable, "-c", "pass"])
    _same(process.figures(sources[:10], rules), figures_of(sources[:10], rules))
    assert not process.running and "ended before it was ready" in process.failure


def test_each_calibration_is_sent_once_and_the_child_is_told_to_forget(surveys, monkeypatch, computed_here):
    """The child keeps the calibrations it was sent (and what it caches on them) by token: a calibration goes
    over the pipe with its first request only, and after :data:`MAX_CALIBRATIONS` the child forgets them all
    and is sent them again."""
    sent = []
    writing = figures_process.write_frame

    def recording(stream, payload):
        if isinstance(payload, tuple) and len(payload) == 4:
            packed, new, forget, _ = payload
            sent.append((len(new), forget, all(isinstance(s.calibration, figures_process.SentCalibration)
                                                for s in packed if s.calibration is not None)))
        writing(stream, payload)

    monkeypatch.setattr(figures_process, "write_frame", recording)
    process = FiguresProcess()
    try:
        for sources, rules in surveys:
            _same(process.figures(sources[:20], rules), figures_of(sources[:20], rules))
            _same(process.figures(sources[20:], rules), figures_of(sources[20:], rules))
        assert sent == [(1, False, True), (0, False, True)] * len(surveys)
        monkeypatch.setattr(figures_process, "MAX_CALIBRATIONS", 2)
        sources, rules = surveys[0]
        _same(process.figures(sources, rules), figures_of(sources, rules))
        assert sent[-1] == (1, True, True)
        assert computed_here == []  # the child used the calibrations it held
    finally:
        process.close()


def test_a_child_killed_between_requests_is_replaced_and_nothing_is_lost(surveys, computed_here):
    sources, rules = surveys[1]
    process = FiguresProcess()
    try:
        process.figures(sources[:5], rules)
        first = process._child
        assert process.running
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
        _same(process.figures(sources, rules), figures_of(sources, rules))  # computed here: the pipe broke
        assert "the figures process failed" in process.failure
        assert computed_here == [len(sources)]
        _same(process.figures(sources, rules), figures_of(sources, rules))  # a new child
        assert process.running and process._child is not first and computed_here == [len(sources)]
    finally:
        process.close()


def test_children_stop_being_started_after_repeated_failures(surveys):
    sources, rules = surveys[2]
    process = FiguresProcess([sys.executable, "-c", "pass"])
    for _ in range(figures_process.MAX_STARTS + 2):
        _same(process.figures(sources[:3], rules), figures_of(sources[:3], rules))
    assert process._starts == figures_process.MAX_STARTS


def test_an_error_in_the_computation_is_raised_where_it_was_asked(surveys, computed_here):
    _, rules = surveys[0]
    process = FiguresProcess()
    try:
        with pytest.raises(AttributeError):
            process.figures(["not a measurement input"], rules)
        assert process.running  # the child answered with the error; it is still there for the next request
        assert computed_here == [1]  # computed again here, where it raised
    finally:
        process.close()


def test_a_print_in_the_child_does_not_break_its_answers(surveys, computed_here):
    sources, rules = surveys[0]
    noisy = ("import usvips.gui.figures_process as f\n"
             "computed = f.figures_of\n"
             "f.figures_of = lambda *a: (print('a stray print', flush=True), computed(*a))[1]\n"
             "f.serve_stdio()\n")
    process = FiguresProcess([sys.executable, "-c", noisy])
    try:
        _same(process.figures(sources[:8], rules), figures_of(sources[:8], rules))
        assert process.running and process.failure == "" and computed_here == []
    finally:
        process.close()


def test_warming_starts_the_child_at_once_and_never_waits(surveys, computed_here):
    """``warm`` (called on the window's thread when a Detect run starts) starts the child and returns without
    waiting for it; while a request holds the process it does nothing rather than wait."""
    import threading

    sources, rules = surveys[0]
    process = FiguresProcess()
    try:
        process.warm()
        assert process._child is not None  # started (its readiness is not waited for)
        first = process._child
        process.warm()
        assert process._child is first  # one child
        _same(process.figures(sources[:4], rules), figures_of(sources[:4], rules))
        assert process.running and computed_here == []
        process._lock.acquire()  # a request in progress
        try:
            done = threading.Event()
            threading.Thread(target=lambda: (process.warm(), done.set()), daemon=True).start()
            assert done.wait(60.0)  # returned while the lock is held: it did not wait for the request
        finally:
            process._lock.release()
    finally:
        process.close()


def test_frames_round_trip_and_a_cut_frame_is_the_end():
    stream = io.BytesIO()
    payloads = [b"x" * 3, {"a": np.arange(5.0)}, [1, "two", None]]
    for payload in payloads:
        write_frame(stream, payload)
    whole = stream.getvalue()
    stream.seek(0)
    assert read_frame(stream) == payloads[0]
    assert np.array_equal(read_frame(stream)["a"], payloads[1]["a"])
    assert read_frame(stream) == payloads[2]
    with pytest.raises(EOFError):
        read_frame(stream)
    cut = io.BytesIO(whole[:-1])  # the last frame cut short
    read_frame(cut), read_frame(cut)
    with pytest.raises(EOFError):
        read_frame(cut)
