"""A figure's sigma broken down, as every place that shows or exports a figure shows it.

The breakdown is computed once, with the figure (:func:`usvips.core.measurements.figures.figures_of`:
the pointing share and the calibration's share of the sigma, from one Jacobian; they add in variance).
This module only reads it out of a :class:`~usvips.core.measurements.Measurement`, for a table
(:func:`breakdown_cells`, the columns :data:`BREAKDOWN_COLUMNS`) and for a person (:func:`breakdown_text`,
the window's readout and the object list's tooltip; :func:`sigma_notes`, the facts a reader of the sigma
must see: a default pointing sigma of unknown source, an assumed σ0, a calibration without covariance).
Nothing here is Qt: the window, the command line and the exports call the same functions.
"""

from __future__ import annotations

import numpy as np

from usvips.core.measurements.evaluate import Measurement
from usvips.core.measurements.figures import Figure

#: the export columns of the main figure's breakdown: its sigma's pointing share and calibration share
#: (the figure's unit), the vertices' pointing sigma (px, one coordinate: their mean, and min-max when they
#: differ), its origin, and the notes on the sigma (";"-joined)
BREAKDOWN_COLUMNS = ["sigma_pointing", "sigma_calibration", "pointing_sigma_px", "pointing_origin", "sigma_notes"]

#: display scale and unit of a figure unit (mm for metres)
_SHOWN = {"m": (1000.0, "mm"), "m²": (1e6, "mm²"), "rad": (180.0 / np.pi, "°"), "1": (1.0, "")}


def pointing_px_text(m: Measurement) -> str:
    """The vertices' pointing sigma (px): "0.5" or "0.3-0.8" (min-max); "" when unknown (stored values)."""
    sigma = m.pointing_sigma_px
    if sigma is None or np.size(sigma) == 0:
        return ""
    low, high = float(np.min(sigma)), float(np.max(sigma))
    return f"{low:.3g}" if np.isclose(low, high) else f"{low:.3g}-{high:.3g}"


def sigma_notes(m: Measurement) -> tuple[str, ...]:
    """What a reader of ``m``'s sigmas must know, one sentence each: its marks (an assumed σ0, a calibration
    without covariance, a default pointing sigma for vertices of unknown source), and when its sigmas come
    from stored per-vertex values, that no breakdown is known."""
    notes = list(m.marks)
    if m.pointing_sigma_px is None:
        notes.append("from stored per-vertex values: no breakdown")
    elif m.combined:
        notes.append(f"combined over {m.instant_count} instants: each instant has its own breakdown")
    return tuple(notes)


def breakdown_cells(m: Measurement, figure: Figure | None = None) -> dict[str, object]:
    """The :data:`BREAKDOWN_COLUMNS` of ``figure`` (default: the main one) of ``m``: shares in the figure's
    unit (None when unknown), pointing sigma text (px), its origin and the notes."""
    figure = figure or m.main
    return {"sigma_pointing": figure.sigma_pointing, "sigma_calibration": figure.sigma_calibration,
            "pointing_sigma_px": pointing_px_text(m), "pointing_origin": m.pointing_origin,
            "sigma_notes": "; ".join(sigma_notes(m))}


def _shown(value: float, unit: str) -> str:
    scale, shown = _SHOWN.get(unit, (1.0, unit))
    return f"{value * scale:.3g}" + (f" {shown}" if shown else "")


def breakdown_text(m: Measurement, figure: Figure | None = None) -> str:
    """How a person reads ``figure``'s sigma (default: the main one): "± 9.0 mm = pointing 7.1 mm ⊕
    calibration 5.6 mm (pointing σ 0.5 px, default)", then the notes, one per line."""
    figure = figure or m.main
    text = f"± {_shown(figure.sigma, figure.unit)}"
    if figure.sigma_pointing is not None and figure.sigma_calibration is not None:
        text += (f" = pointing {_shown(figure.sigma_pointing, figure.unit)} ⊕ calibration "
                 f"{_shown(figure.sigma_calibration, figure.unit)}")
    pixels = pointing_px_text(m)
    if pixels:
        text += f" (pointing σ {pixels} px, {m.pointing_origin or 'default'})"
    return "\n".join([text, *sigma_notes(m)])
