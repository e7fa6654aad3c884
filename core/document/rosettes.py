"""The tool's rosettes (issue 41, item 1): the axes a laminate's plies are
oriented from. A :class:`ToolRosette` is a name, an origin on (or near) the
tool and a 0-degree direction; a project holds a table of them
(``Project.rosettes``) and a piece may be oriented from one
(``Piece.rosette``, ``Piece.orientation``).

A ply's orientation is measured at its seed from the rosette's 0-degree
direction projected on the tangent plane there (the projection rosette of
composites tools), about the surface's normal: its weft angle in the surface's
parameters is :func:`flatweave.method.rosette.weft_for` of them. The
orientation is the datum and the weft angle follows it when the seed moves (a
region redrawn) or the rosette is edited; a weft angle set directly (the Seed
tool's arrow, the settings) turns the orientation instead
(:func:`flatweave.document.pieces.follow_rosettes`). The origin places the
rosette's arrows in the window; it does not change an orientation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from flatweave.errors import SettingsError
from flatweave.method.rosette import weft_for

__all__ = ["ToolRosette", "MAX_ROSETTES", "check_rosettes", "rosette_named", "piece_weft", "orientation_text"]

MAX_ROSETTES = 100  # a part's tool carries one to a handful; a large assembly a few dozen
MAX_NAME = 80


def _vector(value: Any, what: str, nonzero: bool = False) -> tuple[float, float, float]:
    try:
        v = tuple(float(x) for x in value)
    except (TypeError, ValueError):
        raise SettingsError(f"{what} must be three numbers [x, y, z], got {value!r:.60}") from None
    if len(v) != 3 or not all(math.isfinite(x) for x in v) or any(isinstance(x, bool) for x in value):
        raise SettingsError(f"{what} must be three finite numbers [x, y, z], got {value!r:.60}")
    if nonzero and math.hypot(*v) == 0.0:
        raise SettingsError(f"{what} must be a direction, not [0, 0, 0]")
    return v


@dataclass(frozen=True)
class ToolRosette:
    """A rosette on the tool: ``name``, ``origin`` (x, y, z, model units) and
    ``zero`` (dx, dy, dz: the 0-degree direction, any length but zero).
    Values are checked and kept as tuples of floats (a one-line SettingsError)."""

    name: str
    origin: tuple = (0.0, 0.0, 0.0)
    zero: tuple = (1.0, 0.0, 0.0)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip() or len(self.name) > MAX_NAME \
                or "\n" in self.name:
            raise SettingsError(f"a rosette's name must be a line of 1 to {MAX_NAME} characters, "
                                f"got {self.name!r:.60}")
        object.__setattr__(self, "origin", _vector(self.origin, f"rosette {self.name!r}'s origin"))
        object.__setattr__(self, "zero", _vector(self.zero, f"rosette {self.name!r}'s 0-degree direction",
                                                 nonzero=True))

    def to_dict(self) -> dict:
        return {"name": self.name, "origin": list(self.origin), "zero": list(self.zero)}

    @classmethod
    def from_dict(cls, d: Any, where: str = "rosette") -> "ToolRosette":
        """A rosette from its file form; a one-line SettingsError naming ``where``."""
        if not isinstance(d, dict):
            raise SettingsError(f"{where}: a rosette is an object with name, origin and zero")
        unknown = sorted(set(d) - {"name", "origin", "zero"})
        if unknown:
            raise SettingsError(f"{where}: unknown key {unknown[0]!r} (a rosette has name, origin and zero)")
        try:
            return cls(d.get("name"), d.get("origin"), d.get("zero"))
        except SettingsError as exc:
            raise SettingsError(f"{where}: {exc}") from None


def check_rosettes(rosettes, pieces=()) -> None:
    """A one-line SettingsError unless ``rosettes`` are at most MAX_ROSETTES
    ToolRosettes with distinct names and every piece's rosette is among them."""
    if len(rosettes) > MAX_ROSETTES:
        raise SettingsError(f"a project holds at most {MAX_ROSETTES} rosettes, got {len(rosettes)}")
    names = set()
    for r in rosettes:
        if not isinstance(r, ToolRosette):
            raise TypeError(f"a project's rosettes must be ToolRosettes, got {type(r).__name__}")
        if r.name.strip().casefold() in names:
            raise SettingsError(f"two rosettes are named {r.name!r}")
        names.add(r.name.strip().casefold())
    for p in pieces:
        if p.rosette is not None and p.rosette.strip().casefold() not in names:
            raise SettingsError(f"piece {p.name!r} is oriented from rosette {p.rosette!r}, which the project "
                                f"lacks")


def rosette_named(rosettes, name: str) -> ToolRosette:
    """The rosette called ``name``; a one-line SettingsError when there is none."""
    for r in rosettes:
        if r.name.strip().casefold() == str(name).strip().casefold():
            return r
    raise SettingsError(f"no rosette is named {name!r} (the project's: "
                        f"{', '.join(r.name for r in rosettes)[:200] or 'none'})")


def piece_weft(surface, rosettes, piece) -> float:
    """The weft angle (degrees) that lays ``piece`` at its orientation from its rosette,
    at its seed; its own weft angle when it has no rosette. A one-line SettingsError
    when the rosette's 0-degree direction is along the normal at the seed."""
    if piece.rosette is None:
        return float(piece.settings.angle_deg)
    r = rosette_named(rosettes, piece.rosette)
    angle = weft_for(surface, piece.settings.seed, r.zero, piece.orientation)
    if angle is None:
        raise SettingsError(f"piece {piece.name!r}: rosette {r.name!r}'s 0-degree direction is along the "
                            f"surface's normal at its seed: it sets no direction there")
    return angle


def orientation_text(piece, short: bool = False) -> str:
    """A piece's orientation as a table or a page states it: "+45 deg from rosette 1" (short:
    "+45") for a piece oriented from a rosette, "weft +12.5 deg" (short: "w+12.5") for one
    given by its weft angle in the surface's parameters alone."""
    if piece.rosette is None:
        a = float(piece.settings.angle_deg)
        return f"w{a:+g}" if short else f"weft {a:+g} deg"
    return f"{piece.orientation:+g}" if short else f"{piece.orientation:+g} deg from {piece.rosette}"
