"""The QA panel's model (Qt-free): every object of the open survey that breaks a quality rule, checked
from the window's object cache.

The rules and the report are :mod:`usvips.app.quality`'s (ray-intersection RMS, precision/length, range,
length against the species' maximum; an object over several instants checked once, on its combined
figure). The figures come from the :class:`~usvips.gui.object_cache.ObjectCache`: an object whose figures
are cached under the current rules is not computed again; the others are computed in the same job (off
the GUI thread) and remembered in the cache for the object list and the calculator.

:meth:`QaModel.job` takes what the check needs on the GUI thread (references to the cached objects,
records and figures: no per-object work) and returns a plain function ``job(progress, cancelled)`` to run in
a worker, which checks and also makes the panel's rows and summary line; :meth:`QaModel.take` keeps that
result (the newest job wins; a job whose objects changed since is dropped by the cache, and the panel asks
again). So the GUI thread never computes or formats per object: 10,000 objects do not freeze the window.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from usvips.app.quality import FAIL, Checked, Issue, Place, QualityReport, check, species_maxima, weak_vertices
from usvips.gui.calculator import Result
from usvips.gui.signals import Signal

#: the panel's columns: the object, the rule it breaks, its value and the rule's limit (mm for lengths,
#: RMS and range; % for precision/length), the species and where it was measured
COLUMNS = ("object", "rule", "value", "limit", "species", "where")


def number_text(value: float | None, unit: str) -> str:
    """A rule's value or limit for a person: metres as millimetres, a fraction ("1") as a percentage."""
    if value is None:
        return ""
    if unit == "m":
        return f"{value * 1000:.1f} mm"
    if unit == "1":
        return f"{value * 100:.1f} %"
    return f"{value:.4g} {unit}".strip()


@dataclass(frozen=True)
class QaRow:
    """One line of the panel: an :class:`~usvips.app.quality.Issue` as text (``cells`` in
    :data:`COLUMNS` order), its object id and place (to jump there), and whether it is a failure or a
    note (a species without a maximum, a species not in the list)."""

    object_id: int
    cells: tuple[str, ...]
    failure: bool
    place: Place
    message: str

    @classmethod
    def of(cls, issue: Issue) -> QaRow:
        rule = issue.rule_name if issue.status == FAIL else f"note: {issue.rule_name}"
        cells = (issue.object_id, rule, number_text(issue.value, issue.unit), number_text(issue.limit, issue.unit),
                 issue.species, issue.place.where)
        return cls(int(issue.object_id), cells, issue.status == FAIL, issue.place, issue.message)


def qa_rows(report: QualityReport) -> list[QaRow]:
    """The report's issues as rows: failures first, then notes, each by object id."""
    return [QaRow.of(i) for i in sorted(report.issues, key=lambda i: (i.status != FAIL, int(i.object_id)))]


def summary(report: QualityReport | None) -> str:
    """One line over the list: how many objects were checked and how many break a rule."""
    return "checking…" if report is None else report.summary()


@dataclass(frozen=True)
class QaResult:
    """What a check job gives the panel: the report, the figures it computed (for the cache), the rows
    and the summary line (made in the worker)."""

    report: QualityReport
    computed: dict[int, Result]
    rows: list[QaRow]
    text: str


class QaModel:
    """The survey's QA report over ``workspace``'s object cache (its quality rules, its species list).
    ``changed()`` fires when :attr:`rows` and :attr:`report` are new."""

    def __init__(self, workspace) -> None:
        self.workspace = workspace
        self.report: QualityReport | None = None
        self.rows: list[QaRow] = []
        self.text = summary(None)  #: the line over the list
        self.changed = Signal()

    def job(self) -> Callable[..., QaResult]:
        """Take what the check needs (GUI thread: the cached objects, records and figures, the species
        list) and return the check as ``job(progress, cancelled)`` → :class:`QaResult`."""
        ws = self.workspace
        cache = ws.cache
        project = cache.project
        links = project.instant_links() if project is not None else {}
        objects = [o for o in cache.objects() if o.id not in links]  # an object over several instants: once
        known = {o.id: cache.known_figures(o.id) for o in objects}
        missing = [i for i, result in known.items() if result is None]
        figures = cache.figures_job(missing) if missing else None
        records = {o.id: cache.record(o.id) for o in objects}
        rules = ws.rules
        species = species_maxima(project.species_list()) if project is not None else {}

        def run(progress=None, cancelled=None) -> QaResult:
            computed = figures(progress, cancelled) if figures is not None else {}
            checked = []
            for stored in objects:  # frozen records: read here, off the GUI thread
                result = known[stored.id] or computed.get(stored.id)
                if result is None:  # cancelled before its figures were computed
                    continue
                checked.append(Checked(str(stored.id), stored.kind, result.measurement, records[stored.id],
                                       Place.of(stored), result.reason or "no figures", weak_vertices(stored)))
            report = check(checked, rules, species)
            return QaResult(report, computed, qa_rows(report), summary(report))

        run.figures = figures
        return run

    def take(self, job, result: QaResult) -> None:
        """Keep a job's report, rows and summary (and its computed figures in the cache) and announce them."""
        if job.figures is not None:
            self.workspace.cache.remember(job.figures, result.computed)
        self.report, self.rows, self.text = result.report, result.rows, result.text
        self.changed.emit()

    def refresh_now(self) -> None:
        """Check on this thread (tests, small surveys)."""
        job = self.job()
        self.take(job, job())

    def clear(self) -> None:
        self.report, self.rows, self.text = None, [], summary(None)
        self.changed.emit()
