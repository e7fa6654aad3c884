"""The exports read back by readers nobody here wrote: the DXF's tags
parsed by hand and by ezdxf (audit) and GDAL (ogr2ogr, where installed), areas
by shapely; the SVG by xml.etree; the PDF by pypdf; the OBJ by trimesh; the VTP
and VTM by VTK's own XML readers."""

import json
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from flatweave.reading.examples import load_example
from flatweave.export.registry import ExportOptions, export
from flatweave.export.sheet import build_sheet
from flatweave.export.sheet import LINE_PITCH, TEXT_EM
from flatweave.geometry.numerics import polygon_area
from flatweave.method.pattern import polygon_perimeter
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.method.result import result_to_dict

ASTM_LAYERS = {"1", "4", "7", "8", "11", "13", "14", "15"}
PIECE_KEYS = ("Piece Name", "Size", "Quantity", "Material", "Category")
STYLE_KEYS = ("Style Name", "Creation Date", "Author", "Sample Size", "Grading Rule Table", "Units")


@pytest.fixture(scope="module")
def garment():
    return flatten(load_example("garment"), FlattenSettings(spacing=0.04))


# ---------------------------------------------------------------- DXF, tag by tag


def dxf_tags(text: str) -> list[tuple[int, str]]:
    """(group code, value) pairs of an ASCII DXF, read by hand."""
    lines = text.splitlines()
    assert len(lines) % 2 == 0
    return [(int(lines[i]), lines[i + 1].strip()) for i in range(0, len(lines), 2)]


def dxf_sections(tags) -> dict[str, list]:
    out, name, body = {}, None, None
    for k, (code, value) in enumerate(tags):
        if code == 0 and value == "SECTION":
            name, body = tags[k + 1][1], []
        elif code == 0 and value == "ENDSEC":
            out[name], name = body, None
        elif name is not None:
            body.append((code, value))
    return out


def dxf_entities(body) -> list[dict]:
    """Every entity of a section as {"type", "layer", codes: [values]} (the BLOCK and
    ENDBLK markers included)."""
    out = []
    for code, value in body:
        if code == 0:
            out.append({"type": value})
        elif out:
            out[-1].setdefault(code, []).append(value)
    return out


