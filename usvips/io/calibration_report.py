"""The printable calibration report (PDF): what a survey archives with its data.

Pages: summary and provenance (phase, housing, stations, sigma0, RMS, redundancy, global test, condition,
the data files with their SHA-256); the parameters with sigmas and status; the correlation matrix of the
free parameters and the pairs above 0.9; residual vectors per image; residual histograms against the
a-posteriori sigma0; the check-point table (intersected with the calibration, differences against the
control with their predicted sigmas).

Why matplotlib's PDF backend: the command is headless and Qt-free (the CLI must not load Qt, see the
import-linter contracts), matplotlib writes vector PDF directly with no external program (no LaTeX, no
browser engine for an HTML route), and its quiver and histogram plots are the figures we need. We use
``Figure`` objects with ``PdfPages``, never ``pyplot``, so no global backend or GUI state is touched.

Residuals are v = observed − computed (pixels), computed with the calibration model's own evaluation
(``core/calibration/model.StereoModel``), the one the adjustment used.
"""

from __future__ import annotations

import contextlib
import datetime
import hashlib
import io
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from usvips import __version__
from usvips.core.calibration.figures import parameter_table
from usvips.core.calibration.model import StereoModel
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.calibration_views import DEFAULT_GRID, covered_cells
from usvips.core.errors import UsvipsError, concerning
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.atomic import write_bytes_atomic
from usvips.io.tables import read_control, read_observations

A4 = (8.27, 11.69)  # inches, portrait
LINES_PER_PAGE = 62
UNITS = {"f": "px", "xp": "px", "yp": "px", "sy": "", "k1": "", "k2": "", "k3": "", "p1": "", "p2": "",
         "X0": "m", "Y0": "m", "Z0": "m", "omega": "rad", "phi": "rad", "kappa": "rad", "a": "m", "b": "m",
         "c": "m", "r": "m", "d": "", "e": "", "g": "m", "t": "m", "n2": "", "n3": "", "X": "m", "Y": "m", "Z": "m"}


@dataclass
class ReportData:
    """The data a calibration was computed from, found through its ``source`` (None where not found)."""

    control: ControlPoints | None
    observations: StereoObservations | None
    files: list[tuple[str, str, str]]  # (role, path read (or as recorded), SHA-256 or why it is missing)


@dataclass
class Residuals:
    """v = observed − computed per observation (pixels): ids, station, side ('l'/'r'), observed pixel
    (N, 2), residual (N, 2), used (N,): False where the adjustment excluded a coordinate (a blunder)."""

    ids: list[str]
    station: list[str]
    side: list[str]
    observed: np.ndarray
    residual: np.ndarray
    used: np.ndarray


@dataclass
class CheckPoints:
    """Check points intersected with the calibration: ids, difference computed − control (N, 3, metres),
    predicted sigma (N, 3, metres: pointing and the calibration's own uncertainty)."""

    ids: list[str]
    difference: np.ndarray
    sigma: np.ndarray


def resolve_recorded(recorded: str, base: Path | None) -> Path | str:
    """A recorded data path, or why it is not read. A path inside a file is information, not an
    instruction: it is opened only inside the calibration file's own folder (as recorded relative to it,
    else by its name beside the file); an absolute path, one leading out of that folder (``../../etc/passwd``)
    or through a link out of it, is shown unread."""
    if base is None:
        return "no calibration file to look beside: not read"
    if any(c in recorded for c in ("\x00", "\n", "\r")):
        return "not a file name: not read"
    folder = base.resolve()
    candidates = [base / recorded, base / Path(recorded).name]  # an absolute ``recorded`` stays itself
    for candidate in candidates:
        try:
            real = candidate.resolve()
        except (OSError, RuntimeError, ValueError):
            continue
        if real.is_relative_to(folder) and real.is_file():
            return real
    with contextlib.suppress(OSError, RuntimeError, ValueError):
        if not (base / recorded).resolve().is_relative_to(folder):
            return "outside the calibration file's folder: shown, not read"
    return "not found beside the calibration file: not used in this report"


