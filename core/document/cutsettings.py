"""A project's cut plan settings (issue 43): what its markers are nested with, kept with the project.

The roll widths typed per material (the others: the materials table's), the gap between
pieces, the time a marker may take, the seam allowance, the splice overlap, the rotations
(None: each piece's material decides), the splices placed by hand (positions in mm across
a piece from its edge, by the name its marker gives it: the piece's name, numbered "NAME K"
when its pattern has several pieces) and the pieces cut in mirror pairs (a left and a right
panel: half their copies the mirror image). Saved in the project file as ``cut_plan``
(version 8), left out while everything is as made. A piece renamed or removed takes its
splices and its mirror pairing with it (:meth:`CutPlanSettings.renamed`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Any

from flatweave.errors import SettingsError
from flatweave.studies.nesting import DEFAULT_SECONDS, ROTATIONS

__all__ = ["CutPlanSettings", "MAX_SPLICES", "part_of"]

MAX_SPLICES = 100  # a piece's splices at most (a 100-part ply is a hundred rolls' widths)
_MAX_MM = 100_000.0  # a roll, gap, allowance or overlap of 100 m is a typing slip


def part_of(item: str, piece: str) -> str | None:
    """How an item to nest is named after a piece: "" when it is the piece ("NAME"), "K" when it is
    the piece's K-th part ("NAME K": its pattern has several pieces); None when it is not the piece's."""
    if item == piece:
        return ""
    m = re.fullmatch(re.escape(piece) + r" (\d+)", item)
    return m.group(1) if m else None


def _length(label: str, value: Any, low_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or value < 0 or value > _MAX_MM or (low_open and value == 0):
        what = "a positive length" if low_open else "zero or a positive length"
        raise SettingsError(f"the cut plan's {label} must be {what} in mm up to {_MAX_MM:g}, got {value!r:.40}")
    return float(value)


@dataclass(frozen=True)
class CutPlanSettings:
    """How a project's pieces are nested (see the module docstring). ``roll_widths``: (material, mm)
    pairs; ``splices``: (item name, positions) pairs; ``mirror``: piece names. Immutable; checked."""

    roll_widths: tuple = ()
    gap_mm: float = 0.0
    seconds: float = DEFAULT_SECONDS
    allowance_mm: float = 0.0
    overlap_mm: float = 25.0
    rotations: str | None = None
    splices: tuple = ()
    mirror: tuple = field(default=())

    def __post_init__(self):
        widths = tuple((str(m), _length(f"roll width of {m!r:.40}", w, True)) for m, w in self.roll_widths)
        if len({m for m, _ in widths}) != len(widths):
            raise SettingsError("the cut plan gives a material's roll width twice")
        object.__setattr__(self, "roll_widths", widths)
        for label in ("gap_mm", "allowance_mm", "overlap_mm"):
            object.__setattr__(self, label, _length(label[:-3].replace("_", " "), getattr(self, label)))
        s = self.seconds
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not math.isfinite(s) or not 0 < s <= 24 * 3600:
            raise SettingsError(f"the cut plan's time limit must be a positive number of seconds up to a day, "
                                f"got {s!r:.40}")
        object.__setattr__(self, "seconds", float(s))
        if self.rotations is not None and self.rotations not in ROTATIONS:
            raise SettingsError(f"the cut plan's rotations must be one of {', '.join(ROTATIONS)} (or none: "
                                f"each material's), got {self.rotations!r:.40}")
        splices = []
        for name, at in self.splices:
            if not isinstance(name, str) or not name.strip():
                raise SettingsError(f"a splice is given by its piece's name, got {name!r:.40}")
            try:
                at = tuple(float(a) for a in at)
            except (TypeError, ValueError):
                at = ()
            if not 1 <= len(at) <= MAX_SPLICES or not all(math.isfinite(a) for a in at):
                raise SettingsError(f"the splices of {name!r:.60} must be 1 to {MAX_SPLICES} positions in mm")
            splices.append((name, at))
        if len({n for n, _ in splices}) != len(splices):
            raise SettingsError("the cut plan gives a piece's splices twice")
        object.__setattr__(self, "splices", tuple(splices))
        mirror = tuple(self.mirror)
        if not all(isinstance(n, str) and n.strip() for n in mirror) or len(set(mirror)) != len(mirror):
            raise SettingsError("the pieces cut in mirror pairs must be distinct piece names")
        object.__setattr__(self, "mirror", mirror)

    # ------------------------------------------------------------------ queries
    def width_for(self, material: str) -> float | None:
        """The roll width typed for ``material`` (mm), or None (the materials table's)."""
        return dict(self.roll_widths).get(material)

    def splice_map(self) -> dict:
        """{item name: [positions, mm]}: the splices placed by hand, as ``splice_items(placed=...)`` takes them."""
        return {n: list(at) for n, at in self.splices}

    def mirrored(self, piece: str) -> bool:
        """Whether piece ``piece`` is cut in mirror pairs."""
        return piece in self.mirror

    # ------------------------------------------------------------------ edits
    def with_width(self, material: str, mm: float | None) -> "CutPlanSettings":
        """The roll width of ``material`` typed as ``mm`` (None: back to the materials table's)."""
        rest = tuple((m, w) for m, w in self.roll_widths if m != material)
        return replace(self, roll_widths=rest if mm is None else rest + ((material, mm),))

    def with_splices(self, name: str, positions) -> "CutPlanSettings":
        """Item ``name``'s splices placed at ``positions`` (None or empty: chosen again)."""
        rest = tuple((n, at) for n, at in self.splices if n != name)
        return replace(self, splices=rest + (((name, tuple(positions)),) if positions else ()))

    def with_mirror(self, piece: str, on: bool) -> "CutPlanSettings":
        """Piece ``piece`` cut in mirror pairs (``on``) or all as drawn."""
        rest = tuple(n for n in self.mirror if n != piece)
        return replace(self, mirror=rest + ((piece,) if on else ()))

    def renamed(self, names: dict) -> "CutPlanSettings":
        """The settings with pieces renamed by ``names`` (old -> new; new None: the piece is gone): their
        mirror pairing and their splices (an item "OLD" or "OLD K") go with them."""
        if not names:
            return self

        def item(n):
            for old, new in names.items():
                k = part_of(n, old)
                if k is not None:
                    return new if new is None or not k else f"{new} {k}"
            return n

        splices = tuple((item(n), at) for n, at in self.splices if item(n) is not None)
        mirror = tuple(names.get(n, n) for n in self.mirror if names.get(n, n) is not None)
        return replace(self, splices=splices, mirror=mirror)

    # ------------------------------------------------------------------ the file
    @property
    def is_default(self) -> bool:
        return self == CutPlanSettings()

    def to_dict(self) -> dict:
        return {"roll_widths": [{"material": m, "mm": w} for m, w in self.roll_widths], "gap_mm": self.gap_mm,
                "seconds": self.seconds, "allowance_mm": self.allowance_mm, "overlap_mm": self.overlap_mm,
                "rotations": self.rotations, "splices": [{"piece": n, "mm": list(at)} for n, at in self.splices],
                "mirror": list(self.mirror)}

    @classmethod
    def from_dict(cls, d: Any) -> "CutPlanSettings":
        """The settings from :meth:`to_dict`'s document; a one-line SettingsError naming what is wrong."""
        if not isinstance(d, dict):
            raise SettingsError("cut_plan must be an object")
        try:
            widths = tuple((r["material"], r["mm"]) for r in d.get("roll_widths", []))
            splices = tuple((r["piece"], r["mm"]) for r in d.get("splices", []))
            mirror = tuple(d.get("mirror", []))
        except (KeyError, TypeError) as exc:
            raise SettingsError(f"cut_plan: its roll widths ({{material, mm}}), splices ({{piece, mm}}) and mirror "
                                f"(piece names) are lists ({type(exc).__name__})") from None
        if len(widths) > 10_000 or len(splices) > 10_000 or len(mirror) > 10_000:
            raise SettingsError("cut_plan: too many roll widths, splices or mirror pairs (10000 at most)")
        default = cls()
        return cls(widths, d.get("gap_mm", default.gap_mm), d.get("seconds", default.seconds),
                   d.get("allowance_mm", default.allowance_mm), d.get("overlap_mm", default.overlap_mm),
                   d.get("rotations"), splices, mirror)
