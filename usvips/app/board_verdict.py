"""One verdict on a calibration from target views, consistent with the coverage advice shown beside it.

A fit can agree with itself perfectly on three views and still be no calibration: the verdict therefore
weighs, in order, whether the fit is sound (σ0 against the pointing σ; held-out views against fitted
ones) and whether the views support it (the coverage advice of :mod:`usvips.core.calibration_views`):
"the fit is consistent" is said only when both hold.
"""

from __future__ import annotations

from dataclasses import dataclass

from usvips.app.board_calibration import BoardCalibration
from usvips.core.calibration_views import RECOMMENDED_VIEWS, Coverage

#: σ0 over the a-priori pointing σ above which the views, the target or the model do not fit
MISFIT_RATIO = 5.0
#: held-out reprojection RMS over the fitted one above which the calibration does not generalise
HOLDOUT_RATIO = 3.0
#: the fitted RMS below which the ratio above is measured against this floor (pixels)
RMS_FLOOR_PX = 0.05


@dataclass(frozen=True)
class Verdict:
    """``level``: ``poor`` (do not use), ``short`` (a consistent fit from views that do not yet support it:
    a trial only) or ``good``; ``text``: one paragraph for a person, with what to do."""

    level: str
    text: str


def judge(calibration: BoardCalibration, coverage: Coverage | None, sigma_px: float) -> Verdict:
    """The verdict on ``calibration`` given the ``coverage`` of the views it was computed from (None: not
    known) and the a-priori pointing σ (pixels)."""
    ratio = calibration.result.report.sigma0_px / sigma_px
    if ratio > MISFIT_RATIO:
        return Verdict("poor", f"σ0 is {ratio:.1f} × the pointing σ: the views, the target or the model do not fit "
                               "— check the target's description (its square size) and drop the views with large "
                               "residuals")
    validation = calibration.validation
    if validation is not None and validation.held_out.rms_px > HOLDOUT_RATIO * max(validation.fitted.rms_px,
                                                                                    RMS_FLOOR_PX):
        return Verdict("poor", f"held-out views reproject at {validation.held_out.rms_px:.2f} px against "
                               f"{validation.fitted.rms_px:.2f} px fitted: the calibration does not generalise; "
                               "add views")
    agree = " and the held-out views agree" if validation is not None else ""
    advice = list(coverage.advice) if coverage is not None else []
    if coverage is not None and coverage.views < RECOMMENDED_VIEWS:
        return Verdict("short", f"a trial only: the fit agrees with its {coverage.views} views{agree}, but too few "
                                f"views cannot show what is wrong with it — {'; '.join(advice)}")
    if advice:
        return Verdict("short", f"the fit agrees with its views{agree}, but the views leave parts of the images or "
                                f"of the distances and tilts unmeasured, where it is not checked — {'; '.join(advice)}")
    if coverage is None:
        return Verdict("good", f"the fit is consistent{agree} (the views' coverage is not known)")
    return Verdict("good", f"the fit is consistent{agree}, and the views cover the images, distances and tilts")
