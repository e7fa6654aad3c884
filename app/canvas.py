"""The render widgets of the two views: pyvistaqt's OpenGL widget, or a plain
(raster) Qt widget showing an off-screen pyvista render.

Why two: Qt composes a window holding a ``QOpenGLWidget`` with OpenGL on
every paint pass, which a software renderer (Mesa's llvmpipe, no GPU, Xvfb)
pays dearly for; :class:`CanvasPlotter` renders the same pyvista scene off
screen and paints its pixels into an ordinary widget, so the window stays a
raster window (measurements in docs/decisions/0009-window-on-software-opengl.md).

``FLATWEAVE_VIEW`` chooses: ``gl`` (pyvistaqt), ``canvas``, or ``auto`` (the
default): the canvas when Qt's OpenGL renderer is a software one, pyvistaqt
otherwise. Both expose what the views use: ``interactor`` (the QWidget),
``iren``, ``render_window``, ``renderer``, ``render()`` (schedule a repaint),
``close()``, and the rest of pyvista's plotter API.
"""

from __future__ import annotations

import os
import re

import numpy as np
import pyvista as pv
from PySide6.QtCore import QEvent, Qt
from PySide6.QtGui import QColor, QImage, QPainter
from PySide6.QtWidgets import QWidget
from pyvistaqt import QtInteractor
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

from flatweave.app.choices import VIEW_KINDS, view_setting

__all__ = ["CanvasPlotter", "GLPlotter", "make_plotter", "view_kind", "is_software_renderer", "VIEW_KINDS"]

_SOFTWARE = re.compile(r"llvmpipe|softpipe|swrast|software|gdi generic|basic render", re.IGNORECASE)
_GL_RENDERER = 0x1F01
_chosen: str | None = None


def is_software_renderer(renderer: str) -> bool:
    """True for the GL_RENDERER string of a renderer that runs on the CPU."""
    return bool(_SOFTWARE.search(renderer or ""))


def _qt_gl_renderer() -> str | None:
    """The GL_RENDERER string of the OpenGL Qt would compose with, or None if
    Qt gets no OpenGL context at all."""
    from PySide6.QtGui import QOffscreenSurface, QOpenGLContext

    ctx = QOpenGLContext()
    if not ctx.create():
        return None
    surface = QOffscreenSurface()
    surface.setFormat(ctx.format())
    surface.create()
    try:
        if not ctx.makeCurrent(surface):
            return None
        name = ctx.functions().glGetString(_GL_RENDERER)
        ctx.doneCurrent()
        return str(name or "")
    finally:
        surface.destroy()


def view_kind() -> str:
    """``"gl"`` or ``"canvas"``: from ``FLATWEAVE_VIEW``, else by the renderer
    (asked once per process; needs a QApplication)."""
    global _chosen
    wanted = view_setting(os.environ.get("FLATWEAVE_VIEW"))
    if wanted != "auto":
        return wanted
    if _chosen is None:
        name = _qt_gl_renderer()
        _chosen = "canvas" if name is None or is_software_renderer(name) else "gl"
    return _chosen


def make_plotter(parent=None):
    """A plotter of the kind :func:`view_kind` chooses, with no multisampling
    and no lights (the views add a headlight)."""
    if view_kind() == "canvas":
        return CanvasPlotter(parent)
    return GLPlotter(parent, auto_update=False, multi_samples=0, lighting="none")


