"""The one exception family of USVIPS.

Every message names the parameter, file or line at fault and what is wrong, in one line a person can
act on, in the user's terms — never a command-line flag: the same error reaches people who never typed
one. An error about a setting carries it in ``parameter`` (the library's name, e.g. ``max_dt``), so that
each front end says how to fix it in its own terms: the command line appends its option ("… (set it
with --max-dt)") and exits with status 2; the window shows the message in the status bar or a dialog
(where the user set that value in a field of the dialog at hand).
"""

from __future__ import annotations


class UsvipsError(Exception):
    """Base of every error USVIPS reports to a user.

    ``parameter``: the setting the error concerns as the library names it (``max_dt``, ``interior``), or
    None; :func:`concerning` sets it on any error of the family.
    """

    parameter: str | None = None


def concerning(error: UsvipsError, parameter: str) -> UsvipsError:
    """``error`` marked as concerning the setting ``parameter`` (returned, to raise it in one line)."""
    error.parameter = parameter
    return error


class UsvipsWarning(UserWarning):
    """Base of every warning USVIPS emits (tests turn these into errors)."""


class InvalidParameterError(UsvipsError, ValueError):
    """A parameter value is impossible (f <= 0, radius <= 0, an index <= 0, a non-finite value ...).

    ``parameter`` holds the parameter's name as the seeds spell it (``f``, ``r``, ``n2`` ...) or as the
    library's functions name it (``max_dt``); ``label`` (optional) says it in words ("the time between
    partners"), and then heads the message instead of ``parameter NAME``.
    """

    def __init__(self, parameter: str, problem: str, label: str | None = None):
        self.parameter = parameter
        self.problem = problem
        self.label = label
        super().__init__(f"{label}: {problem}" if label else f"parameter {parameter}: {problem}")


class DegenerateGeometryError(UsvipsError):
    """The geometry cannot give an answer: too few points, coplanar control, parallel rays,
    rays that miss a surface or reflect totally, a point behind the camera."""


class ConvergenceError(UsvipsError):
    """An iterative solution did not converge."""


class InputFileError(UsvipsError):
    """A file the user handed us is wrong; the message names the file and, where known, the line."""

    def __init__(self, path: str, problem: str, line: int | None = None):
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = f"{self.path}, line {line}" if line is not None else self.path
        super().__init__(f"{where}: {problem}")
