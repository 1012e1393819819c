"""The kernels' mode and the reference switch are per thread: two worker threads cannot switch each
other's mode (usvips.core.kernels.mode, usvips.core.batch_mode.reference)."""

from __future__ import annotations

import threading

from usvips.core import batch_mode, kernels


def _in_two_threads(first_mode: str, second_mode: str) -> dict[str, list]:
    """Each thread enters its own mode, then both (in lock step) read what is in force for them."""
    both_inside = threading.Barrier(2)
    both_read = threading.Barrier(2)
    seen: dict[str, list] = {}

    def worker(name: str, wanted: str, reference: bool) -> None:
        with kernels.mode(wanted):
            if reference:
                with batch_mode.reference():
                    both_inside.wait()
                    seen[name] = [kernels.current_mode(), batch_mode.using_reference()]
                    both_read.wait()
            else:
                both_inside.wait()
                seen[name] = [kernels.current_mode(), batch_mode.using_reference()]
                both_read.wait()
        seen[name].append(kernels.current_mode())

    threads = [threading.Thread(target=worker, args=("first", first_mode, True)),
               threading.Thread(target=worker, args=("second", second_mode, False))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return seen


def test_two_threads_keep_their_own_kernel_mode_and_reference_switch():
    seen = _in_two_threads("never", "always")
    assert seen["first"] == ["never", True, "auto"]
    assert seen["second"] == ["always", False, "auto"]
    assert kernels.current_mode() == "auto" and not batch_mode.using_reference()


def test_a_thread_does_not_see_the_mode_of_the_thread_that_started_it():
    seen = []
    with kernels.mode("never"), batch_mode.reference():
        thread = threading.Thread(target=lambda: seen.append((kernels.current_mode(), batch_mode.using_reference())))
        thread.start()
        thread.join()
        assert kernels.current_mode() == "never" and batch_mode.using_reference()
    assert seen == [("auto", False)]
    assert kernels.current_mode() == "auto"


def test_a_batch_computation_runs_always_in_its_own_thread_only():
    """``batch_computation`` (the adjustments' wrapper) switches the kernels for its own call, not for a
    window thread picking at the same time."""
    inside = threading.Event()
    release = threading.Event()
    seen = {}

    @batch_mode.batch_computation
    def adjustment():
        seen["adjustment"] = kernels.current_mode()
        inside.set()
        release.wait()

    thread = threading.Thread(target=adjustment)
    thread.start()
    inside.wait()
    seen["window"] = kernels.current_mode()
    release.set()
    thread.join()
    assert seen == {"adjustment": "always", "window": "auto"}
