"""How a batch computation (an adjustment) runs: its dense linear algebra on one BLAS thread, and the
compiled kernels (:mod:`usvips.core.kernels`) for batches of any size.

A calibration's normal equations are small (tens to a few hundred unknowns) and are formed and solved
hundreds of times per run (Jacobian products, damped solves, inverses, SVDs, the variance components).
Threaded OpenBLAS wakes its worker threads for each of these calls; on a shared 2-core machine those
threads spin while they wait for a core, and a 7,372 × 53 product that takes 2 ms on one thread took
120-190 ms (measured with ``usvips bench --only calibration``). One thread is what such sizes need.

:func:`batch_computation` wraps a function so that BLAS and LAPACK run on one thread while it runs (the
previous limits are restored afterwards, also on an exception). It uses ``threadpoolctl``, which finds
the BLAS that numpy and SciPy actually loaded; the controller is created once, on first use.

A calibration evaluates its model block by block (one camera at one station: tens to hundreds of
points), below the size from which the kernels' ``"auto"`` mode compiles (that threshold keeps a window's
single pick from loading numba); an adjustment loads them once and then gains on every block, so within
it the kernels run ``"always"``. They give the numpy reference's numbers (tests/core/test_kernels.py).

The engine's structured fast paths (the normal equations summed block by block,
:mod:`usvips.core.normal_equations`; the housing columns of a side traced in one batch,
:mod:`usvips.core.calibration.derivatives`) keep the straightforward computation as their reference:
``with reference(): ...`` makes them take it, so that tests compare both on the same problem.

Both switches (the kernels' mode and the reference) are context variables: they hold for the thread or
task that entered the block, never for another worker running at the same time. The BLAS thread limit is
the one process-wide setting (the BLAS library has a single pool).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import TypeVar

from usvips.core import kernels

Function = TypeVar("Function", bound=Callable)

_controller = None
_reference: ContextVar[bool] = ContextVar("usvips_reference_paths", default=False)


@contextmanager
def reference() -> Iterator[None]:
    """Within this block the engine's structured fast paths take their straightforward dense reference (in
    this thread or task only)."""
    token = _reference.set(True)
    try:
        yield
    finally:
        _reference.reset(token)


def using_reference() -> bool:
    """Whether :func:`reference` is in force in this thread or task."""
    return _reference.get()


def _blas_controller():
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


def batch_computation(function: Function) -> Function:
    """``function`` with BLAS/LAPACK limited to one thread and the compiled kernels at any batch size for
    the duration of each call."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with _blas_controller().limit(limits=1, user_api="blas"), kernels.mode("always"):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
