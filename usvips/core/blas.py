"""How the adjustment's dense linear algebra runs: on one BLAS thread.

A calibration's normal equations are small (tens to a few hundred unknowns) and are formed and solved
hundreds of times per run (Jacobian products, damped solves, inverses, SVDs, the variance components).
Threaded OpenBLAS wakes its worker threads for each of these calls; on a shared 2-core machine those
threads spin while they wait for a core, and a 7,372 × 53 product that takes 2 ms on one thread took
120-190 ms (measured with ``usvips bench --only calibration``). One thread is what such sizes need.

:func:`single_threaded` wraps a function so that BLAS and LAPACK run on one thread while it runs (the
previous limits are restored afterwards, also on an exception). It uses ``threadpoolctl``, which finds
the BLAS that numpy and SciPy actually loaded; the controller is created once, on first use.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

Function = TypeVar("Function", bound=Callable)

_controller = None


def _blas_controller():
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


def single_threaded(function: Function) -> Function:
    """``function`` with BLAS/LAPACK limited to one thread for the duration of each call."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with _blas_controller().limit(limits=1, user_api="blas"):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
