"""Quality control of a survey: every object that breaks a rule, with the rule, its value, its limit and
where it was measured (so the window can jump there and ``usvips project check`` can list it).

The rules are the per-object quality rules every measurement is checked against when it is stored
(:class:`usvips.core.measurements.QualityRules`: ray-intersection RMS, precision/value, range), and
CheckEM's check of a length against the species' maximum length from the project's species list: a
length (of a kind whose main figure is ``length``) of an object whose observation record names a species
is compared with that species' maximum. A species without a maximum in the list is reported as
``no maximum`` (a note, not a failure); a species not in the list as ``not in the species list``.
An object without figures is reported with the reason (rule ``no figures``).

Two rules look at facts the precision rules cannot see (issue 32: a conjugate about 30 px off on the wrong
peak of the epipolar curve, accepted with Enter, gave 590 ± 9 mm for a 360 mm fish and passed every rule):
``weak match accepted`` — a vertex whose auto-match the matcher refused (ambiguous, textureless, a low
score) and a person accepted all the same, a fact stored with the vertex (:class:`usvips.core.pointing.
WeakMatch`), never read from notes; and ``implausible geometry`` — a length leaning out of the image plane
by more than the project's limit (:mod:`usvips.core.measurements.plausibility`: a wrong conjugate moves a
vertex along the line of sight). Both fail the object until it is looked at; :func:`object_facts` says them
for one object (the window's readout and review mode).

Checking is split from reading, as the figures are (:mod:`usvips.app.project_figures`): :func:`check`
is pure and fast over measurements already computed (the window's figure cache), :func:`check_project`
reads and computes a whole project for the command line.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from usvips.app.calibrations import require_readable_calibrations
from usvips.app.object_instants import survey_objects
from usvips.app.pointing_settings import pointing_in_use
from usvips.app.project_figures import evaluate, instants_by_object, measurement_input, where_measured
from usvips.core.errors import UsvipsError
from usvips.core.measurements import Measurement, QualityRules
from usvips.core.measurements import kind as measurement_kind
from usvips.core.measurements.plausibility import MAX_OUT_OF_PLANE_DEG, out_of_plane_deg
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.pointing import WeakMatch
from usvips.store.interface import ProjectStore
from usvips.store.project import StoredObject

#: the rules' names as reports show them
RULE_NAMES = {"ray_rms": "ray RMS", "precision": "precision/length", "range": "range", "max_sigma": "sigma",
              "species_max": "length > species maximum", "no_maximum": "no maximum",
              "unknown_species": "not in the species list", "no_figures": "no figures",
              "weak_match": "weak match accepted", "geometry": "implausible geometry"}
FAIL, NOTE = "fail", "note"


@dataclass(frozen=True)
class Place:
    """Where an object was measured: its ``pair`` label, or its ``video`` label with the left ``frame``;
    ``where`` says it for a person ("pair P", "video V frame F")."""

    where: str = ""
    pair: str | None = None
    video: str | None = None
    frame: int | None = None

    @classmethod
    def of(cls, stored: StoredObject) -> Place:
        if not stored.vertices:
            return cls()
        v = stored.vertices[0]
        return cls(where_measured(stored), v.pair, v.video, v.frame_left if v.video is not None else None)


@dataclass(frozen=True)
class Issue:
    """One rule one object breaks (``status`` ``fail``) or could not be checked against (``note``):
    ``rule`` (a key of :data:`RULE_NAMES`), ``value`` and ``limit`` in ``unit`` ("m", or "1" for
    precision/value; None where there is no number), the object's kind, species and ``place``, and
    ``message``, how a person reads it."""

    object_id: str
    rule: str
    status: str
    value: float | None
    limit: float | None
    unit: str
    kind: str
    species: str
    place: Place
    message: str

    @property
    def rule_name(self) -> str:
        return RULE_NAMES.get(self.rule, self.rule)

    def as_dict(self) -> dict:
        row = asdict(self)
        row.update(row.pop("place"))
        row["rule_name"] = self.rule_name
        return row


@dataclass(frozen=True)
class QualityReport:
    """The issues of a survey (by object id, then rule) and how many objects were checked."""

    issues: tuple[Issue, ...]
    checked: int

    @property
    def failures(self) -> tuple[Issue, ...]:
        return tuple(i for i in self.issues if i.status == FAIL)

    @property
    def failing_objects(self) -> int:
        return len({i.object_id for i in self.failures})

    @property
    def notes(self) -> int:
        """How many issues are notes (a rule that could not be checked), not failures."""
        return len(self.issues) - len(self.failures)

    def summary(self) -> str:
        """One line in words: ``9 objects checked: 5 break a rule (2 notes)``, ``1 object checked: 1 breaks
        a rule`` — the same wording in the QA panel and ``usvips project check``."""
        failing = self.failing_objects
        text = (f"{self.checked} object{'' if self.checked == 1 else 's'} checked: "
                f"{failing} {'breaks' if failing == 1 else 'break'} a rule")
        return text + (f" ({self.notes} note{'' if self.notes == 1 else 's'})" if self.notes else "")

    def exceeds(self, level: str) -> bool:
        """Whether the report holds an issue at ``level`` or worse: ``"error"`` a broken rule,
        ``"warning"`` also a note (a rule that could not be checked)."""
        return bool(self.failures) if level == "error" else bool(self.issues)


@dataclass(frozen=True)
class Checked:
    """What :func:`check` needs of one object: its measurement (None with ``reason`` when it has no
    figures), its observation record and its place."""

    object_id: str
    kind: str
    measurement: Measurement | None
    record: ObservationRecord | None
    place: Place
    reason: str = ""
    #: the vertices (0-based index) kept from a weak auto-match, with the matcher's score and reason
    weak: tuple[tuple[int, WeakMatch], ...] = ()


def weak_vertices(stored: StoredObject) -> tuple[tuple[int, WeakMatch], ...]:
    """The vertices of ``stored`` kept from a weak auto-match: (0-based index, the stored flag)."""
    return tuple((i, v.weak) for i, v in enumerate(stored.vertices) if v.weak is not None)


def _out_of_plane_limit(rules: QualityRules) -> float:
    return float(rules.extra.get("max_out_of_plane_deg", MAX_OUT_OF_PLANE_DEG))


def fact_issues(weak: tuple[tuple[int, WeakMatch], ...], m: Measurement | None,
                rules: QualityRules) -> list[tuple[str, float | None, float | None, str, str]]:
    """(rule, value, limit, unit, message) of the ``weak match accepted`` and ``implausible geometry``
    rules for one object: its weak vertices, and its measurement's lean out of the image plane."""
    found: list[tuple[str, float | None, float | None, str, str]] = []
    for index, flag in weak:
        found.append(("weak_match", flag.score, None, "", f"vertex {index + 1}: {flag.text}"))
    # a length too imprecise for the precision rule has a direction that is mostly noise: that rule lists it
    if (m is not None and measurement_kind(m.kind).main_name() == "length"
            and m.main.relative_precision <= rules.max_relative_precision):
        angle = out_of_plane_deg(m.points, m.camera)
        limit = _out_of_plane_limit(rules)
        if angle is not None and angle > limit:
            found.append(("geometry", angle, limit, "deg",
                          f"the length leans {angle:.0f}° out of the image plane (> {limit:g}°): a fish side on "
                          "does not; a conjugate on the wrong peak of the epipolar curve does — check the picks"))
    return found


