"""The window's commands, declared in one place: each :class:`Command` says its id, title, where it sits
in the menus, its keys, when it is enabled and which controller method runs it; the window builds its
menus, shortcuts and toolbar actions from :data:`ITEMS`, and the key list (Help › Keys) from the same
declarations. Adding a command = one declaration here and the method it names.

A handler is ``"owner.method"``: ``owner`` is a name the window resolves (``window``, ``tracking``, or a
dialog module such as ``media_dialogs``, whose functions take the window); ``args`` are passed to it.
Keys are Qt's portable text (``"Ctrl+Shift+Q"``) or ``"std:Name"`` for a platform's standard key
(``QKeySequence.StandardKey.Name``). ``scope``: ``window`` (anywhere in the window), ``images`` (only
while the images have the keyboard, so that text fields and tables keep Enter, Esc and the arrows) or
``object list`` (only in the object list). ``enabled_when`` names a condition the window evaluates
(:data:`CONDITIONS`). Menu groups: a separator between consecutive items of different groups."""

from __future__ import annotations

from dataclasses import dataclass

from usvips.core.measurements import kind as measurement_kind
from usvips.gui.pick_tool import TOOLS
from usvips.gui.view_options import LOUPE_SCALES

#: the menu bar, in order: (name used in menu paths, title with its mnemonic)
MENUS = (("File", "&File"), ("Edit", "&Edit"), ("View", "&View"), ("Measure", "&Measure"),
         ("Calibration", "&Calibration"), ("Help", "&Help"))
SCOPES = ("window", "images", "object list")
#: the conditions a command can be enabled by (the window evaluates them when the undo stack changes)
CONDITIONS = ("can_undo", "can_redo")
#: Nudge directions (image pixels per step; y down): Ctrl+arrow moves the current pick 0.1 px, Ctrl+Shift+arrow 1
#: px (plain and Shift+arrows step a video's frames).
NUDGES = {"Left": (-1.0, 0.0), "Right": (1.0, 0.0), "Up": (0.0, -1.0), "Down": (0.0, 1.0)}
TOOL_TIPS = {"pick": "Pick: intersect single points without storing them",
             "point": "Point: each intersected point is stored as an object",
             "line": "Line: digitise a polyline vertex by vertex (Enter finishes; a fish is snout then fork)",
             "polygon": "Polygon: digitise an area vertex by vertex (Enter finishes)"}
TOOL_TIPS.update({tool: measurement_kind(tool).description for tool in TOOLS if tool not in TOOL_TIPS})


@dataclass(frozen=True)
class Command:
    """One command of the window (see the module docstring). ``menu``: the menu path it is listed in
    (``"View/Loupe magnification"``), None for a key or toolbar action only; ``short``: its toolbar label;
    ``exclusive``: commands sharing it are checked one at a time (the tools)."""

    id: str
    title: str
    handler: str
    args: tuple = ()
    menu: str | None = None
    group: str = ""
    keys: tuple[str, ...] = ()
    tip: str = ""
    scope: str = "window"
    checkable: bool = False
    exclusive: str = ""
    enabled_when: str = ""
    short: str = ""

    def __post_init__(self) -> None:
        if self.scope not in SCOPES:
            raise ValueError(f"command {self.id!r}: scope {self.scope!r} is not one of {SCOPES}")
        if self.enabled_when and self.enabled_when not in CONDITIONS:
            raise ValueError(f"command {self.id!r}: condition {self.enabled_when!r} is not one of {CONDITIONS}")
        if "." not in self.handler:
            raise ValueError(f"command {self.id!r}: handler {self.handler!r} is not owner.method")


@dataclass(frozen=True)
class Submenu:
    """A submenu at ``path`` (its parent menu's path, then its name); ``filled_by``: a list the window keeps
    in it (``samples``, ``recent``) instead of declared commands."""

    path: str
    title: str
    group: str = ""
    filled_by: str = ""

    @property
    def menu(self) -> str:
        return self.path.rpartition("/")[0]


@dataclass(frozen=True)
class Section:
    """A place in ``menu`` the window fills with a list of its own (``docks``: each panel's show/hide)."""

    menu: str
    filled_by: str
    group: str = ""


