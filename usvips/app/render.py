"""Rendering a sample project from a scene description: images, control, observations, truth, a
calibration and optionally a stereo video (for ``usvips render`` and anyone else who renders a scene).

:func:`render_scene` renders into a staging folder beside the output and moves the result in only when
everything was written. Units: metres for the scene, pixels for images and observations."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.errors import ConvergenceError, InputFileError, concerning
from usvips.core.observations import StereoObservations
from usvips.core.synth import Disc, Seafloor, Water, render
from usvips.io.atomic import OutputFileError, replacing, write_text_atomic
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.images import write_image
from usvips.io.manifest import split_known
from usvips.io.scene import Scene, read_scene
from usvips.io.tables import read_control, read_observations, write_control, write_observations
from usvips.io.video import write_video
from usvips.io.video_writer import transcode_h264
from usvips.locations import resources_folder

RESOURCES = resources_folder()


def _targets_file(scene, name: str) -> Path:
    """The frame's target file: a plain ``.csv`` name (checked by the scene reader) beside the scene or in
    resources/; never a path that leads elsewhere."""
    for folder in (scene.path.parent, RESOURCES):
        candidate = folder / name
        if candidate.is_file() and candidate.resolve().parent == folder.resolve():
            return candidate
    raise InputFileError(str(scene.path), f"frame.targets: no file {name!r} beside the scene or in resources/")


def _camera_truth(camera) -> dict:
    interior = {k: getattr(camera.interior, k) for k in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2")}
    exterior = {k: getattr(camera.exterior, k) for k in ("X0", "Y0", "Z0", "omega", "phi", "kappa")}
    return {"interior": interior, "exterior": exterior, "housing": {"kind": camera.housing.kind,
                                                                     **camera.housing.parameters()}}


def _object_truth(label: str, kind: str, item) -> dict:
    truth = {"label": label, "kind": kind, "points": item.points()}
    if kind in ("fish", "pipe"):
        truth["length"] = item.length
    return truth


def _object_pixels(scene, index: int, camera, objects) -> dict:
    """Exact pixel positions of every object's named points; an object point out of view is an error."""
    pixels = {}
    for label, _, item in objects:
        names, points = zip(*item.points().items(), strict=True)
        projection = camera.project(np.asarray(points, float))
        if not projection.ok.all():
            raise InputFileError(str(scene.path), f"pairs[{index}]: object {label!r} is not seen by every camera "
                                 "(behind a camera or through no housing surface)")
        pixels[label] = {name: projection.pixels[i].tolist() for i, name in enumerate(names)}
    return pixels


def _calibrate(out: Path, scene, control, manifest: dict, size: tuple[int, int]) -> None:
    """Calibrate the rendered rig as a user would (phase 1 in air, then all water pairs jointly) from the
    written observation files, so that the sample opens ready to measure: ``calibration.json`` is active
    for every underwater pair."""
    options = CalibrationOptions(sigma_px=0.5, image_size=size)
    air = calibrate_air(control, read_observations(out / "observations_air.csv"), options,
                        {"control": "control.csv", "observations": "observations_air.csv"})
    if not air.adjustment.converged:
        raise ConvergenceError(f"{scene.path}: phase 1 of the sample's calibration did not converge")
    fix_values, priors = split_known(scene.housing_known)  # what the rig's user knows of its housing
    known = CalibrationOptions(sigma_px=0.5, image_size=size, fix_values=fix_values, priors=priors)
    water = calibrate_water(air.calibration, scene.data["housing"]["kind"], control,
                            read_observations(out / "observations_water.csv"), known,
                            {"control": "control.csv", "observations": "observations_water.csv",
                             "base": "calibration_air.json"})
    if not water.adjustment.converged:
        raise ConvergenceError(f"{scene.path}: phase 2 of the sample's calibration did not converge")
    for name, result in (("calibration_air.json", air), ("calibration.json", water)):
        write_text_atomic(out / name, json.dumps(calibration_to_dict(result.calibration), indent=2,
                                                 allow_nan=False) + "\n")
    manifest["calibrations"] = [
        {"file": "calibration_air.json", "active_for": [p["label"] for p in manifest["pairs"] if p["medium"] == "air"]},
        {"file": "calibration.json", "active_for": [p["label"] for p in manifest["pairs"] if p["medium"] == "water"]}]


def _frame_truth(camera, item, size: tuple[int, int], time_s: float, index: int) -> dict:
    """The moving object's named points (m) at one frame and their pixels (None when out of the image)."""
    names, points = zip(*item.points().items(), strict=True)
    projection = camera.project(np.asarray(points, float))
    w, h = size
    pixels = {}
    for i, name in enumerate(names):
        x, y = projection.pixels[i]
        inside = bool(projection.ok[i]) and -0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5
        pixels[name] = [float(x), float(y)] if inside else None
    return {"frame": index, "time_s": time_s, "points": dict(zip(names, map(list, points), strict=True)),
            "pixels": pixels}