def judge(stored: StoredObject, m: Measurement | None, rules: QualityRules | None = None,
          record: ObservationRecord | None = None, species: dict[str, Species] | None = None,
          reason: str = "") -> tuple[Issue, ...]:
    """THE verdict on one object: every rule it breaks (failures) or could not be checked against (notes)
    — the precision rules, weak matches, implausible geometry and, with its observation ``record`` and the
    project's ``species`` (:func:`species_maxima`), its species' maximum length. The QA report (:func:`check`
    over a survey), the geo-calculator, the pick tool's message and review mode all come here, so that no
    two places disagree about an object."""
    item = Checked(str(stored.id), stored.kind, m, record, Place.of(stored), reason, weak_vertices(stored))
    return check([item], rules, species).issues


def object_facts(stored: StoredObject, m: Measurement | None, rules: QualityRules | None = None,
                 record: ObservationRecord | None = None, species: dict[str, Species] | None = None) -> list[str]:
    """The rules one object breaks (:func:`judge`), one line each ("rule: why"); empty when it passes them
    all. Notes (a rule that could not be checked) are not listed: they are no failure; nor is a missing
    measurement (``m`` None: its figures are not known here yet, which is no rule broken)."""
    return [f"{i.rule_name}: {i.message}" if i.rule in NAMED_IN_FACTS else i.message
            for i in judge(stored, m, rules, record, species) if i.status == FAIL and i.rule != "no_figures"]


