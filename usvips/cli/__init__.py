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
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import NoReturn

from usvips import __version__
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.plain_numbers import plain_number
from usvips.core.redaction import redact

#: (module name, description) of every subcommand; each module defines ``register(subparsers)``.
COMMANDS: tuple[str, ...] = ("open", "demo", "calibrate", "intersect", "measure", "project", "render", "bench",
                             "calibration", "plan", "video")
COMMANDS += ("batch",)
COMMANDS += ("calibration_views",)  # after "video": it adds the action `video calibration-views`
COMMANDS += ("target",)
COMMANDS += ("target_field",)  # after "target": it adds the action `target field`
COMMANDS += ("species",)
COMMANDS += ("detect",)

#: modules that add actions to another command's parser (imported whenever that command is)
EXTENDS: dict[str, str] = {"calibration_views": "video", "target_field": "target"}

#: each subcommand's line in ``usvips --help``, so that the overview imports no subcommand's module (each
#: imports numpy, OpenCV, SciPy ...: over 0.5 s of CPU all together); a test keeps these equal to the
#: modules' own ``help``
SUMMARIES: dict[str, str] = {
    "open": "the workstation window, optionally on a project or sample",
    "demo": "calibrate a sample project and intersect its check points (headless)",
    "calibrate": "calibrate a stereo rig (phase 1 in air, phase 2 underwater)",
    "intersect": "intersect conjugate pixels: id,X,Y,Z,sX,sY,sZ (metres)",
    "measure": "measure objects from picks: figures with sigmas (CSV), optionally stored in a project",
    "project": "create, inspect, import into and export from a project file",
    "render": "render a sample project from a scene description, or board views through a housing (--target) "
              "to rehearse a calibration",
    "bench": "measure speed as ratios against baselines timed in the same run (JSON)",
    "calibration": "import, export or report a calibration",
    "plan": "map the expected sigma of a point and a length (precision planner)",
    "video": "synchronise a stereo video, set its offset, export a frame pair",
    "batch": "run a task over many pairs or projects on every core",
    "target": "calibration targets: describe, print, detect, find a 3-D field from a few clicks",
    "species": "import or list a project's species list (and maximum lengths)",
    "detect": "propose fish with a detection model: paired through the housing, stored as unreviewed objects",
}


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser, its usage errors printed as one line (``usvips COMMAND: error: …``, exit 2) like
    every other error; ``--help`` shows the usage."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {_one_line(_unrecognized(message), 1000)} (--help shows the usage)\n")


