"""Rendering stereo scenes through any camera model, with truth, for samples and tests."""

from usvips.core.synth.render import Disc, Seafloor, Water, render

__all__ = ["Disc", "Seafloor", "Water", "render"]
