"""The ``usvips`` command line: argument parsing and printing only; the work is in core, io and store.

Each subcommand lives in its own module of this package and registers itself in ``COMMANDS``.
Errors of the :class:`~usvips.core.errors.UsvipsError` family and operating-system errors (a file that
cannot be read or written) print as one line on stderr, exit 2; an unexpected exception (a bug) prints
one line too and exits 70, or shows its traceback with ``USVIPS_DEBUG=1``.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import NoReturn

from usvips import __version__
from usvips.core.errors import UsvipsError

#: (module name, description) of every subcommand; each module defines ``register(subparsers)``.
COMMANDS: tuple[str, ...] = ("open", "demo", "calibrate", "intersect", "measure", "project", "render", "bench",
                             "calibration", "plan", "video")
COMMANDS += ("batch",)
COMMANDS += ("calibration_views",)  # after "video": it adds the action `video calibration-views`
COMMANDS += ("target",)


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser, its usage errors printed as one line (``usvips COMMAND: error: …``, exit 2) like
    every other error; ``--help`` shows the usage."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {_one_line(message, 1000)} (--help shows the usage)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="usvips", description="USVIPS: measurement workstation for underwater stereo imagery.")
    parser.add_argument("--version", action="version", version=f"usvips {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    import importlib

    for name in COMMANDS:
        module = importlib.import_module(f"usvips.cli.{name}")
        module.register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = parser.parse_args(argv or ["open"])  # no arguments: the workstation window
    except SystemExit as stop:  # --help, --version, or a usage error already printed as one line
        return stop.code if isinstance(stop.code, int) else 0 if stop.code is None else 2
    handler: Callable[[argparse.Namespace], int] | None = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 0
    with warnings.catch_warnings():  # the caller's warning filters are back afterwards
        if not os.environ.get("USVIPS_DEBUG"):
            quiet_libraries()
        return _run(args, handler)


def _run(args: argparse.Namespace, handler: Callable[[argparse.Namespace], int]) -> int:
    """The command's handler, its errors as one line (see the module docstring)."""
    try:
        return int(handler(args) or 0)
    except UsvipsError as error:
        return _fail(args.command, str(error))
    except BrokenPipeError:  # output piped into a pager or head that closed early
        return 0
    except KeyboardInterrupt:
        print(f"usvips {args.command}: interrupted", file=sys.stderr)
        return 130
    except OSError as error:  # a file that cannot be read or written: named, one line
        return _fail(args.command, os_problem(error))
    except MemoryError:
        return _fail(args.command, "not enough memory for this input")
    except RecursionError:
        return _fail(args.command, "an input is nested too deeply")
    except Exception as error:  # a bug: one line saying so (USVIPS_DEBUG=1 shows the traceback)
        if os.environ.get("USVIPS_DEBUG"):
            raise
        print(f"usvips {args.command}: internal error: {type(error).__name__}: {_one_line(str(error))} "
              "(please report it; USVIPS_DEBUG=1 shows the details)", file=sys.stderr)
        return 70


def quiet_libraries() -> None:
    """Library and decoder chatter never reaches the terminal unasked (``USVIPS_DEBUG=1`` shows it): Python
    warnings of every kind (numpy's floating-point warnings on an absurd input value would print file and
    line above the one error line that names the input; results are checked for finiteness where made),
    OpenCV's own log lines and FFmpeg's (PyAV) decoder messages."""
    warnings.simplefilter("ignore")
    os.environ.setdefault("OPENCV_LOG_LEVEL", "OFF")  # for a cv2 imported after this
    if "cv2" in sys.modules:
        cv2 = sys.modules["cv2"]
        with contextlib.suppress(AttributeError):
            cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    if "av" in sys.modules:
        with contextlib.suppress(AttributeError):
            sys.modules["av"].logging.set_level(None)


def _one_line(text: str, limit: int = 300) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _fail(command: str, message: str) -> int:
    """Print one error line on stderr; exit status 2 (bad input or a file that cannot be used)."""
    print(f"usvips {command}: error: {_one_line(message, 1000)}", file=sys.stderr)
    return 2


def os_problem(error: OSError) -> str:
    """An operating-system error as one line naming the file: 'PATH: Permission denied'."""
    names = [str(n) for n in (error.filename, error.filename2) if n is not None]
    problem = error.strerror or str(error) or type(error).__name__
    return f"{' -> '.join(names)}: {problem}" if names else problem


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
