"""Exports that could surprise say so first, and what the PDF overview and the DXF
header state is true: read back with pypdf (pages, text and where it is drawn) and
ezdxf (entities and their extents, ``ezdxf.bbox``)."""

import re
import time

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.reading.examples import load_example
from flatweave.export.registry import MAX_QUIET_PAGES, ExportOptions, export, surprises
from flatweave.export.sheet import build_sheet
from flatweave.export.pdf import page_count
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.geometry.surface_json import save_surface

POINTS_PER_MM = 72 / 25.4


def scaled(surface: NurbsSurface, k: float) -> NurbsSurface:
    return NurbsSurface(surface.degree_u, surface.degree_v, surface.knots_u, surface.knots_v,
                        surface.ctrlpts * k, surface.weights)


@pytest.fixture(scope="module")
def octant():
    """The octant of the unit sphere: a 1.6 m piece in metres, 54 A4 pages."""
    return flatten(load_example("octant"), FlattenSettings(spacing=0.1))


@pytest.fixture(scope="module")
def big():
    """The octant of a sphere of radius 4: a 6.3 m piece in metres."""
    return flatten(scaled(load_example("octant"), 4.0), FlattenSettings(spacing=0.4))


def pages(path) -> int:
    from pypdf import PdfReader

    return len(PdfReader(path).pages)


# ---------------------------------------------------------------- page count and surprises
@pytest.mark.slow
@pytest.mark.parametrize("units, paper", [("m", "a4"), ("m", "letter"), ("cm", "a4"), ("in", "letter")])
def test_the_page_count_is_the_written_pdfs(tmp_path, octant, octant_cut, units, paper):
    for result in (octant, octant_cut):
        options = ExportOptions(units=units, paper=paper)
        written = pages(export(result, tmp_path / "p.pdf", options))
        assert page_count(build_sheet(result, units, options.seam_allowance_mm), paper) == written


@pytest.mark.slow
def test_a_pdf_of_many_pages_is_a_surprise_naming_the_pages_and_units(tmp_path, octant):
    path = export(octant, tmp_path / "octant.pdf")
    n = pages(path)
    assert n > MAX_QUIET_PAGES
    (found,) = surprises(octant, [path, tmp_path / "octant.obj"], ExportOptions())
    assert found.files == (path,)
    w, h = build_sheet(octant, "m", 10.0).size
    assert f"{n} pages" in found.text and "units m" in found.text and f"{w / 1e3:.2f} x {h / 1e3:.2f} m" in found.text
    assert found.line().startswith("octant.pdf: the PDF will have")
    # the same piece in cm is a few pages, and a DXF of a 1.6 m piece no surprise
    assert surprises(octant, [tmp_path / "octant.pdf"], ExportOptions(units="cm")) == []
    assert surprises(octant, [tmp_path / "octant.dxf", tmp_path / "octant.svg"], ExportOptions()) == []


def test_a_piece_larger_than_5_m_is_a_surprise_in_every_2d_file(tmp_path, big):
    import ezdxf

    dxf = export(big, tmp_path / "big.dxf")
    (found,) = surprises(big, [dxf, tmp_path / "big.svg", tmp_path / "big.vtp"], ExportOptions())
    assert [p.name for p in found.files] == ["big.dxf", "big.svg"] and "units m" in found.text
    # the size stated is the cut line's, as ezdxf reads it
    doc = ezdxf.readfile(dxf)
    (block,) = [b for b in doc.blocks if not b.name.startswith("*")]
    (cut,) = [e for e in block if e.dxftype() == "POLYLINE" and e.dxf.layer == "1"]
    w, h = np.ptp(np.array([tuple(v.dxf.location)[:2] for v in cut.vertices]), axis=0) / 1000
    assert max(w, h) > 5
    assert re.search(r"piece is (\S+) x (\S+) m", found.text).groups() == (f"{w:.2f}", f"{h:.2f}")
    assert surprises(big, [dxf], ExportOptions(units="mm")) == []
    # with a PDF, the PDF's surprise says the size; the DXF gets its own
    both = surprises(big, [tmp_path / "big.pdf", dxf], ExportOptions())
    assert [[p.name for p in s.files] for s in both] == [["big.pdf"], ["big.dxf"]]


