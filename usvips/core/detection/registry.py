"""The registry of model families: each family (an output layout and how to decode it) is one
:class:`ModelFamily` subclass in one module of ``usvips.core.detection.kinds``; defining the class with a
``kind`` name registers it, and the registry imports those modules the first time it is asked. A user's
model names its family in its description file; an unknown family is an error naming the known ones.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from usvips.core.detection.description import ModelDescription
from usvips.core.detection.detection import Detection
from usvips.core.detection.letterbox import Letterbox
from usvips.core.errors import InvalidParameterError
from usvips.core.kind_modules import KindTable


class ModelFamily:
    """A family of detection models: ``kind`` (its registered name), and :meth:`decode` from the network's
    raw output to detections in image pixels."""

    kind: ClassVar[str]
    order: ClassVar[int] = 0

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if "kind" in cls.__dict__:
            _TABLE.add(cls.__dict__["kind"], cls)

    @classmethod
    def check(cls, description: ModelDescription) -> None:
        """Raise :class:`InvalidParameterError` when ``description`` does not suit this family."""

    @classmethod
    def decode(cls, output: np.ndarray, description: ModelDescription, letterbox: Letterbox) -> tuple[Detection, ...]:
        """Detections (best first) in image pixels from the network's ``output``."""
        raise TypeError(f"{cls.__name__} does not define decode")


_TABLE: KindTable[ModelFamily] = KindTable(__package__, "model family")


def names() -> tuple[str, ...]:
    """Every registered model family."""
    return _TABLE.names()


def family(name: str) -> type[ModelFamily]:
    """The family called ``name``; anything else is an :class:`InvalidParameterError` listing the known ones."""
    _TABLE.discover()
    if name not in _TABLE.kinds:
        raise InvalidParameterError("family", f"unknown model family {name!r}; known: {', '.join(names())}")
    return _TABLE.kinds[name]
