"""Fibre angles of a draped result, per lattice cell, for analysis tools
that take draped fibre orientations.

* weft, warp : unit 3D directions of the cell's threads on the surface, the
  mean of its two weft springs (corners 0-1 and 3-2, along +j) and of its two
  warp springs (0-3 and 1-2, along +i);
* normal : the cell's own tangent plane, from its diagonals (corners 0-2 and
  1-3), so the angles need the mesh only;
* reference : the rosette, the designer's weft direction at the seed (the
  direction the drape starts the weft in: ``angle_deg`` from S_u towards S_v),
  carried to every cell by projecting it onto the cell's tangent plane, as
  composites tools do ("rosette projection");
* deviation_deg : the weft's signed angle from the projected reference, about
  the cell normal (positive from the reference towards normal x reference),
  in (-180, 180]; warp_deviation_deg the warp's from the reference turned by
  90 degrees about the normal (where an unsheared warp would lie). For a
  parallelogram cell deviation - warp_deviation is its shear;
* shear_deg : :func:`flatweave.method.metrics.cell_shear_deg`.

Where the reference is (nearly) normal to a cell's plane it has no projection
and the deviations are NaN (a rosette does not reach a surface that turns by
90 degrees from the seed's tangent plane).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flatweave.geometry.numerics import rowdot, unit_rows
from flatweave.method.metrics import cell_shear_deg
from flatweave.method.lattice import SpringMesh

__all__ = ["FibreAngles", "cell_fibres", "result_fibres", "reference_direction", "CSV_COLUMNS", "fibres_csv"]

_DEGENERATE = 1e-6  # |projected reference| below this: no rosette direction in the cell's plane


@dataclass(frozen=True)
class FibreAngles:
    """Per cell (c rows): centre (c, 3) on the surface (corner mean), uv (c, 2)
    (corner mean), weft, warp, normal (c, 3) unit, reference (c, 3) the
    projected rosette direction (unit; NaN where degenerate), deviation_deg,
    warp_deviation_deg, shear_deg (c,)."""

    centre: np.ndarray
    uv: np.ndarray
    weft: np.ndarray
    warp: np.ndarray
    normal: np.ndarray
    reference: np.ndarray
    deviation_deg: np.ndarray
    warp_deviation_deg: np.ndarray
    shear_deg: np.ndarray


def _signed_deg(ref: np.ndarray, d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Angle from ``ref`` to ``d`` about ``n``, degrees, rows."""
    return np.degrees(np.arctan2(rowdot(np.cross(ref, d), n), rowdot(ref, d)))


def cell_fibres(xyz: np.ndarray, uv: np.ndarray, mesh: SpringMesh, reference: np.ndarray,
                shear_deg: np.ndarray | None = None) -> FibreAngles:
    """The fibre angles of every cell of ``mesh`` with nodes at ``xyz`` (n, 3),
    ``uv`` (n, 2), against the rosette direction ``reference`` (3,);
    ``shear_deg``, when the caller has it, is :func:`cell_shear_deg`'s."""
    xyz, uv = np.asarray(xyz, dtype=float), np.asarray(uv, dtype=float)
    cells = np.asarray(mesh.cells, dtype=np.int64).reshape(-1, 4)
    p0, p1, p2, p3 = (xyz[cells[:, k]] for k in range(4))
    weft = unit_rows((p1 - p0) + (p2 - p3))
    warp = unit_rows((p3 - p0) + (p2 - p1))
    normal = unit_rows(np.cross(p2 - p0, p3 - p1))
    # the lattice's +j x +i is the cell's diagonal normal's side; orient it as weft x warp so the
    # deviations turn the same way whichever side the surface's normal is on
    flip = rowdot(np.cross(weft, warp), normal) < 0
    normal[flip] *= -1.0
    ref = np.asarray(reference, dtype=float).reshape(3)
    ref = ref / np.linalg.norm(ref)
    proj = ref[None, :] - rowdot(normal, ref[None, :])[:, None] * normal
    size = np.linalg.norm(proj, axis=1)
    ok = size > _DEGENERATE
    proj = np.where(ok[:, None], proj / np.where(ok, size, 1.0)[:, None], np.nan)
    dev = _signed_deg(proj, weft, normal)
    wdev = _signed_deg(np.cross(normal, proj), warp, normal)
    return FibreAngles(
        centre=0.25 * (p0 + p1 + p2 + p3),
        uv=0.25 * sum(uv[cells[:, k]] for k in range(4)) if len(cells) else np.zeros((0, 2)),
        weft=weft, warp=warp, normal=normal, reference=proj,
        deviation_deg=dev, warp_deviation_deg=wdev,
        shear_deg=cell_shear_deg(xyz, mesh) if shear_deg is None else np.asarray(shear_deg, dtype=float))


def reference_direction(surface, settings) -> np.ndarray:
    """The rosette: the weft direction the drape starts from at the seed
    (``settings.seed`` as fractions of the domain, ``settings.angle_deg`` from
    S_u towards S_v in the tangent plane), a unit (3,) vector."""
    dom = np.asarray(surface.domain, dtype=float)
    sd = np.asarray(settings.seed, dtype=float)
    uv0 = (dom[:, 0] + sd * (dom[:, 1] - dom[:, 0]))[None, :]
    ev = surface.evaluate(uv0)
    n0, su = ev.normal[0], ev.su[0]
    if np.linalg.norm(su) < 1e-300:  # a pole: S_u vanishes (as the drape does)
        su = ev.sv[0]
    e1 = su - np.dot(su, n0) * n0
    e1 /= np.linalg.norm(e1)
    a = np.radians(settings.angle_deg)
    return np.cos(a) * e1 + np.sin(a) * np.cross(n0, e1)


def result_fibres(result) -> FibreAngles:
    """:func:`cell_fibres` of a :class:`flatweave.method.pipeline.FlattenResult`, against its seed's rosette."""
    return cell_fibres(result.xyz, result.uv, result.mesh, reference_direction(result.surface, result.settings))


CSV_COLUMNS = ("cell", "x", "y", "z", "u", "v", "weft_x", "weft_y", "weft_z", "warp_x", "warp_y", "warp_z",
               "deviation_deg", "warp_deviation_deg", "shear_deg")
"""The fibre-angle CSV's header row (cell k is cell k of the VTP export's quads)."""


def fibres_csv(result) -> str:
    """The result's fibre angles as CSV text: a header row (:data:`CSV_COLUMNS`),
    then one row per cell; coordinates in the model's units, angles in degrees,
    17 significant digits (exact round trip)."""
    f = result_fibres(result)
    c = len(f.shear_deg)
    table = np.column_stack([np.arange(c, dtype=float), f.centre, f.uv, f.weft, f.warp,
                             f.deviation_deg, f.warp_deviation_deg, f.shear_deg]).reshape(c, len(CSV_COLUMNS))
    lines = [",".join(CSV_COLUMNS)]
    lines += [f"{int(row[0])}," + ",".join(f"{x:.17g}" for x in row[1:]) for row in table]
    return "\n".join(lines) + "\n"
