"""The dock panels, one module each (this module only gathers them for older imports): enhancement
(:mod:`usvips.gui.enhancement_panel`), the object list (:mod:`usvips.gui.object_list`), the
geo-calculator (:mod:`usvips.gui.calculator_panel`), the plan view (:mod:`usvips.gui.plan_view`), the
observation form (:mod:`usvips.gui.observation_form`) and the log (:mod:`usvips.gui.log_panel`). Each takes
the :class:`~usvips.gui.workspace.Workspace` in ``__init__``, listens to its events and writes user input
back through its methods; ``cleanup()`` disconnects."""

from usvips.gui.calculator_panel import CalculatorPanel
from usvips.gui.enhancement_panel import STARTING_PARAMETERS, EnhancementPanel, default_operation
from usvips.gui.log_panel import LogPanel
from usvips.gui.object_list import ObjectList
from usvips.gui.observation_form import ObservationForm
from usvips.gui.plan_view import PlanView

__all__ = ["STARTING_PARAMETERS", "CalculatorPanel", "EnhancementPanel", "LogPanel", "ObjectList", "ObservationForm",
           "PlanView", "default_operation"]