def test_astm_dxf_structure_by_hand(tmp_path, octant_cut):
    """ASTM D6673: R12, one block per piece and nothing else in BLOCKS (no layout blocks,
    which Gerber AccuMark takes for pieces: ezdxf issue 786), no TABLES, the piece system
    text on layer 1 in each block, the style system text once in the model space, extents
    in the header, only ASTM layers, 7-bit ASCII."""
    path = export(octant_cut, tmp_path / "p.dxf", ExportOptions(units="m", name="octant"))
    raw = path.read_bytes()
    assert max(raw) < 128
    sections = dxf_sections(dxf_tags(raw.decode("ascii")))
    assert list(sections) == ["HEADER", "BLOCKS", "ENTITIES"]
    header = dict(zip([v for c, v in sections["HEADER"] if c == 9],
                      [None] * len(sections["HEADER"])))
    assert set(header) == {"$ACADVER", "$EXTMIN", "$EXTMAX"}
    assert ("1", "AC1009") in [(str(c), v) for c, v in sections["HEADER"]]
    blocks = [e for e in dxf_entities(sections["BLOCKS"]) if e["type"] == "BLOCK"]
    names = [b[2][0] for b in blocks]
    assert len(names) == len(octant_cut.pattern.pieces) == 2
    assert not any(n.startswith(("*", "$")) for n in names)  # no layout or anonymous blocks
    # per block: its entities
    body, current, per_block = dxf_entities(sections["BLOCKS"]), None, {}
    for e in body:
        if e["type"] == "BLOCK":
            current = e[2][0]
            per_block[current] = []
        elif e["type"] == "ENDBLK":
            current = None
        elif e["type"] not in ("VERTEX", "SEQEND"):
            per_block[current].append(e)
    for name, ents in per_block.items():
        layers = {e[8][0] for e in ents}
        assert layers <= ASTM_LAYERS and {"1", "14", "7"} <= layers
        system = [e[1][0] for e in ents if e["type"] == "TEXT" and e[8][0] == "1"]
        assert [t.split(":")[0] for t in system] == list(PIECE_KEYS)
        assert f"Piece Name: {name.replace('_', ' ')}" in system and "Quantity: 1" in system
        assert [e for e in ents if e["type"] == "POLYLINE" and e[8][0] == "1"]  # the boundary
        assert any(e["type"] == "TEXT" and e[8][0] == "15" for e in ents)  # annotation
    msp = dxf_entities(sections["ENTITIES"])
    inserts = [e for e in msp if e["type"] == "INSERT"]
    assert sorted(e[2][0] for e in inserts) == sorted(names)
    style = [e[1][0] for e in msp if e["type"] == "TEXT"]
    assert [t.split(":")[0] for t in style] == list(STYLE_KEYS) and "Units: METRIC" in style
    assert {e[8][0] for e in msp} <= ASTM_LAYERS
    # the extents: the sheet (and whatever is drawn beyond it), and the style text below it
    import ezdxf

    doc = ezdxf.readfile(path)
    assert not doc.audit().has_errors
    sheet = build_sheet(octant_cut, "m", 10.0, "octant")
    lo, hi = tuple(doc.header["$EXTMIN"]), tuple(doc.header["$EXTMAX"])
    assert min(hi[0] - sheet.size[0], hi[1] - sheet.size[1], -lo[0]) > -1e-5
    lowest = min(float(e[20][0]) for e in msp if e["type"] == "TEXT")
    assert lo[1] < lowest < 0


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["astm", "layered"])
def test_dxf_records_where_each_piece_sits(tmp_path, octant_cut, variant):
    """A piece's block holds it in the result's own frame (nodes.xy in mm); its INSERT's
    insertion point is the offset that lays it on the sheet."""
    import ezdxf
    from tests.test_export import block_polylines, polyline_points

    path = export(octant_cut, tmp_path / "p.dxf", ExportOptions(units="m", seam_allowance_mm=0,
                                                                 dxf_variant=variant))
    doc = ezdxf.readfile(path)
    sheet = build_sheet(octant_cut, "m", 0.0)
    inserts = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    for ins, piece, src in zip(inserts, sheet.pieces, octant_cut.pattern.pieces):
        (sew,) = block_polylines(doc, ins.dxf.name, "14")
        pts = polyline_points(sew)
        outline = src.outline * 1000.0
        if polygon_area(outline) < 0:
            outline = outline[::-1]
        np.testing.assert_allclose(pts, outline, atol=1e-6)  # the result's frame, in mm
        np.testing.assert_allclose(np.array(ins.dxf.insert)[:2], piece.offset, atol=1e-9)
        np.testing.assert_allclose(pts + piece.offset, piece.sew, atol=1e-6)  # on the sheet
    assert np.array(inserts[0].dxf.insert)[:2] == pytest.approx(sheet.pieces[0].offset)


@pytest.mark.skipif(shutil.which("ogr2ogr") is None, reason="GDAL's ogr2ogr is not installed")
@pytest.mark.parametrize("variant", ["astm", "layered"])
def test_gdal_reads_the_sew_line_at_its_place(tmp_path, octant_dart, variant):
    """GDAL (blocks inlined, each entity on its own layer): the sew line's area in mm² is
    the result's, and it lies where the sheet puts it."""
    from shapely.geometry import Polygon, shape

    path = export(octant_dart, tmp_path / "p.dxf", ExportOptions(units="m", dxf_variant=variant))
    out = tmp_path / "sew.geojson"
    subprocess.run(["ogr2ogr", "--config", "DXF_MERGE_BLOCK_GEOMETRIES", "FALSE", "-f", "GeoJSON", str(out),
                    str(path), "-sql", "SELECT * FROM entities WHERE Layer = '14'"], check=True,
                   capture_output=True)
    feats = json.loads(out.read_text())["features"]
    (line,) = [shape(f["geometry"]) for f in feats]
    area = Polygon(line.coords).area
    assert area == pytest.approx(octant_dart.pattern.pieces[0].area * 1e6, rel=1e-9)
    sheet = build_sheet(octant_dart, "m", 10.0)
    assert np.allclose(line.bounds, [*sheet.pieces[0].sew.min(axis=0), *sheet.pieces[0].sew.max(axis=0)],
                       atol=1e-6)


