"""Rendering stereo scenes through any camera model, with truth, for samples and tests."""

from usvips.core.synth.objects import Fish, Pipe, Rock
from usvips.core.synth.render import Disc, SceneObject, Seafloor, Water, render

__all__ = ["Disc", "Fish", "Pipe", "Rock", "SceneObject", "Seafloor", "Water", "render"]