def _nudges() -> tuple[Command, ...]:
    return tuple(Command(f"nudge_{arrow.lower()}_{step:g}", f"Nudge {arrow.lower()} {step:g} px", "window.nudge",
                         (dx * step, dy * step), "Measure/Nudge the current pick", keys=(f"{modifier}+{arrow}",),
                         tip=f"move the current pick {step:g} px {arrow.lower()}", scope="images")
                 for arrow, (dx, dy) in NUDGES.items() for modifier, step in (("Ctrl", 0.1), ("Ctrl+Shift", 1.0)))


#: every menu item in menu order: commands, submenus and sections
ITEMS: tuple[Command | Submenu | Section, ...] = (
    # ---------------------------------------------------------------- File
    Command("open", "&Open project…", "window.open_dialog", menu="File", keys=("std:Open",),
            tip="open a project file (*.usvips) or a sample directory", short="Open"),
    Command("new_project", "&New project…", "media_dialogs.new_project", menu="File"),
    Command("add_pairs", "Add &image pairs…", "media_dialogs.add_image_pairs", menu="File"),
    Command("add_video", "Add stereo &video…", "media_dialogs.add_video", menu="File"),
    Command("relocate", "Re&locate missing media…", "media_dialogs.relocate_media", menu="File"),
    Command("accept_media", "Accept c&hanged media…", "media_dialogs.accept_changed_media", menu="File",
            tip="take a media file that changed since it was added (re-exported, repaired) as the recording the "
                "project means, after reading it whole"),
    Submenu("File/Open sample", "Open &sample", filled_by="samples"),
    Submenu("File/Recent projects", "&Recent projects", filled_by="recent"),
    Command("save_as", "Save &as… (a copy, then work on it)", "window.save_as_dialog", menu="File",
            keys=("Ctrl+Shift+S",)),
    Command("export", "&Export objects…", "window.export_dialog", menu="File"),
    Command("import_species", "I&mport species list…", "window.species_dialog", menu="File"),
    # exchange with other tools (usvips/gui/qt/exchange_dialogs.py)
    Command("import_calibration", "Import &calibration (OpenCV)…", "exchange_dialogs.import_calibration",
            menu="File", group="exchange"),
    Command("export_calibration", "Ex&port calibration (OpenCV)…", "exchange_dialogs.export_calibration",
            menu="File", group="exchange"),
    Command("calibration_report", "Calibration repor&t (PDF)…", "exchange_dialogs.calibration_report",
            menu="File", group="exchange"),
    Command("deployment", "&Deployment and georeference…", "exchange_dialogs.edit_deployment", menu="File",
            group="exchange"),
    Command("double_read", "Dou&ble-read report…", "window.show_double_read", menu="File", group="exchange"),
    Command("annotator", "Annotator: &your name…", "window.annotator_dialog", menu="File", group="exchange",
            tip="who is annotating: every object, pick, record and review made in this window is stamped with the "
                "name"),
    Command("quit", "&Quit", "window.close", menu="File", group="quit", keys=("std:Quit",)),
    # ---------------------------------------------------------------- Edit
    Command("undo", "&Undo", "window.undo", menu="Edit", keys=("std:Undo",), enabled_when="can_undo"),
    Command("redo", "&Redo", "window.redo", menu="Edit", keys=("std:Redo",), enabled_when="can_redo"),
    # the edits a failed save kept (usvips.gui.object_edits: never shown as saved)
    Command("retry_unsaved", "Re&try unsaved edits", "window.retry_unsaved_edits", menu="Edit", group="unsaved"),
    Command("discard_unsaved", "&Discard unsaved edits", "window.discard_unsaved_edits", menu="Edit",
            group="unsaved"),
    # ---------------------------------------------------------------- View
    Command("fit", "&Fit", "window.each_pane", ("fit",), "View", keys=("F",), tip="whole image in view"),
    Command("one", "1:&1", "window.each_pane", ("one_to_one",), "View", keys=("1",),
            tip="one image pixel per screen pixel", short="1:1"),
    Command("zoom_in", "Zoom &in", "window.each_pane", ("zoom_by", 1.25), "View", keys=("std:ZoomIn",)),
    Command("zoom_out", "Zoom &out", "window.each_pane", ("zoom_by", 0.8), "View", keys=("std:ZoomOut",)),
    Command("box", "&Box zoom", "window.apply_box_zoom", menu="View", keys=("B",), tip="drag a box to zoom into",
            checkable=True, short="Box"),
    Command("link", "&Link zoom", "window.apply_link", menu="View", keys=("L",),
            tip="zooming or panning one image brings the other to the same place in the scene (through the "
                "calibration, at the depth of the last measured point)", checkable=True, short="Link"),
    Command("loupe", "Lou&pe", "window.apply_loupe", menu="View", keys=("G",), tip="magnifier around the cursor",
            checkable=True, short="Loupe"),
    Submenu("View/Loupe magnification", "Loupe &magnification"),
    *(Command(f"loupe_{scale}", f"Loupe {scale}×", "window.set_loupe_scale", (scale,), "View/Loupe magnification",
              tip=f"the loupe shows {scale} screen pixels per image pixel", checkable=True, exclusive="loupe")
      for scale in LOUPE_SCALES),
    Command("qa", "&QA panel", "window.show_qa", menu="View", keys=("Ctrl+Shift+Q",),
            tip="the survey's objects that break a quality rule: arrows and Enter go to each one's pair or frame"),
    Command("review", "&Review mode", "window.show_review", menu="View", keys=("Ctrl+Shift+R",),
            tip="walk the unreviewed objects: N next, P previous, A accept, F flag, S skip, J or Enter go to it, "
                "H its history"),
    Section("View", "docks", group="panels"),
    # ---------------------------------------------------------------- Measure
    *(Command(f"tool_{tool}", tool.capitalize(), "window.set_tool", (tool,), "Measure", group="tools",
              keys=(f"Ctrl+{number}",), tip=TOOL_TIPS[tool], checkable=True, exclusive="tools")
      for number, tool in enumerate(TOOLS, 1)),
    Command("accept", "Accept match / finish", "window.accept_or_finish", menu="Measure", group="picking",
            keys=("Return", "Enter"), tip="accept the proposed match; with no proposal, finish the object",
            scope="images"),
    Command("finish", "&Finish object", "window.finish_object", menu="Measure", group="picking",
            keys=("Ctrl+Return", "Ctrl+Enter"), tip="store the object", scope="images", short="Finish"),
    Command("cancel", "Cancel pick", "window.cancel_pick", menu="Measure", group="picking", keys=("Escape",),
            tip="drop the half-made vertex", scope="images"),
    Command("snap", "&Snap to targets", "window.apply_snap", menu="Measure", group="picking", keys=("S",),
            tip="snap each click to the sub-pixel centre of a target disc", checkable=True, short="Snap"),
    Command("auto_match", "&Auto-match", "window.apply_auto_match", menu="Measure", group="picking", keys=("M",),
            tip="propose the conjugate along the epipolar curve", checkable=True, short="Auto-match"),
    Submenu("Measure/Nudge the current pick", "N&udge the current pick", group="picking"),
    *_nudges(),
    Command("previous_pair", "&Previous pair", "window.step_pair", (-1,), "Measure", group="pairs", keys=("PgUp",),
            tip="show the previous image pair", scope="images"),
    Command("next_pair", "&Next pair", "window.step_pair", (1,), "Measure", group="pairs", keys=("PgDown",),
            tip="show the next image pair", scope="images"),
    # issue 25: tracking through a video and objects over several instants (usvips/gui/qt/track_controls.py)
    Command("track", "&Track the object's vertices", "tracking.track", menu="Measure", group="tracking",
            keys=("T",), tip="follow each vertex of the selected object (or the one just stored) backward and "
                             "forward through the video from its frame", scope="images"),
    Command("refollow", "&Re-follow from here", "tracking.refollow", menu="Measure", group="tracking",
            keys=("Shift+T",), tip="after re-picking a tracked point on this frame (left, then right), follow it on "
                                   "from here", scope="images"),
    Command("store_instants", "Store trac&ks as instants…", "tracking.store_dialog", menu="Measure",
            group="tracking", keys=("Ctrl+T",), tip="store the tracked vertices as further instants of the object "
                                                    "(every N frames, or the frames typed); undoable"),
    Command("propose_tracked", "Propose from the &earlier instant", "tracking.propose", menu="Measure",
            group="tracking", keys=("P",), tip="propose the selected object's vertices on this frame, tracked from "
                                               "the frame it was measured on (Enter accepts each)", scope="images"),
    Command("instants", "&Instants of the object…", "window.show_instants", menu="Measure", group="tracking",
            keys=("I",), tip="list the selected object's instants: each one's figure and weight, the combined figure "
                             "and the agreement test", scope="images"),
    # issue 35: a detection model's proposals, stored unreviewed (usvips/gui/qt/detection_dialogs.py)
    Command("detect", "&Detect fish on this frame", "detection_dialogs.detect_frame", menu="Measure",
            group="detection", keys=("Ctrl+D",), tip="a detection model proposes fish on the pair or frame shown, "
            "paired through the housing; stored unreviewed, then review mode: A accepts, F flags"),
    Command("detect_range", "Detect fish on a range &of frames…", "detection_dialogs.detect_range",
            menu="Measure", group="detection", tip="propose fish on frames of the video from the one shown"),
    Command("detect_model", "Detection &model…", "detection_dialogs.choose_model", menu="Measure",
            group="detection", tip="choose the model's description file (.toml; docs/detection.md)"),
    Command("pointing_test", "Pointin&g test…", "window.show_pointing_test", menu="Measure", group="sigma",
            tip="click rendered targets to estimate your pointing σ (stored for you on request)"),
    Command("sigma_check", "Check &σ (Monte Carlo)…", "window.show_sigma_check", menu="Measure", group="sigma",
            tip="whether the open project's stated σ hold for its own geometry"),
    # ---------------------------------------------------------------- Calibration
    Command("phase_1", "Phase &1 (in air)…", "window.open_calibration_wizard", ("air",), "Calibration",
            tip="phase 1: the cameras, from a target filmed in air"),
    Command("phase_2", "Phase &2 (underwater)…", "window.open_calibration_wizard", ("water",), "Calibration",
            tip="phase 2: the housings and the water, the cameras of phase 1 kept"),
    Command("joint", "&Joint underwater calibration…", "window.open_calibration_wizard", ("joint",), "Calibration"),
    Command("import_usvips_calibration", "&Import a USVIPS calibration…", "exchange_dialogs.import_usvips_calibration",
            menu="Calibration", group="stored"),
    Command("use_calibration", "&Use a stored calibration…", "exchange_dialogs.use_calibration", menu="Calibration",
            group="stored"),
    Command("target_field", "Find a &target field…", "window.show_target_field_tool", menu="Calibration",
            group="field", tip="identify six or more targets of a 3-D field by clicking; the rest are found"),
    # ---------------------------------------------------------------- Help
    Command("guide", "&Quick guide", "window.show_guide", menu="Help", keys=("F1",)),
    Command("keys", "&Keys…", "window.show_keys", menu="Help", tip="every command with its keys"),
    # ---------------------------------------------------------------- keys only
    Command("instants_of_listed", "&Instants of the object…", "window.show_instants", keys=("Ctrl+I",),
            scope="object list", tip="list the selected object's instants (in the object list and its context menu)"),
)


def commands() -> tuple[Command, ...]:
    """Every declared command, in menu order."""
    return tuple(item for item in ITEMS if isinstance(item, Command))


def command(command_id: str) -> Command:
    """The command declared as ``command_id`` (KeyError names it when there is none)."""
    found = [c for c in commands() if c.id == command_id]
    if not found:
        raise KeyError(f"no command {command_id!r}")
    return found[0]


def key_list(key_text=lambda key: key) -> list[tuple[str, str, str]]:
    """(keys, title, where it works) of every command with keys, in menu order — the Help › Keys list;
    ``key_text(key)`` writes a key as the platform shows it (the window passes Qt's native text)."""
    where = {"window": "", "images": "on the images", "object list": "in the object list"}
    return [(", ".join(key_text(k) for k in c.keys), c.title.replace("&", ""), where[c.scope])
            for c in commands() if c.keys]


__all__ = ["CONDITIONS", "ITEMS", "MENUS", "NUDGES", "SCOPES", "TOOL_TIPS", "Command", "Section", "Submenu",
           "command", "commands", "key_list"]