class GLPlotter(QtInteractor):
    """pyvistaqt's render widget, whose paint lets other Python threads run
    while VTK renders.

    Its ``paintGL`` renders through ``vtkRenderWindowInteractor.Render()``, and
    VTK's Python wrapping keeps the GIL through that call: only methods VTK
    marks ``VTK_UNBLOCKTHREADS``, ``vtkRenderWindow.Render()`` among them,
    release it. So every render of a view stopped the solve thread for its
    whole length (docs/decisions/0009-window-on-software-opengl.md). Here the interactor's own render is switched off
    for the paint and a ``RenderEvent`` observer, first in line, renders the
    window instead: the same render, events and order, without the GIL.
    """

    def paintGL(self):
        iren = self.iren.interactor if self.iren is not None else None
        rw = self.render_window
        if iren is None or rw is None or not (iren.GetEnabled() and iren.GetEnableRender()):
            super().paintGL()  # not rendering now (or closing): pyvistaqt's paint as it is
            return
        tag = iren.AddObserver("RenderEvent", lambda *_: rw.Render(), 1.0)
        iren.EnableRenderOff()
        try:
            super().paintGL()
        finally:
            iren.EnableRenderOn()
            iren.RemoveObserver(tag)

    def wheelEvent(self, ev):
        """pyvistaqt hands the wheel to VTK without its position (the last mouse
        move's stands): give it, so the 3D view zooms about the cursor."""
        iren = self.iren.interactor if self.iren is not None else None
        if iren is not None:
            dpr = self.devicePixelRatioF()
            pos = ev.position()
            iren.SetEventInformationFlipY(round(pos.x() * dpr), round(pos.y() * dpr),
                                          int(bool(ev.modifiers() & Qt.KeyboardModifier.ControlModifier)),
                                          int(bool(ev.modifiers() & Qt.KeyboardModifier.ShiftModifier)), "\0", 0, None)
        super().wheelEvent(ev)

    def is_ready(self) -> bool:
        rw = self.render_window
        return bool(rw is not None and rw.GetReadyForRendering())

    def render_now(self) -> None:
        """Render at once (before reading pixels back from VTK)."""
        self._render()

    def close(self) -> None:
        super().close()
        # pyvistaqt's wrappers of the Qt-owned GL context and surface must not outlive
        # them: shiboken can hand a stale one out for a new object (docs/decisions/0009-window-on-software-opengl.md).
        forget = getattr(self, "_forget_context", None)
        if forget is not None:
            forget()


class CanvasPlotter(pv.Plotter):
    """A pyvista plotter that renders off screen and is shown by
    :class:`Canvas`, a raster QWidget (``self.interactor``) that forwards the
    mouse to VTK's interactor.

    ``render()`` schedules a repaint, as pyvistaqt's does: repaints asked for
    in one pass of the event loop are merged, and the paint renders (with the
    GIL released) and shows the pixels. The interactor's own renders (the
    camera style and VTK's widgets call it while the user drags) only schedule
    a repaint too.
    """

    def __init__(self, parent=None):
        super().__init__(off_screen=True, lighting="none", window_size=(64, 64))
        rw = self.render_window
        rw.SetMultiSamples(0)  # pyvista's theme asks for 8; software GL pays 3-7x per render
        self.disable_anti_aliasing()
        self._first_time = False  # BasePlotter renders only after show(); the canvas is the show
        iren = self.iren.interactor
        iren.EnableRenderOff()
        self._render_tag = iren.AddObserver("RenderEvent", self._schedule)
        self.interactor = Canvas(self, parent)

    def _schedule(self, *_args) -> None:
        canvas = getattr(self, "interactor", None)  # None while pyvista's __init__ runs
        if canvas is not None and not self._closed:
            canvas.update()

    def render(self) -> None:
        """Schedule a repaint (which renders)."""
        self._schedule()

    def render_now(self) -> None:
        """Render at once (before reading pixels back from VTK)."""
        if not self._closed:
            self.interactor.fit_render_window()
            pv.Plotter.render(self)

    def is_ready(self) -> bool:
        return not self._closed

    def screenshot(self, filename=None, *args, **kwargs):
        self.render_now()
        return super().screenshot(filename, *args, **kwargs)

    def close(self) -> None:
        if self._closed:
            return
        iren = self.iren.interactor if self.iren is not None else None
        if iren is not None:
            iren.RemoveObserver(self._render_tag)
        canvas = self.interactor
        super().close()
        canvas.detach()


_BUTTONS = {Qt.MouseButton.LeftButton: "Left", Qt.MouseButton.MiddleButton: "Middle",
            Qt.MouseButton.RightButton: "Right"}


