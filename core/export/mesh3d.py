"""The 3D result for other tools: VTK PolyData (``.vtp``) and Wavefront OBJ.

Both are in the model's own units (no conversion), like the surface file.

* ``.vtp`` (VTK XML, binary base64, read by ParaView, VTK and pyvista): an
  export to ``NAME.vtp`` writes three files, so that every field is defined
  on every cell of the data set that carries it (no NaN fill, which ParaView
  would colour by default):

  - ``NAME.vtp``, the surface: the nodes (point ``k`` is node ``k`` of the
    result file) and the lattice cells as quads; cell data ``shear_deg``
    (NaN only where a cell's shear is undefined); point data ``uv``,
    ``pattern_xy`` (the node in the 2D pattern) and ``boundary`` (1 on
    boundary nodes);
  - ``NAME_springs.vtp``: the same points and point data, the springs as
    lines; cell data ``strain_pct`` and ``spring_kind`` (0 weft, 1 warp,
    2 diagonal, as ``springs.kind`` of the result file);
  - ``NAME.vtm``, a multiblock naming both (``surface``, ``springs``), to open
    them together in ParaView.
* ``.obj``: the lattice cells as quads with the node normals and, as texture
  coordinates, the nodes' 2D pattern positions (``nodes.xy`` of the result
  file, model units), so a 3D tool maps the pattern onto the surface. Only the
  nodes of some quad are written (readers drop a vertex no face uses, which
  would shift every later one): vertex ``k`` (1-based) is the ``k``-th node
  used by a quad, in node order, and the header's ``# nodes:`` comment lists
  them as ranges. With the ``checker`` texture a ``NAME.mtl`` and a
  ``NAME_checker.png`` are written beside it and the texture coordinates are
  ``(xy - origin) / repeat`` (both stated in the header), so the checker's
  squares are a round length of the pattern.
"""

from __future__ import annotations

import base64
import datetime as _dt
import math
import struct
import zlib
from pathlib import Path

import numpy as np

from flatweave.method.fibres import result_fibres
from flatweave.method.metrics import spring_strain

__all__ = ["OBJ_TEXTURES", "vtp_surface_text", "vtp_springs_text", "vtm_text", "vtp_files", "obj_files",
           "obj_text", "used_nodes", "checker_frame"]

OBJ_TEXTURES = ("none", "checker")
CHECKER_SQUARES = 16  # about this many checker squares across the pattern
CHECKER_PX = 32  # pixels per square


def _array(name: str, a: np.ndarray, vtk_type: str, components: int = 1) -> str:
    dtype = {"Float64": "<f8", "Int64": "<i8", "Int8": "<i1", "UInt8": "<u1"}[vtk_type]
    raw = np.ascontiguousarray(a, dtype=dtype).tobytes()
    blob = base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")
    return (f'<DataArray type="{vtk_type}" Name="{name}" NumberOfComponents="{components}" '
            f'format="binary">{blob}</DataArray>')


def _polydata(result, n_lines: int, n_polys: int, cell_data: list, scalars: str, topology: list) -> str:
    mesh, xyz = result.mesh, np.asarray(result.xyz, dtype=float)
    boundary = mesh.boundary_nodes().astype(np.uint8)
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<PolyData>",
        f'<Piece NumberOfPoints="{mesh.n_nodes}" NumberOfVerts="0" NumberOfLines="{n_lines}" '
        f'NumberOfStrips="0" NumberOfPolys="{n_polys}">',
        '<PointData Scalars="boundary">',
        _array("uv", result.uv, "Float64", 2),
        _array("pattern_xy", result.pattern.xy, "Float64", 2),
        _array("boundary", boundary, "UInt8"),
        "</PointData>",
        f'<CellData Scalars="{scalars}">', *cell_data, "</CellData>",
        "<Points>", _array("Points", xyz, "Float64", 3), "</Points>",
        *topology,
        "</Piece>", "</PolyData>", "</VTKFile>",
    ]
    return "\n".join(lines) + "\n"


