"""The window's *Detect* (Qt-free): a detection model's proposals on the frame shown — the image pair, or
the video's current frame — or on a range of a video's frames, run on the window's worker with progress and
Stop, then stored as unreviewed objects made by the model (usvips/app/detection_service.py). The stored
proposals are drawn on the images as every object is (their keypoints as vertices) with a circle of 95 % around each
keypoint from its measured σ (:func:`sigma_circles`), the object list gives
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

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from usvips.app.detection_model import (
    DetectionModel,
    keep_model,
    load_model,
    model_path_for,
    project_model_path,
)
from usvips.app.detection_service import (
    DetectionPlan,
    DetectionRun,
    is_proposal,
    plan_detection,
    run_detection,
    store_proposals,
)
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, Source
from usvips.gui.workspace import Workspace
from usvips.store.annotator import current_annotator
from usvips.store.records import StoredObject, Vertex

#: a circle of radius k·σ holds a keypoint's true point with 95 % probability (σ per coordinate, 2-D
#: normal: k² is the chi-square quantile of 2 degrees of freedom, −2 ln 0.05)
CIRCLE_SIGMAS = float(np.sqrt(-2.0 * np.log(0.05)))


def sigma_circles(workspace: Workspace) -> dict[str, np.ndarray]:
    """Per side, (n, 3) circles (x, y px; radius px) around the keypoints of the model proposals on the
    pair or frame shown whose vertices are all still the model's keypoints: radius :data:`CIRCLE_SIGMAS` ×
    the keypoint's measured pointing σ (95 %); none for a proposal without a measured σ."""
    out = {"left": [], "right": []}
    place = workspace.place()
    for stored in workspace.cache.objects():
        if not is_proposal(stored) or workspace.place_of(stored.id) != place:
            continue
        for v in stored.vertices:
            if v.pointing_px is None:
                continue
            out["left"].append((v.xl, v.yl, CIRCLE_SIGMAS * v.pointing_px[0]))
            out["right"].append((v.xr, v.yr, CIRCLE_SIGMAS * v.pointing_px[1]))
    return {side: np.array(rows, float).reshape(-1, 3) for side, rows in out.items()}


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
        lines to show: one per proposal and the summary (:meth:`write` then :meth:`show`)."""
        self.write(run)
        return self.show(run)

    def write(self, run: DetectionRun) -> None:
        """Store the run's proposals in the project (GUI thread: the project's); a :class:`UsvipsError` when
        the project was closed while the run went on."""
        if self.workspace.project is None:
            raise UsvipsError(f"the project was closed: the {len(run.proposals)} proposal(s) found were not stored")
        store_proposals(self.workspace.project, run)

    def show(self, run: DetectionRun) -> list[str]:
        """Tell the workspace which of the stored run's objects are new (its views draw them), and return the
        lines to show: one per proposal and the summary."""
        added = tuple(p.object_id for p in run.proposals if p.object_id is not None)
        if added:
            self.workspace.objects_changed_in_store(added=added)
        return [p.line() for p in run.proposals] + run.summary()


def proposal_keypoints(workspace: Workspace) -> list[tuple[int, int, str, tuple[float, float]]]:
    """(object id, vertex index, side, pixel) of every keypoint of the proposals on the pair or frame shown
    whose vertices are all still the model's keypoints — the points a reviewer may drag to correct."""
    out = []
    place = workspace.place()
    for stored in workspace.cache.objects():
        if is_proposal(stored) and workspace.place_of(stored.id) == place:
            for index, v in enumerate(stored.vertices):
                out += [(stored.id, index, "left", (v.xl, v.yl)), (stored.id, index, "right", (v.xr, v.yr))]
    return out


def corrected_vertices(stored: StoredObject, index: int, side: str, pixel: tuple[float, float], geometry,
                       annotator: str) -> list[Vertex]:
    """The vertices of a proposal with vertex ``index``'s ``side`` ("left" or "right") point moved to
    ``pixel`` by a reviewer: that vertex's source becomes the reviewer's hand click (its pointing σ on the
    moved side the hand-click default, the other side's kept) and the object is measured again with its
    calibration (``geometry``: the pair's, None leaves the 3-D points out)."""
    if side not in ("left", "right"):
        raise UsvipsError(f"a keypoint is moved in the left or right image, not {side!r}")
    vertices = list(stored.vertices)
    if not 0 <= index < len(vertices):
        raise UsvipsError(f"object {stored.id} has vertices 1 to {len(vertices)}, not {index + 1}")
    old = vertices[index]
    x, y = float(pixel[0]), float(pixel[1])
    point = old.source.split("(", 1)[1].split(",", 1)[0].strip() if "(" in old.source else ""
    label = Source("hand click", point if point in ("snout", "fork") else "", annotator).label
    sigma = old.pointing_px if old.pointing_px is not None else None
    if sigma is not None:
        sigma = (HAND_CLICK_SIGMA_PX, sigma[1]) if side == "left" else (sigma[0], HAND_CLICK_SIGMA_PX)
    moved = replace(old, **({"xl": x, "yl": y} if side == "left" else {"xr": x, "yr": y}), source=label,
                    pointing_px=sigma)
    vertices[index] = moved
    if geometry is None or any(v.pointing_px is None for v in vertices):
        return [replace(v, xyz=None, covariance=None, calibration_id=None) for v in vertices]
    left = np.array([(v.xl, v.yl) for v in vertices])
    right = np.array([(v.xr, v.yr) for v in vertices])
    sigmas = np.array([v.pointing_px for v in vertices], float)
    m = measure_picks(stored.kind, geometry.calibration, left, right, geometry.station, geometry.frame,
                      pointing_sigma_px=sigmas)
    return [replace(v, xyz=tuple(map(float, m.points[i])), covariance=m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3],
                    calibration_id=geometry.calibration_id) for i, v in enumerate(vertices)]


def correct_keypoint(workspace: Workspace, object_id: int, index: int, side: str, pixel: tuple[float, float]) -> None:
    """Move a proposal's keypoint (vertex ``index``, in the ``side`` image) to ``pixel`` as one undoable
    edit (the object returns to unreviewed until accepted again)."""
    stored = workspace.stored_object(object_id)
    vertices = corrected_vertices(stored, index, side, pixel, workspace.geometry, current_annotator())
    project = workspace.project
    name = "snout" if index == 0 else "fork" if index == len(vertices) - 1 else f"vertex {index + 1}"
    workspace.edit_stored(f"correct the {side} {name} of object {object_id}", object_id,
                          lambda version: project.update_object(object_id, vertices=vertices,
                                                                expected_modified=version))
