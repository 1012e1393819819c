"""The instants dialog's text: a standardised residual signed, never "-0.00", a dash when there is none."""

import math

from usvips.gui.qt.instants_view import residual_text


def test_a_residual_is_signed_and_a_vanishing_one_is_plus_zero():
    assert residual_text(1.234) == "+1.23" and residual_text(-0.5) == "-0.50"
    assert residual_text(-0.004) == "+0.00" and residual_text(-0.0) == "+0.00" and residual_text(0.004) == "+0.00"
    assert residual_text(-0.006) == "-0.01"
    assert residual_text(math.nan) == "—"
