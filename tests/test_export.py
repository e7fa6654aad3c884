"""Exports read back by other programs' readers: ezdxf for DXF, an XML parser
for SVG, pypdf for PDF, pyvista for VTP, a plain parser for OBJ."""

import errno
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from flatweave.errors import FlatweaveError, SettingsError
from flatweave.reading.examples import load_example
from flatweave.export.registry import FORMATS, ExportOptions, check_target, export, export_all
from flatweave.export.sheet import build_sheet
from flatweave.export.pdf import OVERLAP_MM, PAGE_MARGIN_MM, SHEET_MARGIN_MM
from flatweave.export.svg import MARGIN_MM as SVG_MARGIN
from flatweave.files import atomic_write_bytes, decode_array
from tests.helpers import NO_SPACE, FullDisk
from flatweave.method.lattice import WARP
from flatweave.method.metrics import cell_shear_deg, spring_strain
from flatweave.geometry.numerics import polygon_area
from flatweave.method.pattern import polygon_perimeter
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten

MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}
POINTS_PER_MM = 72 / 25.4
PAPER_MM = {"a4": (210.0, 297.0), "letter": (8.5 * 25.4, 11 * 25.4)}  # ISO 216 and ANSI


@pytest.fixture(scope="module")
def cylinder():
    """The half cylinder: its pattern is a 1.5 x (pi/2) rectangle (developable)."""
    return flatten(load_example("half_cylinder"), FlattenSettings(spacing=0.1))