def vtp_surface_text(result) -> str:
    """The draped surface: nodes and lattice quads with their shear, as VTK XML PolyData."""
    mesh = result.mesh
    c = len(mesh.cells)
    f = result_fibres(result)
    data = [_array("shear_deg", f.shear_deg, "Float64"),
            _array("fibre_deviation_deg", f.deviation_deg, "Float64"),
            _array("warp_deviation_deg", f.warp_deviation_deg, "Float64"),
            _array("weft_dir", f.weft, "Float64", 3), _array("warp_dir", f.warp, "Float64", 3)]
    return _polydata(result, 0, c, data, "shear_deg",
                     ["<Polys>", _array("connectivity", np.asarray(mesh.cells).ravel(), "Int64"),
                      _array("offsets", 4 * np.arange(1, c + 1), "Int64"), "</Polys>"])


def vtp_springs_text(result) -> str:
    """The springs as lines with their strain (%) and kind, as VTK XML PolyData."""
    mesh, xyz = result.mesh, np.asarray(result.xyz, dtype=float)
    m = mesh.n_springs
    data = [_array("strain_pct", 100.0 * spring_strain(xyz, mesh), "Float64"),
            _array("spring_kind", mesh.kind, "Int8")]
    return _polydata(result, m, 0, data, "strain_pct",
                     ["<Lines>", _array("connectivity", mesh.ends.ravel(), "Int64"),
                      _array("offsets", 2 * np.arange(1, m + 1), "Int64"), "</Lines>"])


def vtm_text(blocks: list[tuple[str, str]]) -> str:
    """A VTK multiblock file naming PolyData files: ``blocks`` is (name, file) pairs."""
    from xml.sax.saxutils import quoteattr

    out = ['<?xml version="1.0"?>',
           '<VTKFile type="vtkMultiBlockDataSet" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
           "<vtkMultiBlockDataSet>"]
    out += [f'<DataSet index="{k}" name={quoteattr(n)} file={quoteattr(f)}/>' for k, (n, f) in enumerate(blocks)]
    out += ["</vtkMultiBlockDataSet>", "</VTKFile>"]
    return "\n".join(out) + "\n"


def vtp_files(result, path) -> list[tuple[Path, bytes]]:
    """The files of a ``.vtp`` export to ``path``: the surface, its springs, the multiblock naming both."""
    path = Path(path)
    springs = path.with_name(f"{path.stem}_springs.vtp")
    return [(path, vtp_surface_text(result).encode("ascii")),
            (springs, vtp_springs_text(result).encode("ascii")),
            (path.with_suffix(".vtm"),
             vtm_text([("surface", path.name), ("springs", springs.name)]).encode("utf-8"))]


def used_nodes(mesh) -> np.ndarray:
    """The nodes of some lattice cell, in node order: OBJ vertex k + 1 is node used_nodes[k]."""
    return np.unique(np.asarray(mesh.cells, dtype=np.int64).ravel())


def _ranges(ids: np.ndarray) -> str:
    """0 1 2 5 6 -> "0-2 5-6"."""
    if len(ids) == 0:
        return ""
    breaks = np.flatnonzero(np.diff(ids) != 1)
    starts = np.concatenate([[ids[0]], ids[breaks + 1]])
    ends = np.concatenate([ids[breaks], [ids[-1]]])
    return " ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in zip(starts, ends))


def _nice(x: float) -> float:
    """The largest 1, 2, 5 x 10^k not above x."""
    k = 10 ** math.floor(math.log10(x))
    return next(m * k for m in (5, 2, 1) if m * k <= x * (1 + 1e-12))


def checker_frame(xy: np.ndarray) -> tuple[np.ndarray, float, float, int]:
    """(origin, repeat, square, squares per side) of the checker texture for pattern
    positions ``xy``: squares of a round length, the origin on a square's corner, one
    texture over the whole pattern (texture coordinates in [0, 1])."""
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    extent = float(max((hi - lo).max(), 1e-12))
    square = _nice(extent / CHECKER_SQUARES)
    origin = np.floor(lo / square) * square
    n = int(np.ceil(float(((hi - origin) / square).max()) + 1e-9))
    n = max(n, 1)
    return origin, n * square, square, n


