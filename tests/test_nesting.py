"""The cut plan's nesting (issue 43): pieces on a roll by sparrow (spyrrow), their grain kept, the gap
kept, the marker read back from its DXF by ezdxf and checked with shapely, the CSV's placements mapping
each piece's pattern outline onto the marker."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import threading

import ezdxf
import numpy as np
import pytest
from flatweave.cli import main
from flatweave.document.project import load_project, new_project, save_project
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.studies.nesting import NestItem, marker_problems, nest
from pypdf import PdfReader
from shapely import STRtree
from shapely.geometry import Polygon

from tests.helpers import TINY_INSTANCE, ell, rectangle, solved_kit

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def boxes():
    items = [NestItem(f"box {k}", rectangle(300.0 + 40 * k, 200.0), 2, 90.0, "grain") for k in range(4)]
    return items, nest(items, 1000.0, seconds=1, workers=1)


def test_every_copy_is_placed_on_the_roll_without_overlap(boxes):
    items, marker = boxes
    assert marker_problems(marker) == []
    assert len(marker.placements) == 8 and marker.length > 0
    area = sum(it.area * it.quantity for it in items)
    assert marker.pieces_area == pytest.approx(area, rel=1e-12)
    assert marker.utilisation == pytest.approx(area / (marker.length * 1000.0), rel=1e-12)
    assert marker.waste == pytest.approx(marker.length * 1000.0 - area, rel=1e-9)
    # no marker is shorter than the pieces' area over the roll's width, nor than the longest piece's length
    assert marker.length >= area / 1000.0 and marker.length >= 200.0


def test_a_woven_piece_keeps_its_grain_along_the_roll(boxes):
    """The boxes' warp runs along +y in their frame (grain 90 degrees): placed, it runs along the roll (x),
    either way (0 or 180 degrees)."""
    items, marker = boxes
    for p in marker.placements:
        along = (p.rotation_deg + items[p.item].grain_deg) % 180.0
        assert min(along, 180.0 - along) < 1e-9, p


def test_the_gap_is_kept_and_free_pieces_may_turn():
    items = [NestItem("ell", ell(240.0), 5, 0.0, "free"), NestItem("bar", rectangle(400.0, 60.0), 3, 0.0, "free")]
    marker = nest(items, 600.0, gap=8.0, seconds=1, workers=1)
    assert marker_problems(marker) == []  # with the gap: no two nearer than 8 mm
    polys = [Polygon(o) for o in marker.outlines()]
    nearest = min(polys[i].distance(polys[j]) for i in range(len(polys)) for j in range(i + 1, len(polys)))
    assert nearest >= 8.0 - 1e-6


def test_a_stop_keeps_the_best_marker_so_far():
    items = [NestItem(f"p{k}", ell(100.0 + 10 * k), 6, 0.0, "free") for k in range(6)]
    stop = threading.Event()
    seen = []

    def progress(marker):
        seen.append(marker)
        stop.set()

    marker = nest(items, 500.0, seconds=60, workers=1, on_progress=progress, stop=stop, early=False)
    assert marker.stopped and seen and marker.length == seen[-1].length
    assert marker.seconds < 30.0  # not the minute asked: stopped at the first marker
    assert marker_problems(marker) == []


def test_mirror_pairs_place_half_the_copies_reflected_with_their_grain_along_the_roll():
    """An L (not its own mirror image) cut in mirror pairs: of 5 copies, the last 2 reflected. A reflected
    copy's outline is the L's mirror image (congruent to the L with x negated, not to the L itself), its
    warp still along the roll; an odd piece out and a piece not in pairs stay as drawn."""
    items = [NestItem("ell", ell(240.0), 5, 30.0, "grain", mirror=True),
             NestItem("odd", ell(120.0), 1, 90.0, "grain", mirror=True),
             NestItem("plain", ell(150.0), 2, 90.0, "grain")]
    marker = nest(items, 800.0, gap=3.0, seconds=1, workers=1)
    assert marker_problems(marker) == []
    flags = sorted((items[p.item].name, p.copy, p.mirrored) for p in marker.placements)
    assert flags == [("ell", 0, False), ("ell", 1, False), ("ell", 2, False), ("ell", 3, True), ("ell", 4, True),
                     ("odd", 0, False), ("plain", 0, False), ("plain", 1, False)]
    ell_area = Polygon(ell(240.0)).area
    for p, outline in zip(marker.placements, marker.outlines()):
        it = items[p.item]
        g = math.radians(it.grain_deg)
        warp = p.place(np.array([[0.0, 0.0], [math.cos(g), math.sin(g)]]))
        d = warp[1] - warp[0]
        assert abs(d[1]) < 1e-9, (it.name, p)  # the warp along the roll, either way
        if it.name != "ell":
            continue
        # signed area: a reflection turns the outline's winding, a rotation does not
        signed = 0.5 * float(np.sum(outline[:, 0] * np.roll(outline[:, 1], -1) - outline[:, 1] *
                                    np.roll(outline[:, 0], -1)))
        assert abs(abs(signed) - ell_area) < 1e-6 * ell_area
        assert (signed < 0) == p.mirrored
    # a marker that claims a pair's copy as drawn is refused by the check
    bad = marker.placements[0]
    wrong = dataclasses.replace(marker, placements=(dataclasses.replace(bad, mirrored=not bad.mirrored),)
                                + marker.placements[1:])
    assert any("its pair asks otherwise" in line for line in marker_problems(wrong))


@pytest.mark.parametrize("kw, says", [
    ({"roll_width": 100.0}, "wider than the roll"),
    ({"roll_width": -5.0}, "positive length"),
    ({"roll_width": 1000.0, "gap": float("nan")}, "gap"),
    ({"roll_width": 1000.0, "seconds": 0.0}, "time limit"),
])
def test_bad_nesting_input_is_one_line(kw, says):
    with pytest.raises(SettingsError, match=says) as info:
        nest([NestItem("wide", rectangle(300.0, 200.0), 1, 0.0, "grain")], **kw)
    assert "\n" not in str(info.value)
    with pytest.raises(SettingsError, match="no piece"):
        nest([], 1000.0)


# ---------------------------------------------------------------------- the command, on a project
def status(argv) -> int:
    """The command's exit status (an option argparse refuses exits from inside it)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.fixture(scope="module")
