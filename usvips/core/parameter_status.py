"""How a parameter enters an adjustment: ``free`` (estimated), ``fixed`` (held at its value) or ``prior``
(estimated with its stated sigma as an observation). Its own module so that reading a calibration file does
not import the adjustment engine (:mod:`usvips.core.adjustment`)."""

from __future__ import annotations

#: a parameter's statuses (``Parameter.status`` of the adjustment, ``ParameterEstimate.status`` of a calibration)
STATUSES = ("free", "fixed", "prior")