def _render_video(out: Path, scene, discs, floor, water, objects) -> dict:
    """``video_left.avi`` and ``video_right.avi``: the object moving at constant velocity; the right video
    lags by ``frame_offset`` frames. Returns the truth: per camera and frame, the time, the object's
    points and their pixels."""
    video = scene.data["video"]
    index = next(i for i, p in enumerate(scene.data["pairs"]) if p["label"] == video["pair"])
    pair = scene.data["pairs"][index]
    rig = scene.rig(pair)
    image = scene.data["image"]
    contents = scene.contents(pair)
    medium = pair.get("medium", "water")
    moving = next(item for label, _, item in objects if label == video["object"])
    still = [item for label, _, item in objects if label != video["object"]]
    fps, offset, velocity = video["fps"], video["frame_offset"], np.asarray(video["velocity"], float)
    size = (image["width"], image["height"])
    truth = {"pair": video["pair"], "object": video["object"], "fps": fps, "frames": video["frames"],
             "frame_offset": offset, "velocity": velocity.tolist(),
             "convention": "right frame j shows the instant of left frame j - frame_offset; time = "
                           "(frame - lag) / fps seconds, lag 0 (left) or frame_offset (right)"}
    for side, camera in (("left", rig.left), ("right", rig.right)):
        lag = offset if side == "right" else 0
        frames_truth = []

        def frames(camera=camera, lag=lag, side=side, frames_truth=frames_truth):
            for j in range(video["frames"]):
                time_s = (j - lag) / fps
                item = moving.translated(velocity * time_s)
                frames_truth.append(_frame_truth(camera, item, size, time_s, j))
                yield render(camera, discs if "frame" in contents else [], floor if "floor" in contents else None,
                             water if medium == "water" else None, supersample=video.get("supersample", 1),
                             seed=scene.seed * 100_000 + 10_000 + 2 * j + (side == "right"),
                             objects=still + [item], colour=bool(pair.get("colour", image.get("colour", False))),
                             lighting=float(pair.get("lighting", image.get("lighting", 0.0))),
                             interlace=float(image.get("interlace", 0.0)))

        write_video(out / f"video_{side}.avi", frames(), fps)
        transcode_h264(out / f"video_{side}.avi", out / f"video_{side}.mp4")  # when FFmpeg has an H.264 encoder
        truth[side] = frames_truth
    return truth


