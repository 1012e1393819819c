"""What a calibration from target views was made from, found again for its printable report: the target
file it names (its points are the control) and the views (the target found again in the image pairs it
names, or in the project's video it names, with the same choice of views), read only inside the
calibration file's folder as every data file of a report is
(:func:`usvips.io.calibration_report.resolve_recorded`).

Used by ``usvips calibration report`` on a board or video calibration, whose ``source`` names a target and
images or a video instead of a control file and an observation file.
"""

from __future__ import annotations

from pathlib import Path

from usvips.app.board_calibration import as_target, views_from_images, views_from_video
from usvips.core.calibration_targets import stereo_observations
from usvips.core.errors import UsvipsError
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_report import ReportData, resolve_recorded, sha256_of
from usvips.store.opening import open_project


def is_from_target(calibration: StereoCalibration) -> bool:
    """Whether the calibration was computed from views of a target (its source names one)."""
    return isinstance(calibration.source.get("target"), str)


def target_report_data(calibration: StereoCalibration, calibration_path: str | Path) -> ReportData:
    """The target's points and the views found again (fitted and held out), with every file read and its
    SHA-256; where a file is not found, the data stay None and the file is listed with why."""
    source = calibration.source
    base = Path(calibration_path).parent
    files: list[tuple[str, str, str]] = []
    target_path = resolve_recorded(source["target"], base)
    if isinstance(target_path, str):
        return ReportData(None, None, [("target", source["target"], target_path)])
    target = as_target(target_path)
    files.append(("target", str(target_path), sha256_of(target_path)))
    control = target.control_points()
    try:
        if isinstance(source.get("images"), list):
            found = []
            for recorded in source["images"]:
                path = resolve_recorded(str(recorded), base)
                files.append(("image", str(path if not isinstance(path, str) else recorded),
                              path if isinstance(path, str) else sha256_of(path)))
                found.append(path)
            if any(isinstance(path, str) for path in found) or len(found) % 2:
                return ReportData(control, None, files)
            views = views_from_images(target, list(zip(found[0::2], found[1::2], strict=True))).views
        elif isinstance(source.get("video"), str) and isinstance(source.get("project"), str):
            project_path = resolve_recorded(source["project"], base)
            if isinstance(project_path, str):
                return ReportData(control, None, files + [("project", source["project"], project_path)])
            files.append(("project", str(project_path), f"the stereo video {source['video']} in it"))
            with open_project(project_path, read_only=True) as project:
                views = views_from_video(project, source["video"], target, int(source.get("every", 5)),
                                         int(source.get("max_views", 30))).views
        else:
            return ReportData(control, None, files)
    except UsvipsError as error:
        files.append(("views", "found again", f"not found: {error}"))
        return ReportData(control, None, files)
    return ReportData(control, stereo_observations(list(views)), files)
