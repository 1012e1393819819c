"""The ``usvips`` command line: argument parsing and printing only; the work is in core, io and store.

Each subcommand lives in its own module of this package and registers itself in ``COMMANDS``.
Errors of the :class:`~usvips.core.errors.UsvipsError` family and operating-system errors (a file that
cannot be read or written) print as one line on stderr, exit 2; an unexpected exception (a bug) prints
one line too and exits 70, or shows its traceback with ``USVIPS_DEBUG=1``.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Callable, Sequence

from usvips import __version__
from usvips.core.errors import UsvipsError

#: (module name, description) of every subcommand; each module defines ``register(subparsers)``.
COMMANDS: tuple[str, ...] = ("open", "demo", "calibrate", "intersect", "measure", "project", "render", "bench",
                             "calibration", "plan", "video")
COMMANDS += ("batch",)
COMMANDS += ("calibration_views",)  # after "video": it adds the action `video calibration-views`
COMMANDS += ("target",)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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
    args = parser.parse_args(argv or ["open"])  # no arguments: the workstation window
    handler: Callable[[argparse.Namespace], int] | None = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 0
    if not os.environ.get("USVIPS_DEBUG"):
        # numpy's floating-point warnings (an overflow on an absurd input value) would print file and line
        # above the one-line error that names the input; results are checked for finiteness where made
        warnings.simplefilter("ignore", RuntimeWarning)
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