def render_scene(scene_path: str | Path, out: str | Path, replace: bool = False) -> Scene:
    """Render the scene described at ``scene_path`` (JSON) into the folder ``out`` (created if needed) and
    return the scene read. It is rendered into a staging folder beside ``out`` and moved in only when
    everything was written: a failure leaves ``out`` as it was. Every file name comes from this module
    (pair labels are checked as plain names by the scene reader), so nothing is written outside ``out``.
    A file of ``out`` the rendering would replace that is the scene itself or holds a USVIPS calibration
    or project is refused (:func:`usvips.io.atomic.replacing`, before anything is moved in) unless
    ``replace``: then it is kept as ``NAME.bak``."""
    scene = read_scene(scene_path)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise concerning(OutputFileError(str(out), "the output must be a folder (it is a file)"), "out")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.render-", dir=str(out.parent)))
    except OSError as error:
        raise OutputFileError(str(out), f"cannot create the output folder: {error.strerror or error}") from None
    try:
        _render(scene, staging, Path(scene_path).name)
        targets = [out / f.relative_to(staging) for f in staging.rglob("*") if f.is_file()] if out.exists() else []
        targets = [t for t in targets if t.exists() or t.is_symlink()]  # only what would be replaced
        with replacing(targets, [scene_path], replace=replace):
            _publish(staging, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return scene


def _publish(staging: Path, out: Path) -> None:
    """Move a complete rendering into ``out`` (renamed whole when ``out`` does not exist yet)."""
    try:
        if not out.exists():
            os.rename(staging, out)
            return
        for source in sorted(staging.rglob("*")):
            target = out / source.relative_to(staging)
            if source.is_dir():
                if target.exists() and not target.is_dir():
                    raise OutputFileError(str(target), "is a file where the rendering needs a folder")
                target.mkdir(exist_ok=True)
            else:
                if target.is_dir():
                    raise OutputFileError(str(target), "is a folder where the rendering writes a file")
                os.replace(source, target)
    except OSError as error:
        raise OutputFileError(str(out), f"cannot move the rendering in: {error.strerror or error}") from None


def _render(scene, out: Path, scene_name: str) -> None:
    """Everything ``usvips render`` writes, into the (new, empty) folder ``out``."""
    data = scene.data
    (out / "images").mkdir()
    frame = data.get("frame")
    control = read_control(_targets_file(scene, frame["targets"])) if frame else None
    discs = [Disc(tuple(p), (0.0, 0.0, 1.0), radius=frame.get("radius", 0.04), cross_width=0.2 * frame.get(
        "radius", 0.04)) for p in control.xyz] if control is not None else []
    floor_spec = data.get("floor")
    floor = Seafloor((0.0, 0.0, floor_spec["z"]), cell=floor_spec.get("cell", 0.03), mean=floor_spec.get("mean", 70),
                     contrast=floor_spec.get("contrast", 25), seed=floor_spec.get("seed", 0)) if floor_spec else None
    water = Water(**data["water"]) if "water" in data else Water()
    image = data["image"]
    noise_px = float(data.get("observation_noise_px", 0.3))
    rng = np.random.default_rng(scene.seed)
    objects = scene.objects()
    truth = {"scene": scene.name, "pairs": [], "objects": [_object_truth(label, kind, item)
                                                         for label, kind, item in objects]}
    observations: dict[str, list] = {"air": [], "water": []}
    pairs_manifest = []
    for index, pair in enumerate(data["pairs"]):
        rig = scene.rig(pair)
        medium = pair.get("medium", "water")
        entry = {"label": pair["label"], "medium": medium, "cameras": {}}
        contents = scene.contents(pair)
        shown = [item for _, _, item in objects] if "objects" in contents else []
        projections = []
        for side, camera in (("left", rig.left), ("right", rig.right)):
            picture = render(camera, discs if "frame" in contents else [], floor if "floor" in contents else None,
                             water if medium == "water" else None, supersample=image.get("supersample", 3),
                             seed=scene.seed * 100 + index * 2 + (side == "right"), objects=shown,
                             colour=bool(pair.get("colour", image.get("colour", False))),
                             lighting=float(pair.get("lighting", image.get("lighting", 0.0))),
                             interlace=float(image.get("interlace", 0.0)))
            write_image(out / "images" / f"{pair['label']}_{side}.png", picture)
            entry["cameras"][side] = _camera_truth(camera)
            if shown:
                entry["cameras"][side]["objects"] = _object_pixels(scene, index, camera, objects)
            projection = camera.project(control.xyz) if control is not None and "frame" in contents else None
            projections.append(projection)
            if projection is not None:
                entry["cameras"][side]["targets"] = {
                    pid: (projection.pixels[i].tolist() if projection.ok[i] else None)
                    for i, pid in enumerate(control.ids)}
        if projections[0] is not None:
            seen = projections[0].ok & projections[1].ok
            if seen.sum() < 6:
                raise InputFileError(str(scene.path), f"pairs[{index}]: only {int(seen.sum())} targets are seen by "
                                     "both cameras: is the frame behind the cameras or out of view?")
            idx = np.flatnonzero(seen)
            left = projections[0].pixels[idx] + rng.normal(0, noise_px, (idx.size, 2))
            right = projections[1].pixels[idx] + rng.normal(0, noise_px, (idx.size, 2))
            observations[medium].append(StereoObservations(tuple(control.ids[i] for i in idx), left, right,
                                                           (pair["label"],) * idx.size))
        truth["pairs"].append(entry)
        entry["contents"] = list(contents)
        pairs_manifest.append({"label": pair["label"], "medium": medium, "left": f"images/{pair['label']}_left.png",
                               "right": f"images/{pair['label']}_right.png"})
    manifest = {"format": "usvips-sample", "version": 1, "name": scene.name,
                "description": data.get("description", f"rendered from {scene_name}"),
                "housing": data["housing"]["kind"], "pairs": pairs_manifest, "observations": [], "truth": "truth.json"}
    if scene.housing_known:
        manifest["housing_known"] = {k: v if s is None else [v, s] for k, (v, s) in scene.housing_known.items()}
    if control is not None:
        write_control(out / "control.csv", control)
        manifest["control"] = "control.csv"
        for medium, role in (("air", "calibration-air"), ("water", "calibration-water")):
            if observations[medium]:
                joined = observations[medium]
                merged = StereoObservations(sum((o.ids for o in joined), ()), np.vstack([o.left for o in joined]),
                                            np.vstack([o.right for o in joined]), sum((o.pairs for o in joined), ()))
                write_observations(out / f"observations_{medium}.csv", merged)
                manifest["observations"].append({"file": f"observations_{medium}.csv", "role": role,
                                                 "pairs": list(dict.fromkeys(merged.pairs))})
        if observations["air"] and observations["water"]:
            _calibrate(out, scene, control, manifest, (image["width"], image["height"]))
    if "video" in data:
        truth["video"] = _render_video(out, scene, discs, floor, water, objects)
        manifest["video"] = {"left": "video_left.avi", "right": "video_right.avi",
                             "frame_offset": data["video"]["frame_offset"]}
    truth["observation_noise_px"] = noise_px
    write_text_atomic(out / "truth.json", json.dumps(truth, indent=1, allow_nan=False) + "\n")
    write_text_atomic(out / "project.json", json.dumps(manifest, indent=2) + "\n")
