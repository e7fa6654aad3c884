"""A project's sources (issue 41, item 1): its pieces lie on one or more
surfaces (the faces of a CAD part, other files), each piece on its own,
shared by identity among the pieces on it. Saved as a list of sources (project
version 6; a version-5 file's one surface is its only source), solved each on
its own surface, judged, booked and refitted per surface; a job file's plies
name their source and face."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from flatweave.document import pieces as P
from flatweave.document.checks import project_checks
from flatweave.document.history import Document
from flatweave.document.plybook import plybook_bytes
from flatweave.document.project import (PROJECT_VERSION, load_project, new_project, project_problems,
                                        project_to_dict, save_project)
from flatweave.document.solving import solve_pieces
from flatweave.errors import SettingsError
from flatweave.geometry.nurbs import NurbsSurface
from flatweave.geometry.region import cover_for, region_from_spec
from flatweave.method.pipeline import flatten
from flatweave.method.settings import FlattenSettings
from flatweave.reading.examples import example_path, load_example
from flatweave.reading.registry import open_path

ROOT = Path(__file__).resolve().parent.parent
V5 = ROOT / "tests" / "data" / "projects" / "v5-octant-laminate-solved.flatweave"


@pytest.fixture(scope="module")
def two():
    """Two pieces on the octant and one on the half cylinder, the second octant piece active."""
    octant, cyl = load_example("octant"), load_example("half_cylinder")
    p = new_project(octant, "kit", str(example_path("octant")), spacing=0.12)
    p = P.rename(p, 0, "cap")
    p = P.duplicate(p, 0, "cap +45", angle_deg=45.0)
    region = region_from_spec(cyl, {"uv": [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]]})
    settings = FlattenSettings(spacing=0.1, region=region, seed=cover_for(cyl, region).default_seed)
    p = P.add(p, "side", settings, select_it=False, surface=cyl, source=str(example_path("half_cylinder")))
    return p


def test_pieces_lie_on_their_own_surfaces_and_selecting_one_shows_its_surface(two):
    octant = two.surface
    assert [q.name for q in two.pieces] == ["cap", "cap +45", "side"] and two.piece_name == "cap +45"
    side = two.pieces[2]
    assert side.surface is not octant and two.pieces[0].surface is octant
    assert [len(ks) for _, _, ks in P.sources_of(two)] == [2, 1]
    p = P.select(two, "side")
    assert p.surface is side.surface and p.source == side.source and p.settings is side.settings
    back = P.select(p, 0)
    assert back.surface is octant and back.pieces[2].surface is side.surface  # nothing moved surfaces
    with pytest.raises(SettingsError, match="its own settings"):
        P.add(two, "x", surface=side.surface)


def test_a_project_of_two_sources_saves_and_opens_bit_for_bit(two, tmp_path):
    solved, outcomes = solve_pieces(two, workers=1)
    assert [o.error for o in outcomes] == ["", "", ""]
    path = save_project(solved, tmp_path / "kit.flatweave")
    doc = json.loads(path.read_text())
    assert doc["version"] == PROJECT_VERSION >= 7 and len(doc["sources"]) == 2
    assert [q["source"] for q in doc["pieces"]] == [0, 0, 1]
    assert doc["sources"][1]["source"].endswith("half_cylinder.json")
    back = load_project(path)
    assert project_to_dict(back) == project_to_dict(solved)
    # the pieces on one source share its surface after opening, and every result is current on it
    ps = back.pieces
    assert ps[0].surface is ps[1].surface is back.surface and ps[2].surface is not back.surface
    for k in range(3):
        q = P.select(back, k)
        assert q.result_is_current and project_problems(q) == []


def test_each_piece_is_solved_on_its_own_surface_as_alone(two):
    solved, _ = solve_pieces(two, workers=2)
    for piece in solved.pieces:
        alone = flatten(piece.surface, piece.settings)
        assert piece.result.surface is piece.surface
        np.testing.assert_array_equal(piece.result.pattern.xy, alone.pattern.xy)
        np.testing.assert_array_equal(piece.result.uv, alone.uv)
    # the half cylinder is developable: its piece flattens exactly, which the octant's cannot
    side = solved.pieces[2].result.metrics
    assert abs(side["area_error_pct"]) < 0.05 and side["max_shear_deg"] < 0.5
    assert solved.pieces[0].result.metrics["max_shear_deg"] > 2.0


def test_checks_judge_each_piece_on_its_own_surface(two):
    """A region reaching u = 1.5 lies on a surface whose domain is [0, 2] x [0, 2] (the half cylinder's
    knots doubled), not on the octant's [0, 1] x [0, 1]: judged on its own surface, it is on it."""
    c = two.pieces[2].surface
    wide = NurbsSurface(c.degree_u, c.degree_v, 2.0 * c.knots_u, 2.0 * c.knots_v, c.ctrlpts, c.weights)
    box = {"uv": [[0.1, 0.1], [0.75, 0.1], [0.75, 0.75], [0.1, 0.75]]}  # fractions of the domain
    region = region_from_spec(wide, box)
    assert np.isclose(np.concatenate(region.loops).max(), 1.5)
    settings = FlattenSettings(spacing=0.1, region=region, seed=cover_for(wide, region).default_seed)
    p = P.add(two, "wide", settings, select_it=False, surface=wide, source="wide cylinder")
    assert not any("beyond" in w for w in project_checks(p))
    # the same region on the octant leaves its domain: said, naming the piece
    p = P.add(p, "off", settings, select_it=False)
    assert [w for w in project_checks(p) if "beyond" in w] == [
        "piece 'off' reaches beyond its surface: its region leaves the surface's domain"]