def dxf_label_boxes(doc, block):
    """The label's box from the block's TEXT entities: each character at most TEXT_EM
    heights wide (CAD's standard fonts), as LibreCAD or AutoCAD would draw it."""
    from shapely.geometry import box

    texts = [e for e in doc.blocks[block] if e.dxftype() == "TEXT"]
    boxes = []
    for t in texts:
        x, y = tuple(t.dxf.insert)[:2]
        h = t.dxf.height
        boxes.append(box(x, y - 0.3 * h, x + TEXT_EM * h * len(t.dxf.text), y + h))
    return boxes, texts


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["octant_dart", "octant_cut", "garment"])
def test_labels_lie_in_free_space_inside_the_piece(tmp_path, fixture, request):
    """Every label line, measured at CAD's widest standard font, lies inside the sew line,
    clear of the grain line, dart legs, drill holes and notches (LibreCAD drew the
    annotation across the grain line)."""
    import ezdxf
    from shapely.geometry import LineString, Point, Polygon
    from tests.test_export import block_polylines, polyline_points

    result = request.getfixturevalue(fixture)
    doc = ezdxf.readfile(export(result, tmp_path / "p.dxf", ExportOptions(units="m")))
    for ins in [e for e in doc.modelspace() if e.dxftype() == "INSERT"]:
        b = ins.dxf.name
        sew = Polygon(polyline_points(block_polylines(doc, b, "14")[0]))
        marks = [LineString(polyline_points(e)) for layer in ("7", "8") for e in block_polylines(doc, b, layer)]
        marks += [LineString([tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]]) for e in doc.blocks[b]
                  if e.dxftype() == "LINE" and e.dxf.layer in ("4", "7")]
        marks += [Point(tuple(e.dxf.location)[:2]).buffer(1.0) for e in doc.blocks[b] if e.dxftype() == "POINT"]
        boxes, texts = dxf_label_boxes(doc, b)
        assert len(texts) == 11  # the material's shear angles and the share beyond lock
        h = texts[0].dxf.height
        assert h >= 1.5
        ys = [t.dxf.insert[1] for t in texts]
        np.testing.assert_allclose(-np.diff(ys), LINE_PITCH * h)
        for bx, t in zip(boxes, texts):
            assert sew.contains(bx), t.dxf.text
            assert all(not bx.intersects(m) for m in marks), t.dxf.text
            assert sew.exterior.distance(bx) >= 0.99 * h  # a margin of a text height


# ---------------------------------------------------------------- SVG


def test_svg_metadata_maps_the_result_onto_the_drawing(tmp_path, octant_cut):
    """The SVG's metadata gives each piece's offset and the matrix from the result's
    nodes.xy (model units) to SVG user units: applied to the result's outline it gives the
    drawn sew line."""
    from flatweave.export.svg import NS

    path = export(octant_cut, tmp_path / "p.svg", ExportOptions(units="cm", seam_allowance_mm=0))
    root = ET.parse(path).getroot()
    ns = {"s": "http://www.w3.org/2000/svg", "f": NS}
    sheet_el = root.find("s:metadata/f:sheet", ns)
    assert sheet_el.get("units") == "mm" and float(sheet_el.get("mm-per-unit")) == 10.0
    pieces = sheet_el.findall("f:piece", ns)
    sew = root.find("s:g[@id='layer-14-sew']", ns).findall("s:polygon", ns)
    assert len(pieces) == len(sew) == 2
    sheet = build_sheet(octant_cut, "cm", 0.0)
    for el, poly, src, sp in zip(pieces, sew, octant_cut.pattern.pieces, sheet.pieces):
        a, b, c, d, e, f = (float(v) for v in re.match(r"matrix\(([^)]*)\)", el.get("transform")).group(1).split())
        outline = src.outline if polygon_area(src.outline) > 0 else src.outline[::-1]
        mapped = np.column_stack([a * outline[:, 0] + c * outline[:, 1] + e, b * outline[:, 0] + d * outline[:, 1] + f])
        drawn = np.array([[float(v) for v in xy.split(",")] for xy in poly.get("points").split()])
        np.testing.assert_allclose(mapped, drawn, atol=1e-3)  # the file's 4 decimals
        np.testing.assert_allclose([float(v) for v in el.get("offset-mm").split()], sp.offset, atol=1e-5)