#: rules whose message does not say which rule it is (the precision rules' and the species rule's do)
NAMED_IN_FACTS = ("weak_match", "geometry")


def species_maxima(species: list[Species]) -> dict[str, Species]:
    """The species list by the name records carry ("Genus species"), for :func:`check`."""
    return {s.name.lower(): s for s in species}


def check(objects: list[Checked], rules: QualityRules | None = None,
          species: dict[str, Species] | None = None) -> QualityReport:
    """Every rule every object breaks (pure: any thread). ``species``: :func:`species_maxima` of the
    project's list (None: the species rule is not checked)."""
    rules = rules or QualityRules()
    issues: list[Issue] = []
    for item in objects:
        m = item.measurement
        name = item.record.name if item.record is not None else ""

        def issue(rule, status, value, limit, unit, message, item=item, name=name):
            issues.append(Issue(item.object_id, rule, status, value, limit, unit, item.kind, name, item.place,
                                message))

        for rule, value, limit, unit, message in fact_issues(item.weak, m, rules):
            issue(rule, FAIL, value, limit, unit, message)
        if m is None:
            issue("no_figures", FAIL, None, None, "", item.reason or "no figures")
            continue
        measurement_kind_ = measurement_kind(m.kind)
        main = m.main
        for breach in rules.breaches(main, m.ray_rms_m, m.range_m, relative=measurement_kind_.relative_rule):
            issue(breach.rule, FAIL, breach.value, breach.limit, breach.unit, breach.text)
        if species is None or not name or main.name != "length":
            continue
        entry = species.get(name.lower())
        if entry is None:
            issue("unknown_species", NOTE, main.value, None, "m", f"{name} is not in the project's species list")
        elif entry.max_length_m is None:
            issue("no_maximum", NOTE, main.value, None, "m", f"{name} has no maximum length in the species list")
        elif main.value > entry.max_length_m:
            issue("species_max", FAIL, main.value, entry.max_length_m, "m",
                  f"length {main.value * 1000:.0f} mm > {name}'s maximum {entry.max_length_m * 1000:.0f} mm")
    return QualityReport(tuple(issues), len(objects))


def checked_objects(project: ProjectStore, rules: QualityRules | None = None) -> list[Checked]:
    """Read and measure every object of the survey (each once; one on several instants combined) for
    :func:`check`. Call on the project's thread."""
    cache: dict = {}
    instants = instants_by_object(project)
    pointing = pointing_in_use(project)  # read once, not once an object
    out = []
    for stored in survey_objects(project):
        place = Place.of(stored)
        record = project.record(stored.id)
        try:
            measurement, reason = evaluate(measurement_input(project, stored, cache, instants=instants,
                                                             pointing=pointing), rules), ""
        except UsvipsError as error:
            measurement, reason = None, str(error)
        out.append(Checked(str(stored.id), stored.kind, measurement, record, place, reason, weak_vertices(stored)))
    return out


def check_project(project: ProjectStore, rules: QualityRules | None = None) -> QualityReport:
    """The quality report of a whole project (its species list's maxima included); a stored calibration
    that cannot be read is an error (:func:`usvips.app.calibrations.require_readable_calibrations`)."""
    require_readable_calibrations(project)
    return check(checked_objects(project, rules), rules, species_maxima(project.species_list()))


#: the columns of the exported report (CheckEM's style: one row per object and rule, tab separated)
REPORT_COLUMNS = ["ObjectId", "Kind", "Genus species", "Rule", "Status", "Value", "Limit", "Unit", "Where",
                  "Pair", "Video", "FrameLeft", "Message"]


def report_rows(report: QualityReport) -> list[list]:
    """The report as rows of :data:`REPORT_COLUMNS` (lengths, RMS and range in mm as CheckEM gives them;
    precision/value as a fraction)."""
    rows = []
    for i in report.issues:
        scale = 1000.0 if i.unit == "m" else 1.0
        unit = "mm" if i.unit == "m" else i.unit

        def number(value, scale=scale):
            return "" if value is None else f"{value * scale:.6g}"

        rows.append([i.object_id, i.kind, i.species, i.rule_name, i.status, number(i.value), number(i.limit), unit,
                     i.place.where, i.place.pair or "", i.place.video or "",
                     "" if i.place.frame is None else i.place.frame, i.message])
    return rows
