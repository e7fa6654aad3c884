"""The cut plan kept in the project (issue 43, project version 8): the nesting's settings, the splices
placed by hand and the pieces cut in mirror pairs are saved and read back, go with a piece renamed or
removed, and are what ``nest`` uses on the project when no option says otherwise; a version-7 file opens
nesting as made."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import ezdxf

import numpy as np
import pytest
from shapely.geometry import Polygon

from flatweave.cli import main
from flatweave.document import pieces as P
from flatweave.document.cutsettings import CutPlanSettings
from flatweave.document.project import (PROJECT_VERSION, load_project, new_project, project_to_dict,
                                        save_project)
from flatweave.document.solving import solve_pieces
from flatweave.errors import SettingsError
from flatweave.method.lattice import MATERIALS
from flatweave.method.settings import FlattenSettings
from flatweave.reading.examples import load_example

from tests.helpers import assert_refused_in_one_line

OLD = Path(__file__).parent / "data" / "projects"


@pytest.fixture(scope="module")
def kit():
    """Two solved pieces: the woven octant "cap" (2 copies) and the isotropic half cylinder "side"."""
    p = new_project(load_example("octant"), "kit", "octant", spacing=0.1)
    p = P.set_quantity(P.rename(p, 0, "cap"), 0, 2)
    p = P.add(p, "side", FlattenSettings(spacing=0.1, material=MATERIALS["isotropic"]),
              surface=load_example("half_cylinder"), source="half_cylinder")
    p, _ = solve_pieces(p, workers=1)
    return p


def test_a_cut_plan_is_saved_and_read_back(kit, tmp_path):
    plan = CutPlanSettings(roll_widths=(("woven", 1270.0),), gap_mm=4.0, seconds=5.0, allowance_mm=10.0,
                           overlap_mm=30.0, rotations="one-way", splices=(("cap", (400.0, 800.0)),), mirror=("cap",))
    path = save_project(replace(kit, cut_plan=plan), tmp_path / "k.flatweave")
    doc = json.loads(path.read_text())
    assert doc["version"] == PROJECT_VERSION == 8
    assert doc["cut_plan"]["splices"] == [{"piece": "cap", "mm": [400.0, 800.0]}]
    back = load_project(path)
    assert back.cut_plan == plan and back.cut_plan.width_for("woven") == 1270.0
    assert back.cut_plan.width_for("isotropic") is None and back.cut_plan.mirrored("cap")
    assert project_to_dict(back) == project_to_dict(load_project(save_project(back, tmp_path / "again.flatweave")))
    # as made, the file holds no cut plan at all
    assert "cut_plan" not in json.loads(save_project(kit, tmp_path / "bare.flatweave").read_text())


def test_a_version_7_project_opens_nesting_as_made():
    p = load_project(OLD / "v7-sleeve-two-panels-solved.flatweave")
    assert p.cut_plan.is_default
    assert [q.name for q in p.pieces] == ["panel 1", "panel 2"] and p.pieces[0].quantity == 2
    assert all(q.result is not None for q in p.pieces) and p.sewings[0].panels == ("panel 1", "panel 2")


def test_splices_and_mirror_pairs_go_with_a_piece_renamed_or_removed(kit):
    plan = CutPlanSettings(splices=(("cap", (500.0,)), ("cap 2", (300.0,)), ("cap +45", (200.0,)),
                                    ("side", (100.0,))), mirror=("cap", "side"))
    p = P.rename(replace(kit, cut_plan=plan), "cap", "lid")
    # "cap" and its numbered items follow; "cap +45" is another piece's name, left as it is
    assert dict(p.cut_plan.splices) == {"lid": (500.0,), "lid 2": (300.0,), "cap +45": (200.0,), "side": (100.0,)}
    assert set(p.cut_plan.mirror) == {"lid", "side"}
    p = P.remove(p, "side")
    assert "side" not in dict(p.cut_plan.splices) and p.cut_plan.mirror == ("lid",)
    assert p.cut_plan.with_splices("lid", None).splice_map() == {"lid 2": [300.0], "cap +45": [200.0]}
    assert p.cut_plan.with_mirror("lid", False).mirror == ()
    assert p.cut_plan.with_width("woven", 1500.0).with_width("woven", None).roll_widths == ()


@pytest.mark.parametrize("kw, says", [
    ({"gap_mm": -1.0}, "gap"), ({"overlap_mm": float("nan")}, "overlap"), ({"seconds": 0}, "time limit"),
    ({"roll_widths": (("woven", 0.0),)}, "roll width"), ({"rotations": "sideways"}, "rotations"),
    ({"splices": (("cap", ()),)}, "splices of 'cap'"), ({"mirror": ("cap", "cap")}, "mirror pairs"),
])
def test_bad_cut_plan_settings_are_one_line(kw, says):
    with pytest.raises(SettingsError, match=says) as info:
        CutPlanSettings(**kw)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("damage, says", [
    (lambda d: d.update(cut_plan=[]), "cut_plan must be an object"),
    (lambda d: d.update(cut_plan={"gap_mm": "wide"}), "cut_plan: the cut plan's gap"),
    (lambda d: d.update(cut_plan={"splices": [{"mm": [1.0]}]}), "cut_plan: its roll widths"),
])
def test_a_damaged_cut_plan_is_named_in_one_line(kit, tmp_path, damage, says):
    doc = project_to_dict(kit)
    damage(doc)
    assert_refused_in_one_line(doc, tmp_path, says)


def _rows(path):
    return list(csv.DictReader(path.read_text().splitlines()))


@pytest.mark.slow
def test_nest_uses_the_projects_cut_plan_unless_told_otherwise(kit, tmp_path, capsys):
    """The project's roll widths (no --roll-width needed), gap, mirror pairs and splices; an option
    given wins."""
    plan = CutPlanSettings(roll_widths=(("woven", 2500.0), ("isotropic", 2500.0)), gap_mm=6.0, seconds=1.0,
                           splices=(("cap", (700.0,)),), mirror=("side",))
    path = save_project(replace(kit, cut_plan=plan), tmp_path / "k.flatweave")
    table = tmp_path / "m.csv"
    assert main(["nest", str(path), "--export", str(table), "--export", str(tmp_path / "m.dxf"), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "cap: " in err and "spliced as asked into 2 parts at 700 mm" in err
    assert "on a roll 2500 mm wide" in err
    woven, iso = _rows(tmp_path / "m-woven.csv"), _rows(tmp_path / "m-isotropic.csv")
    assert sorted(r["name"] for r in woven) == ["cap part 1 of 2"] * 2 + ["cap part 2 of 2"] * 2
    # "side" has one copy: a mirror pair's odd one is cut as drawn
    assert [r["mirrored"] for r in iso] == ["false"]
    # the gap kept: the DXF's placed cut lines, read back by ezdxf, at least 6 mm apart
    polys = [Polygon([(q[0], q[1]) for q in v.points()]) for e in ezdxf.readfile(tmp_path / "m-woven.dxf")
             .modelspace().query("INSERT") for v in e.virtual_entities()
             if v.dxf.layer == "1" and v.dxftype() == "POLYLINE"]
    assert len(polys) == 4
    assert min(a.distance(b) for i, a in enumerate(polys) for b in polys[i + 1:]) >= 6.0 - 1e-3
    # options given win over the project's: no gap, "cap" (both its parts) in mirror pairs too
    assert main(["nest", str(path), "--gap", "0", "--mirror", "cap", "--export", str(table), "--quiet"]) == 0
    woven = _rows(tmp_path / "m-woven.csv")
    assert sorted(r["mirrored"] for r in woven) == ["false", "false", "true", "true"]
    assert np.isfinite([float(r["x"]) for r in woven]).all()


def test_an_item_is_a_piece_or_one_of_its_numbered_parts():
    """The one rule the renames and ``nest --mirror`` share: an item "NAME" is the piece, "NAME K" its
    K-th part; a longer name that starts the same is another piece's (names are matched literally)."""
    from flatweave.document.cutsettings import part_of

    assert part_of("front", "front") == "" and part_of("front 2", "front") == "2"
    assert part_of("front 12", "front") == "12"
    for other in ("front panel", "front 2a", "front2", "fronts", "back 2", "front 2 3"):
        assert part_of(other, "front") is None, other
    assert part_of("sleeve (L) 3", "sleeve (L)") == "3" and part_of("sleeveXL) 3", "sleeve.L)") is None
