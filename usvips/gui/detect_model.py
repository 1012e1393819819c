"""The window's *Detect* (Qt-free): a detection model's proposals on the frame shown — the image pair, or
the video's current frame — or on a range of a video's frames, run on the window's worker with progress and
Stop, then stored as unreviewed objects made by the model (usvips/app/detection_service.py). The stored
proposals are drawn on the images as every object is (their keypoints as vertices) with a circle of 95 % around each
keypoint from its measured σ (:mod:`usvips.gui.proposal_marks`), the object list gives
their lengths with σ, and review mode walks them: A accepts, F flags (rejects, with a reason), a vertex
re-picked corrects a keypoint (the edit returns the object to unreviewed until accepted again).

:meth:`DetectSession.plan` reads the project (the GUI thread); :meth:`DetectSession.job` is the worker's
function ``job(progress, cancelled)``; :meth:`DetectSession.store` writes and tells the workspace. On a
range of a video's frames, the proposals of one fish on successive frames are stored as one object with
further instants (usvips/app/detection_tracks.py): the object list shows the fish once, its length combined.

The model is the one chosen (Detection model…), which becomes the project's default
(:func:`usvips.app.detection_model.remember_model`), or else the project's default model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

from usvips.app.detection_model import (
    DetectionModel,
    keep_model,
    load_model,
    model_path_for,
    project_model_path,
)
from usvips.app.detection_service import (
    STORE_STEP,
    DetectionPlan,
    DetectionRun,
    StoringStep,
    plan_detection,
    run_detection,
    storing_proposals,
)
from usvips.core.errors import UsvipsError
from usvips.gui.workspace import Workspace


class DetectSession:
    """Detect in ``workspace``'s project; ``model`` is loaded once per description file chosen."""

    def __init__(self, workspace: Workspace) -> None:
        self.workspace = workspace
        self.model: DetectionModel | None = None
        self.model_path: str | None = None

    def choose_model(self, path: str, remember: bool = False) -> DetectionModel:
        """Load the model a description file describes (refused by name when it is bad); ``remember``: make
        it the open project's default model too."""
        if self.model is None or not self.is_loaded(path):  # once per file, however its path is spelt
            self.model, self.model_path = load_model(path), path
        if remember and self.workspace.project is not None:
            keep_model(self.workspace.project, path)  # loaded above: not loaded again to check it
        return self.model

    def is_loaded(self, path: str) -> bool:
        """Whether the model ``path`` describes is the one loaded (however its path is spelt)."""
        return self.model_path is not None and (
            Path(path).expanduser().resolve() == Path(self.model_path).expanduser().resolve())

    def adopt(self, model: DetectionModel, path: str, remember: bool = False) -> None:
        """Keep ``model``, loaded from ``path`` on the worker, as the session's (GUI thread); ``remember``: make
        it the open project's default too (it loaded, so it is not loaded again to check it)."""
        if not self.is_loaded(path):
            self.model, self.model_path = model, path
        if remember and self.workspace.project is not None:
            keep_model(self.workspace.project, path)

    def project_model(self) -> DetectionModel | None:
        """The open project's default model, loaded (None: the project has none); a default whose file is gone
        is a :class:`UsvipsError` naming it."""
        project = self.workspace.project
        if project is None or project_model_path(project) is None:
            return None
        return self.choose_model(str(model_path_for(project)))

    def plan(self, frames: int = 1, every: int = 1) -> DetectionPlan:
        """What to detect on: the image pair shown, or ``frames`` frames of the video shown from its current
        frame on, every ``every``-th; a :class:`UsvipsError` saying what is missing."""
        ws = self.workspace
        if ws.project is None:
            raise UsvipsError("open a project first")
        if ws.pair is None:
            raise UsvipsError("show an image pair or a video frame to detect on")
        if ws.video_frame is None:
            return plan_detection(ws.project, pair=ws.pair)
        label, frame = ws.video_frame[0], int(ws.video_frame[1])
        count = ws.project.video(label).frame_count
        last = min(frame + max(int(frames), 1) * max(int(every), 1) - 1, count - 1)
        return plan_detection(ws.project, video=label, every=every, frames=(frame, last))

    def job(self, plan: DetectionPlan, path: str | None = None
            ) -> Callable[[Callable[[float], None], Callable[[], bool]], DetectionRun]:
        """The worker's function: detect on every frame of ``plan``, reporting the fraction done; a Stop
        keeps the frames done. ``path``: the model to detect with, loaded by the worker first unless it is the
        one loaded (loading runs the network once: not on the window's thread); the run carries it
        (:meth:`adopt` keeps it). Without ``path``, the model loaded."""
        if path is not None and self.is_loaded(path):
            path = None
        if path is None and self.model is None:
            raise UsvipsError("choose a detection model first")
        model = self.model

        def run(progress: Callable[[float], None], cancelled: Callable[[], bool]) -> DetectionRun:
            used = model if path is None else load_model(path)
            return run_detection(plan, used, cancelled, lambda done, total: progress(done / max(total, 1)))

        return run

    def store(self, run: DetectionRun) -> list[str]:
        """Store the run's proposals (GUI thread), tell the workspace which objects are new, and return the
        lines to show: one per proposal and the summary (:meth:`write` then :meth:`lines`)."""
        self.write(run)
        return self.lines(run)

    def write(self, run: DetectionRun) -> None:
        """Store the run's proposals in the project (GUI thread: the project's) and tell the workspace (its views
        draw them); a :class:`UsvipsError` when the project was closed while the run went on."""
        for _ in self.writing(run, per_step=max(len(run.proposals), 1)):
            pass

    def writing(self, run: DetectionRun, per_step: int = STORE_STEP) -> Iterator[StoringStep]:
        """:meth:`write` a slice at a time (:func:`usvips.app.detection_service.storing_proposals`), for the
        window to take a step a turn of its event loop: each step stores at most ``per_step`` proposals or
        links at most ``per_step`` instants, tells the workspace of them at once (its views — the object list,
        the panes, the σ circles — take them in the same step; what this window stored but had not told would
        reach it as a colleague's change) and yields what it stored. A :class:`UsvipsError` when the project
        was closed while the run went on, or is closed (another opened) between two steps: the steps done are
        stored, the rest not, and the error says how many were."""
        project = self.workspace.project
        if project is None:
            raise UsvipsError(f"the project was closed: the {len(run.proposals)} proposal(s) found were not stored")
        for step in storing_proposals(project, run, per_step=per_step):
            if step.added or step.links:
                self.workspace.objects_changed_in_store(added=step.added, updated=step.changed)
            yield step
            if self.workspace.project is not project:
                stored = sum(p.object_id is not None for p in run.proposals)
                raise UsvipsError(f"the project was closed while the run's proposals were being stored: {stored} of "
                                  f"the {len(run.proposals)} proposal(s) found were stored (unreviewed), the rest not")

    @staticmethod
    def lines(run: DetectionRun) -> list[str]:
        """The lines a stored run shows: one per proposal and the summary."""
        return [p.line() for p in run.proposals] + run.summary()
