"""A calibration target named in words with its units, as the window and the reports show it wherever a
target is named: ``chessboard 9 × 6 inner corners, square 24.00 mm (54 points)``. A square typed wrong
scales every length the calibration measures, so its size is never left out."""

from __future__ import annotations

from usvips.core.calibration_targets import CalibrationTarget

#: the lengths of a description (metres in the file), in the order named, with their words
LENGTHS = (("square", "square"), ("marker", "marker"), ("spacing", "spacing"), ("diameter", "circles"),
           ("separation", "separation"), ("size", "marks"))


def target_words(target: CalibrationTarget) -> str:
    """The target's kind, its grid, every length of its description in millimetres and its point count."""
    try:
        described = target.describe()
    except NotImplementedError:  # a kind that cannot describe itself (not a registered kind): its name only
        described = {}
    parts = [str(described.get("kind", target.kind or type(target).__name__))]
    if "cols" in described and "rows" in described:
        corners = " inner corners" if described.get("kind") == "chessboard" else ""
        parts[0] += f" {described['cols']} × {described['rows']}{corners}"
    lengths = [f"{word} {1000 * float(described[key]):.2f} mm" for key, word in LENGTHS if key in described]
    points = len(target.control_points().ids)
    return ", ".join(parts + lengths) + f" ({points} points)"