def kit(tmp_path_factory):
    """tests.helpers.solved_kit, saved."""
    folder = tmp_path_factory.mktemp("kit")
    p = solved_kit()
    return save_project(p, folder / "kit.flatweave")


def _dxf_marker(path):
    """The marker read back from its DXF by ezdxf alone: per INSERT (a copy), its block's cut line (layer
    1) and grain line (layer 7) in world coordinates, and the roll's length and width (layer 15 lines)."""
    doc = ezdxf.readfile(path)
    copies, roll = [], []
    for e in doc.modelspace():
        if e.dxftype() == "INSERT":
            cut = grain = None
            for v in e.virtual_entities():
                if v.dxf.layer == "1" and v.dxftype() == "POLYLINE":
                    cut = np.array([(q[0], q[1]) for q in v.points()])
                elif v.dxf.layer == "7" and v.dxftype() == "LINE":
                    grain = np.array([(v.dxf.start.x, v.dxf.start.y), (v.dxf.end.x, v.dxf.end.y)])
            copies.append((e.dxf.name, cut, grain))
        elif e.dxftype() == "LINE" and e.dxf.layer == "15":
            roll.append(((e.dxf.start.x, e.dxf.start.y), (e.dxf.end.x, e.dxf.end.y)))
    ends = np.array([q for line in roll for q in line])
    return copies, float(ends[:, 0].max()), float(ends[:, 1].max())


