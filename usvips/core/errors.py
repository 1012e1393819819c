"""The one exception family of USVIPS.

Every message names the parameter, file or line at fault and what is wrong, in one line a person can
act on. The command line prints ``str(error)`` and exits with status 2; the GUI shows it in the status
bar or a dialog.
"""

from __future__ import annotations


class UsvipsError(Exception):
    """Base of every error USVIPS reports to a user."""


class UsvipsWarning(UserWarning):
    """Base of every warning USVIPS emits (tests turn these into errors)."""


class InvalidParameterError(UsvipsError, ValueError):
    """A parameter value is impossible (f <= 0, radius <= 0, an index <= 0, a non-finite value ...).

    ``parameter`` holds the parameter's name as the seeds spell it (``f``, ``r``, ``n2`` ...).
    """

    def __init__(self, parameter: str, problem: str):
        self.parameter = parameter
        self.problem = problem
        super().__init__(f"parameter {parameter}: {problem}")


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