def _png(rgb: np.ndarray) -> bytes:
    """An 8-bit RGB PNG of an (h, w, 3) uint8 array, top row first (stdlib zlib)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[r].tobytes() for r in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def checker_png(n: int, px: int = CHECKER_PX) -> bytes:
    """n x n squares, light and dark; every fifth line of squares a little darker, to count by."""
    i = np.arange(n * px) // px
    odd = (i[:, None] + i[None, :]) % 2 == 1
    img = np.where(odd[..., None], np.array([70, 110, 160], np.uint8), np.array([235, 235, 225], np.uint8))
    edge = np.arange(n * px) % (5 * px) == 0
    img[edge, :] = (200, 60, 40)
    img[:, edge] = (200, 60, 40)
    return _png(img[::-1].copy())  # row 0 of the PNG is the top: v = 1


def obj_files(result, path, name: str = "piece", texture: str = "none") -> list[tuple[Path, bytes]]:
    """The files of an ``.obj`` export to ``path``: the OBJ, and with ``texture="checker"``
    its ``.mtl`` and checker PNG."""
    path = Path(path)
    mesh = result.mesh
    nodes = used_nodes(mesh)
    index = np.full(mesh.n_nodes, -1, dtype=np.int64)
    index[nodes] = np.arange(1, len(nodes) + 1)
    xyz = np.asarray(result.xyz, dtype=float)[nodes]
    normals = result.surface.evaluate(np.asarray(result.uv, dtype=float)[nodes]).normal
    xy = np.asarray(result.pattern.xy, dtype=float)[nodes]
    f = index[np.asarray(mesh.cells, dtype=np.int64)]
    out = [f"# flatweave {_dt.date.today().isoformat()}: {len(nodes)} of {mesh.n_nodes} nodes "
           f"(those of some quad), {len(f)} quads",
           "# v: nodes on the surface; vt: the same nodes in the flat pattern; vn: normals",
           f"# nodes: {_ranges(nodes)}",
           "#   (vertex k is the k-th node listed, numbered as nodes in the result file, from 0)"]
    files = []
    if texture == "checker":
        origin, repeat, square, n = checker_frame(xy)
        vt = (xy - origin) / repeat
        mtl, png = path.with_suffix(".mtl"), path.with_name(f"{path.stem}_checker.png")
        out += [f"# vt = (xy - ({origin[0]:.12g}, {origin[1]:.12g})) / {repeat:.12g}: "
                f"{n} x {n} checker squares of {square:g} model units",
                f"mtllib {mtl.name}"]
        files = [(mtl, "\n".join([
            f"# flatweave: the pattern as a checker of {square:g} model units (every fifth line red)",
            "newmtl pattern", "Ka 1 1 1", "Kd 1 1 1", "Ks 0 0 0", "d 1", "illum 1",
            f"map_Kd {png.name}"]).encode("ascii") + b"\n"),
            (png, checker_png(n))]
    else:
        vt = xy
        out.append("# vt = xy: the pattern position in model units")
    out.append(f"o {name}")
    out += ["v %.12g %.12g %.12g" % tuple(p) for p in xyz]
    out += ["vt %.12g %.12g" % tuple(p) for p in vt]
    out += ["vn %.9g %.9g %.9g" % tuple(p) for p in normals]
    if texture == "checker":
        out.append("usemtl pattern")
    out += ["f " + " ".join(f"{i}/{i}/{i}" for i in row) for row in f]
    text = ("\n".join(out) + "\n").encode("ascii", errors="replace")
    return [(path, text)] + files


def obj_text(result, name: str = "piece") -> str:
    """The mesh's quads with normals and the 2D pattern as texture coordinates (OBJ)."""
    return obj_files(result, Path(f"{name}.obj"), name)[0][1].decode("ascii")
