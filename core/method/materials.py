"""The materials table (issue 41): what the shop knows about each material a
project's pieces are cut from. A :class:`Fabric` is a name, its mechanics (a
:class:`flatweave.method.lattice.Material`: the spring constants, whose ratio
says woven or isotropic, and the shear warning and lock angles that judge a
result) and the cutting room's data: roll width, thickness and areal weight.

A piece uses a fabric by putting its material in the piece's settings (the
settings' material carries the fabric's name); the project keeps its table
(``Project.materials``) and saves it, and a table can be written to a file of
its own and read into another project (:func:`save_materials`,
:func:`load_materials`). :data:`FABRICS` are the bundled presets: typical
catalogue values, to be replaced by the supplier's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from flatweave.errors import SettingsError
from flatweave.files import parse_json, read_input, write_json
from flatweave.method.lattice import MATERIALS, Material

__all__ = ["Fabric", "FABRICS", "KINDS", "fabric_kind", "materials_to_dict", "materials_from_dict",
           "save_materials", "load_materials", "MATERIALS_FORMAT"]

MATERIALS_FORMAT = "flatweave-materials"
KINDS = ("woven", "isotropic", "custom")
MAX_FABRICS = 200


def fabric_kind(material: Material) -> str:
    """"woven" (diagonals far softer than the threads: the threads carry the load, the cell shears
    freely), "isotropic" (diagonals half the threads': the lattice's isotropic ratio), else "custom"."""
    a = min(material.k_weft, material.k_warp)
    if material.k_diag <= 0.01 * a:
        return "woven"
    if material.k_weft == material.k_warp and math.isclose(material.k_diag, 0.5 * material.k_weft, rel_tol=1e-9):
        return "isotropic"
    return "custom"


@dataclass(frozen=True)
class Fabric:
    """One row of the materials table. ``material.name`` is the fabric's name
    (the key pieces use); ``roll_width_mm`` None for material not sold on a
    roll (hides); ``thickness_mm`` and ``areal_weight_gsm`` (g/m^2) None when
    not known."""

    material: Material
    roll_width_mm: float | None = None
    thickness_mm: float | None = None
    areal_weight_gsm: float | None = None

    def __post_init__(self):
        name = self.material.name
        if not isinstance(name, str) or not name.strip() or len(name) > 80 or "\n" in name:
            raise SettingsError(f"a material's name must be a line of 1 to 80 characters, got {name!r:.60}")
        for label, value, top in (("roll width", self.roll_width_mm, 20_000.0),
                                  ("thickness", self.thickness_mm, 100.0),
                                  ("areal weight", self.areal_weight_gsm, 100_000.0)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not math.isfinite(value) or not 0 < value <= top):
                raise SettingsError(f"material {name!r}: the {label} must be a positive number up to {top:g} "
                                    f"(or none), got {value!r:.40}")
        m = self.material
        for label, value in (("k_weft", m.k_weft), ("k_warp", m.k_warp), ("k_diag", m.k_diag)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0:
                raise SettingsError(f"material {name!r}: {label} must be a positive number, got {value!r:.40}")
        if not 0 < m.warn_deg < m.lock_deg <= 90:
            raise SettingsError(f"material {name!r}: the shear warning angle ({m.warn_deg:g}) must be above 0 and "
                                f"below the lock angle ({m.lock_deg:g}), itself at most 90 degrees")

    @property
    def name(self) -> str:
        return self.material.name

    @property
    def kind(self) -> str:
        return fabric_kind(self.material)

    def to_dict(self) -> dict:
        return {**self.material.to_dict(), "roll_width_mm": self.roll_width_mm, "thickness_mm": self.thickness_mm,
                "areal_weight_gsm": self.areal_weight_gsm}

    @classmethod
    def from_dict(cls, d: Any, where: str = "materials") -> "Fabric":
        if not isinstance(d, dict):
            raise SettingsError(f"{where}: a material must be an object, got {type(d).__name__}")
        try:
            m = Material(d["name"], d["k_weft"], d["k_warp"], d["k_diag"], d.get("warn_deg", 15.0),
                         d.get("lock_deg", 30.0))
        except KeyError as exc:
            raise SettingsError(f"{where}: a material lacks {exc.args[0]!r}") from None
        try:
            return cls(m, d.get("roll_width_mm"), d.get("thickness_mm"), d.get("areal_weight_gsm"))
        except TypeError:
            raise SettingsError(f"{where}: material {d.get('name')!r:.60} has a value that is not a number") from None
        except SettingsError as exc:
            raise SettingsError(f"{where}: {exc}") from None


def _woven(name: str, warn: float, lock: float) -> Material:
    base = MATERIALS["woven"]
    return replace(base, name=name, warn_deg=warn, lock_deg=lock)


# Typical catalogue values (a 3K plain-weave carbon of 200 g/m^2 on a 50-inch roll, a 2/2 twill glass of
# 290 g/m^2, a shirting cotton, a garment leather); the shear angles are CATIA's defaults (15 and 30
# degrees) but for the twill, whose floats let it shear further before it locks.
FABRICS: dict[str, Fabric] = {f.name: f for f in (
    Fabric(_woven("carbon plain weave 200", 15.0, 30.0), 1270.0, 0.22, 200.0),
    Fabric(_woven("glass twill 290", 20.0, 40.0), 1270.0, 0.23, 290.0),
    Fabric(_woven("garment woven", 15.0, 30.0), 1500.0, 0.3, 120.0),
    Fabric(replace(MATERIALS["isotropic"], name="leather-like", warn_deg=20.0, lock_deg=40.0), None, 1.2, 800.0),
)}


def materials_to_dict(fabrics) -> dict:
    """A materials table as its file's JSON (:data:`MATERIALS_FORMAT`)."""
    return {"format": MATERIALS_FORMAT, "version": 1, "materials": [f.to_dict() for f in fabrics]}


def materials_from_dict(d: Any, where: str = "materials") -> tuple[Fabric, ...]:
    """A materials table from its JSON; a one-line SettingsError naming the entry on any problem."""
    if not isinstance(d, dict) or d.get("format") != MATERIALS_FORMAT:
        raise SettingsError(f"{where}: not a flatweave materials table (format {MATERIALS_FORMAT!r})")
    rows = d.get("materials")
    if not isinstance(rows, list) or len(rows) > MAX_FABRICS:
        raise SettingsError(f"{where}: materials must be a list of at most {MAX_FABRICS}")
    fabrics = tuple(Fabric.from_dict(r, f"{where}: materials[{k}]") for k, r in enumerate(rows))
    check_table(fabrics, where)
    return fabrics


def check_table(fabrics, where: str = "materials") -> None:
    """A one-line SettingsError when two rows share a name (case and outer spaces aside)."""
    seen = set()
    for f in fabrics:
        key = f.name.strip().casefold()
        if key in seen:
            raise SettingsError(f"{where}: two materials are named {f.name!r}")
        seen.add(key)


def save_materials(fabrics, path) -> Path:
    """Write a materials table to ``path`` (atomically), to share it with other projects."""
    path = Path(path)
    write_json(path, materials_to_dict(fabrics))
    return path


def load_materials(path) -> tuple[Fabric, ...]:
    """Read a materials table file; a one-line SettingsError naming the file on any problem."""
    name = str(path)
    raw = read_input(name, "small", SettingsError)
    return materials_from_dict(parse_json(raw, name, "JSON materials table", SettingsError), name)
