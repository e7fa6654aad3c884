"""The marker as a PDF and in the ply book (issue 43, item 4), read back with pypdf: the first page
states the marker's numbers and draws the roll at the round scale it states; the tiles cover the
marker's extent over the printable area and draw every placed copy's cut outline at 1:1 where the
tile's arithmetic says; the ply book's marker page has its numbers and its table of pieces;
``flatweave-cli nest --export MARKER.pdf`` writes one."""

from __future__ import annotations

import io
import json
import math
import re

import numpy as np
import pytest
from flatweave.cli import main
from flatweave.document.plybook import plybook_bytes
from flatweave.document.project import new_project
from flatweave.export.marker import MARKER_FORMATS, MarkerSource, marker_files, marker_pdf
from flatweave.export.pdf import MM, OVERLAP_MM, PAGE_MARGIN_MM, PAPERS, ROUND_SCALES, SHEET_MARGIN_MM
from flatweave.export.sheet import SheetPiece
from flatweave.reading.examples import load_example
from flatweave.studies.nesting import NestItem, nest
from pypdf import PdfReader
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

from tests.helpers import TINY_INSTANCE, ell, rectangle
from tests.pdf_paths import page_drawing

pytestmark = pytest.mark.slow

ROLL = 1000.0




@pytest.fixture(scope="module")
def marker():
    # small enough that many of their edges lie whole on one A4 tile
    items = [NestItem("panel", rectangle(150.0, 100.0), 3, 0.0, "grain"),
             NestItem("strip", rectangle(400.0, 60.0), 2, 0.0, "grain"),
             NestItem("ell", ell(120.0), 2, 0.0, "free"),
             NestItem("tab", rectangle(40.0, 30.0), 2, 0.0, "grain")]
    m = nest(items, ROLL, seconds=1, workers=1)
    sources = [MarkerSource("kit.json", k, SheetPiece(it.name, it.outline, None, grain=np.array([[0, 0], [1, 0]])))
               for k, it in enumerate(items)]
    return m, sources


@pytest.fixture(scope="module")
def reader(marker):
    m, sources = marker
    return PdfReader(io.BytesIO(marker_pdf(m, sources, "kit", "a4")))


def _round(k: float) -> bool:
    """k is 1, 2, 2.5, 5, 10, 20, 25 or 50 times a power of ten."""
    return any(math.isclose(k / s, 10.0 ** round(math.log10(k / s)), rel_tol=1e-9) for s in ROUND_SCALES)


def _grid(m):
    """(rows, cols, tile width, tile height, drawing height) of the 1:1 tiles, from the page's arithmetic."""
    pw, ph = PAPERS["a4"]
    cw, ch = pw - 2 * PAGE_MARGIN_MM, ph - 2 * PAGE_MARGIN_MM
    W, H = m.length + 2 * SHEET_MARGIN_MM, m.roll_width + 2 * SHEET_MARGIN_MM
    return (math.ceil((H - OVERLAP_MM) / (ch - OVERLAP_MM)), math.ceil((W - OVERLAP_MM) / (cw - OVERLAP_MM)),
            cw, ch, H)


def _window(r, col, cw, ch, H):
    """(x0, y0, x1, y1) of tile (r, col)'s window on the roll, mm."""
    x0 = col * (cw - OVERLAP_MM) - SHEET_MARGIN_MM
    y1 = H - r * (ch - OVERLAP_MM) - SHEET_MARGIN_MM
    return x0, y1 - ch, x0 + cw, y1


def test_the_first_page_states_the_marker_and_draws_it_at_a_round_scale(marker, reader):
    m, _ = marker
    page = reader.pages[0]
    text = page.extract_text()
    assert f"marker {m.length:.1f} mm long on a roll {ROLL:g} mm wide" in text
    assert f"utilisation {100 * m.utilisation:.2f} %" in text
    assert f"{len(m.placements)} pieces placed" in text
    for name in ("panel", "strip", "ell", "tab"):
        assert name in text.splitlines()  # each copy named inside it where its name fits
    k = float(re.search(r"scale 1:([\d.]+)", text).group(1))
    assert _round(k)
    # the roll used drawn at that scale, whole on the page
    rects, _, _ = page_drawing(page)
    w, h = m.length * MM / k, m.roll_width * MM / k
    roll = [r for r in rects if abs(r[2] - w) < 1e-3 and abs(r[3] - h) < 1e-3]
    assert len(roll) == 1
    x, y = roll[0][:2]
    assert 0 < x and x + w < float(page.mediabox.width) and 0 < y and y + h < float(page.mediabox.height)
    # the next larger round scale would not fit between the page's margins, the title and the scale bar
    if k > 1:
        larger = max(s for s in (k / 2.5, k / 2.0, k / 1.25) if _round(s))
        assert m.length * MM / larger > float(page.mediabox.width) - 2 * PAGE_MARGIN_MM * MM \
            or m.roll_width * MM / larger > float(page.mediabox.height) - 50.0 * MM