def sha256_of(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def find_data(calibration: StereoCalibration, calibration_path: str | Path | None) -> ReportData:
    """Control and observations of the calibration's ``source``, read only inside the calibration file's
    folder (:func:`resolve_recorded`); the others are listed with why they were not read."""
    base = Path(calibration_path).parent if calibration_path else None
    files, control, observations = [], None, None
    for role in ("control", "observations", "base"):
        recorded = calibration.source.get(role)
        if not isinstance(recorded, str):
            continue
        path = resolve_recorded(recorded, base)
        if isinstance(path, str):
            files.append((role, recorded, path))
            continue
        files.append((role, str(path), sha256_of(path)))
        if role == "control":
            control = read_control(path)
        elif role == "observations":
            observations = read_observations(path)
    return ReportData(control, observations, files)


def calibration_residuals(calibration: StereoCalibration, control: ControlPoints,
                          observations: StereoObservations) -> Residuals:
    """Residuals of the calibration's own observations, v = observed − computed (pixels), by the model's
    evaluation at the calibration's parameter values. Observations of pairs the calibration does not hold
    are left out."""
    values = {name: p.value for name, p in calibration.parameters.items()}
    if not values:
        raise UsvipsError("the calibration carries no parameters (imported?): its residuals cannot be recomputed")
    labels = set(calibration.stations)
    if not observations.pairs:
        observations = StereoObservations(observations.ids, observations.left, observations.right,
                                          (calibration.stations[0],) * len(observations.ids))
    keep = np.array([p in labels for p in observations.pairs])
    if not keep.any():
        raise UsvipsError(f"none of the observations belongs to the calibrated pairs {sorted(labels)}")
    observations = observations.take(np.flatnonzero(keep))
    model = StereoModel(calibration.left.housing.kind, control, observations, calibration.sigma0_px,
                        (calibration.left.width, calibration.left.height))
    if model.stations != calibration.stations:
        raise UsvipsError(f"the observations' pairs {list(model.stations)} are not the calibration's "
                          f"{list(calibration.stations)}")
    computed, ok = model.evaluate(values)
    observed = model.observation_set.values
    residual = np.where(ok, observed - computed, np.nan).reshape(-1, 2)
    obs = model.observation_set
    excluded = {(str(e.get("point")), str(e.get("side")), str(e.get("group")))
                for e in calibration.statistics.get("excluded") or [] if isinstance(e, dict)}
    used = np.array([(p, s, g) not in excluded for p, s, g in zip(obs.point[0::2], obs.side[0::2], obs.group[0::2],
                                                                   strict=True)], dtype=bool)
    return Residuals(obs.point[0::2], obs.group[0::2], obs.side[0::2], observed.reshape(-1, 2), residual, used)


def check_points(calibration: StereoCalibration, control: ControlPoints, observations: StereoObservations,
                 station: int | str = 0) -> CheckPoints:
    """Intersect check observations with the calibration and compare with the control coordinates."""
    index = control.index_of(list(observations.ids), "check point")
    result = intersect_with_calibration(calibration, observations.left, observations.right, station)
    difference = np.where(result.ok[:, None], result.points - control.xyz[index], np.nan)
    sigma = np.sqrt(np.einsum("nii->ni", result.covariance))
    return CheckPoints(list(observations.ids), difference, np.where(result.ok[:, None], sigma, np.nan))


# ------------------------------------------------------------------------------------------ pages
def _text_page(pdf: PdfPages, title: str, lines: list[str]) -> None:
    for start in range(0, max(len(lines), 1), LINES_PER_PAGE):
        figure = Figure(figsize=A4)
        figure.text(0.07, 0.96, title + ("" if start == 0 else " (continued)"), fontsize=13, weight="bold")
        figure.text(0.07, 0.93, "\n".join(lines[start:start + LINES_PER_PAGE]), family="monospace", fontsize=7.2,
                    va="top")
        pdf.savefig(figure)


def _summary_lines(calibration: StereoCalibration, data: ReportData, calibration_path) -> list[str]:
    stats = calibration.statistics
    lines = [f"calibration file : {calibration_path or '(in memory)'}",
             f"phase            : {calibration.phase}",
             f"housing          : {calibration.left.housing.kind}",
             f"stations (pairs) : {', '.join(calibration.stations)}",
             f"image size       : {calibration.left.width} x {calibration.left.height} px"
             if calibration.left.width else "image size       : not recorded",
             f"sigma0           : {calibration.sigma0_px:.4f} px (a posteriori)"]
    for key, label, unit in (("sigma_px_a_priori", "sigma a priori   ", " px"), ("rms_px", "RMS residual     ", " px"),
                             ("redundancy", "redundancy       ", ""), ("iterations", "iterations       ", ""),
                             ("converged", "converged        ", ""), ("condition_number", "condition number ", "")):
        if key in stats:
            value = stats[key]
            lines.append(f"{label}: {value:.4g}{unit}" if isinstance(value, float) else f"{label}: {value}{unit}")
    estimation = stats.get("estimation")
    if isinstance(estimation, dict) and estimation.get("estimator"):
        lines.append(f"estimator        : {estimation['estimator']}"
                     + (f" (tuning {estimation['tuning']:g}, robust scale {estimation['robust_scale']:.3g})"
                        if isinstance(estimation.get("tuning"), float | int)
                        and isinstance(estimation.get("robust_scale"), float | int) else ""))
    test = stats.get("global_test")
    if isinstance(test, dict) and "chi2" in test:
        passed = test.get("accepted_95")
        lines.append(f"global test      : chi2 = {test['chi2']:.2f} on {test.get('redundancy')} d.o.f., "
                     f"95 % interval {test.get('interval_95')}: "
                     + ("passed" if passed else "rejected" if passed is not None else "not decided"))
        # what it means, in words (a rejected test is not a failed calibration: sigmas are rescaled)
        for text in (test.get("verdict"), "rejected means the residuals are not the size the pointing sigma "
                     "assumed; every sigma is scaled by sigma0 all the same" if passed is False else None):
            for line in textwrap.wrap(text or "", 96):
                lines.append(f"                   {line}")
    excluded = stats.get("excluded") or []
    lines.append(f"excluded obs.    : {len(excluded)}")
    for item in excluded[:20]:
        lines.append(f"   {item.get('point')} {item.get('side')} {item.get('coordinate')} pair {item.get('group')}: "
                     f"{item.get('reason', '')}"[:110])
    lines += ["", "DATA USED AND PROVENANCE"]
    if not data.files and not calibration.source:
        lines.append("  the calibration records no data files (e.g. imported from OpenCV)")
    for role, recorded, digest in data.files:
        lines.append(f"  {role:<13}: {recorded}")
        lines.append(f"  {'':<13}  sha256 {digest}")
    if data.control is not None:
        lines.append(f"  control points: {len(data.control.ids)}"
                     + (" (with sigmas)" if data.control.sigmas is not None else ""))
    if data.observations is not None:
        lines.append(f"  observations  : {len(data.observations.ids)} conjugate pairs of pixels")
    for key, value in calibration.source.items():
        if key not in ("control", "observations", "base"):
            lines.append(f"  source {key}: {value}"[:110])
    lines += ["", f"report written by USVIPS {__version__} on "
              f"{datetime.datetime.now(datetime.UTC).strftime('%Y-%m-%d %H:%M UTC')}"]
    return lines


def _figure_lines(calibration: StereoCalibration) -> list[str]:
    """The figures a colleague checks first (:func:`~usvips.core.calibration.figures.parameter_table`):
    value ± sigma with units, grouped by camera, rig and housing."""
    lines, group = [], None
    for figure in parameter_table(calibration):
        if figure.group != group:
            lines += ["", figure.group.upper()]
            group = figure.group
        lines.append(f"  {figure.label[:44]:<46}{figure.text()}")
    return lines


def _parameter_lines(calibration: StereoCalibration) -> list[str]:
    lines = _figure_lines(calibration)[1:] + ["", "EVERY PARAMETER (the exterior of every station included)",
                                              f"{'parameter':<22}{'value':>20}{'sigma':>14}  {'unit':<5}{'status':<8}",
                                              "-" * 72]
    for name, estimate in calibration.parameters.items():
        unit = UNITS.get(name.split("@")[0].rsplit("_", 1)[0] if "_" in name.split("@")[0] else name.split("@")[0],
                         "")
        sigma = "" if estimate.sigma is None else f"{estimate.sigma:.6g}"
        lines.append(f"{name:<22}{estimate.value:>20.10g}{sigma:>14}  {unit:<5}{estimate.status:<8}")
    if not calibration.parameters:
        lines.append("(no parameters recorded)")
    lines += ["", "free: estimated; prior: estimated with a prior value and sigma; fixed: held (no sigma)."]
    return lines


def correlation_matrix(calibration: StereoCalibration) -> tuple[list[str], np.ndarray] | None:
    """Correlations of the free parameters from the calibration's covariance (None without one)."""
    if calibration.covariance is None:
        return None
    names, covariance = calibration.covariance
    covariance = np.asarray(covariance, dtype=np.float64)
    sigma = np.sqrt(np.clip(np.diag(covariance), 1e-300, None))
    return list(names), covariance / np.outer(sigma, sigma)


def _correlation_page(pdf: PdfPages, calibration: StereoCalibration) -> None:
    figure = Figure(figsize=A4)
    figure.text(0.07, 0.96, "Correlations of the free parameters", fontsize=13, weight="bold")
    found = correlation_matrix(calibration)
    if found is None:
        figure.text(0.07, 0.9, "The calibration carries no covariance.", fontsize=10)
        pdf.savefig(figure)
        return
    names, corr = found
    axes = figure.add_axes((0.17, 0.38, 0.7, 0.52))
    image = axes.imshow(corr, vmin=-1, vmax=1, cmap="RdBu_r")
    size = 6 if len(names) <= 40 else 4
    axes.set_xticks(range(len(names)), names, rotation=90, fontsize=size)
    axes.set_yticks(range(len(names)), names, fontsize=size)
    figure.colorbar(image, ax=axes, fraction=0.04)
    upper = [(abs(corr[i, j]), names[i], names[j], corr[i, j]) for i in range(len(names))
             for j in range(i + 1, len(names)) if abs(corr[i, j]) > 0.9]
    upper.sort(reverse=True)
    text = [f"{len(upper)} pairs with |r| > 0.9" + (" (the strongest 24):" if len(upper) > 24 else ":")]
    text += [f"  {a:<18} {b:<18} r = {r:+.3f}" for _, a, b, r in upper[:24]]
    figure.text(0.07, 0.3, "\n".join(text), family="monospace", fontsize=7, va="top")
    pdf.savefig(figure)


def _residual_pages(pdf: PdfPages, calibration: StereoCalibration, residuals: Residuals) -> None:
    width = calibration.left.width or float(np.nanmax(residuals.observed[:, 0])) + 1
    height = calibration.left.height or float(np.nanmax(residuals.observed[:, 1])) + 1
    finite = np.isfinite(residuals.residual).all(axis=1) & residuals.used
    longest = float(np.max(np.hypot(*residuals.residual[finite].T))) if finite.any() else 1.0
    scale = 0.08 * max(width, height) / max(longest, 1e-9)  # drawn length per pixel of residual
    stations = list(dict.fromkeys(residuals.station))
    for start in range(0, len(stations), 2):
        figure = Figure(figsize=A4)
        figure.text(0.07, 0.96, "Residual vectors per image (v = observed − computed)", fontsize=13, weight="bold")
        figure.text(0.07, 0.945, f"arrows drawn {scale:.3g} × their length in pixels; the frame is the image "
                    f"({width} × {height} px, y down);\nx: observations the adjustment excluded (not drawn, not in "
                    "the RMS)", fontsize=8, va="top")
        for row, station in enumerate(stations[start:start + 2]):
            for col, side in enumerate(("l", "r")):
                axes = figure.add_axes((0.08 + 0.46 * col, 0.52 - 0.45 * row, 0.4, 0.36))
                chosen = np.array([s == station and d == side for s, d in zip(residuals.station, residuals.side,
                                                                                  strict=True)])
                dropped = residuals.observed[chosen & ~residuals.used]
                chosen &= residuals.used
                pts, res = residuals.observed[chosen], residuals.residual[chosen]
                axes.plot(pts[:, 0], pts[:, 1], ".", color="0.4", markersize=3)
                axes.plot(dropped[:, 0], dropped[:, 1], "x", color="0.3", markersize=5)
                axes.quiver(pts[:, 0], pts[:, 1], res[:, 0], res[:, 1], angles="xy", scale_units="xy",
                            scale=1.0 / scale, color="tab:red", width=0.004)
                axes.set_xlim(0, width)
                axes.set_ylim(height, 0)
                axes.set_aspect("equal")
                axes.tick_params(labelsize=6)
                rms = float(np.sqrt(np.nanmean(res ** 2))) if len(res) else float("nan")
                axes.set_title(f"pair {station}, {'left' if side == 'l' else 'right'}: {len(res)} points, "
                               f"RMS {rms:.3f} px" + (f", {len(dropped)} excluded" if len(dropped) else ""),
                               fontsize=8)
        pdf.savefig(figure)


def _histogram_page(pdf: PdfPages, calibration: StereoCalibration, residuals: Residuals) -> None:
    figure = Figure(figsize=A4)
    figure.text(0.07, 0.96, "Residual histograms", fontsize=13, weight="bold")
    sigma = calibration.sigma0_px
    for k, (axis_name, column) in enumerate((("x", 0), ("y", 1))):
        values = residuals.residual[residuals.used, column]
        values = values[np.isfinite(values)]
        axes = figure.add_axes((0.12, 0.55 - 0.43 * k, 0.78, 0.33))
        edges = np.linspace(-4 * sigma, 4 * sigma, 33) if len(values) else 10
        if len(values) and np.max(np.abs(values)) > 4 * sigma:
            edges = np.linspace(-np.max(np.abs(values)), np.max(np.abs(values)), 33)
        axes.hist(values, bins=edges, color="tab:blue", alpha=0.7, label="residuals")
        if len(values):
            grid = np.linspace(edges[0], edges[-1], 200)
            density = np.exp(-0.5 * (grid / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi))
            axes.plot(grid, density * len(values) * (edges[1] - edges[0]), color="k",
                      label=f"normal, sigma0 = {sigma:.3f} px")
        axes.set_xlabel(f"{axis_name} residual (px)", fontsize=8)
        axes.set_ylabel("count", fontsize=8)
        rms = float(np.sqrt(np.mean(values ** 2))) if len(values) else float("nan")
        axes.set_title(f"{axis_name}: {len(values)} residuals, RMS {rms:.3f} px", fontsize=9)
        axes.legend(fontsize=7)
        axes.tick_params(labelsize=7)
    pdf.savefig(figure)


def _views_page(pdf: PdfPages, calibration: StereoCalibration, observations: StereoObservations,
                residuals: Residuals | None) -> None:
    """The views: per camera the coverage map (views per grid cell, with its colour scale) with every
    view's points on it, and a table of the views (points, fitted or held out, reprojection RMS)."""
    validation = calibration.statistics.get("validation") or {}
    held = set((validation.get("held_out") or {}).get("views") or [])
    held_rms = (validation.get("held_out") or {}).get("rms_px_by_view") or {}
    width = calibration.left.width or float(np.nanmax(observations.left[:, 0])) + 1
    height = calibration.left.height or float(np.nanmax(observations.left[:, 1])) + 1
    labels = list(dict.fromkeys(observations.pairs)) if observations.pairs else list(calibration.stations[:1])
    cols, rows = DEFAULT_GRID
    figure = Figure(figsize=A4)
    figure.text(0.07, 0.96, "Views and their coverage", fontsize=13, weight="bold")
    figure.text(0.07, 0.945, f"{len(labels)} views ({len(held)} held out for validation). Colour: how many views "
                f"cover each cell of a {cols} × {rows} grid (a cell is {width / cols:.0f} × {height / rows:.0f} px); "
                "dots: the points\nobserved (black: fitted views, orange: held out). Axes in pixels of the image "
                f"({width} × {height} px, y down).", fontsize=8, va="top")
    for column, (side, name) in enumerate((("left", "left"), ("right", "right"))):
        counts = np.zeros((rows, cols))
        axes = figure.add_axes((0.08 + 0.47 * column, 0.6, 0.33, 0.3))
        for label in labels:
            view = observations.pair(label) if observations.pairs else observations
            pixels = getattr(view, side)
            for cell in covered_cells(pixels, (width, height), (cols, rows)):
                counts.flat[cell] += 1
            colour = "tab:orange" if label in held else "k"
            axes.plot(pixels[:, 0], pixels[:, 1], ".", color=colour, markersize=1.2)
        image = axes.imshow(counts, extent=(-0.5, width - 0.5, height - 0.5, -0.5), cmap="viridis",
                            vmin=0, vmax=max(counts.max(), 1), alpha=0.75, interpolation="nearest")
        axes.set_xlim(-0.5, width - 0.5)
        axes.set_ylim(height - 0.5, -0.5)
        axes.set_title(f"{name} image: {100 * np.mean(counts > 0):.0f} % of the cells covered", fontsize=8)
        axes.set_xlabel("x (px)", fontsize=7)
        axes.set_ylabel("y (px)", fontsize=7)
        axes.tick_params(labelsize=6)
        bar = figure.colorbar(image, ax=axes, fraction=0.046, pad=0.02)
        bar.set_label("views per cell", fontsize=7)
        bar.ax.tick_params(labelsize=6)
    fitted_rms: dict[str, float] = {}
    if residuals is not None:
        for label in labels:
            chosen = np.array([s == label for s in residuals.station]) & residuals.used
            values = residuals.residual[chosen]
            if len(values):
                fitted_rms[label] = float(np.sqrt(np.nanmean(values ** 2)))
    lines = [f"{'view':<24}{'points':>8}  {'role':<10}{'RMS (px)':>10}", "-" * 56]
    for label in labels:
        view = observations.pair(label) if observations.pairs else observations
        role = "held out" if label in held else "fitted"
        rms = held_rms.get(label) if label in held else fitted_rms.get(label)
        lines.append(f"{label[:23]:<24}{len(view.ids):>8}  {role:<10}" + (f"{rms:>10.3f}" if rms is not None else
                                                                          f"{'—':>10}"))
    lines += ["", "RMS per coordinate: a fitted view's from the adjustment's residuals, a held-out view's after "
              "resecting its pose", "with the calibrated rig held fixed."]
    figure.text(0.07, 0.53, "\n".join(lines[:70]), family="monospace", fontsize=7, va="top")
    pdf.savefig(figure)


def _number(value, spec: str = ".2f") -> str:
    """A figure of the report's dictionaries, or a dash where it is missing or not finite."""
    return format(value, spec) if isinstance(value, float | int) and np.isfinite(value) else "—"


def _bin_row(b: dict) -> str:
    if not b.get("count"):
        return f"{'none':>34}"
    return (f"{b['count']:>6}{1000 * b['rms_m']:>10.2f}{100 * b['rms_relative']:>9.2f}"
            f"{1000 * b['mean_m']:>+10.2f}")


def _validation_page(pdf: PdfPages, validation: dict, calibration: StereoCalibration) -> None:
    """Held-out views against fitted ones: reprojection, known distances by range (table and chart), and
    OpenCV's solution of the same views beside ours (in air)."""
    fitted, held = validation.get("fitted") or {}, validation.get("held_out") or {}
    figure = Figure(figsize=A4)
    figure.text(0.07, 0.96, "Validation: views held out, measured with the calibration", fontsize=13,
                weight="bold")
    lines = [f"views fitted   : {len(fitted.get('views') or [])}",
             f"views held out : {len(held.get('views') or [])} ({', '.join(held.get('views') or [])})"[:110],
             f"reprojection RMS: fitted {fitted.get('rms_px', float('nan')):.3f} px, held out "
             f"{held.get('rms_px', float('nan')):.3f} px (held-out poses resected with the rig held fixed)", "",
             "KNOWN DISTANCES BY RANGE (estimated − true; adjacent points and the diagonal of each view)",
             f"{'kind':<10}{'range (m)':<13}{'fitted: n':>10}{'RMS mm':>10}{'RMS %':>9}{'mean mm':>10}"
             f"{'  held out: n':>14}{'RMS mm':>10}{'RMS %':>9}{'mean mm':>10}"]
    for kind in ("adjacent", "diagonal"):
        for a, b in zip(fitted.get(kind) or [], held.get(kind) or [], strict=False):
            lines.append(f"{kind:<10}{a['low']:.2f}–{a['high']:.2f}{'':<4}{_bin_row(a)}    {_bin_row(b)}")
    honesty = validation.get("honesty")
    if isinstance(honesty, dict):
        low, high = (list(honesty.get("interval_95") or []) + [None, None])[:2]
        r_low, r_high = (list(honesty.get("reprojection_interval_95") or []) + [None, None])[:2]
        lines += ["", "HONESTY OF THE STATED SIGMAS ON THE HELD-OUT VIEWS (NEES: 1 when they hold)",
                  f"  known distances: NEES {_number(honesty.get('distance_nees'))} over "
                  f"{honesty.get('distances')} distances in {honesty.get('views')} views (95 % interval "
                  f"{_number(low)}-{_number(high)})",
                  f"  reprojections  : NEES {_number(honesty.get('reprojection_nees'))} over "
                  f"{honesty.get('reprojection_dof')} degrees of freedom ({_number(r_low)}-{_number(r_high)})",
                  f"  covariance scale factor: {_number(honesty.get('covariance_factor'), '.3g')}"
                  + (" (applied: every sigma of this calibration is scaled by its square root)"
                     if honesty.get("scaled") else " (not applied)")]
        for why in honesty.get("why") or []:
            lines += textwrap.wrap(f"  {why}", 100)
    opencv, ours = validation.get("opencv"), validation.get("ours") or {}
    lines += ["", "OPENCV BESIDE OURS (stereoCalibrate on the fitted views, its default five-term distortion)"]
    if opencv:
        lines += [f"{'':<14}{'f left (px)':>13}{'f right (px)':>14}{'baseline (mm)':>15}{'RMS (px)':>10}",
                  f"{'OpenCV':<14}{opencv['f_l']:>13.2f}{opencv['f_r']:>14.2f}{1000 * opencv['baseline_m']:>15.2f}"
                  f"{opencv['rms_px']:>10.3f}",
                  f"{'USVIPS':<14}{ours.get('f_l', float('nan')):>13.2f}{ours.get('f_r', float('nan')):>14.2f}"
                  f"{1000 * ours.get('baseline_m', float('nan')):>15.2f}{ours.get('rms_px', float('nan')):>10.3f}"]
        sigma = {f.name: f.sigma for f in parameter_table(calibration)}
        if all(sigma.get(name) is not None for name in ("f_l", "f_r", "baseline")):
            lines.append(f"{'  its sigma':<14}{sigma['f_l']:>13.2f}{sigma['f_r']:>14.2f}"
                         f"{1000 * sigma['baseline']:>15.2f}")
    else:
        lines.append("  not computed (underwater, a 3-D target, or no image size)")
    for note in validation.get("notes") or []:
        lines += textwrap.wrap(f"note: {note}", 100)
    figure.text(0.07, 0.93, "\n".join(lines), family="monospace", fontsize=7, va="top")
    for k, kind in enumerate(("adjacent", "diagonal")):
        axes = figure.add_axes((0.1 + 0.45 * k, 0.1, 0.36, 0.24))
        bins = fitted.get(kind) or []
        centres = np.arange(len(bins))
        for offset, (name, figures, colour) in enumerate((("fitted", bins, "tab:blue"),
                                                          ("held out", held.get(kind) or [], "tab:orange"))):
            values = [1000 * b["rms_m"] if b.get("count") else np.nan for b in figures]
            axes.bar(centres[:len(values)] + 0.4 * offset - 0.2, values, width=0.38, color=colour, label=name)
        axes.set_xticks(centres, [f"{b['low']:.2f}–{b['high']:.2f}" for b in bins], fontsize=6)
        axes.set_xlabel("range from the left camera (m)", fontsize=7)
        axes.set_ylabel("RMS length error (mm)", fontsize=7)
        axes.set_title(f"{kind} distances", fontsize=8)
        axes.tick_params(labelsize=6)
        axes.legend(fontsize=6)
    pdf.savefig(figure)


def _check_lines(checks: CheckPoints | None, reason: str) -> list[str]:
    if checks is None:
        return [reason]
    lines = [f"{'id':<10}{'dX':>10}{'dY':>10}{'dZ':>10}{'sX':>10}{'sY':>10}{'sZ':>10}   (mm; d = computed − control,",
             f"{'':<70}    s = predicted sigma)", "-" * 84]
    for pid, d, s in zip(checks.ids, checks.difference * 1e3, checks.sigma * 1e3, strict=True):
        if np.all(np.isfinite(d)):
            lines.append(f"{pid:<10}" + "".join(f"{v:>10.2f}" for v in d) + "".join(f"{v:>10.2f}" for v in s))
        else:
            lines.append(f"{pid:<10}  (the rays do not intersect)")
    ok = np.isfinite(checks.difference).all(axis=1)
    if ok.any():
        rms = np.sqrt(np.mean(checks.difference[ok] ** 2, axis=0)) * 1e3
        normalised = np.mean((checks.difference[ok] / checks.sigma[ok]) ** 2)
        lines += ["-" * 84, f"{'RMS':<10}" + "".join(f"{v:>10.2f}" for v in rms),
                  f"mean squared normalised difference (d/s)²: {normalised:.2f} (near 1 when the predicted sigmas "
                  "are right)"]
    return lines


def write_calibration_report(calibration: StereoCalibration, out: str | Path,
                             calibration_path: str | Path | None = None, check: str | Path | None = None,
                             check_control: str | Path | None = None, data: ReportData | None = None) -> int:
    """Write the report PDF atomically; returns its number of pages. ``check``: observations CSV of check
    points (ids in the control, or in ``check_control``), intersected at the first station. ``data``:
    the control and observations used when they are not files named in the calibration (the wizard's)."""
    out = Path(out)
    if out.suffix.lower() != ".pdf":
        raise UsvipsError(f"{out}: the report is a PDF; give a name ending in .pdf")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise UsvipsError(f"{out}: the folder {out.parent} does not exist")
    data = data if data is not None else find_data(calibration, calibration_path)
    residuals, residual_note = None, ""
    if data.control is not None and data.observations is not None and calibration.parameters:
        residuals = calibration_residuals(calibration, data.control, data.observations)
    else:
        unread = [f"{role} {recorded}: {why}" for role, recorded, why in data.files
                  if not (len(why) == 64 and all(c in "0123456789abcdef" for c in why))]
        residual_note = ("the calibration's control and observations were not found: no residual plots"
                         + (f" ({'; '.join(unread[:3])})" if unread else ""))
    checks, check_reason = None, "No check points given (observations of points with known coordinates)."
    if check is not None:
        control = read_control(check_control) if check_control else data.control
        if control is None:
            raise concerning(UsvipsError("the check points have no control to compare with: give their control "
                                         "points"), "check_control")
        checks = check_points(calibration, control, read_observations(check))
    buffer = io.BytesIO()
    metadata = {"Title": f"USVIPS calibration report: {Path(calibration_path).name if calibration_path else ''}",
                "Creator": f"USVIPS {__version__}"}
    with PdfPages(buffer, metadata=metadata) as pdf:
        summary = _summary_lines(calibration, data, calibration_path)
        if residual_note:
            summary += ["", residual_note]
        _text_page(pdf, "USVIPS calibration report", summary)
        _text_page(pdf, "Parameters (seeds' symbols; _l left, _r right, @pair further stations)",
                   _parameter_lines(calibration))
        _correlation_page(pdf, calibration)
        if data.observations is not None and "target" in calibration.source:
            _views_page(pdf, calibration, data.observations, residuals)
        if isinstance(calibration.statistics.get("validation"), dict):
            _validation_page(pdf, calibration.statistics["validation"], calibration)
        if residuals is not None:
            _residual_pages(pdf, calibration, residuals)
            _histogram_page(pdf, calibration, residuals)
        _text_page(pdf, "Check points", _check_lines(checks, check_reason))
        pages = pdf.get_pagecount()
    write_bytes_atomic(out, buffer.getvalue())
    return pages