def test_the_page_count_of_a_huge_pdf_is_cheap():
    """A 52 m piece: tens of thousands of pages, counted without drawing one (about 0.15 s
    here; the bound leaves room for a loaded machine; writing them would take many minutes)."""
    huge = flatten(scaled(load_example("octant"), 33.0), FlattenSettings(spacing=3.3))
    t = time.perf_counter()
    (found,) = surprises(huge, ["huge.pdf"], ExportOptions())
    seconds = time.perf_counter() - t
    n = int(re.search(r"have ([\d,]+) pages", found.text).group(1).replace(",", ""))
    assert n > 10_000 and seconds < 5.0


@pytest.mark.slow
def test_the_cli_warns_before_writing_and_still_writes(tmp_path, capsys):
    pdf = tmp_path / "octant.pdf"
    assert main(["flatten", "octant", "--spacing", "0.1", "--export", str(pdf)]) == 0
    err = capsys.readouterr().err.splitlines()
    warnings = [k for k, line in enumerate(err) if line.startswith("flatweave: warning: octant.pdf:")]
    assert len(warnings) == 1
    line = err[warnings[0]]
    assert f"{pages(pdf)} pages" in line and "units m" in line and "--units" in line
    written = [k for k, line in enumerate(err) if f"-> {pdf}" in line]
    assert written and warnings[0] < written[0]  # said before the summary of what was written
    # in cm the piece is 40 mm: a few pages, no warning
    assert main(["flatten", "octant", "--spacing", "0.1", "--units", "cm", "--export", str(pdf), "--quiet"]) == 0
    assert "octant.pdf:" not in capsys.readouterr().err and pages(pdf) < MAX_QUIET_PAGES


def test_the_cli_warns_of_a_surface_taken_as_metres(tmp_path, capsys):
    """A 6 m surface file without units, exported to DXF: warned, written, exit 0."""
    surface = tmp_path / "big.json"
    save_surface(scaled(load_example("octant"), 4.0), surface)
    dxf = tmp_path / "big.dxf"
    assert main(["flatten", str(surface), "--spacing", "0.4", "--export", str(dxf), "--quiet"]) == 0
    (line,) = [w for w in capsys.readouterr().err.splitlines() if "big.dxf" in w]
    assert line.startswith("flatweave: warning: big.dxf: the piece is") and "units m" in line and "--units" in line
    assert dxf.stat().st_size > 0


# ---------------------------------------------------------------- the PDF's scaled pages
def text_runs(page):
    """Every string shown on a page: (text, baseline start, box in points), the box from
    the text and current matrices and the standard font's metrics."""
    from reportlab.pdfbase.pdfmetrics import getAscentDescent, stringWidth

    runs = []

    def visit(text, cm, tm, font_dict, font_size):
        if not text.strip():
            return
        text = text.strip("\n")
        font = str(font_dict["/BaseFont"])[1:]
        T = np.array([[tm[0], tm[1], 0], [tm[2], tm[3], 0], [tm[4], tm[5], 1]]) @ \
            np.array([[cm[0], cm[1], 0], [cm[2], cm[3], 0], [cm[4], cm[5], 1]])
        ascent, descent = getAscentDescent(font, font_size)
        w = stringWidth(text, font, font_size)
        corners = np.array([[0, descent, 1], [w, descent, 1], [w, ascent, 1], [0, ascent, 1]]) @ T
        runs.append((text, (np.array([0, 0, 1]) @ T)[:2], corners[:, :2]))

    page.extract_text(visitor_text=visit)
    return runs