class Canvas(QWidget):
    """Shows a :class:`CanvasPlotter`'s render and hands it the mouse.

    A paint resizes the render window to the widget (device pixels), renders,
    reads the pixels back and draws them. Mouse presses, releases, double
    clicks (a press with a repeat count of 1, as VTK's own Qt widget sends),
    moves, the wheel and entering or leaving go to the VTK interactor with the
    modifier keys. Keys stay with Qt: the window's shortcuts own them, and
    VTK's one-letter keys ('w' turns every actor to wireframe, 'q' closes a
    pyvista plotter) are not a designer's.
    """

    def __init__(self, plotter: CanvasPlotter, parent=None):
        super().__init__(parent)
        self._plotter: CanvasPlotter | None = plotter
        self._pixels = vtkUnsignedCharArray()
        self._rows = np.zeros((1, 1, 4), dtype=np.uint8)  # the shown image's memory
        self.renders = 0
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)
        self.setMouseTracking(True)
        self.setFocusPolicy(Qt.FocusPolicy.WheelFocus)
        self.setMinimumSize(64, 64)

    def detach(self) -> None:
        """The plotter is closed: paint the background from now on."""
        self._plotter = None
        self.update()

    # ------------------------------------------------------------------ drawing
    def _device_size(self) -> tuple[int, int]:
        dpr = self.devicePixelRatioF()
        return max(1, round(self.width() * dpr)), max(1, round(self.height() * dpr))

    def fit_render_window(self) -> None:
        """Give the render window (and the interactor, which flips y with it) the widget's size."""
        p = self._plotter
        if p is None:
            return
        w, h = self._device_size()
        if tuple(p.render_window.GetSize()) != (w, h):
            p.iren.interactor.UpdateSize(w, h)

    def image(self) -> np.ndarray:
        """(h, w, 3) uint8, the pixels the widget shows now, top row first."""
        return self._rows[:, :, :3].copy()

    def paintEvent(self, _event) -> None:
        painter = QPainter(self)
        try:
            p = self._plotter
            if p is None or p._closed:
                painter.fillRect(self.rect(), QColor("#ffffff"))
                return
            p.render_now()
            self.renders += 1
            rw = p.render_window
            w, h = rw.GetSize()
            rw.GetRGBACharPixelData(0, 0, w - 1, h - 1, 0, self._pixels, 0)
            self._rows = np.ascontiguousarray(vtk_to_numpy(self._pixels).reshape(h, w, 4)[::-1])
            image = QImage(self._rows.data, w, h, 4 * w, QImage.Format.Format_RGBX8888)
            image.setDevicePixelRatio(self.devicePixelRatioF())
            painter.drawImage(0, 0, image)
        finally:
            painter.end()

    def resizeEvent(self, event) -> None:
        self.fit_render_window()
        p = self._plotter
        if p is not None:
            p.iren.interactor.InvokeEvent("ConfigureEvent")
        super().resizeEvent(event)

    # ------------------------------------------------------------------ input
    def _send(self, event, vtk_event: str, repeat: int = 0) -> None:
        p = self._plotter
        if p is None or p._closed:
            return
        self.fit_render_window()
        iren = p.iren.interactor
        dpr = self.devicePixelRatioF()
        if hasattr(event, "position"):
            pos = event.position()
            x, y = round(pos.x() * dpr), round(pos.y() * dpr)
        else:  # enter/leave without a position
            x, y = iren.GetEventPosition()
            y = self._device_size()[1] - 1 - y
        mods = event.modifiers() if hasattr(event, "modifiers") else Qt.KeyboardModifier.NoModifier
        iren.SetEventInformationFlipY(int(x), int(y), int(bool(mods & Qt.KeyboardModifier.ControlModifier)),
                                      int(bool(mods & Qt.KeyboardModifier.ShiftModifier)), "\0", repeat, None)
        iren.SetAltKey(int(bool(mods & Qt.KeyboardModifier.AltModifier)))
        iren.InvokeEvent(vtk_event)

    def mousePressEvent(self, event) -> None:
        name = _BUTTONS.get(event.button())
        if name:
            self._send(event, f"{name}ButtonPressEvent")

    def mouseDoubleClickEvent(self, event) -> None:
        name = _BUTTONS.get(event.button())
        if name:
            self._send(event, f"{name}ButtonPressEvent", repeat=1)

    def mouseReleaseEvent(self, event) -> None:
        name = _BUTTONS.get(event.button())
        if name:
            self._send(event, f"{name}ButtonReleaseEvent")

    def mouseMoveEvent(self, event) -> None:
        self._send(event, "MouseMoveEvent")

    def wheelEvent(self, event) -> None:
        dy = event.angleDelta().y()
        if dy:
            self._send(event, "MouseWheelForwardEvent" if dy > 0 else "MouseWheelBackwardEvent")

    def enterEvent(self, event) -> None:
        self._send(event, "EnterEvent")

    def leaveEvent(self, event) -> None:
        if event.type() == QEvent.Type.Leave:
            self._send(event, "LeaveEvent")