def seg_distance(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of every point p (k, 2) to the closed polygon's edges."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    ap = p[:, None, :] - a[None]
    t = np.clip(np.einsum("kij,ij->ki", ap, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    return np.linalg.norm(ap - t[..., None] * ab[None], axis=2).min(axis=1)


def densify(poly: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` along a closed polygon, vertices included."""
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + np.linspace(0, 1, n, endpoint=False)[:, None] * (b - a))
    return np.vstack(out)


def warp_angle(result) -> float:
    """Direction of the warp threads in the pattern, from the result's nodes and springs."""
    m, xy = result.mesh, result.pattern.xy
    e = m.ends[m.kind == WARP]
    d = xy[e[:, 1]] - xy[e[:, 0]]
    d *= np.sign(m.ij[e[:, 1], 0] - m.ij[e[:, 0], 0])[:, None]
    d = d.sum(axis=0)
    return math.atan2(d[1], d[0])


# ---------------------------------------------------------------- DXF


def read_dxf(path):
    import ezdxf

    return ezdxf.readfile(path)


def block_polylines(doc, block, layer):
    """LWPOLYLINEs (R2000) or POLYLINEs (R12) of a block on a layer."""
    return [e for e in doc.blocks[block] if e.dxftype() in ("LWPOLYLINE", "POLYLINE") and e.dxf.layer == layer]


def polyline_points(e) -> np.ndarray:
    if e.dxftype() == "LWPOLYLINE":
        return np.array([p[:2] for p in e.get_points("xy")])
    return np.array([tuple(v.dxf.location)[:2] for v in e.vertices])


def polyline_closed(e) -> bool:
    return bool(e.closed if e.dxftype() == "LWPOLYLINE" else e.is_closed)


def test_dxf_layered_header_and_layers(tmp_path, octant_cut):
    """The layered variant: R2000, mm in the header, a layer table that describes the layers."""
    path = export(octant_cut, tmp_path / "p.dxf", ExportOptions(units="m", name="octant", dxf_variant="layered"))
    doc = read_dxf(path)
    assert doc.dxfversion == "AC1015"
    assert doc.header["$INSUNITS"] == 4  # millimetres
    assert doc.header["$MEASUREMENT"] == 1
    assert doc.layers.get("14").description == "sew line"
    assert {"1", "14", "8", "4", "7", "15"} <= {layer.dxf.name for layer in doc.layers}


@pytest.mark.parametrize("variant", ["astm", "layered"])
def test_dxf_one_block_per_piece(tmp_path, octant_cut, variant):
    path = export(octant_cut, tmp_path / "p.dxf", ExportOptions(units="m", name="octant", dxf_variant=variant))
    doc = read_dxf(path)
    assert doc.dxfversion == {"astm": "AC1009", "layered": "AC1015"}[variant]  # R12 or R2000
    auditor = doc.audit()
    assert not auditor.has_errors, [str(e) for e in auditor.errors]
    inserts = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    assert len(octant_cut.pattern.pieces) == 2
    assert len(inserts) == 2 and len({i.dxf.name for i in inserts}) == 2
    for ins in inserts:
        assert len(block_polylines(doc, ins.dxf.name, "1")) == 1
        assert len(block_polylines(doc, ins.dxf.name, "14")) == 1
        texts = [e for e in doc.blocks[ins.dxf.name] if e.dxftype() == "TEXT"]
        # ASTM: the piece system text on layer 1, the rest on 15; layered: all of it on 15
        assert {e.dxf.layer for e in texts} == ({"1", "15"} if variant == "astm" else {"15"})
        joined = " ".join(e.dxf.text for e in texts)
        assert "octant" in joined and "woven" in joined and "mm" in joined and "spacing" in joined


@pytest.mark.parametrize("units", ["m", "cm", "in"])
def test_dxf_sew_and_cut_lines_match_the_pattern_in_mm(tmp_path, octant_dart, units):
    """Without an allowance cut = sew = the pattern's outline, scaled to mm."""
    path = export(octant_dart, tmp_path / "p.dxf", ExportOptions(seam_allowance_mm=0, units=units))
    doc = read_dxf(path)
    (ins,) = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    piece = octant_dart.pattern.pieces[0]
    s = MM[units]
    for layer in ("1", "14"):
        (pl,) = block_polylines(doc, ins.dxf.name, layer)
        assert polyline_closed(pl)
        pts = polyline_points(pl)
        assert abs(polygon_area(pts)) == pytest.approx(abs(polygon_area(piece.outline)) * s * s, rel=1e-3)
        assert polygon_perimeter(pts) == pytest.approx(polygon_perimeter(piece.outline) * s, rel=1e-3)


def test_dxf_seam_allowance_and_notches(tmp_path, octant_dart):
    sa = 12.0
    doc = read_dxf(export(octant_dart, tmp_path / "p.dxf", ExportOptions(seam_allowance_mm=sa, units="m")))
    (ins,) = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    (cut,) = block_polylines(doc, ins.dxf.name, "1")
    (sew,) = block_polylines(doc, ins.dxf.name, "14")
    cut, sew = polyline_points(cut), polyline_points(sew)
    assert abs(polygon_area(cut)) > abs(polygon_area(sew))
    # notches: where the dart's legs meet the outline, from the cut line inwards
    notches = [e for e in doc.blocks[ins.dxf.name] if e.dxftype() == "LINE" and e.dxf.layer == "4"]
    assert len(notches) == 2
    for n in notches:
        start, end = np.array(n.dxf.start)[:2], np.array(n.dxf.end)[:2]
        assert seg_distance(start[None], cut)[0] < 1e-6
        assert seg_distance(end[None], sew)[0] == pytest.approx(sa - 6.0, abs=1e-6)
    legs = block_polylines(doc, ins.dxf.name, "8")
    assert len(legs) == 2
    assert [e for e in doc.blocks[ins.dxf.name] if e.dxftype() == "POINT" and e.dxf.layer == "13"]


@pytest.mark.parametrize("fixture", ["octant_dart", "cylinder"])
def test_dxf_grain_line_follows_the_warp(tmp_path, fixture, request):
    result = request.getfixturevalue(fixture)
    doc = read_dxf(export(result, tmp_path / "p.dxf"))
    (ins,) = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    (line,) = [e for e in doc.blocks[ins.dxf.name] if e.dxftype() == "LINE" and e.dxf.layer == "7"]
    d = np.array(line.dxf.end)[:2] - np.array(line.dxf.start)[:2]
    assert np.linalg.norm(d) > 50.0  # mm: a grain line a user can align
    diff = (math.atan2(d[1], d[0]) - warp_angle(result) + math.pi / 2) % math.pi - math.pi / 2
    assert abs(math.degrees(diff)) < 0.01
    # the grain line lies inside the piece
    (sew,) = block_polylines(doc, ins.dxf.name, "14")
    from shapely.geometry import LineString, Polygon

    assert Polygon(polyline_points(sew)).contains(
        LineString([tuple(line.dxf.start)[:2], tuple(line.dxf.end)[:2]]))


# ---------------------------------------------------------------- seam allowance


@pytest.mark.slow
@pytest.mark.parametrize("sa", [5.0, 10.0, 15.875])
def test_seam_allowance_lies_outside_at_the_set_distance(octant_dart, sa):
    sheet = build_sheet(octant_dart, "m", sa)
    (p,) = sheet.pieces
    from shapely.geometry import Point, Polygon

    cut_poly = Polygon(p.cut)
    assert cut_poly.is_valid and cut_poly.contains(Polygon(p.sew))
    # every point of the cut line is at least sa from the sew line, and no more
    # than the mitre limit (2 sa) at sharp corners
    d = seg_distance(densify(p.cut, 1.0), p.sew)
    assert d.min() >= sa * (1 - 1e-6)
    assert d.max() <= 2 * sa * (1 + 1e-6)
    assert np.median(d) == pytest.approx(sa, rel=1e-6)  # along the edges: exactly sa
    # every point of the sew line is at least sa from the cut line
    e = seg_distance(densify(p.sew, 1.0), p.cut)
    assert e.min() >= sa * (1 - 1e-6)
    assert not any(cut_poly.exterior.distance(Point(q)) < sa * (1 - 1e-6) for q in p.sew[::7])


def test_bad_export_options_are_one_line_errors():
    with pytest.raises(SettingsError, match="seam allowance"):
        ExportOptions(seam_allowance_mm=-1)
    with pytest.raises(SettingsError, match="units"):
        ExportOptions(units="furlong")
    with pytest.raises(SettingsError, match="paper"):
        ExportOptions(paper="a3")


# ---------------------------------------------------------------- SVG


def test_svg_size_in_mm_is_the_pattern_plus_margins(tmp_path, octant_dart):
    sa = 10.0
    path = export(octant_dart, tmp_path / "p.svg", ExportOptions(seam_allowance_mm=sa, units="m"))
    root = ET.parse(path).getroot()
    w, h = root.get("width"), root.get("height")
    assert w.endswith("mm") and h.endswith("mm")
    w, h = float(w[:-2]), float(h[:-2])
    vb = [float(x) for x in root.get("viewBox").split()]
    assert vb == pytest.approx([0, 0, w, h])
    # the pattern's bounding box, from the sew line grown by the allowance
    sheet = build_sheet(octant_dart, "m", sa)
    cut = sheet.pieces[0].cut
    assert w == pytest.approx(np.ptp(cut[:, 0]) + 2 * SVG_MARGIN, abs=1e-3)
    assert h == pytest.approx(np.ptp(cut[:, 1]) + 2 * SVG_MARGIN, abs=1e-3)
    ns = {"s": "http://www.w3.org/2000/svg"}
    groups = {g.get("id"): g for g in root.findall("s:g", ns)}
    assert {"layer-1-cut", "layer-14-sew", "layer-8-internal", "layer-4-notch", "layer-7-grain",
            "layer-15-annotation"} <= set(groups)
    (sew,) = groups["layer-14-sew"].findall("s:polygon", ns)
    pts = np.array([[float(v) for v in xy.split(",")] for xy in sew.get("points").split()])
    piece = octant_dart.pattern.pieces[0]
    assert abs(polygon_area(pts)) == pytest.approx(abs(polygon_area(piece.outline)) * 1e6, rel=1e-3)
    assert polygon_perimeter(pts) == pytest.approx(polygon_perimeter(piece.outline) * 1e3, rel=1e-3)
    assert pts.min() >= 0 and pts[:, 0].max() <= w and pts[:, 1].max() <= h


# ---------------------------------------------------------------- PDF


def page_rects(page):
    """Every rectangle drawn on a page, in the page's own units (points):
    (x, y, w, h) after the current transformation matrix."""
    from pypdf.generic import ContentStream

    ops = ContentStream(page.get_contents(), page.pdf).operations
    ctm, stack, out = np.eye(3), [], []
    for operands, op in ops:
        if op == b"q":
            stack.append(ctm.copy())
        elif op == b"Q":
            ctm = stack.pop()
        elif op == b"cm":
            a, b, c, d, e, f = (float(x) for x in operands)
            ctm = np.array([[a, b, 0], [c, d, 0], [e, f, 1]]) @ ctm
        elif op == b"re":
            x, y, w, h = (float(v) for v in operands)
            p0 = np.array([x, y, 1]) @ ctm
            p1 = np.array([x + w, y + h, 1]) @ ctm
            out.append((p0[0], p0[1], p1[0] - p0[0], p1[1] - p0[1]))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("paper", ["a4", "letter"])
def test_pdf_pages_tiles_and_test_square(tmp_path, cylinder, paper):
    """The half cylinder's 1.5 m x 1.57 m rectangle covers every tile of the grid."""
    from pypdf import PdfReader

    sa = 10.0
    path = export(cylinder, tmp_path / "p.pdf", ExportOptions(seam_allowance_mm=sa, units="m", paper=paper))
    reader = PdfReader(path)
    pw, ph = PAPER_MM[paper]
    sheet = build_sheet(cylinder, "m", sa)
    W, H = (s + 2 * SHEET_MARGIN_MM for s in sheet.size)
    cw, ch = pw - 2 * PAGE_MARGIN_MM, ph - 2 * PAGE_MARGIN_MM
    cols = math.ceil((W - OVERLAP_MM) / (cw - OVERLAP_MM))
    rows = math.ceil((H - OVERLAP_MM) / (ch - OVERLAP_MM))
    assert rows * cols > 1
    assert len(reader.pages) == 2 + rows * cols  # overview, assembly map, tiles
    # Every page has a test square: 100 mm on the overview and the map; on a tile the
    # largest of 100, 50, 20 mm that finds a place clear of the pattern's lines (
    # a 100 mm square in a fixed corner used to cover pattern lines).
    from flatweave.export.pdf import TILE_SQUARES_MM
    from tests.pdf_paths import lines_over, page_drawing, find_squares

    for k, page in enumerate(reader.pages):
        box = page.mediabox
        assert float(box.width) == pytest.approx(pw * POINTS_PER_MM, abs=0.5)
        assert float(box.height) == pytest.approx(ph * POINTS_PER_MM, abs=0.5)
        rects, segments, _ = page_drawing(page)
        sides = [100.0] if k < 2 else list(TILE_SQUARES_MM)
        squares = find_squares(rects, [s * POINTS_PER_MM for s in sides])
        assert len(squares) == 1, "every page has one test square"
        x, y, w, h = squares[0]
        assert 0 <= x and x + w <= float(box.width) and 0 <= y and y + h <= float(box.height)
        if k >= 2:
            assert not lines_over(squares[0], segments), f"page {k + 1}: the test square covers a line"
    texts = [p.extract_text() for p in reader.pages]
    assert "overview" in texts[0] and "scale 1:" in texts[0]
    assert "assembly map" in texts[1]
    assert "A1" in texts[2] and "row A, column 1" in texts[2]
    last = f"{chr(64 + rows)}{cols}"
    assert f"{last}   row {chr(64 + rows)}, column {cols}" in texts[-1]


@pytest.mark.slow
def test_pdf_leaves_out_blank_tiles(tmp_path, octant_dart):
    """The octant is a curved triangle: corner tiles of its grid are blank and not printed."""
    from pypdf import PdfReader

    from flatweave.export.pdf import tile_grid, tiles

    sheet = build_sheet(octant_dart, "m", 10.0)
    rows, cols, _, _ = tile_grid(sheet.size, "a4")
    grid = tiles(sheet, "a4")
    printed = sum(t[2] for t in grid)
    # The curved triangle spans several tiles but misses the grid's top-left
    # corner: both bounds fail if blank tiles were printed or pieces dropped.
    assert 1 < printed < rows * cols
    assert not grid[0][2]  # A1, beyond the octant's curved edge, is blank
    reader = PdfReader(export(octant_dart, tmp_path / "p.pdf"))
    assert len(reader.pages) == 2 + printed


def test_pdf_small_pattern_fits_one_tile(tmp_path, cylinder):
    """In mm the half cylinder is 1.5 x 1.6 mm: one tile."""
    from pypdf import PdfReader

    reader = PdfReader(export(cylinder, tmp_path / "p.pdf", ExportOptions(units="mm", seam_allowance_mm=2)))
    assert len(reader.pages) == 3


# ---------------------------------------------------------------- OBJ, VTP


def parse_ranges(text: str) -> np.ndarray:
    """"0-2 5 7-8" -> [0, 1, 2, 5, 7, 8]."""
    out = []
    for part in text.split():
        lo, _, hi = part.partition("-")
        out += range(int(lo), int(hi or lo) + 1)
    return np.array(out, dtype=int)


def test_obj_texture_coordinates_are_the_pattern(tmp_path, octant_dart):
    """Vertices are the nodes some quad uses ( readers drop the others and shift
    the rest), listed in the header; vt is the node's nodes.xy, v its xyz."""
    from flatweave.method.result import result_to_dict

    path = export(octant_dart, tmp_path / "p.obj")
    v, vt, vn, faces, nodes = [], [], [], [], None
    for line in path.read_text().splitlines():
        if line.startswith("# nodes:"):
            nodes = parse_ranges(line[len("# nodes:"):])
        key, *vals = line.split() or [""]
        if key == "v":
            v.append([float(x) for x in vals])
        elif key == "vt":
            vt.append([float(x) for x in vals])
        elif key == "vn":
            vn.append([float(x) for x in vals])
        elif key == "f":
            faces.append([[int(i) for i in x.split("/")] for x in vals])
    d = result_to_dict(octant_dart)
    cells = octant_dart.mesh.cells
    np.testing.assert_array_equal(nodes, np.unique(cells))
    assert len(nodes) < octant_dart.mesh.n_nodes  # this mesh has a node in no quad
    np.testing.assert_allclose(np.array(vt), decode_array(d["nodes"]["xy"], "xy")[nodes], atol=1e-10)
    np.testing.assert_allclose(np.array(v), decode_array(d["nodes"]["xyz"], "xyz")[nodes], atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(vn, axis=1), 1.0, atol=1e-6)
    f = np.array(faces)
    assert f.shape == (len(cells), 4, 3)
    np.testing.assert_array_equal(nodes[f[:, :, 0] - 1], cells)
    assert (f[:, :, 0] == f[:, :, 1]).all() and (f[:, :, 0] == f[:, :, 2]).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.obj"]  # no texture: no .mtl


def test_vtp_reads_back_with_strain_and_shear(tmp_path, octant_dart):
    """Surface and springs are two files (and a multiblock naming both), each with only the
    fields defined on its cells ( NaN-filled quads coloured ParaView's default view)."""
    import pyvista as pv

    path = export(octant_dart, tmp_path / "p.vtp")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.vtm", "p.vtp", "p_springs.vtp"]
    r = octant_dart
    m, c = r.mesh.n_springs, len(r.mesh.cells)
    surface, springs = pv.read(path), pv.read(tmp_path / "p_springs.vtp")
    assert surface.n_points == springs.n_points == r.mesh.n_nodes
    assert surface.n_cells == c and springs.n_cells == m
    for mesh in (surface, springs):
        np.testing.assert_allclose(mesh.points, r.xyz, atol=1e-12)
        np.testing.assert_allclose(mesh.point_data["pattern_xy"], r.pattern.xy, atol=1e-12)
    assert set(surface.cell_data) == {"shear_deg", "fibre_deviation_deg", "warp_deviation_deg", "weft_dir",
                                      "warp_dir"}
    assert set(springs.cell_data) == {"strain_pct", "spring_kind"}
    np.testing.assert_allclose(springs.cell_data["strain_pct"], 100 * spring_strain(r.xyz, r.mesh), atol=1e-12)
    np.testing.assert_allclose(surface.cell_data["shear_deg"], cell_shear_deg(r.xyz, r.mesh), atol=1e-12)
    np.testing.assert_array_equal(springs.cell_data["spring_kind"], r.mesh.kind)
    assert set(np.unique(springs.cell_data["spring_kind"])) <= {0, 1, 2}
    np.testing.assert_array_equal(springs.lines.reshape(-1, 3)[:, 1:], r.mesh.ends)
    np.testing.assert_array_equal(surface.faces.reshape(-1, 5)[:, 1:], r.mesh.cells)
    blocks = pv.read(tmp_path / "p.vtm")
    assert list(blocks.keys()) == ["surface", "springs"]
    assert blocks["surface"].n_cells == c and blocks["springs"].n_cells == m


# ---------------------------------------------------------------- targets and failures


def test_unknown_suffix_and_bad_folder_are_refused(tmp_path):
    with pytest.raises(SettingsError, match="unknown format '.xyz'"):
        check_target(tmp_path / "p.xyz")
    with pytest.raises(SettingsError, match="does not exist"):
        check_target(tmp_path / "nowhere" / "p.dxf")
    (tmp_path / "file").write_text("x")
    with pytest.raises(SettingsError, match="is not a folder"):
        check_target(tmp_path / "file" / "p.dxf")
    assert set(FORMATS) == {".dxf", ".svg", ".pdf", ".vtp", ".obj", ".csv"}


def test_a_failed_write_leaves_no_partial_file_and_the_old_one_intact(tmp_path, octant_dart, monkeypatch):
    old = tmp_path / "p.dxf"
    old.write_bytes(b"previous export")
    new = tmp_path / "q.svg"
    FullDisk(monkeypatch, "write")
    for target in (old, new):
        with pytest.raises(FlatweaveError, match="No space left on device") as info:
            export(octant_dart, target)
        assert "\n" not in str(info.value)
    monkeypatch.undo()
    assert old.read_bytes() == b"previous export"
    assert not new.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf"]  # no temporary files left


def test_export_all_writes_every_format(tmp_path, octant_dart):
    paths = export_all(octant_dart, [tmp_path / f"p{s}" for s in FORMATS], ExportOptions(units="cm"))
    assert [p.suffix for p in paths] == list(FORMATS)
    assert all(p.stat().st_size > 0 for p in paths)
    assert all(p.stat().st_mode & 0o044 for p in paths)  # readable by others, as the umask allows


# ---------------------------------------------------------------- full disk, refused folders, several targets
@pytest.mark.slow
@pytest.mark.parametrize("how", ["write", "fsync"])
@pytest.mark.parametrize("suffix", list(FORMATS))
def test_a_full_disk_leaves_every_target_as_it_was(tmp_path, octant_dart, monkeypatch, suffix, how):
    old = tmp_path / f"old{suffix}"
    old.write_bytes(b"previous export")
    new = tmp_path / f"new{suffix}"
    FullDisk(monkeypatch, how)
    for target, write in ((old, export), (new, lambda r, p: export_all(r, [p]))):
        with pytest.raises(FlatweaveError) as info:
            write(octant_dart, target)
        assert str(info.value) == f"cannot write {target}: {NO_SPACE}"
    monkeypatch.undo()
    assert old.read_bytes() == b"previous export"
    assert sorted(p.name for p in tmp_path.iterdir()) == [old.name]  # no new file, no temporary file


def test_an_unwritable_folder_leaves_nothing_behind(tmp_path, octant_dart, monkeypatch):
    # a "folder" that is a regular file: refused by the target check, and by the writer itself
    (tmp_path / "file.txt").write_text("x")
    target = tmp_path / "file.txt" / "out.dxf"
    with pytest.raises(SettingsError) as info:
        export(octant_dart, target)
    assert str(info.value) == f"cannot export {target}: {tmp_path / 'file.txt'} is not a folder"
    with pytest.raises(FlatweaveError) as info:
        atomic_write_bytes(target, b"data")
    assert str(info.value) == f"cannot write {target}: {os.strerror(errno.ENOTDIR)}"
    # a folder without write permission
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    target = locked / "p.dxf"
    try:
        if os.access(locked, os.W_OK):
            # running as root, whom permissions do not stop: the writer is then told
            # what the system tells anyone else, and must say so
            real_mkstemp = tempfile.mkstemp

            def mkstemp(*args, dir=None, **kw):
                if dir is not None and Path(dir) == locked:
                    raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))
                return real_mkstemp(*args, dir=dir, **kw)

            monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
            with pytest.raises(FlatweaveError) as info:
                export_all(octant_dart, [tmp_path / "fine.svg", target])
            assert str(info.value) == f"cannot write {target}: {os.strerror(errno.EACCES)}"
        else:
            with pytest.raises(SettingsError) as info:
                export_all(octant_dart, [tmp_path / "fine.svg", target])
            assert str(info.value) == f"cannot export {target}: folder {locked} is not writable"
        assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o700)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt", "locked"]  # fine.svg was not written either


@pytest.mark.slow
def test_export_all_is_all_or_nothing(tmp_path, octant_dart, monkeypatch):
    """Every target is checked and built, and written to a temporary file, before
    any is renamed into place: one failure leaves all of them as they were."""
    targets = [tmp_path / f"p{s}" for s in FORMATS]  # .dxf, .svg, .pdf, .vtp, .obj
    targets[0].write_bytes(b"previous dxf")
    # a bad target among good ones: refused before anything is built or written
    with pytest.raises(SettingsError, match="does not exist"):
        export_all(octant_dart, targets + [tmp_path / "nowhere" / "p.svg"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf"]
    # the disk fills up at the third file (the PDF)
    FullDisk(monkeypatch, "write", fail_on=3)
    with pytest.raises(FlatweaveError) as info:
        export_all(octant_dart, targets)
    assert str(info.value) == f"cannot write {targets[2]}: {NO_SPACE}"
    monkeypatch.undo()
    assert targets[0].read_bytes() == b"previous dxf"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf"]
    # a rename that fails after the first: the first is new, the rest as they were, and the message says so
    real_replace = os.replace
    calls = []

    def replace(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(FlatweaveError) as info:
        export_all(octant_dart, targets)
    monkeypatch.undo()
    assert str(info.value) == f"cannot write {targets[1]}: {os.strerror(errno.EIO)} ({targets[0]} already written)"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.dxf"] and b"SECTION" in targets[0].read_bytes()[:200]
    # and with room on the disk every file is written
    assert export_all(octant_dart, targets) == targets
    assert all(p.stat().st_size > 100 for p in targets)