def drawn_faces(page):
    """The areas the page's stroked paths enclose (the pieces' outlines), rectangles
    (test square, tile grid) left out."""
    from shapely.geometry import LineString
    from shapely.ops import polygonize, unary_union

    from tests.pdf_paths import page_drawing

    rects, segments, _ = page_drawing(page)
    edges = unary_union([LineString([(x, y), (x + w, y), (x + w, y + h), (x, y + h), (x, y)])
                         for x, y, w, h in rects]).buffer(0.01)
    lines = [LineString([a, b]) for a, b, _ in segments if a != b]
    lines = [g for g in lines if not g.within(edges)]
    return unary_union(list(polygonize(unary_union(lines))))


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["octant", "octant_cut"])
@pytest.mark.parametrize("units", ["m", "cm", "mm"])
def test_overview_names_lie_whole_inside_their_pieces_on_the_page(tmp_path, fixture, units, request):
    """The overview and the assembly map write each piece's name inside the piece as drawn,
    on the page; a label placed for 1:1 used to put it off the page ("ta" of "octant")."""
    from pypdf import PdfReader
    from shapely.geometry import Polygon

    result = request.getfixturevalue(fixture)
    options = ExportOptions(units=units, name="octant")
    reader = PdfReader(export(result, tmp_path / "p.pdf", options))
    names = [p.name for p in build_sheet(result, units, options.seam_allowance_mm, "octant").pieces]
    for k in (0, 1):
        page = reader.pages[k]
        box = page.mediabox
        runs = text_runs(page)
        for text, _, corners in runs:  # nothing written off the page
            assert corners[:, 0].min() >= 0 and corners[:, 0].max() <= float(box.width), text
            assert corners[:, 1].min() >= 0 and corners[:, 1].max() <= float(box.height), text
        faces = drawn_faces(page)
        for name in names:
            (corners,) = [c for text, _, c in runs if text == name]
            assert Polygon(corners).within(faces.buffer(0.01)), f"page {k + 1}: {name!r} is not inside its piece"
        assert all(name in page.extract_text().splitlines() for name in names)


@pytest.mark.slow
@pytest.mark.parametrize("units", ["m", "cm", "mm"])
def test_the_overview_states_its_scale_once_and_truly(tmp_path, octant, units):
    from pypdf import PdfReader

    from tests.pdf_paths import page_drawing

    page = PdfReader(export(octant, tmp_path / "p.pdf", ExportOptions(units=units))).pages[0]
    text = page.extract_text()
    assert "not to scale" not in text
    (statement,) = re.findall(r"scale \S+", text)
    m = re.search(r"([\d.]+) mm +scale (?:1:([\d.]+)|([\d.]+):1)", text)
    bar_mm = float(m.group(1))
    stated = 1 / float(m.group(2)) if m.group(2) else float(m.group(3))  # printed mm per mm
    # the scale bar as drawn: the horizontal line that ends just left of the statement, a little above it
    (origin,) = [o for t, o, _ in text_runs(page) if statement in t]
    _, segments, _ = page_drawing(page)
    bar = [(a, b) for a, b, _ in segments if abs(a[1] - b[1]) < 1e-6 and 0 < a[1] - origin[1] < 2 * POINTS_PER_MM
           and 0 < origin[0] - max(a[0], b[0]) < 4 * POINTS_PER_MM]
    (a, b), = bar
    measured = abs(b[0] - a[0]) / POINTS_PER_MM / bar_mm
    assert measured == pytest.approx(stated, rel=5e-3)
    assert (units == "m") == (m.group(2) is not None)  # 1.6 m is reduced, 60 and 28 mm are enlarged


# ---------------------------------------------------------------- the DXF's extents
@pytest.mark.parametrize("variant", ["astm", "layered"])
@pytest.mark.parametrize("units", ["m", "cm"])
def test_dxf_extents_are_the_drawings(tmp_path, octant, variant, units):
    """$EXTMIN / $EXTMAX bound exactly what ezdxf finds drawn: the piece, its label (which
    stands out of the 60 mm piece in cm) and, in ASTM files, the style text below."""
    import ezdxf
    from ezdxf import bbox

    path = export(octant, tmp_path / "p.dxf", ExportOptions(units=units, dxf_variant=variant))
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    found = bbox.extents(msp)
    assert tuple(doc.header["$EXTMIN"])[:2] == pytest.approx(tuple(found.extmin)[:2], abs=1e-3)
    assert tuple(doc.header["$EXTMAX"])[:2] == pytest.approx(tuple(found.extmax)[:2], abs=1e-3)
    if variant == "astm":  # the style text lies below every piece and its label
        style = bbox.extents(e for e in msp if e.dxftype() == "TEXT")
        pieces = bbox.extents(e for e in msp if e.dxftype() == "INSERT")
        assert style.extmax.y < pieces.extmin.y
