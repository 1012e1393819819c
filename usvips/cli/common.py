"""Small helpers shared by subcommands: parsing ``name=value`` options, atomic output files."""

from __future__ import annotations

import argparse
import csv
import io
import math
from collections.abc import Callable

from usvips.cli import whole_number
from usvips.core.errors import InvalidParameterError
from usvips.core.plain_numbers import plain_number
from usvips.io.atomic import write_text_atomic

__all__ = ["add_annotator_option", "add_pointing_option", "csv_text", "parse_assignment", "parse_prior",
           "positive_number", "write_text_atomic"]


def add_annotator_option(parser) -> None:
    """``--annotator NAME`` on a command that writes objects: who is working, for this command (else
    ``$USVIPS_ANNOTATOR``, else the operating system's user name); ``usvips.cli.main`` applies it."""
    parser.add_argument("--annotator", metavar="NAME", help="who is annotating: stamped on what this command "
                        "writes and in the project's history (default: $USVIPS_ANNOTATOR, else your user name)")


def positive_number(not_a: str, must_be: str) -> Callable[[str], float]:
    """An argparse ``type``: a finite number > 0; else "'x' is not {not_a}" (not a number) or
    "must be {must_be}, got 'x'" (zero, negative, infinite, NaN)."""

    def parse(text: str) -> float:
        try:
            value = float(plain_number(text))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {not_a}") from None
        if not math.isfinite(value) or value <= 0:
            raise argparse.ArgumentTypeError(f"must be {must_be}, got {text!r}")
        return value

    return parse


def whole_number_from(least: int) -> Callable[[str], int]:
    """An argparse ``type``: a whole number from ``least`` to 2**63 − 1; else one line saying so."""

    def parse(text: str) -> int:
        try:  # (whole_number: the 64-bit bound of every int option)
            value = whole_number(text)
        except argparse.ArgumentTypeError:
            value = None
        if value is None or value < least:
            raise argparse.ArgumentTypeError(f"must be a whole number from {least} to 2**63 - 1, got {text!r}")
        return value

    return parse


#: the pointing precisions (px, one image coordinate) a pick may be given: finer than a thousandth of a pixel
#: no image point is found (and the weights of the intersection underflow); coarser than 1000 px it is no pick
POINTING_SIGMA_RANGE_PX = (1e-3, 1e3)


_positive_pixels = positive_number("a number of pixels", "a finite number of pixels > 0")


def _pointing_sigma(text: str) -> float:
    value = _positive_pixels(text)
    least, most = POINTING_SIGMA_RANGE_PX
    if not least <= value <= most:
        raise argparse.ArgumentTypeError(f"must be {least:g} to {most:g} pixels (a pick's pointing precision), "
                                         f"got {text!r}")
    return value


def add_pointing_option(parser) -> None:
    """``--pointing-sigma PX`` on a command that measures picks: their pointing precision (pixels, one image
    coordinate); without it, the documented default of a hand click (``usvips.core.pointing``)."""
    parser.add_argument("--pointing-sigma", metavar="PX", type=_pointing_sigma,
                        help="pointing precision of the picks (pixels, one image coordinate); default: the "
                             "hand-click default, said in the output")


def parse_assignment(option: str, text: str) -> tuple[str, float]:
    """``name=value`` → (name, value)."""
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise InvalidParameterError(option, f"expected NAME=VALUE, got {text!r}")
    try:
        number = float(plain_number(value))
    except ValueError:
        raise InvalidParameterError(option, f"{text!r}: {value!r} is not a number") from None
    if not math.isfinite(number):
        raise InvalidParameterError(option, f"{text!r}: the value must be a finite number")
    return name.strip(), number


def parse_prior(text: str) -> tuple[str, tuple[float, float]]:
    """``name=value:sigma`` → (name, (value, sigma))."""
    name, sep, rest = text.partition("=")
    value, sep2, sigma = rest.partition(":")
    if not sep or not sep2 or not name:
        raise InvalidParameterError("--prior", f"expected NAME=VALUE:SIGMA, got {text!r}")
    try:
        numbers = float(plain_number(value)), float(plain_number(sigma))
    except ValueError:
        raise InvalidParameterError("--prior", f"{text!r}: value and sigma must be numbers") from None
    if not all(math.isfinite(n) for n in numbers):
        raise InvalidParameterError("--prior", f"{text!r}: value and sigma must be finite numbers")
    if not numbers[1] > 0:
        raise InvalidParameterError("--prior", f"{text!r}: the sigma must be > 0")
    return name.strip(), numbers


def csv_text(header: list[str], rows: list[list]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()