# ---------------------------------------------------------------- PDF


@pytest.mark.slow
def test_pdf_tiles_squares_clear_and_neighbours_printed(tmp_path, octant_dart):
    """On every tile the test square covers no line, and the neighbour labels name printed
    tiles only (A5 said "< A4", a blank tile that is not printed)."""
    from pypdf import PdfReader

    from flatweave.export.pdf import TILE_SQUARES_MM, tiles
    from tests.pdf_paths import lines_over, page_drawing, find_squares

    mm = 72 / 25.4
    reader = PdfReader(export(octant_dart, tmp_path / "p.pdf", ExportOptions(units="m")))
    grid = tiles(build_sheet(octant_dart, "m", 10.0), "a4")
    printed = {f"{chr(65 + r)}{c + 1}" for r, c, show in grid if show}
    assert len(reader.pages) == 2 + len(printed) and len(printed) < len(grid)
    blanks = 0
    for page in reader.pages[2:]:
        rects, segments, texts = page_drawing(page)
        (square,) = find_squares(rects, [s * mm for s in TILE_SQUARES_MM])
        assert not lines_over(square, segments)
        for t in texts:
            m = re.fullmatch(r"(?:[<^v] (\S+))|(?:(\S+) >)", t)
            if m:
                name = m.group(1) or m.group(2)
                assert name == "blank" or name in printed, t
                blanks += name == "blank"
    assert blanks > 0  # the octant's grid has blank neighbours


# ---------------------------------------------------------------- OBJ with trimesh


@pytest.mark.parametrize("texture", ["none", "checker"])
def test_trimesh_reads_every_vertex_in_place(tmp_path, octant_dart, texture):
    """trimesh keeps the OBJ's vertices in order: they are the nodes of some quad, the
    mapping in the header; with the checker, the .mtl and its PNG load as the material."""
    trimesh = pytest.importorskip("trimesh")
    from tests.test_export import parse_ranges

    path = export(octant_dart, tmp_path / "p.obj", ExportOptions(obj_texture=texture))
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == (["p.mtl", "p.obj", "p_checker.png"] if texture == "checker" else ["p.obj"])
    mesh = trimesh.load(path, process=False, force="mesh")
    header = next(line for line in path.read_text().splitlines() if line.startswith("# nodes:"))
    nodes = parse_ranges(header[len("# nodes:"):])
    r = octant_dart
    np.testing.assert_array_equal(nodes, np.unique(r.mesh.cells))
    assert len(mesh.vertices) == len(nodes) < r.mesh.n_nodes
    np.testing.assert_allclose(mesh.vertices, r.xyz[nodes], atol=1e-9)
    assert len(mesh.faces) == 2 * len(r.mesh.cells)  # quads as two triangles
    uv = np.asarray(mesh.visual.uv)
    xy = r.pattern.xy[nodes]
    if texture == "none":
        np.testing.assert_allclose(uv, xy, atol=1e-9)
    else:
        line = next(t for t in path.read_text().splitlines() if t.startswith("# vt = (xy - ("))
        x0, y0, s = map(float, re.match(r"# vt = \(xy - \(([^,]+), ([^)]+)\)\) / ([^:]+):", line).groups())
        np.testing.assert_allclose(uv, (xy - [x0, y0]) / s, atol=1e-9)
        assert uv.min() >= 0 and uv.max() <= 1
        image = mesh.visual.material.image
        assert image is not None and image.size[0] == image.size[1] >= 32


