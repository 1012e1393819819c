"""The precision planner's map as a picture (PNG, PDF or SVG by the extension), matplotlib without pyplot.

Two panels over across position × range (metres): the point's total sigma (root of the sum of its three
variances) and the RMS over orientations of a length's sigma, in millimetres, blank where the two cameras
do not both see the position. Written atomically.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from usvips.core.errors import InvalidParameterError
from usvips.core.planner import PrecisionMap
from usvips.io.atomic import write_bytes_atomic

FORMATS = (".png", ".pdf", ".svg")


def write_plan_figure(plan: PrecisionMap, out: str | Path, title: str = "") -> None:
    """Draw both maps of ``plan`` into ``out`` (.png, .pdf or .svg)."""
    out = Path(out)
    if out.suffix.lower() not in FORMATS:
        raise InvalidParameterError("out", f"{out}: the picture's extension must be one of {', '.join(FORMATS)}",
                                    label="output")
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise InvalidParameterError("out", f"{out}: the folder {folder} does not exist", label="output")
    figure = Figure(figsize=(11, 5.2))
    FigureCanvasAgg(figure)
    total = np.sqrt(np.sum(plan.point_sigma ** 2, axis=-1)) * 1e3
    panels = ((total, "point: total sigma (mm)"),
              (plan.length_rms * 1e3, f"{plan.length:g} m length, any orientation: RMS sigma (mm)"))
    for k, (values, label) in enumerate(panels):
        axes = figure.add_subplot(1, 2, k + 1)
        masked = np.ma.masked_invalid(np.where(plan.visible, values, np.nan))
        mesh = axes.pcolormesh(plan.across, plan.ranges, masked, shading="nearest", cmap="viridis")
        figure.colorbar(mesh, ax=axes, label=label)
        if masked.count() > 3 and len(plan.across) > 1 and len(plan.ranges) > 1:
            contours = axes.contour(plan.across, plan.ranges, masked, levels=6, colors="white", linewidths=0.6)
            axes.clabel(contours, fontsize=7, fmt="%.3g")
        axes.set_xlabel("across (m, along the baseline from its middle)")
        axes.set_ylabel("range (m, from the middle of the baseline)")
        axes.set_title(label, fontsize=10)
    calibration_part = "with the calibration's own uncertainty" if plan.with_calibration else "pointing only"
    figure.suptitle(f"{title}  sigma0 {plan.sigma_px:.3g} px, {calibration_part}, height {plan.height:g} m",
                    fontsize=10)
    buffer = io.BytesIO()
    figure.savefig(buffer, format=out.suffix.lower().lstrip("."), dpi=110)
    write_bytes_atomic(out, buffer.getvalue())
