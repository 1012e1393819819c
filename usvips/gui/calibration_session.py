"""The calibration wizards' model, free of Qt: what the operator chose and measured, the computation,
and what the result says (thesis 3.4.4, Fig. 3.4).

Three phases share it: ``air`` (phase 1, both cameras in air, one or more pairs), ``water`` (phase 2,
one underwater pair, housing by ray tracing from a phase-1 calibration) and ``joint`` (phase 2 over
several underwater pairs at once). Observations are pixels (x right, y down, origin at the centre of the
top-left pixel); control coordinates are metres in the object frame.

The computation (:meth:`CalibrationSession.job`) is a plain function of copied inputs, so it runs in a
worker thread while the project (SQLite) stays on the GUI thread.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvips.app.calibration_size import check_for
from usvips.app.calibrations import read_calibration, store_calibration
from usvips.core import housing as housings
from usvips.core.adjustment import W_CRITICAL
from usvips.core.calibration import CalibrationOptions, CalibrationResult, calibrate_air, calibrate_water
from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.core.calibration.report import ResidualRow
from usvips.core.dlt import check_spread
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.intersection import intersect
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.gui.signals import Signal
from usvips.io.tables import read_control, read_observations
from usvips.store.interface import ProjectStore

PHASES = {"air": "Phase 1 — cameras in air", "water": "Phase 2 — housing and water (one pair)",
          "joint": "Phase 2 — joint calibration of several underwater pairs"}
ROLES = {"air": "calibration-air", "water": "calibration-water", "joint": "calibration-water"}
MINIMUM_POINTS = 6
#: Below this spread across the weakest direction (relative to the largest) the control is called weak:
#: the DLT still runs (it refuses below 1e-3, core/dlt.py) but determines the start poorly.
WEAK_RATIO = 0.05


@dataclass(frozen=True)
class Spread:
    """How well a pair's measured control points cover space: count, the ratio of the smallest to the
    largest principal spread, and a sentence for the operator; ``ok`` when the DLT can start."""

    count: int
    flatness: float
    message: str
    ok: bool


def control_spread(control: ControlPoints, ids: list[str]) -> Spread:
    """Enough points (6) and not coplanar (the DLT's needs, as core/dlt.py checks them); a warning when
    the geometry is weak."""
    if len(ids) < MINIMUM_POINTS:
        return Spread(len(ids), 0.0, f"{len(ids)} of at least {MINIMUM_POINTS} points measured", False)
    index = {pid: i for i, pid in enumerate(control.ids)}
    xyz = control.xyz[[index[i] for i in ids]]
    singular = np.linalg.svd(xyz - xyz.mean(axis=0), compute_uv=False)
    flatness = float(singular[-1] / singular[0]) if singular[0] > 0 else 0.0
    try:
        check_spread(xyz)
    except DegenerateGeometryError:
        return Spread(len(ids), flatness, f"{len(ids)} points, but coplanar (depth spread {flatness:.2%} of the "
                      "width): the DLT cannot start; measure points at other depths of the frame", False)
    if flatness < WEAK_RATIO:
        return Spread(len(ids), flatness, f"{len(ids)} points, nearly coplanar (depth spread {flatness:.1%} of the "
                      "width): weak geometry — the start and the parameters will be poorly determined; points at "
                      "other depths of the frame would strengthen it", True)
    if len(ids) < 10 or flatness < 0.15:
        return Spread(len(ids), flatness, f"{len(ids)} points, depth spread {flatness:.0%} of the width: enough "
                      "to compute, but more points at other depths will strengthen the result", True)
    return Spread(len(ids), flatness, f"{len(ids)} points, depth spread {flatness:.0%} of the width: good", True)


@dataclass(frozen=True)
class CheckPoint:
    """A check point intersected with the new calibration at its ``pair``'s station: its ``id``, the
    ``difference`` from its control coordinates (dX, dY, dZ; metres) and the intersection's ``sigma``
    (σX, σY, σZ; metres)."""

    pair: str
    id: str
    difference: tuple[float, float, float]
    sigma: tuple[float, float, float]


@dataclass(frozen=True)
class ParameterChange:
    """A parameter shared with the calibration compared against: its ``name``, ``old`` and ``new`` values
    (the parameter's unit) and the change in units of the new σ (None when the new σ is 0 or unknown)."""

    name: str
    old: float
    new: float
    change_sigmas: float | None


@dataclass
class CalibrationSession:
    """The state of one wizard. ``observations``: (pair, point id) → (xl, yl, xr, yr) pixels; ``check``:
    the (pair, id) held out of the adjustment as check points; ``excluded``: those the operator left out."""

    project: ProjectStore
    phase: str
    pairs: list[str] = field(default_factory=list)
    control: ControlPoints | None = None
    control_source: str = "project"
    housing: str = field(default_factory=lambda: housings.water_names()[0])  # the registry's first water kind
    base_id: int | None = None
    known: dict[str, tuple[float, float | None]] = field(default_factory=dict)
    observations: dict[tuple[str, str], tuple[float, float, float, float]] = field(default_factory=dict)
    check: set[tuple[str, str]] = field(default_factory=set)
    excluded: set[tuple[str, str]] = field(default_factory=set)
    automatic_blunders: bool = False
    sigma_px: float = 0.5
    image_size: tuple[int | None, int | None] = (None, None)

    def __post_init__(self) -> None:
        if self.phase not in PHASES:
            raise UsvipsError(f"unknown calibration phase {self.phase!r}; phases: {', '.join(PHASES)}")
        self.result: CalibrationResult | None = None
        self.previous_result: CalibrationResult | None = None
        #: Events: ``step_changed(step)`` (the wizard's page, a name), ``data_changed(what, keys)`` with
        #: ``what`` one of pairs, control, known, observations, check, exclusions and ``keys`` the (pair, point)
        #: changed (empty: all of that kind), ``result_changed()`` (a result was set or dropped).
        self.step = ""
        self.step_changed = Signal()
        self.data_changed = Signal()
        self.result_changed = Signal()
        if self.control is None:
            control = self.project.control()
            self.control = control if len(control.ids) else None
        if self.base_id is None and self.phase != "air":
            bases = [c for c in self.project.calibrations() if c.phase == "air"]
            self.base_id = bases[-1].id if bases else None
        water = [c for c in self.project.calibrations() if c.phase in ("water", "joint")]
        if self.phase != "air" and water:  # the rig's housing, as its last underwater calibration says
            housing = self.project.calibration(water[-1].id).get("housing")
            if housing in DEFAULT_HOUSING:
                self.housing = housing
                self._housing_from = water[-1].id

    def housing_source(self) -> str:
        """Where the housing kind shown first comes from (a line for the wizard)."""
        calibration_id = getattr(self, "_housing_from", None)
        if calibration_id is not None:
            return f"as in the project's calibration {calibration_id}"
        return "no underwater calibration in the project yet: check the housing kind"

    # ------------------------------------------------------------------ choices
    def candidate_pairs(self) -> list[str]:
        medium = "air" if self.phase == "air" else "water"
        return [p.label for p in self.project.pairs() if p.medium == medium]

    def set_pairs(self, pairs: list[str]) -> None:
        unknown = [p for p in pairs if p not in self.candidate_pairs()]
        if unknown:
            raise UsvipsError(f"pair {unknown[0]!r} is not an {'in-air' if self.phase == 'air' else 'underwater'} "
                              "pair of this project")
        if self.phase == "water" and len(pairs) > 1:
            raise UsvipsError("phase 2 on one pair: choose one pair, or use the joint calibration for several")
        self.pairs = list(pairs)
        self.data_changed.emit("pairs", ())

    def load_control(self, path: str) -> None:
        self.control = read_control(path)
        self.control_source = str(path)
        self.data_changed.emit("control", ())

    def base_calibrations(self) -> list[dict]:
        return [c for c in self.project.calibrations() if c.phase == "air"]

    def default_name(self) -> str:
        """The calibration's name unless the user gives one: its phase and pairs."""
        return f"{self.phase} {'+'.join(self.pairs)}"

    def set_known(self, name: str, value: float, sigma: float | None) -> None:
        """A housing value known beforehand: fixed (sigma None) or a prior (value ± sigma)."""
        if name not in DEFAULT_HOUSING.get(self.housing, {}):
            raise UsvipsError(f"{name!r} is not a parameter of the {self.housing} housing; "
                              f"parameters: {', '.join(DEFAULT_HOUSING[self.housing])}")
        if not np.isfinite(value) or (sigma is not None and not (np.isfinite(sigma) and sigma > 0)):
            raise UsvipsError(f"{name}: the value must be a number and its sigma a positive number")
        self.known[name] = (float(value), None if sigma is None else float(sigma))
        self.data_changed.emit("known", ())

    # ------------------------------------------------------------------ observations
    def load_project_observations(self) -> int:
        """The project's stored control observations of the chosen pairs (for this phase's role)."""
        count = 0
        for pair in self.pairs:
            stored = self.project.control_observations(ROLES[self.phase], pair)
            for i, pid in enumerate(stored.ids):
                self.observations[(pair, pid)] = (*map(float, stored.left[i]), *map(float, stored.right[i]))
                count += 1
        self._observations_changed(())
        return count

    def import_observations(self, path: str, pair: str | None = None) -> int:
        """Observations from a CSV (id,xl,yl,xr,yr[,pair]); rows of pairs not chosen are ignored; a file
        without a pair column goes to ``pair`` (or the only chosen pair)."""
        data = read_observations(path)
        has_pairs = set(data.pairs) != {"1"}
        if not has_pairs:
            target = pair or (self.pairs[0] if len(self.pairs) == 1 else None)
            if target is None:
                raise UsvipsError(f"{path}: the file has no pair column: choose the pair it belongs to")
        count = 0
        for i, pid in enumerate(data.ids):
            label = data.pairs[i] if has_pairs else target
            if label not in self.pairs:
                continue
            if self.control is not None and pid not in self.control.ids:
                raise UsvipsError(f"{path}: point {pid!r} is not a control point")
            self.observations[(label, pid)] = (*map(float, data.left[i]), *map(float, data.right[i]))
            count += 1
        if count == 0:
            raise UsvipsError(f"{path}: no observations of the chosen pair(s) {', '.join(self.pairs)}")
        self._observations_changed(())
        return count

    def set_observation(self, pair: str, point: str, left, right) -> None:
        if self.control is None or point not in self.control.ids:
            raise UsvipsError(f"{point!r} is not a control point: type the number printed on the target")
        values = (*map(float, left), *map(float, right))
        if not np.all(np.isfinite(values)):
            raise UsvipsError("an observation needs both picks")
        self.observations[(pair, point)] = values
        self._observations_changed(((pair, point),))

    def remove_observation(self, pair: str, point: str) -> None:
        self.observations.pop((pair, point), None)
        self.check.discard((pair, point))
        self.excluded.discard((pair, point))
        self._observations_changed(((pair, point),))

    def set_check(self, pair: str, point: str, checked: bool) -> None:
        """Use the observation of ``point`` in ``pair`` as a check point (left out of the adjustment) or not."""
        key = (pair, point)
        if (key in self.check) == checked:
            return
        (self.check.add if checked else self.check.discard)(key)
        self._observations_changed((key,), "check")

    def _observations_changed(self, keys: tuple, what: str = "observations") -> None:
        """The observations (or their use, ``what``) changed (``keys``: which; empty: many): any result is
        of other data."""
        had = self.result is not None
        self.result = None
        self.data_changed.emit(what, keys)
        if had:
            self.result_changed.emit()

    def set_step(self, step: str) -> None:
        """The wizard shows another step (page); announced when it changes."""
        if step != self.step:
            self.step = step
            self.step_changed.emit(step)

    def measured(self, pair: str) -> list[str]:
        return [pid for (p, pid) in self.observations if p == pair]

    def spread(self, pair: str) -> Spread:
        if self.control is None:
            return Spread(0, 0.0, "no control points: load a control file", False)
        used = [pid for pid in self.measured(pair) if (pair, pid) not in self.check | self.excluded]
        return control_spread(self.control, used)

    def readiness(self) -> tuple[bool, str]:
        """Whether the adjustment can run, and why not."""
        if not self.pairs:
            return False, "choose at least one pair"
        if self.control is None:
            return False, "load the control points (file or the project's)"
        if self.phase != "air" and self.base_id is None:
            return False, "phase 2 needs a phase-1 (in-air) calibration in the project"
        for pair in self.pairs:
            spread = self.spread(pair)
            if not spread.ok:
                return False, f"pair {pair}: {spread.message}"
        return True, "ready"

    # ------------------------------------------------------------------ computing
    def inputs(self) -> tuple[ControlPoints, StereoObservations, CalibrationOptions]:
        ok, reason = self.readiness()
        if not ok:
            raise UsvipsError(reason)
        keys = [k for k in self.observations if k[0] in self.pairs and k not in self.check | self.excluded]
        values = np.array([self.observations[k] for k in keys], float)
        observations = StereoObservations(tuple(k[1] for k in keys), values[:, :2], values[:, 2:],
                                          tuple(k[0] for k in keys), source="wizard")
        fix_values = {n: v for n, (v, s) in self.known.items() if s is None}
        priors = {n: (v, s) for n, (v, s) in self.known.items() if s is not None}
        options = CalibrationOptions(fix_values=fix_values, priors=priors, sigma_px=self.sigma_px,
                                     robust=self.automatic_blunders, snooping=self.automatic_blunders,
                                     image_size=self.image_size)
        return self.control, observations, options

    def job(self) -> Callable[..., CalibrationResult]:
        """The computation with its inputs copied now (call on the GUI thread; run the result anywhere)."""
        control, observations, options = self.inputs()
        phase, housing = self.phase, self.housing
        base = None
        if phase != "air":
            base = read_calibration(self.project, self.base_id)
        source = {"wizard": phase, "pairs": list(self.pairs), "control": self.control_source}

        def run(progress=None, cancelled=None) -> CalibrationResult:
            if phase == "air":
                return calibrate_air(control, observations, options, source)
            return calibrate_water(base, housing, control, observations, options, source)

        return run

    def set_result(self, result: CalibrationResult) -> None:
        if self.result is not None:
            self.previous_result = self.result
        self.result = result
        self.result_changed.emit()

    # ------------------------------------------------------------------ results
    def flagged(self) -> list[ResidualRow]:
        """Residual rows still used by the adjustment whose w-test exceeds Baarda's critical value (3.29):
        likely blunders. Rows the adjustment already left out (robust weights, snooping) are not counted."""
        if self.result is None:
            return []
        rows = self.result.report.used_residuals()
        return [r for r in rows if max(abs(r.wx), abs(r.wy)) > W_CRITICAL]

    def left_out(self) -> list[ResidualRow]:
        """Residual rows the adjustment itself left out (robust weights and data snooping)."""
        return [] if self.result is None else list(self.result.report.set_aside_residuals())

    def exclude_flagged(self) -> list[tuple[str, str]]:
        """Leave out the flagged observation with the largest w-test (to be re-run); returns what was
        excluded. One at a time, as Baarda's data snooping does: a blunder inflates its neighbours' w too,
        and they usually drop below 3.29 once it is gone."""
        flagged = self.flagged()
        if not flagged:
            return []
        worst = max(flagged, key=lambda r: max(abs(r.wx), abs(r.wy)))
        key = (worst.station, worst.id)
        self.excluded.add(key)
        self.data_changed.emit("exclusions", (key,))
        return [key]

    def check_points(self) -> tuple[list[CheckPoint], float | None]:
        """Check points intersected with the new calibration at their pair's station: differences from
        their control coordinates (m) and the RMS of the 3-D differences (thesis Tables 3.8-3.9)."""
        if self.result is None or not self.check:
            return [], None
        calibration = self.result.calibration
        rows = []
        index = {pid: i for i, pid in enumerate(self.control.ids)}
        for pair, pid in sorted(self.check):
            if pair not in calibration.stations:
                continue
            xl, yl, xr, yr = self.observations[(pair, pid)]
            result = intersect(calibration.rig(pair).cameras, [np.array([[xl, yl]]), np.array([[xr, yr]])],
                               calibration.sigma0_px)
            if not result.ok[0]:
                continue
            difference = result.points[0] - self.control.xyz[index[pid]]
            rows.append(CheckPoint(pair, pid, tuple(float(d) for d in difference),
                                   tuple(float(s) for s in result.sigmas[0])))
        if not rows:
            return [], None
        rms = float(np.sqrt(np.mean([sum(d ** 2 for d in r.difference) for r in rows])))
        return rows, rms

    def comparison(self) -> list[ParameterChange]:
        """Parameters shared with the calibration active now for the first pair (or the previous run):
        old and new values and the change in units of the new sigma, largest change first."""
        if self.result is None:
            return []
        old = None
        if self.previous_result is not None:
            old = self.previous_result.calibration
        elif self.pairs:
            active = self.project.active_calibration(self.pairs[0])
            if active is not None:
                try:
                    old = read_calibration(self.project, active)
                except UsvipsError:
                    old = None
        if old is None:
            return []
        new = self.result.calibration.parameters
        rows = []
        for name, estimate in new.items():
            if name in old.parameters and "@" not in name:
                before = old.parameters[name].value
                change = estimate.value - before
                sigma = estimate.sigma or 0.0
                rows.append(ParameterChange(name, before, estimate.value,
                                            abs(change) / sigma if sigma > 0 else None))
        rows.sort(key=lambda r: -(r.change_sigmas or 0.0))
        return rows

    def save(self, name: str, active_for: list[str]) -> int:
        """Store the calibration (active for ``active_for``) and the observations used, in the project;
        the draft is dropped."""
        if self.result is None or not self.result.adjustment.converged:
            raise UsvipsError("there is no converged result to save")
        name = name.strip() or PHASES[self.phase]
        check_for(self.project, self.result.calibration, active_for, f"the calibration {name!r}")
        calibration_id = store_calibration(self.project, name, self.result.calibration, active_for)
        for pair in self.pairs:
            ids = self.measured(pair)
            if ids:
                values = np.array([self.observations[(pair, i)] for i in ids])
                self.project.add_control_observations(StereoObservations(tuple(ids), values[:, :2], values[:, 2:],
                                                                         (pair,) * len(ids)), ROLES[self.phase], pair,
                                                 replace=True)
        self.project.set_draft(self.draft_name, None)
        return calibration_id

    # ------------------------------------------------------------------ drafts
    @property
    def draft_name(self) -> str:
        return f"calibration-{self.phase}"

    def to_json(self) -> str:
        return json.dumps({"phase": self.phase, "pairs": self.pairs, "control_source": self.control_source,
                           "housing": self.housing, "base_id": self.base_id,
                           "known": {k: list(v) for k, v in self.known.items()},
                           "observations": [[p, i, *v] for (p, i), v in self.observations.items()],
                           "check": sorted(map(list, self.check)), "excluded": sorted(map(list, self.excluded)),
                           "automatic_blunders": self.automatic_blunders, "sigma_px": self.sigma_px})

    def save_draft(self) -> None:
        """Keep the half-finished wizard in the project, to resume later."""
        self.project.set_draft(self.draft_name, self.to_json())

    @classmethod
    def resume(cls, project: ProjectStore, phase: str) -> CalibrationSession | None:
        """The saved draft of a phase, or None."""
        text = project.draft(f"calibration-{phase}")
        if text is None:
            return None
        try:
            data = json.loads(text)
            session = cls(project, phase, housing=data["housing"], base_id=data["base_id"],
                          automatic_blunders=data["automatic_blunders"], sigma_px=data["sigma_px"])
            session.pairs = list(data["pairs"])
            if data["control_source"] != "project":
                session.load_control(data["control_source"])
            session.known = {k: (v[0], v[1]) for k, v in data["known"].items()}
            session.observations = {(r[0], r[1]): tuple(r[2:6]) for r in data["observations"]}
            session.check = {tuple(k) for k in data["check"]}
            session.excluded = {tuple(k) for k in data["excluded"]}
        except (KeyError, TypeError, ValueError, IndexError) as error:
            raise UsvipsError(f"{project.path}: the saved {phase} calibration draft cannot be read ({error})") from None
        return session