def test_the_tiles_cover_the_marker_over_the_printable_area(marker, reader):
    m, _ = marker
    rows, cols, cw, ch, H = _grid(m)
    region = unary_union([Polygon(o) for o in m.outlines()])
    printed = [(r, c) for r in range(rows) for c in range(cols) if region.intersects(box(*_window(r, c, cw, ch, H)))]
    assert len(reader.pages) == 2 + len(printed)  # the whole marker, the assembly map, then the tiles
    assert f"assembly map, {len(printed)} pages of a {rows} x {cols} grid" in reader.pages[1].extract_text()
    for k, page in enumerate(reader.pages[2:]):
        assert float(page.mediabox.width) == pytest.approx(210.0 * MM, abs=0.5)  # tiles are portrait A4
        assert f"(tile {k + 1} of {len(printed)})" in page.extract_text()


def test_the_tiles_draw_every_outline_at_full_size_where_the_tile_says(marker, reader):
    m, _ = marker
    rows, cols, cw, ch, H = _grid(m)
    checked = 0
    for page in reader.pages[2:]:
        found = re.search(r"row ([A-Z]+), column (\d+)", page.extract_text())
        r, col = ord(found.group(1)) - 65, int(found.group(2)) - 1
        x0, y0, x1, y1 = _window(r, col, cw, ch, H)
        _, segments, _ = page_drawing(page)
        drawn = np.array([[*a, *b] for a, b, clipped in segments if clipped])

        def on_page(q):  # roll mm -> page points: the tile's window starts at the printable area's corner
            return (PAGE_MARGIN_MM + q[0] - x0) * MM, (PAGE_MARGIN_MM + q[1] - y0) * MM

        for outline in m.outlines():
            for a, b in zip(outline, np.roll(outline, -1, axis=0)):
                if not all(x0 + 1 < q[0] < x1 - 1 and y0 + 1 < q[1] < y1 - 1 for q in (a, b)):
                    continue  # an edge cut by the tile's edge
                want = np.array([*on_page(a), *on_page(b)])
                err = np.minimum(np.abs(drawn - want).max(axis=1),
                                 np.abs(drawn - np.r_[want[2:], want[:2]]).max(axis=1))
                assert err.min() < 0.01, (r, col, a, b)
                checked += 1
    assert checked >= 20


def test_a_marker_pdf_without_tiles_and_through_marker_files(marker, tmp_path):
    m, sources = marker
    assert ".pdf" in MARKER_FORMATS
    one = PdfReader(io.BytesIO(marker_pdf(m, sources, "kit", "letter", tiled=False)))
    assert len(one.pages) == 1 and "utilisation" in one.pages[0].extract_text()
    [(path, data)] = marker_files(m, sources, tmp_path / "m.pdf", "kit")
    assert path == tmp_path / "m.pdf" and data.startswith(b"%PDF")


def test_the_ply_book_has_a_page_per_marker_with_its_numbers(marker):
    m, sources = marker
    project = new_project(load_example("octant"), "bare", "octant", spacing=0.1)
    plain = PdfReader(io.BytesIO(plybook_bytes(project)))
    book = PdfReader(io.BytesIO(plybook_bytes(project, markers=[("carbon", m, sources)])))
    assert len(book.pages) == len(plain.pages) + 1
    page = book.pages[-1]
    text = page.extract_text()
    lines = text.splitlines()
    assert lines[0] == "Marker: carbon"
    for want in (f"{ROLL:g} mm", f"{m.length:.1f} mm", f"{100 * m.utilisation:.2f} %", f"{m.waste / 1e6:.4f} m2",
                 str(len(m.placements))):
        assert want in lines, want
    # the table of pieces: name, copies, source, a cell a line
    cells = lines[lines.index("source") + 1:]
    table = [cells[k:k + 3] for k in range(0, 3 * len(m.items), 3)]
    assert [row[:2] for row in table] == [["panel", "3"], ["strip", "2"], ["ell", "2"], ["tab", "2"]]
    assert table[0][2] == "kit.json, piece 1"
    # the whole marker drawn at the scale the page states
    k = float(re.search(r"scale 1:([\d.]+) \(printed at 100 %\)", text).group(1))
    assert _round(k)
    rects, _, _ = page_drawing(page)
    assert any(abs(r[2] - m.length * MM / k) < 1e-3 and abs(r[3] - m.roll_width * MM / k) < 1e-3 for r in rects)


def test_nest_exports_a_marker_pdf(tmp_path, capsys):
    instance = TINY_INSTANCE
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(instance))
    out = tmp_path / "m.pdf"
    assert main(["nest", str(path), "--time-limit", "1", "--export", str(out), "--quiet"]) == 0
    book = PdfReader(str(out))
    assert len(book.pages) == 3  # a marker this small is one tile
    first = book.pages[0].extract_text()
    assert "on a roll 40 mm wide" in first and "5 pieces placed" in first and "scale 1:1" in first
    assert "-> " in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["nest", "--help"])
    assert ".pdf" in capsys.readouterr().out