def test_the_ply_book_draws_each_piece_on_its_own_surface(two):
    solved, _ = solve_pieces(two, workers=1)
    pdf = PdfReader(io.BytesIO(plybook_bytes(solved)))
    assert len(pdf.pages) == 4
    text = pdf.pages[0].extract_text()
    assert all(name in text for name in ("cap", "cap +45", "side"))


def test_a_refit_moves_every_piece_on_that_source_and_no_other(two):
    doc = Document(two)
    octant = two.surface
    twin = load_example("octant")  # the same surface anew: what a refit of the same (u, v) map gives
    doc.refit_surface("Refit", twin)
    p = doc.project
    assert p.surface is twin and p.pieces[0].surface is twin and p.pieces[1].surface is twin
    assert p.pieces[2].surface is two.pieces[2].surface
    doc.undo()
    assert doc.project.surface is octant and doc.project.pieces[0].surface is octant


def test_solve_all_results_attach_to_the_pieces_on_their_surfaces(two):
    doc = Document(two)
    solved, _ = solve_pieces(two, workers=1)
    taken = doc.attach_results({q.name: q.result for q in solved.pieces}, two)
    assert taken == ["cap", "cap +45", "side"]
    assert all(P.select(doc.project, k).result_is_current for k in range(3))


def test_the_version_5_laminate_opens_on_its_one_source():
    raw = json.loads(V5.read_text())
    assert raw["version"] == 5 and "sources" not in raw
    p = load_project(V5)
    assert [q.name for q in p.pieces] == ["ply 1", "ply 2", "ply 3"] and p.piece_name == "ply 2"
    assert all(q.surface is p.surface for q in p.pieces) and p.source == raw["source"]
    assert [q.orientation for q in p.pieces] == [0.0, 45.0, 90.0] and p.rosettes[0].name == "rosette 1"
    assert [q.sequence for q in p.pieces] == [1, 2, 3] and p.pieces[2].quantity == 2
    for k in (0, 1):
        q = P.select(p, k)
        assert q.result_is_current and q.result.mesh.n_nodes == raw["pieces"][k]["result"]["metrics"]["nodes"]
        np.testing.assert_allclose(q.result.pattern.xy, raw["pieces"][k]["result"]["nodes"]["xy"], atol=1e-9)
    assert p.pieces[2].result is None
    doc = project_to_dict(p)
    assert doc["sources"] == [{"source": raw["source"], "surface": raw["surface"]}]


JOB = '''source = "octant"
spacing = 0.12
material = "garment woven"
[rosette]
origin = [0, 0, 1]
zero = [1, 0, 0]
[[ply]]
name = "top"
[[ply]]
name = "top 2"
orientation = 45
[[ply]]
name = "wall"
source = "half_cylinder"
spacing = 0.1
boundary = { uv = [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.9]] }
'''


def test_a_jobs_plies_name_their_source_each_opened_once(tmp_path):
    path = tmp_path / "kit.toml"
    path.write_text(JOB)
    p = open_path(path).project
    top, top2, wall = p.pieces
    assert top.surface is top2.surface is p.surface and wall.surface is not top.surface
    assert wall.source == "half_cylinder" and top.source == "octant"
    assert len(P.sources_of(p)) == 2
    assert cover_for(wall.surface, wall.settings.region).contains(np.array([wall.settings.seed])).all()


def test_a_ply_on_a_source_that_is_not_there_is_one_line_naming_its_line(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(JOB.replace('source = "half_cylinder"', 'source = "nowhere.step"'))
    with pytest.raises(SettingsError, match=re.escape("ply 'wall': source 'nowhere.step'")) as exc:
        open_path(path)
    assert str(exc.value).startswith(f"{path}:12: ") and "\n" not in str(exc.value)
