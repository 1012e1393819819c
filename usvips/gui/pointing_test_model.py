"""The pointing test (Measure › Pointing test…), free of Qt: rendered targets whose true points are known
(:mod:`usvips.core.pointing_test`), the user's clicks on them, and the pointing σ they give
(:func:`usvips.core.pointing_estimates.from_pointing_test`) with its interval.

A trial shows one feature (a target's centre, a fish's snout or fork) in clear, hazy or turbid water. The
cursor is placed by a mouse click (which also confirms it) or moved by the keyboard (:meth:`move`) and
confirmed (:meth:`confirm`). A click farther than :data:`MISS_PX` from the feature is a miss — another
point taken for it, not pointing noise — counted and left out of the estimate, and the trial is not
repeated. Image pixels: the centre of the top-left pixel at (0, 0).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.pointing_estimates import PointingEstimate, from_pointing_test
from usvips.core.pointing_test import HEIGHT, WIDTH, Trial, plan, render_trial

#: a click this far (px) from the feature or farther is a miss
MISS_PX = 6.0
#: the clicks an estimate needs at least
MINIMUM_CLICKS = 3
#: the trials of a test by default
COUNT = 12


class PointingTestModel:
    """``count`` trials drawn by ``seed``; rendered by :meth:`render` (a worker's job), then clicked."""

    def __init__(self, count: int = COUNT, seed: int | None = None) -> None:
        self.plan = plan(count, int(np.random.default_rng(seed).integers(0, 2**31)) if seed is None else seed)
        self.trials: list[Trial] = []
        self.index = 0
        self.cursor = np.array([(WIDTH - 1) / 2, (HEIGHT - 1) / 2])
        self.clicks: list[tuple[float, float]] = []
        self.truths: list[tuple[float, float]] = []
        self.conditions: list[str] = []
        self.misses: list[float] = []

    # ------------------------------------------------------------------ rendering (any thread)
    def render(self, progress: Callable[[float], None] | None = None,
               cancelled: Callable[[], bool] | None = None) -> list[Trial]:
        """Every trial rendered (slow: a worker's job; ``progress`` told 0..1, ``cancelled`` asked between
        trials — an empty list when it turned true)."""
        out = []
        for k, (feature, condition, seed) in enumerate(self.plan):
            if cancelled is not None and cancelled():
                return []
            out.append(render_trial(feature, condition, seed, supersample=2))
            if progress is not None:
                progress((k + 1) / len(self.plan))
        return out

    def set_trials(self, trials: list[Trial]) -> None:
        self.trials = list(trials)
        self.index = 0
        self._centre()

    # ------------------------------------------------------------------ clicking
    @property
    def current(self) -> Trial | None:
        return self.trials[self.index] if self.trials and self.index < len(self.trials) else None

    @property
    def finished(self) -> bool:
        return bool(self.trials) and self.index >= len(self.trials)

    def _centre(self) -> None:
        self.cursor = np.array([(WIDTH - 1) / 2, (HEIGHT - 1) / 2])

    def place(self, x: float, y: float) -> None:
        """Put the cursor at image pixel (x, y), kept inside the image."""
        self.cursor = np.clip(np.array([x, y], float), [-0.5, -0.5], [WIDTH - 0.5, HEIGHT - 0.5])

    def move(self, dx: float, dy: float) -> None:
        """Move the cursor by (dx, dy) image pixels."""
        self.place(*(self.cursor + [dx, dy]))

    def confirm(self) -> str:
        """Take the cursor as the click of the current trial and go to the next; what became of it, in
        words ("" when there is no trial to click)."""
        trial = self.current
        if trial is None:
            return ""
        click = self.cursor.copy()
        error = float(np.linalg.norm(click - trial.truth))
        self.index += 1
        self._centre()
        if error >= MISS_PX:
            self.misses.append(error)
            return f"missed: {error:.1f} px from the {trial.feature} (not counted)"
        self.clicks.append((float(click[0]), float(click[1])))
        self.truths.append(trial.truth)
        self.conditions.append(trial.condition)
        return f"{error:.2f} px from the {trial.feature}"

    def click(self, x: float, y: float) -> str:
        """A mouse click at image pixel (x, y): place and confirm."""
        self.place(x, y)
        return self.confirm()

    # ------------------------------------------------------------------ the result
    @property
    def progress_text(self) -> str:
        trial = self.current
        if trial is None:
            return "done" if self.finished else "rendering the targets…"
        return f"target {self.index + 1} of {len(self.trials)}: {trial.instruction}"

    def estimate(self) -> PointingEstimate:
        """The pointing σ of the clicks so far; fewer than :data:`MINIMUM_CLICKS` is a :class:`UsvipsError`."""
        if len(self.clicks) < MINIMUM_CLICKS:
            raise UsvipsError(f"{len(self.clicks)} clicks on their targets: at least {MINIMUM_CLICKS} are needed "
                              "to estimate a pointing σ")
        return from_pointing_test(np.array(self.clicks), np.array(self.truths))

    def summary(self) -> list[str]:
        """The result in words: the estimate, the RMS error per water condition, the misses."""
        lines = [f"your pointing σ: {self.estimate().summary()}"]
        errors = np.array(self.clicks) - np.array(self.truths)
        for condition in dict.fromkeys(self.conditions):
            mine = errors[[c == condition for c in self.conditions]]
            lines.append(f"{condition} water: RMS {np.sqrt(np.mean(mine ** 2)):.2f} px per coordinate over "
                         f"{len(mine)} click{'s' if len(mine) != 1 else ''}")
        if self.misses:
            lines.append(f"{len(self.misses)} miss{'es' if len(self.misses) > 1 else ''} (≥ {MISS_PX:g} px from the "
                         "point: another point taken for it) left out")
        return lines
