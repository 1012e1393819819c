"""Train USVIPS's own fish keypoint model on rendered fish, and export it to ONNX with its description file.

A development tool, never imported by USVIPS at run time; it needs PyTorch (the ``train`` extra). The model
is a small CenterNet-style network (strided convolutions down to 1/32, a feature pyramid back up to 1/4;
one output tensor in the ``centre-pose`` layout of :mod:`usvips.core.detection.kinds.centre_pose`, heatmaps
through a sigmoid inside the graph). Training frames are rendered by :mod:`usvips.core.synth.fish_scene`
through every housing kind, letterboxed into the input as the ONNX runner does, and cached in a folder;
every random draw comes from the seed. Run (one thread, at low priority, on a shared machine):

    nice -n 10 python -m usvips.training.fish_model --out resources/models --cache /tmp/fish_cache

Writes ``<out>/fish-centre-pose.onnx``, ``<out>/fish-centre-pose.toml`` and ``<out>/training.json`` (the
command, the seed, torch's version, the steps, the time, the held-out figures of the training's own check, the
training sets used and what the run continued from).

**Continuing a run** (``--resume``): from a training's output folder (its ``.pt``: every weight and BatchNorm
statistic, trained on as before), or from an ONNX file of this architecture, such as the shipped model. The
export folded each BatchNorm into its convolution (:mod:`usvips.training.folded_onnx`), so from an ONNX file
each convolution takes the folded weight and its BatchNorm becomes an identity carrying the folded bias (mean 0,
variance 1 − ε, scale 1, shift the bias); those BatchNorms keep their statistics FROZEN (eval mode) while
training, their scale and shift still learned — the usual choice when fine-tuning with small batches, whose
statistics are too noisy to re-estimate, and the only one here, as the original statistics are not in the file.

**Fine-tuning on a team's reviewed fish** (``--training-set DIR``, repeatable; docs/detection.md): each export
of ``usvips project export PROJECT OUT --format training-set`` is read by
:mod:`usvips.training.training_set_frames`, and ``--real-share`` of every batch (rounded) is drawn from its
crops, the rest from the rendered frames. Their caudal tips are not labelled, so those keypoints' heatmaps are
ignored on those frames and their displacements not taught; and as other fish, unlabelled, may lie in a crop,
it teaches background only inside its fish's box (``--crop-background crop``: over the whole crop)
(:mod:`usvips.training.fish_targets`).
``--hold-out SHARE`` keeps that share of each set's objects (both images of one) out of training and checks the
model on them beside the rendered check frames, at the start and at every check. Without ``--resume`` a
fine-tuning run starts from the shipped model (``resources/models/fish-centre-pose.onnx``):

    nice -n 10 python -m usvips.training.fish_model --out /tmp/tuned --training-set /data/reviewed \
        --hold-out 0.2 --frames 400 --steps 200 --batch 12 --learning-rate 0.0002 --zoom 0.6 2.2

Bad input (an export, an ONNX file of another network, a missing folder) is refused in one line.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import torch
from torch import nn
from torch.nn import functional

from usvips.core import housing as housings
from usvips.core.detection.description import ModelDescription
from usvips.core.detection.kinds.centre_pose import CentrePose, channel_count, channel_slices
from usvips.core.detection.letterbox import Letterbox
from usvips.core.detection.validation import TrueObject, ValidationFigures, match_image
from usvips.core.errors import UsvipsError
from usvips.core.synth.fish_scene import KEYPOINTS, random_camera, random_scene, render_fish_scene
from usvips.locations import resources_folder
from usvips.training.fish_augment import random_zoom
from usvips.training.fish_targets import INPUT, targets
from usvips.training.folded_onnx import folded_convolutions, matched
from usvips.training.training_set_frames import read_training_set

NAME = "fish-centre-pose"
FRAME_SIZES = ((320, 240), (320, 180), (288, 216))
#: the displacement loss's weight: 0.2 left the displacements under-trained (their median error was 20-50 % of
#: a fish's length on held-out frames, so keypoints were snapped to the wrong heatmap peaks)
DISPLACEMENT_WEIGHT = 0.5
#: share of training frames zoomed (scale augmentation); the rest are shown as rendered
ZOOM_PROBABILITY = 0.7
WARMUP = 0.05  # share of the steps the learning rate climbs to its peak
FLOOR = 0.02  # the learning rate at the end, a share of its peak


def sample(seed: int) -> tuple[np.ndarray, list[dict]]:
    """One letterboxed training frame (INPUT × INPUT × 3 BGR uint8) and its fish in input coordinates."""
    rng = np.random.default_rng(seed)
    kind = housings.names()[int(rng.integers(len(housings.names())))]
    size = FRAME_SIZES[int(rng.integers(len(FRAME_SIZES)))]
    camera = random_camera(rng, kind, size)
    image, truths = render_fish_scene(camera, random_scene(rng, camera))
    box = Letterbox.fit(size, (INPUT, INPUT))
    boxed = box.apply(image, (INPUT, INPUT), 114)
    fish = []
    for truth in truths:
        if not np.isfinite(truth.box[0]):
            continue
        u, v = box.to_input(truth.keypoints[:, 0], truth.keypoints[:, 1])
        bu0, bv0 = box.to_input(np.array(truth.box[0]), np.array(truth.box[1]))
        bu1, bv1 = box.to_input(np.array(truth.box[2]), np.array(truth.box[3]))
        in_frame = (truth.keypoints[:, 0] >= -0.5) & (truth.keypoints[:, 0] <= size[0] - 0.5) \
            & (truth.keypoints[:, 1] >= -0.5) & (truth.keypoints[:, 1] <= size[1] - 0.5)
        fish.append({"keypoints": np.column_stack([u, v]), "visible": truth.visible, "in_frame": in_frame,
                     "box": (float(bu0), float(bv0), float(bu1), float(bv1)), "required": truth.unhidden})
    return boxed, fish


def _read_cache(images_path: Path, fish_path: Path) -> tuple[list[int], np.ndarray, list[list[dict]]]:
    stored = json.loads(fish_path.read_text())
    fish = [[{k: (np.asarray(v) if k in ("keypoints", "visible", "in_frame") else v) for k, v in f.items()}
             for f in frame] for frame in stored["fish"]]
    return stored["seeds"], np.load(images_path), fish


def _cached_prefix(folder: Path, seeds: list[int]) -> tuple[np.ndarray, list[list[dict]]]:
    """The longest run of frames already cached in ``folder`` whose seeds begin ``seeds`` (a larger training
    draws the same first seeds, so its frames need not be rendered again)."""
    best: tuple[np.ndarray, list[list[dict]]] = (np.zeros((0, INPUT, INPUT, 3), np.uint8), [])
    for fish_path in sorted(folder.glob("*.json")) if folder.is_dir() else []:
        images_path = fish_path.with_suffix(".npy")
        if not images_path.is_file():
            continue
        stored_seeds = json.loads(fish_path.read_text())["seeds"]
        if len(best[1]) < len(stored_seeds) <= len(seeds) and stored_seeds == seeds[:len(stored_seeds)]:
            _, images, fish = _read_cache(images_path, fish_path)
            best = (images, fish)
    return best


def build_cache(folder: Path, name: str, seeds: list[int]) -> tuple[np.ndarray, list[list[dict]]]:
    """The frames of ``seeds`` rendered once and kept in ``folder`` (``name``.npy and .json); frames of the
    same seeds cached under another name (a smaller run's first seeds) are taken from there."""
    images_path, fish_path = folder / f"{name}.npy", folder / f"{name}.json"
    if images_path.is_file() and fish_path.is_file():
        stored_seeds, images, fish = _read_cache(images_path, fish_path)
        if stored_seeds == seeds:
            return images, fish
    cached_images, fish = _cached_prefix(folder, seeds)
    folder.mkdir(parents=True, exist_ok=True)
    images = np.zeros((len(seeds), INPUT, INPUT, 3), np.uint8)
    images[:len(fish)] = cached_images
    start = time.time()
    for i in range(len(fish), len(seeds)):
        images[i], frame = sample(seeds[i])
        fish.append(frame)
        if i % 200 == 0:
            print(f"{name}: rendered {i}/{len(seeds)} in {time.time() - start:.0f} s", flush=True)
    np.save(images_path, images)
    plain = [[{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in f.items()} for f in frame]
             for frame in fish]
    fish_path.write_text(json.dumps({"seeds": seeds, "fish": plain}))
    return images, fish


def _block(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class FishNet(nn.Module):
    """Encoder to 1/32, top-down pyramid back to 1/4, one head; heatmaps through a sigmoid.

    ``frozen_statistics``: its BatchNorms stay in eval mode even while the rest trains (they normalise with
    their running statistics, never a batch's, and never update them); set when continuing from an ONNX file."""

    def __init__(self, keypoints: int = len(KEYPOINTS)) -> None:
        super().__init__()
        self.keypoints = keypoints
        self.frozen_statistics = False
        self.s2 = _block(3, 16, 2)
        self.s4 = nn.Sequential(_block(16, 24, 2), _block(24, 24))
        self.s8 = nn.Sequential(_block(24, 40, 2), _block(40, 40))
        self.s16 = nn.Sequential(_block(40, 64, 2), _block(64, 64))
        self.s32 = nn.Sequential(_block(64, 96, 2), _block(96, 96))
        self.up16 = _block(96 + 64, 64)
        self.up8 = _block(64 + 40, 40)
        self.up4 = _block(40 + 24, 32)
        self.head = nn.Sequential(_block(32, 32), nn.Conv2d(32, channel_count(keypoints), 1))
        c = channel_slices(keypoints)
        heat = torch.zeros(channel_count(keypoints), dtype=torch.bool)
        heat[c["centre"]] = True
        heat[c["keypoint_heat"]] = True
        self.register_buffer("heat", heat.view(1, -1, 1, 1), persistent=False)
        with torch.no_grad():
            self.head[1].bias[heat] = -2.2

    def train(self, mode: bool = True) -> FishNet:
        super().train(mode)
        if self.frozen_statistics:
            for module in self.modules():
                if isinstance(module, nn.BatchNorm2d):
                    module.eval()
        return self

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        s4 = self.s4(self.s2(x))
        s8 = self.s8(s4)
        s16 = self.s16(s8)
        s32 = self.s32(s16)
        y = self.up16(torch.cat([functional.interpolate(s32, scale_factor=2.0, mode="nearest"), s16], 1))
        y = self.up8(torch.cat([functional.interpolate(y, scale_factor=2.0, mode="nearest"), s8], 1))
        y = self.up4(torch.cat([functional.interpolate(y, scale_factor=2.0, mode="nearest"), s4], 1))
        raw = self.head(y)
        return torch.where(self.heat, torch.sigmoid(raw), raw)


def _convolutions(model: nn.Module) -> list[tuple[nn.Conv2d, nn.BatchNorm2d | None]]:
    """The network's convolutions in the order it runs them (its modules' order), each with the BatchNorm
    that follows it (None for the head's last)."""
    modules = list(model.modules())
    return [(m, modules[n + 1] if n + 1 < len(modules) and isinstance(modules[n + 1], nn.BatchNorm2d) else None)
            for n, m in enumerate(modules) if isinstance(m, nn.Conv2d)]


def load_onnx(model: FishNet, path: Path) -> None:
    """Set ``model``'s weights from the folded ONNX file at ``path`` (see the module docstring) and freeze its
    BatchNorm statistics; a file that does not fit the architecture is refused (UsvipsError, one line)."""
    pairs = _convolutions(model)
    expected = [(tuple(conv.weight.shape), tuple(conv.stride), (*conv.padding, *conv.padding), tuple(conv.dilation),
                 conv.groups) for conv, _ in pairs]
    stored = matched(path, folded_convolutions(path), expected)
    with torch.no_grad():
        for n, ((conv, norm), folded) in enumerate(zip(pairs, stored, strict=True), start=1):
            conv.weight.copy_(torch.from_numpy(folded.weight))
            bias = torch.from_numpy(folded.bias)
            if conv.bias is not None:
                conv.bias.copy_(bias)
            elif norm is not None:
                norm.running_mean.zero_()
                norm.running_var.fill_(1.0 - norm.eps)
                norm.weight.fill_(1.0)
                norm.bias.copy_(bias)
            elif bool(torch.any(bias != 0)):
                raise UsvipsError(f"{path}: convolution {n} has a bias the fish model cannot hold")
    model.frozen_statistics = True
    model.train(model.training)


def _focal(prediction: torch.Tensor, target: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """CenterNet's penalty-reduced focal loss, normalised by the number of peaks."""
    p = prediction.clamp(1e-4, 1 - 1e-4)
    positive = (target >= 0.999).float()
    negative = (1 - positive) * weight
    loss = -(positive * (1 - p) ** 2 * torch.log(p) + negative * (1 - target) ** 4 * p**2 * torch.log(1 - p)).sum()
    return loss / positive.sum().clamp(min=1.0)


def _masked_l1(prediction: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    return (torch.abs(prediction - target) * mask).sum() / mask.sum().clamp(min=1.0)


def loss(output: torch.Tensor, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
    c = channel_slices(len(KEYPOINTS))
    centre_mask = batch["centre_mask"][:, None]
    parts = {
        "centre": _focal(output[:, c["centre"]], batch["centre_heat"][:, None], batch["ignore"][:, None]),
        "keypoint_heat": _focal(output[:, c["keypoint_heat"]], batch["keypoint_heat"], batch["keypoint_ignore"]),
        "centre_offset": _masked_l1(output[:, c["centre_offset"]], batch["centre_offset"],
                                    centre_mask.expand(-1, 2, -1, -1)),
        "extent": 0.1 * _masked_l1(output[:, c["extent"]], batch["extent"], centre_mask.expand(-1, 4, -1, -1)),
        "displacement": DISPLACEMENT_WEIGHT * _masked_l1(output[:, c["displacement"]], batch["displacement"],
                                         batch["displacement_mask"]),
        "keypoint_offset": _masked_l1(output[:, c["keypoint_offset"]], batch["keypoint_offset"],
                                      batch["keypoint_mask"][:, None].expand(-1, 2, -1, -1)),
    }
    total = sum(parts.values())
    return total, {k: float(v) for k, v in parts.items()}


def _to_tensor(images: np.ndarray) -> torch.Tensor:
    """BGR uint8 (N, H, W, 3) → the network's input (N, 3, H, W): RGB scaled to 0..1, as the description says."""
    return torch.from_numpy(np.ascontiguousarray(images[..., ::-1].transpose(0, 3, 1, 2))).float() / 255.0


class Frames:
    """Several arrays of frames (N × INPUT × INPUT × 3) indexed as one, in order, without copying them."""

    def __init__(self, *parts: np.ndarray) -> None:
        self.parts = parts
        self.ends = np.cumsum([len(p) for p in parts])

    def __len__(self) -> int:
        return int(self.ends[-1]) if len(self.ends) else 0

    def __getitem__(self, index: int) -> np.ndarray:
        part = int(np.searchsorted(self.ends, index, side="right"))
        return self.parts[part][index - (int(self.ends[part - 1]) if part else 0)]


def batch(images: np.ndarray | Frames, fish: list[list[dict]], indices: np.ndarray, rng: np.random.Generator,
          zoom: tuple[float, float] | None = None) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """A training batch: frames ``indices``, each zoomed (with probability ZOOM_PROBABILITY when ``zoom`` is
    given), mirrored half the time, with random gains and offsets per channel."""
    frames, frame_fish = [], []
    for i in indices:
        if zoom is not None and rng.uniform() < ZOOM_PROBABILITY:
            image, f = random_zoom(images[i], fish[i], zoom, rng)
        else:
            image, f = images[i], fish[i]
        frames.append(image)
        frame_fish.append(f)
    flips = rng.uniform(size=len(indices)) < 0.5
    frames = np.stack([image[:, ::-1] if flip else image for image, flip in zip(frames, flips, strict=True)])
    gains = rng.uniform(0.8, 1.2, (len(indices), 1, 1, 3))
    frames = np.clip(frames * gains + rng.normal(0, 8, (len(indices), 1, 1, 3)), 0, 255).astype(np.uint8)
    all_targets = [targets(f, flip) for f, flip in zip(frame_fish, flips, strict=True)]
    stacked = {k: torch.from_numpy(np.stack([t[k] for t in all_targets])) for k in all_targets[0]}
    return _to_tensor(frames), stacked


def learning_rate(peak: float, step_fraction: float, time_fraction: float) -> float:
    """The schedule: a linear warm-up over the first WARMUP of the steps, then a cosine down to FLOOR × peak,
    following whichever of the steps or the time limit is further on (so a run cut by its time limit has
    still come down)."""
    if step_fraction < WARMUP:
        return peak * max(step_fraction / WARMUP, 0.02)
    progress = min(max(step_fraction, time_fraction), 1.0)
    return peak * (FLOOR + (1 - FLOOR) * 0.5 * (1 + math.cos(math.pi * progress)))


def description(threshold: float) -> ModelDescription:
    return ModelDescription(model=f"{NAME}.onnx", family=CentrePose.kind, input_width=INPUT, input_height=INPUT,
                            class_names=("fish",), keypoint_names=KEYPOINTS, channel_order="RGB",
                            score_threshold=threshold, iou_threshold=0.5, max_detections=100)


def evaluate(model: nn.Module, images: np.ndarray, fish: list[list[dict]], threshold: float) -> ValidationFigures:
    """Figures on cached frames in input coordinates (the training's own check; the shipped figures come
    from full frames through the ONNX runner); a keypoint a fish does not know (a reviewed crop's caudal
    tips) is not measured."""
    model.eval()
    figures = ValidationFigures()
    desc = description(threshold)
    identity = Letterbox(1.0, 1.0, 0, 0, (INPUT, INPUT))
    with torch.no_grad():
        for start in range(0, len(images), 16):
            out = model(_to_tensor(images[start:start + 16])).numpy()
            for n, frame in enumerate(fish[start:start + 16]):
                found = CentrePose.decode(out[n:n + 1], desc, identity)
                truths = [TrueObject({name: (float(x) - 0.5, float(y) - 0.5) for name, (x, y), known
                                      in zip(KEYPOINTS, f["keypoints"], f.get("known", [True] * len(KEYPOINTS)),
                                             strict=True) if known}, f["required"])
                          for f in frame]
                match_image(found, truths, figures)
    model.train()
    return figures


def export(model: nn.Module, path: Path) -> None:
    model.eval()
    dummy = torch.zeros(1, 3, INPUT, INPUT)
    torch.onnx.export(model, (dummy,), str(path), input_names=["images"], output_names=["maps"], opset_version=13,
                      dynamo=False)


def onnx_difference(model: nn.Module, path: Path, seed: int = 0) -> float:
    """The largest absolute difference between the network in torch and its ONNX file run by OpenCV's DNN
    module (as USVIPS runs it), on a random input."""
    model.eval()
    x = torch.from_numpy(np.random.default_rng(seed).uniform(0, 1, (1, 3, INPUT, INPUT)).astype(np.float32))
    net = cv2.dnn.readNetFromONNX(str(path))
    net.setInput(x.numpy())
    with torch.no_grad():
        return float(np.abs(net.forward() - model(x).numpy()).max())


def write_description(path: Path, threshold: float) -> None:
    lines = ["# USVIPS's own fish keypoint model (docs/detection.md): trained on RENDERED fish only, to propose",
             "# snout and fork for a person to review. MIT licence, made by usvips/training/fish_model.py.",
             "[model]", f'file = "{NAME}.onnx"', f'family = "{CentrePose.kind}"', f"input_width = {INPUT}",
             f"input_height = {INPUT}", "", "[normalisation]", "scale = 0.00392156862745098",
             "mean = [0.0, 0.0, 0.0]", "std = [1.0, 1.0, 1.0]", 'channels = "RGB"', "", "[output]",
             'classes = ["fish"]', "keypoints = [" + ", ".join(f'"{k}"' for k in KEYPOINTS) + "]",
             f"score_threshold = {threshold}", "iou_threshold = 0.5", "max_detections = 100"]
    path.write_text("\n".join(lines) + "\n")


SHIPPED = resources_folder() / "models" / f"{NAME}.onnx"


def resume(model: FishNet, source: Path) -> dict:
    """Load ``source`` into ``model`` — a training's output folder (its .pt) or an ONNX file of this
    architecture (frozen BatchNorm statistics, see the module docstring) — and say what it was, for
    training.json."""
    if source.is_dir():
        weights = source / f"{NAME}.pt"
        if not weights.is_file():
            raise UsvipsError(f"{weights}: missing (a training's output folder holds it; to continue from an "
                              f"exported model give its .onnx file: --resume {source / f'{NAME}.onnx'})")
        model.load_state_dict(torch.load(weights))
        record = source / "training.json"
        return json.loads(record.read_text()) if record.is_file() else {"folder": str(source.resolve())}
    if source.suffix.lower() != ".onnx":
        raise UsvipsError(f"{source}: neither a training's output folder nor an ONNX file")
    load_onnx(model, source)
    record = source.parent / "training.json"
    return {"onnx": str(source.resolve()), "sha256": hashlib.sha256(source.read_bytes()).hexdigest(),
            "batch_norm": "folded in the file; loaded as identities carrying the folded bias, statistics frozen",
            "training": json.loads(record.read_text()) if record.is_file() else None}


def main(argv: list[str] | None = None) -> int:
    try:
        return _train(argv)
    except UsvipsError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


def _train(argv: list[str] | None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the .onnx, .toml and training.json")
    parser.add_argument("--cache", type=Path, default=Path("/tmp/fish_cache"), help="rendered frames' folder")
    parser.add_argument("--seed", type=int, default=20261128)
    parser.add_argument("--frames", type=int, default=2400, help="training frames rendered")
    parser.add_argument("--check-frames", type=int, default=200, help="held-out frames of the training's check")
    parser.add_argument("--steps", type=int, default=1500)
    parser.add_argument("--batch", type=int, default=16)
    parser.add_argument("--threshold", type=float, default=0.35, help="score threshold written in the description")
    parser.add_argument("--minutes", type=float, default=40.0, help="stop training after this long")
    parser.add_argument("--resume", type=Path,
                        help="continue from a training's output folder (its .pt) or from an ONNX file of this "
                             "architecture (BatchNorm statistics then frozen); with --training-set and no "
                             "--resume, the shipped model")
    parser.add_argument("--training-set", type=Path, action="append", default=[], metavar="DIR",
                        help="a reviewed training set (usvips project export ... --format training-set) to "
                             "fine-tune on; repeatable")
    parser.add_argument("--real-share", type=float, default=0.3,
                        help="with --training-set: the share of each batch drawn from the training sets")
    parser.add_argument("--hold-out", type=float, default=0.0, metavar="SHARE",
                        help="with --training-set: hold out this share of each set's objects (both images of "
                             "one) from training and check the model on them as on the rendered check frames")
    parser.add_argument("--crop-background", choices=("box", "crop"), default="box",
                        help="with --training-set: where a crop teaches background — inside its fish's box only "
                             "(other fish, unlabelled, may lie in a crop) or over the whole crop")
    parser.add_argument("--learning-rate", type=float, default=3e-3, help="the schedule's peak")
    parser.add_argument("--zoom", type=float, nargs=2, metavar=("LOW", "HIGH"),
                        help="scale augmentation: zoom frames by a factor drawn log-uniformly from LOW..HIGH")
    args = parser.parse_args(argv)
    if not 0 < args.real_share <= 1:
        raise UsvipsError(f"--real-share {args.real_share}: must lie in (0, 1]")
    if not 0 <= args.hold_out < 1:
        raise UsvipsError(f"--hold-out {args.hold_out}: must lie in [0, 1)")
    splits = [read_training_set(folder).split(args.hold_out, args.seed)  # refused before any rendering
              for folder in args.training_set]
    real = [trained for trained, _ in splits]
    if args.crop_background == "crop":  # the whole crop taught as background, but for its labelled fish
        for fish in (f for t in real for frame in t.fish for f in frame):
            fish["background_known"] = True
    held = [frame for _, h in splits for frame in zip(h.images, h.fish, strict=True)]
    held_images = np.stack([image for image, _ in held]) if held else None
    held_fish = [fish for _, fish in held]
    if any(not len(t.names) for t in real):
        raise UsvipsError(f"--hold-out {args.hold_out} leaves a training set without a crop to train on")
    real_count = round(args.real_share * args.batch) if real else 0
    if real and real_count == 0:
        raise UsvipsError(f"--real-share {args.real_share} of a batch of {args.batch} draws no crop")
    source = args.resume if args.resume is not None else (SHIPPED if real else None)
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)
    model = FishNet()
    previous = resume(model, source) if source is not None else None  # a bad file refused before rendering
    sequence = np.random.SeedSequence(args.seed)
    train_seed, check_seed, batch_seed = sequence.spawn(3)
    train_seeds = [int(s) for s in np.random.default_rng(train_seed).integers(0, 2**31, args.frames)]
    check_seeds = [int(s) for s in np.random.default_rng(check_seed).integers(0, 2**31, args.check_frames)]
    started = time.time()
    images, fish = build_cache(args.cache, f"train{args.seed}_{args.frames}", train_seeds)
    check_images, check_fish = build_cache(args.cache, f"check{args.seed}_{args.check_frames}", check_seeds)
    rendered = time.time() - started
    print(f"rendered in {rendered:.0f} s", flush=True)
    if source is not None:
        batch_seed = batch_seed.spawn(1)[0]  # new batches, not the first run's again
    pool: np.ndarray | Frames = images
    if real:
        pool = Frames(images, *(t.images for t in real))
        fish = fish + [frame for t in real for frame in t.fish]
        print(f"training sets: {sum(len(t.names) for t in real)} crops, {real_count} of each batch of {args.batch}",
              flush=True)
    optimiser = torch.optim.AdamW(model.parameters(), lr=args.learning_rate, weight_decay=1e-4)
    zoom = tuple(args.zoom) if args.zoom else None
    rng = np.random.default_rng(batch_seed)
    args.out.mkdir(parents=True, exist_ok=True)
    model.train()
    history = []
    def held_out_check() -> dict:
        """The figures on the held-out crops (snout and fork only), empty without any."""
        if held_images is None:
            return {}
        summary = evaluate(model, held_images, held_fish, args.threshold).summary(KEYPOINTS[:2])
        print("held-out crops", json.dumps(summary), flush=True)
        return {"held_out_crops": summary}

    if source is not None:  # where the run starts, on the same check frames
        summary = evaluate(model, check_images, check_fish, args.threshold).summary(KEYPOINTS)
        print("check at the start", json.dumps(summary), flush=True)
        history.append({"step": 0, "learning_rate": 0.0, "seconds": 0, **summary, **held_out_check()})
    train_start = time.time()
    step = 0
    for step in range(1, args.steps + 1):
        rate = learning_rate(args.learning_rate, step / args.steps, (time.time() - train_start) / (args.minutes * 60))
        for group in optimiser.param_groups:
            group["lr"] = rate
        if real:
            indices = np.concatenate([rng.integers(0, len(images), args.batch - real_count),
                                      rng.integers(len(images), len(pool), real_count)])
        else:
            indices = rng.integers(0, len(images), args.batch)
        x, y = batch(pool, fish, indices, rng, zoom)
        total, parts = loss(model(x), y)
        optimiser.zero_grad()
        total.backward()
        optimiser.step()
        if step % 25 == 0:
            print(f"step {step} loss {float(total):.3f} " + " ".join(f"{k} {v:.3f}" for k, v in parts.items())
                  + f" lr {rate:.2e} {time.time() - train_start:.0f} s", flush=True)
        if step % 250 == 0 or step == args.steps:
            figures = evaluate(model, check_images, check_fish, args.threshold)
            summary = figures.summary(KEYPOINTS)
            print("check", json.dumps(summary), flush=True)
            history.append({"step": step, "learning_rate": rate, "seconds": round(time.time() - train_start),
                            **summary, **held_out_check()})
            torch.save(model.state_dict(), args.out / f"{NAME}.pt")
        if time.time() - train_start > args.minutes * 60:
            print(f"time limit at step {step}", flush=True)
            break
    trained = time.time() - train_start
    export(model, args.out / f"{NAME}.onnx")
    difference = onnx_difference(model, args.out / f"{NAME}.onnx")
    print(f"ONNX (OpenCV) against torch: largest difference {difference:.2e}", flush=True)
    write_description(args.out / f"{NAME}.toml", args.threshold)
    (args.out / "training.json").write_text(json.dumps({
        "command": " ".join(["python -m usvips.training.fish_model", *(argv if argv is not None else sys.argv[1:])]),
        "seed": args.seed, "torch": torch.__version__, "steps": step, "batch": args.batch, "frames": args.frames,
        "render_seconds": round(rendered), "train_seconds": round(trained), "onnx_difference": difference,
        "training_sets": [{**t.record(), "held_out_samples": len(h.names)} for t, h in splits],
        "real_share": args.real_share if real else None, "hold_out": args.hold_out if real else None,
        "crop_background": args.crop_background if real else None,
        "real_per_batch": real_count, "frozen_batch_norm_statistics": model.frozen_statistics,
        "history": history, "resumed_from": previous}, indent=1,
        default=lambda v: None if isinstance(v, float) and math.isnan(v) else v))
    return 0


if __name__ == "__main__":
    sys.exit(main())
