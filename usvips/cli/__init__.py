"""The ``usvips`` command line: argument parsing and printing only; the work is in core, io and store.

Each subcommand lives in its own module of this package and registers itself in ``COMMANDS``.
Errors of the :class:`~usvips.core.errors.UsvipsError` family print as one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from usvips import __version__
from usvips.core.errors import UsvipsError

#: (module name, description) of every subcommand; each module defines ``register(subparsers)``.
COMMANDS: tuple[str, ...] = ("open", "demo", "calibrate", "intersect", "measure", "project", "render", "bench",
                             "video")


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
    try:
        return int(handler(args) or 0)
    except UsvipsError as error:
        print(f"usvips {args.command}: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a pager or head that closed early
        return 0
    except KeyboardInterrupt:
        print(f"usvips {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
