"""The detection model a project's proposals come from: its description file read, its ONNX model checked
by one trial run (a description that does not match the model's output is refused here, naming the file),
and its identity — the description's name and the model file's SHA-256 — recorded with every proposal.

A model is chosen by its description file (docs/detection.md); without one, the project's default model
(:func:`remember_model`) is used, else the model shipped in ``resources/models/`` when exactly one is there.
The project's default is kept in the store's key/value drafts (``ProjectStore.set_draft``, key
:data:`PROJECT_MODEL_KEY`: the store has no settings table of its own, and no schema change is made), so a
file project and a server survey both keep it, for everyone who opens them.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.core.detection import Detector, ModelDescription
from usvips.core.detection.keypoint_sigma import StereoSigma
from usvips.core.detection.letterbox import Letterbox
from usvips.core.detection.runner import OnnxDetector
from usvips.core.errors import InputFileError, InvalidParameterError, UsvipsError
from usvips.io.model_description import onnx_detector, read_model_description, read_model_file
from usvips.locations import resources_folder
from usvips.store.interface import ProjectStore

#: the project's key/value entry naming its default detection model's description file (absolute path)
PROJECT_MODEL_KEY = "detection-model"


@dataclass(frozen=True)
class DetectionModel:
    """A model ready to run: its ``name`` (the description file's stem), the model file's ``sha256`` (hex),
    its :class:`ModelDescription` and ``make_detector``, which gives a fresh detector for the calling thread
    (a network is not shared between threads)."""

    name: str
    sha256: str
    description: ModelDescription
    make_detector: Callable[[], Detector]

    @property
    def tag(self) -> str:
        """How proposals name their model: ``name sha256:<first 12 hex digits>``."""
        return f"{self.name} sha256:{self.sha256[:12]}"

    def keypoint_sigma(self, keypoints: tuple[str, ...],
                       image_size: tuple[int, int] | None = None) -> dict[str, float] | None:
        """The measured pointing sigma (image px) of each of ``keypoints``: the description's
        ``[keypoint_sigma]`` table; else, for an image of ``image_size`` (width, height px), the held-out
        validation's sigma (model input px) divided by the letterbox's scale; None when any was never measured."""
        sigmas = {name: self.description.measured_sigma(name) for name in keypoints}
        if any(v is None for v in sigmas.values()):
            validated = self._validated_sigma(keypoints, image_size)
            return validated
        return sigmas  # type: ignore[return-value]

    def _validated_sigma(self, keypoints: tuple[str, ...],
                         image_size: tuple[int, int] | None) -> dict[str, float] | None:
        description = self.description
        if not description.validated_keypoint_sigma or image_size is None:
            return None
        table = dict(zip(description.keypoint_names, description.validated_keypoint_sigma, strict=True))
        if any(name not in table for name in keypoints):
            return None
        box = Letterbox.fit(image_size, (description.input_width, description.input_height))
        scale = min(box.scale_x, box.scale_y)  # input px per image px: one scale when the aspect is kept
        return {name: table[name] / scale for name in keypoints}

    def input_scale(self, image_size: tuple[int, int]) -> float:
        """The model's input pixels per image pixel for an image of ``image_size`` (width, height px): the
        letterbox's one scale (the aspect is kept)."""
        box = Letterbox.fit(image_size, (self.description.input_width, self.description.input_height))
        return min(box.scale_x, box.scale_y)

    def stereo_sigma(self, keypoints: tuple[str, ...]) -> StereoSigma | None:
        """The description's ``[stereo_sigma]`` (how the refined stereo keypoints err by the fish's size) when
        it covers ``keypoints`` and no ``[keypoint_sigma]`` table (measured from reviews of real proposals,
        which then rules) gives theirs; else None: each keypoint's one sigma, alike and independent in both
        images (:meth:`keypoint_sigma`)."""
        stereo = self.description.stereo_sigma
        if stereo is None or not all(k in stereo.left for k in keypoints) or all(
                self.description.measured_sigma(k) is not None for k in keypoints):
            return None
        return stereo

    def sigma_basis(self, keypoints: tuple[str, ...]) -> str:
        """What the lengths' keypoint sigma rests on: the ``[stereo_sigma]`` table (:meth:`stereo_sigma`), else
        what the sigmas :meth:`keypoint_sigma` gives were measured on."""
        stereo = self.stereo_sigma(keypoints)
        if stereo is not None:
            return (f"rendered stereo clips by the fish's size, the refined right keypoints following the left "
                    f"({stereo.basis or 'basis not stated'})")
        if all(self.description.measured_sigma(k) is not None for k in keypoints):
            return self.description.keypoint_sigma_basis or "basis not stated"
        source = self.description.validation_source or "data not stated"
        return f"the model's held-out validation ({source}), scaled from its input pixels to the image's"

    def sigma_line(self, keypoints: tuple[str, ...], image_size: tuple[int, int] | None = None) -> str:
        """One line on the keypoints' pointing sigma: measured (values and basis), or why lengths get none."""
        stereo = self.stereo_sigma(keypoints)
        if stereo is not None and self.keypoint_sigma(keypoints, image_size or (640, 480)) is not None:
            values = ", ".join(f"{k} {stereo.left[k](50.0):.2f}-{stereo.left[k](200.0):.2f} input px, match "
                               f"{stereo.match[k](50.0):.2f}-{stereo.match[k](200.0):.2f} image px" for k in keypoints)
            return (f"model {self.tag}: lengths' keypoint pointing sigma by the fish's size, the refined right "
                    f"keypoints following the left, measured ({self.sigma_basis(keypoints)}); for a fish 50-200 px "
                    f"long: {values}")
        sigmas = self.keypoint_sigma(keypoints, image_size)
        if sigmas is None:
            if self.description.validated_keypoint_sigma and image_size is None:
                described = self.description
                values = ", ".join(f"{k} {v:.2f}" for k, v in zip(described.keypoint_names,
                                                                     described.validated_keypoint_sigma, strict=True))
                return (f"model {self.tag}: keypoint pointing sigma measured on held-out validation, in the "
                        f"model's input pixels: {values} (scaled to each image's pixels by its letterbox)")
            missing = [k for k in keypoints if self.description.measured_sigma(k) is None]
            return (f"model {self.tag}: no measured pointing sigma for {', '.join(missing)}: proposals are stored "
                    "as picks without a length (a length's sigma is never assumed; measure the model's keypoint "
                    "sigma and record it in its description's [keypoint_sigma] table)")
        values = ", ".join(f"{k} {v:.2f} px" for k, v in sigmas.items())
        return f"model {self.tag}: keypoint pointing sigma measured ({self.sigma_basis(keypoints)}): {values}"


def load_model(path: str | Path) -> DetectionModel:
    """The model a description file describes, its ONNX file read, hashed and run once on a blank image of
    its input size: an output that does not match the description is an :class:`InputFileError` naming the
    description file."""
    path = Path(path)
    description = read_model_description(path)
    model, data = read_model_file(path, description)

    def make() -> OnnxDetector:
        return onnx_detector(description, data, model)

    trial = make()
    try:
        trial.detect(np.full((description.input_height, description.input_width, 3), description.pad_value, np.uint8))
    except InvalidParameterError as error:
        raise InputFileError(str(path), f"does not match its model's output: {error.problem}") from None
    except Exception as error:  # noqa: BLE001 (OpenCV's network refusing to run is the model's problem, named)
        reason = str(error).strip().splitlines()[-1] if str(error).strip() else type(error).__name__
        raise InputFileError(str(model), f"OpenCV cannot run the model: {reason}") from None
    return DetectionModel(path.stem, hashlib.sha256(data).hexdigest(), description, make)


def bundled_model_path() -> Path:
    """The description file of the model shipped in ``resources/models/`` (the only ``.toml`` there); a
    :class:`UsvipsError` when none or several are shipped."""
    folder = resources_folder() / "models"
    found = sorted(folder.glob("*.toml")) if folder.is_dir() else []
    if len(found) != 1:
        raise UsvipsError(f"no model was given and {'none' if not found else len(found)} "
                          f"{'is' if len(found) < 2 else 'are'} shipped in {folder}: name a model description file")
    return found[0]


def project_model_path(project: ProjectStore) -> Path | None:
    """The description file of the project's default detection model; None when none was chosen."""
    text = project.draft(PROJECT_MODEL_KEY)
    return Path(text) if text else None


def remember_model(project: ProjectStore, path: str | Path) -> Path:
    """Make the model described by ``path`` the project's default (kept as an absolute path; the model is
    loaded first, so a bad description is refused by name and nothing is kept); returns the path kept."""
    load_model(Path(path).expanduser().resolve())
    return keep_model(project, path)


def keep_model(project: ProjectStore, path: str | Path) -> Path:
    """Make the model described by ``path``, which the caller has loaded, the project's default (kept as an
    absolute path) without loading it again; returns the path kept."""
    kept = Path(path).expanduser().resolve()
    project.set_draft(PROJECT_MODEL_KEY, str(kept))
    return kept


def model_path_for(project: ProjectStore | None, given: str | Path | None = None) -> Path:
    """The description file a detection uses: ``given``; else the project's default, which must still be
    there (a default that is gone is an :class:`InputFileError` naming it); else the shipped model."""
    if given is not None:
        return Path(given)
    remembered = project_model_path(project) if project is not None else None
    if remembered is None:
        return bundled_model_path()
    if not remembered.is_file():
        raise InputFileError(str(remembered), "the project's default detection model is no longer there "
                                              "(choose another model for the project)")
    return remembered
