"""The ply book and the cut files of all pieces (issue 41, item 5;
flatweave.document.plybook, flatweave.document.cutfiles), read back with
third-party readers: pypdf (pages, the stacking table's text, the pattern
drawn at the scale the page states), ezdxf (a block per piece) and the
standard library's XML parser (an SVG per piece)."""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from pypdf import PdfReader

from flatweave.document.cutfiles import export_pieces, file_stem
from flatweave.document.pieces import pieces_of, with_pieces
from flatweave.document.plybook import BOOK_SCALES, book_order, book_rows, book_scale, write_ply_book
from flatweave.document.project import load_project
from flatweave.document.solving import solve_pieces
from flatweave.errors import FlatweaveError, SettingsError
from flatweave.export.pdf import MM
from flatweave.export.sheet import build_sheet
from flatweave.reading.registry import open_path
from tests.pdf_paths import page_drawing

HEAD = 'name = "test laminate"\nsource = "dome"\nunits = "m"\nspacing = 0.1\nmaterial = "carbon plain weave 200"\n' \
       '[rosette]\norigin = [0, 0, 0]\nzero = [1, 0, 0]\n'
PLY = '[[ply]]\nname = "{name}"\nsequence = {seq}\norientation = {o}\noffset = {off}\n' \
      'boundary = {{ uv = [[0.2, 0.2], [0.8, 0.2], [0.8, 0.8], [0.2, 0.8]] }}\n'


def _job(tmp_path) -> Path:
    # listed out of laying order: the book lays them by sequence
    body = PLY.format(name="P3 ninety", seq=3, o=90, off=-0.02) + PLY.format(name="P1", seq=1, o=0, off=0.0) \
        + PLY.format(name="P2/45", seq=2, o=45, off=-0.01) + PLY.format(name="P4 spare", seq=4, o=-45, off=-0.03)
    path = tmp_path / "lam.toml"
    path.write_text(HEAD + body)
    return path


@pytest.fixture(scope="module")
def laminate(tmp_path_factory):
    """Four plies, three solved (the fourth left unsolved on purpose)."""
    project = open_path(_job(tmp_path_factory.mktemp("job"))).project
    project, outcomes = solve_pieces(project, ["P1", "P2/45", "P3 ninety"], workers=1)
    assert all(o.result is not None for o in outcomes)
    return project


@pytest.fixture(scope="module")
def book(laminate, tmp_path_factory):
    path = tmp_path_factory.mktemp("book") / "book.pdf"
    write_ply_book(laminate, path)
    return PdfReader(str(path))


def _table(text: str) -> list[list[str]]:
    """The stacking table's rows as pypdf reads the cover: a cell a line, ten to a row."""
    lines = text.splitlines()
    cells = lines[lines.index("status") + 1:lines.index("Project checks")]
    assert len(cells) % 10 == 0
    return [cells[k:k + 10] for k in range(0, len(cells), 10)]


def test_the_stacking_table_lists_the_plies_in_laying_order(laminate, book):
    assert len(book.pages) == 1 + 4  # the cover, then a page per piece
    cover = book.pages[0].extract_text()
    table = _table(cover)
    assert [row[:2] for row in table] == [["1", "P1"], ["2", "P2/45"], ["3", "P3 ninety"], ["4", "P4 spare"]]
    assert [row[4] for row in table] == ["+0", "+45", "+90", "-45"]
    rows = {r.name: r for r in book_rows(laminate)}
    assert rows["P4 spare"].status == "not solved" and rows["P4 spare"].size_mm is None
    for cells in table[:3]:
        r = rows[cells[1]]
        assert cells[3] == "carbon plain weave 200" and cells[2] == "1"
        assert cells[5] == f"{r.size_mm[0]:.0f} x {r.size_mm[1]:.0f}"
        assert cells[6] == f"{r.area_m2:.3f}" and cells[7] == f"{r.max_shear_deg:.1f}"
        assert cells[9].startswith("converged")
    assert table[3][5:] == ["-", "-", "-", "-", "not solved"]
    assert "its fibres turn up to" in cover  # the project's checks follow the table


def test_the_flat_size_and_area_are_the_patterns(laminate):
    for row in book_rows(laminate):
        piece = next(p for p in laminate.pieces if p.name == row.name)
        if piece.result is None:
            continue
        xy = piece.result.pattern.outline * 1000.0  # m -> mm
        assert np.allclose(row.size_mm, np.ptp(xy, axis=0), rtol=1e-9)
        assert row.area_m2 == pytest.approx(piece.result.metrics["area_2d"], rel=1e-6)


