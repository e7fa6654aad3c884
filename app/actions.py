"""The window's actions: one table (:func:`action_specs`: :data:`BASE_ACTIONS`
and a row for each registered tool, :func:`flatweave.app.tooling.tool_specs`,
read when a window is made) from which the actions, the menus and the toolbar
are built (:func:`build_actions`, :func:`build_menus`, :func:`build_toolbar`),
and one function that enables, names and checks them for the window's state
(:func:`update_actions`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from PySide6.QtCore import Qt
from PySide6.QtGui import QAction, QActionGroup, QKeySequence

from flatweave.app.tooling import tool_specs

__all__ = ["ActionSpec", "BASE_ACTIONS", "action_specs", "MENUS", "UiState", "build_actions", "build_menus",
           "build_toolbar", "update_actions", "view_choices", "show_view_choices"]

Keys = QKeySequence.StandardKey


@dataclass(frozen=True)
class UiState:
    """What the actions depend on: the document (or None), the runner's state
    ("idle", "running", "paused", "stopping"), an export under way, the tools."""

    document: object
    run_state: str
    exporting: bool
    tools: object

    @property
    def has_doc(self) -> bool:
        return self.document is not None

    @property
    def solving(self) -> bool:
        return self.run_state in ("running", "paused")


def _has_doc(s: UiState) -> bool:
    return s.has_doc


def _any_solved(s: UiState) -> bool:
    return s.has_doc and any(p.result is not None for p in s.document.project.pieces)


@dataclass(frozen=True)
class ActionSpec:
    """One action.

    slot : the window attribute (dotted) it triggers, or that gets the checked state when checkable
    option : a checkable action setting this ViewOptions field to its state; ``value`` (an exclusive
        ``group``'s choice) sets the field to ``value`` when checked
    menu, section : its menu and its group there (separators between groups, in table order per group)
    toolbar : its group on the toolbar (None: not there)
    enabled, text_of : its enabled state and text for a :class:`UiState` (None: always enabled, fixed text)
    tool : the tool class a tool action makes (checked while that tool is active)
    """

    key: str
    text: str
    slot: str | None = None
    shortcut: object = None
    tip: str | None = None
    checkable: bool = False
    checked: bool = False
    option: str | None = None
    value: object = None
    group: str | None = None
    menu: str | None = None
    section: int = 0
    toolbar: int | None = None
    enabled: Callable[[UiState], bool] | None = None
    text_of: Callable[[UiState], str] | None = None
    tool: type | None = None


def _has_fit(s: UiState) -> bool:
    """The document's surface was fitted to a mesh (:class:`flatweave.geometry.meshfit.FittedSurface`)."""
    return s.has_doc and getattr(s.document.project.surface, "fit", None) is not None


def _redo_keys() -> list:
    keys = list(QKeySequence.keyBindings(Keys.Redo))
    if QKeySequence("Ctrl+Y") not in keys:
        keys.append(QKeySequence("Ctrl+Y"))
    return keys


def _undo_text(s: UiState) -> str:
    doc = s.document
    return f"&Undo {doc.undo_label}" if doc and doc.can_undo else "&Undo"


def _redo_text(s: UiState) -> str:
    doc = s.document
    return f"&Redo {doc.redo_label}" if doc and doc.can_redo else "&Redo"


MENUS = ("&File", "&Edit", "E&xamples", "&Tools", "&Solve", "&View")
"""The menu bar, in order (the examples menu is filled by ``Files.fill_examples_menu``)."""

_FILE, _EDIT, _TOOLS, _SOLVE, _VIEW = "&File", "&Edit", "&Tools", "&Solve", "&View"

BASE_ACTIONS: tuple[ActionSpec, ...] = (
    ActionSpec("open", "&Open...", "open_dialog", Keys.Open,
               "Open a project (.flatweave), a surface (geomdl JSON, STEP, IGES) or a mesh (STL, OBJ, PLY, OFF)",
               menu=_FILE),
    ActionSpec("save", "&Save", "save", Keys.Save, "Save the project", menu=_FILE, enabled=_has_doc),
    ActionSpec("save_as", "Save &As...", "save_as", Keys.SaveAs, "Save the project under a new name", menu=_FILE,
               enabled=_has_doc),
    ActionSpec("export", "&Export pattern...", "export_dialog", "Ctrl+E",
               "Write the pattern as DXF, SVG, tiled PDF, VTP or OBJ", menu=_FILE, section=1,
               enabled=lambda s: bool(s.document and s.document.project.result is not None) and not s.exporting),
    ActionSpec("export_pieces", "Export all p&ieces...", "export_pieces_dialog", None,
               "Write every solved piece's cut files into a folder: one DXF with a block per piece, an SVG and a "
               "tiled PDF per piece", menu=_FILE, section=1, enabled=lambda s: _any_solved(s) and not s.exporting),
    ActionSpec("export_book", "Export ply &book...", "export_book_dialog", None,
               "Write the ply book (PDF): the stacking table, then a page per piece with the tool, its numbers and "
               "its pattern at a stated scale", menu=_FILE, section=1,
               enabled=lambda s: _has_doc(s) and not s.exporting),
    ActionSpec("quit", "&Quit", "close", Keys.Quit, menu=_FILE, section=2),
    ActionSpec("undo", "&Undo", "undo", Keys.Undo, menu=_EDIT,
               enabled=lambda s: bool(s.document and s.document.can_undo), text_of=_undo_text),
    ActionSpec("redo", "&Redo", "redo", _redo_keys, menu=_EDIT,
               enabled=lambda s: bool(s.document and s.document.can_redo), text_of=_redo_text),
    ActionSpec("run", "&Run", "run", "F5", "Drape the mesh and minimise its energy", menu=_SOLVE, toolbar=0,
               enabled=lambda s: s.has_doc and s.run_state == "idle"),
    ActionSpec("pause", "&Pause", "toggle_pause", "F6", "Pause or resume the solve", menu=_SOLVE, toolbar=0,
               enabled=lambda s: s.solving, text_of=lambda s: "&Resume" if s.run_state == "paused" else "&Pause"),
    ActionSpec("stop", "&Stop", "stop", "Shift+F5", "Stop the solve; keep the last iterate", menu=_SOLVE, toolbar=0,
               enabled=lambda s: s.solving),
    ActionSpec("reset_view", "&Reset 3D view", "view.reset_camera", "R", menu=_VIEW, section=2, toolbar=4,
               enabled=_has_doc),
    ActionSpec("fit_pattern", "&Fit pattern", "pattern_view.fit", "F", menu=_VIEW, section=2, toolbar=4,
               enabled=_has_doc),
    ActionSpec("mode_strain", "&Strain", None, "1",
               "Colour springs by strain: red tensile, green zero, blue compressive", checkable=True, checked=True,
               option="mode", value="strain", group="mode", menu=_VIEW, toolbar=1),
    ActionSpec("mode_shear", "S&hear", None, "2",
               "Colour cells by shear angle against the warning and limit angles", checkable=True,
               option="mode", value="shear", group="mode", menu=_VIEW, toolbar=1),
    ActionSpec("mode_fibre", "&Fibre angle", None, "3",
               "Colour cells by the weft's angle from the rosette (the weft direction at the seed)", checkable=True,
               option="mode", value="fibre", group="mode", menu=_VIEW, toolbar=1),
    ActionSpec("show_weft", "&Weft", None, None, "Show weft springs", True, True, "weft", menu=_VIEW, section=1,
               toolbar=2),
    ActionSpec("show_warp", "W&arp", None, None, "Show warp springs", True, True, "warp", menu=_VIEW, section=1,
               toolbar=2),
    ActionSpec("show_diag", "&Diagonal", None, None, "Show diagonal springs", True, True, "diag", menu=_VIEW,
               section=1, toolbar=2),
    ActionSpec("show_surface", "S&urface", None, None, "Show the surface under the mesh", True, True, "surface",
               menu=_VIEW, section=1, toolbar=2),
    ActionSpec("show_nodes", "&Nodes", None, None, "Show boundary nodes (yellow) and dart nodes (red, blue)",
               True, True, "nodes", menu=_VIEW, section=1, toolbar=2),
    # not view choices kept with the project (no option): drawn on request, a reopened project rereads the mesh
    ActionSpec("show_fit_deviation", "Mesh fit &deviation", "presenter.show_fit_deviation", None,
               "Colour the mesh the surface was fitted to by each vertex's distance to the surface",
               True, False, menu=_VIEW, section=3, enabled=_has_fit),
    ActionSpec("show_fit_mesh", "&Mesh beside the surface", "presenter.show_fit_mesh_beside", None,
               "Draw the mesh the surface was fitted to beside it (off: over it, when its deviation is shown)",
               True, False, menu=_VIEW, section=3, enabled=_has_fit),
    ActionSpec("sweep", "&Best orientation...", "sweep_dialog", "Ctrl+Shift+A",
               "Solve at several weft angles and rank them: area beyond the lock angle, max shear, boundary error",
               menu=_SOLVE, section=1, enabled=lambda s: s.has_doc and not s.solving),
    ActionSpec("nest", "&Nest pieces on the roll", "nest_pieces", None,
               "Place every solved piece's copies on the roll as short as it can be, a marker per material, in "
               "the Cut plan panel", menu=_SOLVE, section=2, enabled=_any_solved),
    ActionSpec("cut_plan", "&Cut plan", "show_cut_plan", None,
               "Show the Cut plan panel: the solved pieces nested on the roll", menu=_VIEW, section=4,
               enabled=_has_doc),
    ActionSpec("suggest_darts", "S&uggest darts...", "suggest_dialog", "Ctrl+Shift+D",
               "Try darts from the edge inwards and list those that lower the strain most", menu=_TOOLS, section=2,
               enabled=lambda s: bool(s.document and s.document.project.result_is_current) and not s.solving),
    ActionSpec("tool_finish", "&Finish", "finish_tool", (Qt.Key.Key_Return, Qt.Key.Key_Enter),
               "Make the dart or constraint (Enter)", menu=_TOOLS, section=1,
               enabled=lambda s: s.tools.tool is not None and not s.tools.tool.implied),
    ActionSpec("tool_back", "Take &back a point", "back_tool", ("Backspace", "Delete"),
               "Remove the last point of the dart being drawn (the region tool: the picked region point)",
               menu=_TOOLS, section=1,
               enabled=lambda s: s.tools.tool is not None and s.tools.tool.takes_back),
    ActionSpec("tool_cancel", "Ca&ncel", "cancel_tool", "Esc", "Drop the dart or yarn being made (Esc)",
               menu=_TOOLS, section=1, enabled=lambda s: s.tools.tool is not None and not s.tools.tool.implied),
)
"""The window's actions other than the tools' (their order matters only within a menu's or the toolbar's section)."""


def action_specs() -> tuple[ActionSpec, ...]:
    """The window's actions: :data:`BASE_ACTIONS` and a checkable action for each
    registered tool that has a key (section 0 of its menu, section 3 of the toolbar)."""
    return BASE_ACTIONS + tuple(
        ActionSpec(t.key, t.text, None, t.shortcut, t.tip, checkable=True, menu=t.menu,
                   toolbar=3 if t.toolbar else None, enabled=_has_doc, tool=t.tool) for t in tool_specs() if t.key)


def _resolve(window, dotted: str):
    target = window
    for part in dotted.split("."):
        target = getattr(target, part)
    return target


def _set_shortcut(action: QAction, shortcut) -> None:
    if shortcut is None:
        return
    if callable(shortcut) and not isinstance(shortcut, (str, Keys)):
        action.setShortcuts(shortcut())
    elif isinstance(shortcut, tuple):
        action.setShortcuts([QKeySequence(k) for k in shortcut])
    else:
        action.setShortcut(shortcut)
    # Qt's default context, WindowShortcut, keeps every key to this window.


def build_actions(window, specs) -> dict[str, QAction]:
    """The window's QActions by key, connected to their slots, view options or tools."""
    acts: dict[str, QAction] = {}
    groups: dict[str, QActionGroup] = {}
    for spec in specs:
        a = QAction(spec.text, window)
        _set_shortcut(a, spec.shortcut)
        if spec.tip:
            a.setStatusTip(spec.tip)
            a.setToolTip(spec.tip)
        if spec.checkable:
            a.setCheckable(True)
            a.setChecked(spec.checked)
            if spec.tool is not None:
                a.toggled.connect(lambda on, kind=spec.tool: window.tools.toggled(kind, on))
            elif spec.value is not None:
                a.toggled.connect(lambda on, f=spec.option, v=spec.value: on and window.set_view_options(**{f: v}))
            elif spec.option is not None:
                a.toggled.connect(lambda on, f=spec.option: window.set_view_options(**{f: on}))
            elif spec.slot is not None:
                a.toggled.connect(_resolve(window, spec.slot))
        elif spec.slot is not None:
            a.triggered.connect(_resolve(window, spec.slot))
        if spec.group is not None:
            group = groups.get(spec.group)
            if group is None:
                group = groups[spec.group] = QActionGroup(window)
                group.setExclusive(True)
            group.addAction(a)
        acts[spec.key] = a
    return acts


def _sections(items):
    """(spec, separator before it) in section order, table order within a section."""
    ordered = sorted(items, key=lambda pair: pair[0])
    for k, (section, spec) in enumerate(ordered):
        yield spec, k > 0 and section != ordered[k - 1][0]


def build_menus(window, actions: dict[str, QAction], specs) -> dict[str, object]:
    """The menu bar's menus (by title, in :data:`MENUS` order) with their actions."""
    menus = {title: window.menuBar().addMenu(title) for title in MENUS}
    for title, menu in menus.items():
        for spec, separate in _sections([(s.section, s) for s in specs if s.menu == title]):
            if separate:
                menu.addSeparator()
            menu.addAction(actions[spec.key])
    return menus


def build_toolbar(window, actions: dict[str, QAction], specs):
    tb = window.addToolBar("Main")
    tb.setObjectName("main-toolbar")
    tb.setMovable(False)
    for spec, separate in _sections([(s.toolbar, s) for s in specs if s.toolbar is not None]):
        if separate:
            tb.addSeparator()
        tb.addAction(actions[spec.key])
    return tb


def update_actions(actions: dict[str, QAction], state: UiState, specs) -> None:
    """Enable, name and check the actions for ``state`` (the one place that does)."""
    for spec in specs:
        a = actions[spec.key]
        if spec.enabled is not None:
            a.setEnabled(spec.enabled(state))
        if spec.text_of is not None:
            a.setText(spec.text_of(state))
        if spec.tool is not None:
            a.blockSignals(True)
            a.setChecked(state.tools.checked(spec.tool))
            a.blockSignals(False)


def _view_specs(specs=BASE_ACTIONS):
    return [s for s in specs if s.option is not None and s.tool is None]


def view_choices(actions: dict[str, QAction], specs=BASE_ACTIONS) -> dict[str, object]:
    """The view choices the actions hold ({"mode": "shear", "weft": True, ...}: the
    checkable view actions' ViewOptions fields), as a project file keeps them."""
    out: dict[str, object] = {}
    for spec in _view_specs(specs):
        on = actions[spec.key].isChecked()
        if spec.value is None:
            out[spec.option] = on
        elif on:
            out[spec.option] = spec.value
    return out


def show_view_choices(actions: dict[str, QAction], choices, specs=BASE_ACTIONS) -> None:
    """Check the view actions for ``choices`` (a mapping as :func:`view_choices`
    makes; missing or unknown entries leave an action as it is). The actions'
    toggles set the views' options, so the views and the toolbar follow."""
    choices = dict(choices)
    for spec in _view_specs(specs):
        if spec.option not in choices:
            continue
        value = choices[spec.option]
        if spec.value is None:
            if isinstance(value, bool):
                actions[spec.key].setChecked(value)
        elif value == spec.value:
            actions[spec.key].setChecked(True)  # the exclusive group unchecks the others