# ---------------------------------------------------------------- VTP, VTM with VTK


def test_vtk_reads_surface_springs_and_multiblock(tmp_path, octant_dart):
    """VTK's XML readers: the surface colours by shear, the springs by strain, no NaN and no
    -1 anywhere; the multiblock holds both, named."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLMultiBlockDataReader, vtkXMLPolyDataReader

    export(octant_dart, tmp_path / "p.vtp")

    def read(name):
        rd = vtkXMLPolyDataReader()
        rd.SetFileName(str(tmp_path / name))
        rd.Update()
        return rd.GetOutput()

    surface, springs = read("p.vtp"), read("p_springs.vtp")
    assert surface.GetCellData().GetScalars().GetName() == "shear_deg"
    assert springs.GetCellData().GetScalars().GetName() == "strain_pct"
    assert surface.GetNumberOfPolys() == surface.GetNumberOfCells() == len(octant_dart.mesh.cells)
    assert springs.GetNumberOfLines() == springs.GetNumberOfCells() == octant_dart.mesh.n_springs
    strain = vtk_to_numpy(springs.GetCellData().GetArray("strain_pct"))
    kind = vtk_to_numpy(springs.GetCellData().GetArray("spring_kind"))
    assert np.isfinite(strain).all() and set(np.unique(kind)) <= {0, 1, 2}
    assert surface.GetCellData().GetNumberOfArrays() == 5 and springs.GetCellData().GetNumberOfArrays() == 2
    # the fibre angles (flatweave.method.fibres) as VTK reads them: unit 3-vectors and degrees
    for name, comps in (("fibre_deviation_deg", 1), ("warp_deviation_deg", 1), ("weft_dir", 3), ("warp_dir", 3)):
        arr = surface.GetCellData().GetArray(name)
        assert arr.GetNumberOfComponents() == comps and arr.GetNumberOfTuples() == len(octant_dart.mesh.cells)
    np.testing.assert_allclose(np.linalg.norm(vtk_to_numpy(surface.GetCellData().GetArray("weft_dir")), axis=1), 1.0)
    mb = vtkXMLMultiBlockDataReader()
    mb.SetFileName(str(tmp_path / "p.vtm"))
    mb.Update()
    out = mb.GetOutput()
    assert out.GetNumberOfBlocks() == 2
    names = [out.GetMetaData(k).Get(out.NAME()) for k in range(2)]
    assert names == ["surface", "springs"]
    assert out.GetBlock(1).GetNumberOfLines() == octant_dart.mesh.n_springs


# ---------------------------------------------------------------- result file


def test_result_names_outline_perimeter_and_sew_length(tmp_path, octant_dart):
    """perimeter_outline is along the region's boundary (what boundary_error_pct compares);
    sew_length is the exported sew line's length, dart legs included."""
    import ezdxf
    from tests.test_export import block_polylines, polyline_points

    (piece,) = result_to_dict(octant_dart)["pattern"]["pieces"]
    assert "perimeter" not in piece
    assert piece["perimeter_outline"] == pytest.approx(octant_dart.pattern.pieces[0].perimeter)
    doc = ezdxf.readfile(export(octant_dart, tmp_path / "p.dxf", ExportOptions(units="m")))
    (ins,) = [e for e in doc.modelspace() if e.dxftype() == "INSERT"]
    sew = sum(polygon_perimeter(polyline_points(e)) for e in block_polylines(doc, ins.dxf.name, "14"))
    assert piece["sew_length"] * 1000 == pytest.approx(sew, rel=1e-9)
    assert piece["sew_length"] > piece["perimeter_outline"] * 1.05
