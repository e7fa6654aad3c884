"""The 3D result for other tools: VTK PolyData (``.vtp``) and Wavefront OBJ.

Both are in the model's own units (no conversion), like the surface file.

* ``.vtp`` (VTK XML, binary base64, read by ParaView and pyvista): the nodes
  on the surface; the springs as line cells, then the lattice cells as quads.
  Cell data ``strain_pct`` (springs; NaN on quads), ``spring_kind`` (0 weft,
  1 warp, 2 diagonal; -1 on quads), ``shear_deg`` (quads; NaN on springs);
  point data ``uv``, ``pattern_xy`` (the node in the 2D pattern) and
  ``boundary`` (1 on boundary nodes).
* ``.obj``: the lattice cells as quads with the node normals and, as
  texture coordinates, the nodes' 2D pattern positions (``nodes.xy`` of the
  result file, model units), so a 3D tool maps the pattern onto the surface.
"""

from __future__ import annotations

import base64
import datetime as _dt

import numpy as np

from core.metrics import cell_shear_deg, spring_strain

__all__ = ["vtp_text", "obj_text"]


def _array(name: str, a: np.ndarray, vtk_type: str, components: int = 1) -> str:
    dtype = {"Float64": "<f8", "Int64": "<i8", "Int8": "<i1", "UInt8": "<u1"}[vtk_type]
    raw = np.ascontiguousarray(a, dtype=dtype).tobytes()
    blob = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
    return (f'<DataArray type="{vtk_type}" Name="{name}" NumberOfComponents="{components}" '
            f'format="binary">{blob}</DataArray>')


def vtp_text(result) -> str:
    """The draped mesh with per-spring strain and per-cell shear, as VTK XML PolyData."""
    mesh, xyz = result.mesh, np.asarray(result.xyz, dtype=float)
    m, c = mesh.n_springs, len(mesh.cells)
    strain = 100.0 * spring_strain(xyz, mesh)
    shear = cell_shear_deg(xyz, mesh)
    nan_m, nan_c = np.full(m, np.nan), np.full(c, np.nan)
    boundary = mesh.boundary_nodes().astype(np.uint8)
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<PolyData>",
        f'<Piece NumberOfPoints="{mesh.n_nodes}" NumberOfVerts="0" NumberOfLines="{m}" '
        f'NumberOfStrips="0" NumberOfPolys="{c}">',
        '<PointData Scalars="boundary">',
        _array("uv", result.uv, "Float64", 2),
        _array("pattern_xy", result.pattern.xy, "Float64", 2),
        _array("boundary", boundary, "UInt8"),
        "</PointData>",
        '<CellData Scalars="strain_pct">',
        _array("strain_pct", np.concatenate([strain, nan_c]), "Float64"),
        _array("spring_kind", np.concatenate([mesh.kind, np.full(c, -1)]), "Int8"),
        _array("shear_deg", np.concatenate([nan_m, shear]), "Float64"),
        "</CellData>",
        "<Points>", _array("Points", xyz, "Float64", 3), "</Points>",
        "<Lines>",
        _array("connectivity", mesh.ends.ravel(), "Int64"),
        _array("offsets", 2 * np.arange(1, m + 1), "Int64"),
        "</Lines>",
        "<Polys>",
        _array("connectivity", np.asarray(mesh.cells).ravel(), "Int64"),
        _array("offsets", 4 * np.arange(1, c + 1), "Int64"),
        "</Polys>",
        "</Piece>", "</PolyData>", "</VTKFile>",
    ]
    return "\n".join(lines) + "\n"


def obj_text(result, name: str = "piece") -> str:
    """The mesh's quads with normals and the 2D pattern as texture coordinates (OBJ)."""
    mesh = result.mesh
    xyz = np.asarray(result.xyz, dtype=float)
    normals = result.surface.evaluate(np.asarray(result.uv, dtype=float)).normal
    xy = np.asarray(result.pattern.xy, dtype=float)
    f = np.asarray(mesh.cells, dtype=np.int64) + 1
    out = [f"# flatweave {_dt.date.today().isoformat()}: {mesh.n_nodes} nodes, {len(f)} quads",
           "# v: nodes on the surface; vt: the same nodes in the flat pattern (model units); vn: normals",
           f"o {name}"]
    out += ["v %.12g %.12g %.12g" % tuple(p) for p in xyz]
    out += ["vt %.12g %.12g" % tuple(p) for p in xy]
    out += ["vn %.9g %.9g %.9g" % tuple(p) for p in normals]
    out += ["f " + " ".join(f"{i}/{i}/{i}" for i in row) for row in f]
    return "\n".join(out) + "\n"