def test_nest_places_a_projects_pieces_and_its_files_agree(kit, tmp_path, capsys):
    dxf, table = tmp_path / "m.dxf", tmp_path / "m.csv"
    code = main(["nest", f"{kit}:2", "--roll-width", "2500", "--gap", "5", "--time-limit", "1",
                 "--export", str(dxf), "--export", str(table), "--quiet"])
    assert code == 0
    err = capsys.readouterr().err
    # two materials (woven, isotropic): a marker each, written as NAME-MATERIAL.EXT
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["m-isotropic.csv", "m-isotropic.dxf", "m-woven.csv", "m-woven.dxf"], files
    assert "utilisation" in err and "marker" in err
    project = load_project(kit)
    outlines = {p.name: p.result.pattern.pieces for p in project.pieces}
    for material, copies_expected in (("woven", (2 + 2) * 2), ("isotropic", 2)):  # a duplicate keeps its quantity
        copies, length, width = _dxf_marker(tmp_path / f"m-{material}.dxf")
        assert width == pytest.approx(2500.0) and len(copies) == copies_expected
        polys = [Polygon(c) for _, c, _ in copies]
        for poly in polys:  # on the roll
            x0, y0, x1, y1 = poly.bounds
            assert x0 >= -1e-6 and y0 >= -1e-6 and y1 <= 2500.0 + 1e-6 and x1 <= length + 1e-6
        tree = STRtree(polys)
        for i, j in zip(*tree.query(polys, predicate="dwithin", distance=5.0 - 1e-3)):
            assert i == j, "two pieces nearer than the 5 mm gap"
        if material == "woven":  # the grain (the warp) along the roll
            for _, _, grain in copies:
                d = grain[1] - grain[0]
                assert abs(d[1]) <= 1e-6 * abs(d[0])
        # each CSV row maps its pattern outline (mm, no allowance: the cut line) onto a copy of the DXF
        rows = list(csv.DictReader((tmp_path / f"m-{material}.csv").read_text().splitlines()))
        assert len(rows) == copies_expected
        for row in rows:
            piece = row["source"].split("#", 1)[1]
            outline = np.asarray(outlines[piece][int(row["piece"])].outline) * 1000.0
            a = math.radians(float(row["rotation_deg"]))
            c, s = math.cos(a), math.sin(a)
            placed = np.column_stack([c * outline[:, 0] - s * outline[:, 1] + float(row["x"]),
                                      s * outline[:, 0] + c * outline[:, 1] + float(row["y"])])
            best = min(Polygon(placed).symmetric_difference(p).area / p.area for p in polys)
            assert best < 1e-6


