"""The convolutions of an exported fish model's ONNX file, read back as weights to continue training from
(numpy and onnx only; :mod:`usvips.training.fish_model` loads them into its network).

torch's ONNX export (in eval mode) folds each BatchNorm into the convolution before it: the file holds, per
convolution, a weight W' = W · γ / √(var + ε) and a bias b' = β − mean · γ / √(var + ε) (initializers named
``onnx::Conv_NNN``; only a convolution without a BatchNorm, the head's last, keeps its module's name). The
original BatchNorm statistics cannot be recovered, but they need not be: a convolution with W' followed by a
BatchNorm that adds b' and does nothing else (mean 0, var 1 − ε, γ 1, β b') computes exactly what the file
computes.

The convolutions are matched to the network's by their order in the graph (the export writes them in the
order the network runs them), each checked against the expected shape, stride, padding, dilation and groups;
a file that does not fit is refused in one line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnx
from onnx import numpy_helper

from usvips.core.errors import UsvipsError


@dataclass(frozen=True)
class Convolution:
    """One convolution: its weight (out, in, kh, kw), bias (out; zeros when the file has none), stride,
    padding (top, left, bottom, right), dilation and groups."""

    weight: np.ndarray
    bias: np.ndarray
    stride: tuple[int, int]
    padding: tuple[int, int, int, int]
    dilation: tuple[int, int] = (1, 1)
    groups: int = 1

    def layout(self) -> tuple:
        return (tuple(self.weight.shape), self.stride, self.padding, self.dilation, self.groups)


def folded_convolutions(path: str | Path) -> list[Convolution]:
    """The convolutions of the ONNX file at ``path`` in graph order, their weights as stored."""
    path = Path(path)
    try:
        model = onnx.load(str(path))
    except FileNotFoundError:
        raise UsvipsError(f"{path}: no such file") from None
    except Exception as error:  # onnx raises DecodeError and others for a file that is not ONNX
        raise UsvipsError(f"{path}: not an ONNX model ({type(error).__name__})") from None
    weights = {i.name: i for i in model.graph.initializer}
    if any(node.op_type == "BatchNormalization" for node in model.graph.node):
        raise UsvipsError(f"{path}: holds BatchNormalization nodes (exported in training mode?); the fish model's "
                          "export folds them into its convolutions")
    out = []
    for n, node in enumerate(model.graph.node):
        if node.op_type != "Conv":
            continue
        names = list(node.input[1:])
        if not names or any(name not in weights for name in names):
            raise UsvipsError(f"{path}: convolution {len(out) + 1} (node {node.name or n}) takes weights that are "
                              "not stored in the file")
        weight = numpy_helper.to_array(weights[names[0]]).astype(np.float32)
        if weight.ndim != 4:
            raise UsvipsError(f"{path}: convolution {len(out) + 1} is not two-dimensional (weight {weight.shape})")
        bias = (numpy_helper.to_array(weights[names[1]]).astype(np.float32) if len(names) > 1
                else np.zeros(weight.shape[0], np.float32))
        attributes = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        if attributes.get("auto_pad", b"NOTSET") not in (b"NOTSET", "NOTSET"):
            raise UsvipsError(f"{path}: convolution {len(out) + 1} uses auto_pad, which the fish model never does")
        out.append(Convolution(weight, bias, tuple(attributes.get("strides", (1, 1))),
                               tuple(attributes.get("pads", (0, 0, 0, 0))), tuple(attributes.get("dilations", (1, 1))),
                               int(attributes.get("group", 1))))
    return out


def matched(path: str | Path, convolutions: list[Convolution], expected: list[tuple]) -> list[Convolution]:
    """``convolutions`` (from the file at ``path``) when they fit the network's ``expected`` layouts (see
    :meth:`Convolution.layout`), one for one in order; otherwise a one-line refusal naming the first misfit."""
    if len(convolutions) != len(expected):
        raise UsvipsError(f"{path}: {len(convolutions)} convolution{'' if len(convolutions) == 1 else 's'}, the fish "
                          f"model has {len(expected)}: not a model of its architecture")
    for n, (convolution, layout) in enumerate(zip(convolutions, expected, strict=True), start=1):
        if convolution.layout() != tuple(layout):
            raise UsvipsError(f"{path}: convolution {n} is {_words(convolution.layout())}, the fish model's is "
                              f"{_words(tuple(layout))}: not a model of its architecture")
        if convolution.bias.shape != (convolution.weight.shape[0],):
            raise UsvipsError(f"{path}: convolution {n}'s bias has shape {convolution.bias.shape}")
        if not (np.all(np.isfinite(convolution.weight)) and np.all(np.isfinite(convolution.bias))):
            raise UsvipsError(f"{path}: convolution {n} holds a weight that is not finite")
    return convolutions


def _words(layout: tuple) -> str:
    shape, stride, padding, dilation, groups = layout
    return (f"weight {'x'.join(map(str, shape))}, stride {stride}, padding {padding}"
            + (f", dilation {dilation}" if tuple(dilation) != (1, 1) else "")
            + (f", groups {groups}" if groups != 1 else ""))
