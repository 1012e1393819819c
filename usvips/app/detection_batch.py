"""``usvips batch detect``'s task: one project's image pairs and videos run through a detection model, the
proposals stored in the project (usvips/app/detection_service.py). A plain function of paths, so that the
batch runner's process pool or a Dask cluster runs it (usvips/app/batch.py, usvips/app/batch_cluster.py).

Every image pair with images and every video is detected on (a video on every ``every``-th left frame,
its proposals of one fish on successive frames joined as instants of one object); one without an active
calibration is skipped and said so, as a pair without images is. Without a model given, each project's
default model is used (else the shipped one)."""

from __future__ import annotations

from pathlib import Path

from usvips.app.calibrations import active_calibration_id
from usvips.app.detection_model import load_model, model_path_for
from usvips.app.detection_service import detect_in_project
from usvips.core.errors import UsvipsError
from usvips.io.file_errors import not_a_file


def detect_project_task(project: str, model: str | None = None, every: int = 1) -> dict:
    """Detect with the model described by ``model`` (a description file; None: the project's default, else
    the shipped one) on every pair and video of ``project``. Returns {"proposals": stored, "duplicates": not
    stored, "instants": proposals joined as further instants of a fish, "looked_at": pairs and videos,
    "skipped": [why, ...], "out": project}."""
    from usvips.store.location import is_server_location, shown
    from usvips.store.opening import open_project

    if not is_server_location(project) and not Path(project).is_file():
        raise not_a_file(project, "project file")
    loaded = load_model(model) if model is not None else None
    stored = duplicates = looked = instants = 0
    skipped: list[str] = []
    with open_project(project) as opened:
        loaded = loaded or load_model(model_path_for(opened))
        videos = {v.label for v in opened.videos()}
        targets = [("video", label) for label in sorted(videos)]
        for pair in opened.pairs():
            if pair.label in videos:
                continue
            if pair.left is None or pair.right is None:
                skipped.append(f"pair {pair.label}: no image files")
                continue
            targets.append(("pair", pair.label))
        for kind, label in targets:
            if active_calibration_id(opened, label) is None:
                skipped.append(f"{kind} {label}: no active calibration")
                continue
            try:
                run = detect_in_project(opened, loaded, label if kind == "pair" else None,
                                        label if kind == "video" else None, every if kind == "video" else 1)
            except UsvipsError as error:
                skipped.append(f"{kind} {label}: {error}")
                continue
            looked += 1
            stored += sum(p.object_id is not None for p in run.proposals)
            duplicates += sum(p.duplicate_of is not None for p in run.proposals)
            instants += run.joined.instants if run.joined is not None else 0
    return {"proposals": stored, "duplicates": duplicates, "instants": instants, "looked_at": looked,
            "skipped": skipped,
            "out": shown(project)}