def test_each_piece_page_draws_its_pattern_at_the_stated_scale(laminate, book):
    pages = {p.extract_text().split("\n")[0].strip(): p for p in book.pages[1:]}
    for piece in book_order(laminate):
        page = next(p for title, p in pages.items() if title.startswith(piece.name))
        text = page.extract_text()
        if piece.result is None:
            assert "no pattern: not solved" in text
            continue
        k = float(re.search(r"scale 1:([\d.]+) \(printed at 100 %\)", text).group(1))
        assert k in BOOK_SCALES or k / 10 ** round(np.log10(k) - 1) in BOOK_SCALES
        sheet = build_sheet(piece.result, "m", 0.0, piece.name)
        outer = sheet.pieces[0].outer
        want = np.linalg.norm(np.roll(outer, -1, axis=0) - outer, axis=1) * MM / k  # printed, points
        _, segments, _ = page_drawing(page)
        got = np.array([np.hypot(b[0] - a[0], b[1] - a[1]) for a, b, _ in segments])
        matched = np.min(np.abs(got[None, :] - want[:, None]), axis=1) < 1e-3
        assert matched.mean() > 0.98, (piece.name, matched.mean())
        # the overall dimensions are written, in mm
        w, h = np.ptp(outer, axis=0)
        assert f"{w:.0f} mm" in text and f"{h:.0f} mm" in text
        assert f"orientation {piece.settings.angle_deg:+g} deg" in text


@pytest.mark.parametrize("size, box, k", [
    ((1593.0, 1593.0), (186.0, 115.0), 20.0),  # a dome ply
    ((50.0, 20.0), (186.0, 115.0), 1.0),  # small: full size, never enlarged
    ((170.0, 10.0), (186.0, 115.0), 1.0),  # (the dimension lines take 9 mm)
    ((180.0, 10.0), (186.0, 115.0), 2.0),
    ((40000.0, 100.0), (186.0, 115.0), 250.0),
])
def test_the_scale_is_the_largest_round_one_that_fits(size, box, k):
    s = book_scale(size, box)
    assert s == pytest.approx(1.0 / k)
    assert size[0] * s <= box[0] and size[1] * s <= box[1]


def test_the_cut_files_are_one_dxf_of_blocks_and_a_file_per_piece(laminate, tmp_path):
    folder = tmp_path / "cut"
    paths, left = export_pieces(laminate, folder)
    assert left == ["P4 spare"]
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted(["test_laminate-pieces.dxf"] + [f"{file_stem(n)}{s}" for n in ("P1", "P2/45", "P3 ninety")
                                                          for s in (".svg", ".pdf")])
    assert sorted(p.name for p in paths) == names
    doc = ezdxf.readfile(folder / "test_laminate-pieces.dxf")
    blocks = {b.name for b in doc.blocks if not b.name.startswith("*")}
    assert {"P1", "P2_45", "P3_ninety"} <= blocks
    assert len(doc.modelspace().query("INSERT")) == 3
    svg = ET.parse(folder / "P2_45.svg").getroot()
    assert svg.get("width").endswith("mm")
    assert len(PdfReader(str(folder / "P1.pdf")).pages) >= 3  # overview, assembly map, tiles


def test_a_failed_export_writes_nothing(laminate, tmp_path):
    folder = tmp_path / "cut"

    def refuse():
        raise FlatweaveError("the project could not be saved")
    with pytest.raises(FlatweaveError, match="could not be saved"):
        export_pieces(laminate, folder, before_replace=refuse)
    assert not folder.exists()  # not even the folder made for them
    (tmp_path / "a file").write_text("")
    with pytest.raises(SettingsError, match="not a folder"):
        export_pieces(laminate, tmp_path / "a file")
    nothing = with_pieces(laminate, [replace(p, result=None) for p in pieces_of(laminate)], laminate.piece_index)
    with pytest.raises(SettingsError, match="no piece of the project is solved"):
        export_pieces(nothing, folder)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def test_solve_writes_the_project_the_ply_book_and_the_cut_files(tmp_path):
    job = _job(tmp_path)
    out, book, cut = tmp_path / "lam.flatweave", tmp_path / "book.pdf", tmp_path / "cut"
    p = _cli("solve", job, "--workers", "1", "--ply-book", book, "--export", cut, "--quiet")
    assert p.returncode == 0, p.stderr
    assert len(load_project(out).pieces) == 4
    assert len(PdfReader(str(book)).pages) == 5
    assert len(list(cut.glob("*.svg"))) == 4 and len(list(cut.glob("*.dxf"))) == 1


@pytest.mark.parametrize("args, says", [
    (["--ply-book", "book.txt"], "a ply book is a PDF"),
    (["--ply-book", "nowhere/book.pdf"], "does not exist"),
    (["--export", "lam.toml"], "is not a folder"),
    (["--export", "nowhere/cut"], "does not exist"),
])
def test_bad_outputs_are_refused_before_anything_is_solved(tmp_path, args, says):
    job = _job(tmp_path)
    p = subprocess.run([sys.executable, "-m", "flatweave", "solve", str(job), *args], capture_output=True, text=True,
                       timeout=600, cwd=tmp_path)
    assert p.returncode == 2 and says in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == ["lam.toml"]  # nothing written