def test_nest_mirror_cuts_a_piece_in_pairs_in_every_file(kit, tmp_path, capsys):
    """--mirror cap: of its 2 copies 1 is reflected: the CSV says so, the DXF inserts a block of their own
    ("... mirrored") drawn reflected, and each CSV row (its outline reflected first when mirrored) lands on
    a DXF copy; a name no piece has is one line, nothing written."""
    dxf, table = tmp_path / "m.dxf", tmp_path / "m.csv"
    assert main(["nest", str(kit), "--roll-width", "2500", "--time-limit", "1", "--rotations", "grain",
                 "--mirror", "cap", "--export", str(dxf), "--export", str(table), "--quiet"]) == 0
    rows = list(csv.DictReader((tmp_path / "m-woven.csv").read_text().splitlines()))
    cap = [r for r in rows if r["name"] == "cap"]
    assert sorted(r["mirrored"] for r in cap) == ["false", "true"]
    assert all(r["mirrored"] == "false" for r in rows if r["name"] != "cap")
    copies, _, _ = _dxf_marker(tmp_path / "m-woven.dxf")
    assert sorted(name for name, _, _ in copies) == ["cap", "cap_45", "cap_45", "cap_mirrored"]
    polys = [Polygon(c) for _, c, _ in copies]
    outlines = {p.name: p.result.pattern.pieces for p in load_project(kit).pieces}
    for row in rows:
        outline = np.asarray(outlines[row["source"].split("#", 1)[1]][int(row["piece"])].outline) * 1000.0
        if row["mirrored"] == "true":
            outline = outline * np.array([-1.0, 1.0])
        a = math.radians(float(row["rotation_deg"]))
        c, s = math.cos(a), math.sin(a)
        placed = np.column_stack([c * outline[:, 0] - s * outline[:, 1] + float(row["x"]),
                                  s * outline[:, 0] + c * outline[:, 1] + float(row["y"])])
        assert min(Polygon(placed).symmetric_difference(p).area / p.area for p in polys) < 1e-6
    capsys.readouterr()
    assert status(["nest", str(kit), "--roll-width", "2500", "--mirror", "hat",
                   "--export", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--mirror 'hat'" in err[0] and not (tmp_path / "x.csv").exists()


def test_a_roll_narrower_than_a_splice_and_bad_options_write_nothing(kit, tmp_path, capsys):
    out = tmp_path / "m.dxf"
    refusals = ((["--roll-width", "20"], "not wider than the splice overlap"),
                (["--roll-width", "2500", "--gap", "-1"], "--gap"), (["--roll-width", "0"], "--roll-width"),
                ([], "roll's width"))
    for args, says in refusals:
        assert status(["nest", str(kit), "--time-limit", "1", "--export", str(out), *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err
        assert not out.exists()
    fresh = save_project(new_project(load_example("octant"), "bare", "octant", spacing=0.1), tmp_path / "b.flatweave")
    assert main(["nest", str(fresh), "--roll-width", "2500", "--export", str(out)]) == 2
    assert "no piece is solved" in capsys.readouterr().err and not out.exists()


def test_nest_reads_a_nesting_instance(tmp_path, capsys):
    """A nesting instance in sparrow's JSON (the ESICUP sets' form): its strip height is the roll's width."""
    instance = TINY_INSTANCE
    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(instance))
    table = tmp_path / "tiny.csv"
    assert main(["nest", str(path), "--time-limit", "1", "--export", str(table), "--quiet"]) == 0
    rows = list(csv.DictReader(table.read_text().splitlines()))
    assert len(rows) == 5 and {r["source"] for r in rows} == {"tiny.json"}
    assert all(float(r["rotation_deg"]) % 180.0 == pytest.approx(0.0, abs=1e-9) for r in rows if r["piece"] == "0")
    assert "on a roll 40 mm wide" in capsys.readouterr().err


def test_nest_writes_the_projects_ply_book_with_its_markers(kit, tmp_path, capsys):
    book, pdf = tmp_path / "book.pdf", tmp_path / "m.pdf"
    assert main(["nest", str(kit), "--roll-width", "2500", "--time-limit", "1", "--ply-book", str(book),
                 "--paper", "letter", "--export", str(pdf), "--quiet"]) == 0
    # --paper: the book's and the marker's pages are US letter (612 x 792 points), either way up
    for path in (book, tmp_path / "m-woven.pdf"):
        sizes = {tuple(sorted((round(float(p.mediabox.width)), round(float(p.mediabox.height)))))
                 for p in PdfReader(path).pages}
        assert sizes == {(612, 792)}, (path.name, sizes)
    pages = [p.extract_text() for p in PdfReader(book).pages]
    markers = [t for t in pages if t.startswith("Marker:")]
    assert [t.splitlines()[0] for t in markers] == ["Marker: woven", "Marker: isotropic"]
    assert all("utilisation" in t and "2500 mm" in t for t in markers)
    capsys.readouterr()
    instance = tmp_path / "i.json"
    instance.write_text(json.dumps({"strip_height": 40.0, "items": [
        {"id": 0, "demand": 1, "allowed_orientations": [0.0], "shape": {"data": [[0, 0], [5, 0], [5, 5], [0, 5]]}}]}))
    assert status(["nest", str(instance), "--ply-book", str(tmp_path / "b2.pdf")]) == 2
    assert "ply book of one project" in capsys.readouterr().err and not (tmp_path / "b2.pdf").exists()