def build_parser(command: str | None = "*") -> argparse.ArgumentParser:
    """The parser. ``command``: the subcommand about to run — only its module (and those that extend it,
    :data:`EXTENDS`) is imported, the others are listed by their :data:`SUMMARIES`; None: none (the
    overview, ``usvips --help``); ``"*"``: all."""
    parser = OneLineParser(
        prog="usvips", description="USVIPS: measurement workstation for underwater stereo imagery.")
    parser.add_argument("--version", action="version", version=f"usvips {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    import importlib

    for name in COMMANDS:
        extended = EXTENDS.get(name)
        if command == "*" or name == command or (extended is not None and extended == command):
            importlib.import_module(f"usvips.cli.{name}").register(subparsers)
        elif extended is None:
            subparsers.add_parser(name, help=SUMMARIES[name] or None, add_help=False)
    _bound_whole_numbers(parser)
    return parser


#: the largest whole number an option takes (a 64-bit integer: what the project store and numpy hold)
LARGEST_WHOLE = 2**63 - 1


def whole_number(text: str) -> int:
    """An option's whole number (``type=int``), refused when it is no 64-bit integer (a count, an id or a
    seed of 30 digits is a typing slip, and would overflow the store or numpy)."""
    try:
        value = plain_number(text, int)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if abs(value) > LARGEST_WHOLE:
        raise argparse.ArgumentTypeError(f"{text} is too large (at most {LARGEST_WHOLE:.3g} either way)")
    return value


def plain_float(text: str) -> float:
    """An option's number (``type=float``) in ASCII digits (:mod:`usvips.core.plain_numbers`)."""
    try:
        return float(plain_number(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def _bound_whole_numbers(parser: argparse.ArgumentParser) -> None:
    """Every ``type=int`` option of ``parser`` and its subcommands read by :func:`whole_number`, every
    ``type=float`` one by :func:`plain_float`."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _bound_whole_numbers(sub)
        elif action.type is int:
            action.type = whole_number
        elif action.type is float:
            action.type = plain_float


def _command_in(argv: Sequence[str]) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not an option), if it is one."""
    first = next((word for word in argv if not word.startswith("-")), None)
    return first if first in SUMMARIES else None


def main(argv: Sequence[str] | None = None) -> int:
    brief_blas_spin()  # before any command's module imports numpy
    argv = list(sys.argv[1:] if argv is None else argv) or ["open"]  # no arguments: the workstation window
    parser = build_parser(_command_in(argv))
    try:
        with _redacted_output():  # a usage error quotes what was typed: a server URL's password too
            args = parser.parse_args(argv)
    except SystemExit as stop:  # --help, --version, or a usage error already printed as one line
        return stop.code if isinstance(stop.code, int) else 0 if stop.code is None else 2
    handler: Callable[[argparse.Namespace], int] | None = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 0
    with warnings.catch_warnings(), _redacted_output(), _terminated_as_interrupted(args):
        if not os.environ.get("USVIPS_DEBUG"):  # (the caller's warning filters are back afterwards)
            quiet_libraries()
        return _run(args, handler, _options_of(parser, argv))


@contextlib.contextmanager
def _terminated_as_interrupted(args: argparse.Namespace) -> Iterator[None]:
    """A SIGTERM (``kill``, a job's time limit) ends a command as Ctrl+C does: the interruption unwinds it, so
    what it was writing into a staging folder or temporary file is removed on the way out rather than left
    beside its output. Not for the window (``open``: Qt ends it) nor off the main thread (where Python lets no
    handler be set); the handler before is restored."""
    if getattr(args, "command", "") == "open" or threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame) -> None:
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


#: unit suffixes a parameter's name may carry beyond its option's (``max_blur_px`` is ``--max-blur``)
UNIT_SUFFIXES = ("px", "s", "m", "mm", "deg", "frames")


def _options_of(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> dict[str, str]:
    """Every option of ``parser`` and of the subcommands ``argv`` chose (all loaded ones without
    ``argv``): its destination → its long option string."""
    options: dict[str, str] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            words = list(argv) if argv is not None else None
            chosen = next((i for i, word in enumerate(words) if word in action.choices), None) \
                if words is not None else None
            if words is None:
                for sub in action.choices.values():
                    options.update(_options_of(sub))
            elif chosen is not None:
                options.update(_options_of(action.choices[words[chosen]], words[chosen + 1:]))
        elif action.option_strings:
            options.setdefault(action.dest, max(action.option_strings, key=len))
    return options


def _in_option_terms(error: UsvipsError, options: dict[str, str], named: dict[str, str] | None = None) -> str:
    """An error about a setting (``error.parameter``) said with the option that sets it: an invalid value
    named as the option the user typed (``--max-views: must be …``), any other error followed by its option
    (``… (set it with --pair)``). The option is the command's own word for the library's name (``named``: a
    command's ``parameter_options``) or an option of that name (``max_blur_px`` is ``--max-blur``);
    without one, the error as the library says it."""
    name = error.parameter
    if name is None:
        return str(error)
    if named and name in named:
        option = named[name]
    else:
        candidates = [name] + [name.removesuffix("_" + unit) for unit in UNIT_SUFFIXES if name.endswith("_" + unit)]
        option = next((options[c] for c in candidates if c in options), None)
    if option is not None and isinstance(error, InvalidParameterError) and not error.label:
        return f"{option}: {error.problem}"
    replace = options.get(getattr(error, "replace_parameter", None) or "")
    hints = ([f"set it with {option}"] if option else []) + ([f"{replace} replaces it"] if replace else [])
    return f"{error} ({'; '.join(hints)})" if hints else str(error)


class RedactedStream:
    """A text stream whose every write passes :func:`usvips.core.redaction.redact` (no password reaches a
    terminal, a pipe or a log file: results, progress lines, errors of every command); the rest of the
    stream (``isatty``, ``buffer``, ``flush`` …) is the wrapped one's."""

    def __init__(self, stream) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        self._stream.write(redact(text))
        return len(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


@contextlib.contextmanager
def _redacted_output():
    """Every line a command prints, on stdout and stderr, redacted (see :class:`RedactedStream`)."""
    with contextlib.redirect_stdout(RedactedStream(sys.stdout)), contextlib.redirect_stderr(RedactedStream(sys.stderr)):
        yield


def _run(args: argparse.Namespace, handler: Callable[[argparse.Namespace], int],
         options: dict[str, str] | None = None) -> int:
    """The command's handler, its errors as one line (see the module docstring)."""
    try:
        from usvips.store.annotator import annotating_as  # --annotator of a writing command (cli/common.py)

        with annotating_as(getattr(args, "annotator", None)):
            return int(handler(args) or 0)
    except UsvipsError as error:
        return _fail(args.command, _in_option_terms(error, options or {}, getattr(args, "parameter_options", None)))
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
        if isinstance(error.__cause__ or error.__context__, KeyboardInterrupt):  # raised inside compiled code
            print(f"usvips {args.command}: interrupted", file=sys.stderr)
            return 130
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


#: how long OpenBLAS's idle worker threads busy-wait for work before they sleep, as log2 of CPU cycles
#: (OpenBLAS's ``OPENBLAS_THREAD_TIMEOUT``, 4–30; its default, 28, is 0.1 s at 2.6 GHz; 20 is 0.4 ms)
BLAS_SPIN_LOG2_CYCLES = 20
#: the environment variable OpenBLAS reads :data:`BLAS_SPIN_LOG2_CYCLES` from when it is loaded
BLAS_SPIN_VARIABLE = "OPENBLAS_THREAD_TIMEOUT"


def brief_blas_spin() -> None:
    """OpenBLAS's idle threads busy-wait for :data:`BLAS_SPIN_LOG2_CYCLES`, not for 0.1 s, unless the
    environment says otherwise; read by each OpenBLAS loaded afterwards (numpy's, OpenCV's and SciPy's
    each bring their own), so it is set before any command imports numpy.

    Each OpenBLAS starts a worker thread per further core when it is loaded, and a worker that runs out of
    work busy-waits for 2**28 cycles (0.1 s here) before it sleeps: once after it is made, again after every
    call that used it. Where a core is idle that is CPU time burnt for nothing: the window's start
    (``usvips open SAMPLE`` until its first pair is drawn, 0.45 s of CPU on its own thread) spent 0.10 s
    more in each of two such threads (numpy's and OpenCV's), and how much of it a start paid depended on
    whether the machine's other core was free (the start's CPU swung between 0.5 and 0.8 s with what
    else ran). With 2**20 cycles the threads still work in parallel and calls in quick succession still
    find them awake (a loop of 128 × 128 and 300 × 300 products and solves ran as fast as with the
    default); with 2**4 the 128 × 128 loop took twice as long."""
    os.environ.setdefault(BLAS_SPIN_VARIABLE, str(BLAS_SPIN_LOG2_CYCLES))


#: how many unrecognised words an error names before it counts the rest
SHOWN_UNRECOGNIZED = 3


def _unrecognized(message: str) -> str:
    """argparse's 'unrecognized arguments: a b c …' shortened to the first few and a count; when they look
    like files (an unquoted pattern the shell expanded after an option that takes one value), say so."""
    head = "unrecognized arguments: "
    if not message.startswith(head):
        return message
    words = message[len(head):].split()
    if len(words) <= SHOWN_UNRECOGNIZED:
        return message
    shown = " ".join(words[:SHOWN_UNRECOGNIZED]) + f" … ({len(words) - SHOWN_UNRECOGNIZED} more)"
    files = sum(1 for word in words if "." in word.rsplit("/", 1)[-1] and not word.startswith("-"))
    hint = ("; they look like files: the shell expanded a pattern — quote it ('*.png') so that USVIPS "
            "expands it" if files > len(words) // 2 else "")
    return f"{len(words)} {head}{shown}{hint}"


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
