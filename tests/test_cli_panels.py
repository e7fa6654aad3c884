"""``flatten --seam`` on a surface (issue 42): the seams split it into panels, each flattened, their
sew lines matched in the panels' result file; a mismatch past the tolerance is a warning; what the
panels do not take yet, and bad seams, are one line with nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flatweave.cli import main


def _write(path, doc):
    path.write_text(json.dumps(doc))
    return str(path)


def test_the_half_cylinder_cut_in_three_panels_whose_sew_lines_match(tmp_path, capsys):
    left = _write(tmp_path / "left.json", {"uv": [[1 / 3, 0.0], [1 / 3, 1.0]], "name": "left"})
    # drawn from above, beyond both ends of the cylinder: projected onto its top generator and clipped to it
    top = _write(tmp_path / "top.json", {"points": [[0.0, -0.2, 0.6], [0.0, 1.7, 0.6]],
                                         "view_direction": [0, 0, -1], "name": "top"})
    out = tmp_path / "panels.json"
    assert main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", left, "--seam", top,
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "3 panels, 2 sew lines ->" in err and "warning" not in err
    doc = json.loads(out.read_text())
    assert doc["format"] == "flatweave-panels" and doc["units"] == "m"
    assert [p["name"] for p in doc["panels"]] == ["panel 1", "panel 2", "panel 3"]
    seams = {s["name"]: s for s in doc["seams"]}
    assert sorted(seams) == ["left", "top"]
    for s in seams.values():
        assert s["lengths"] == pytest.approx([1.5, 1.5], rel=1e-5) and s["difference_pct"] < 0.01
    assert seams["left"]["panels"] == ["panel 1", "panel 2"] and seams["top"]["panels"] == ["panel 2", "panel 3"]
    # each panel a piece of the pattern, named; the three areas make the half cylinder's pi R L
    pieces = doc["pattern"]["pieces"]
    assert [p["panel"] for p in pieces] == ["panel 1", "panel 2", "panel 3"]
    assert sum(p["area"] for p in pieces) == pytest.approx(np.pi * 0.5 * 1.5, rel=1e-4)
    for p in doc["panels"]:
        assert p["result"]["format"] == "flatweave-result" and p["result"]["status"] == "converged"


def test_a_sew_line_apart_past_the_tolerance_is_a_warning(tmp_path, capsys):
    """On the octant (doubly curved) the two sides of a seam come out of their solves 0.6 % apart."""
    mid = _write(tmp_path / "mid.json", {"uv": [[0.5, 0.0], [0.5, 1.0]], "name": "mid"})
    out = tmp_path / "panels.json"
    assert main(["flatten", "octant", "--spacing", "0.05", "--seam", mid, "--out", str(out), "--quiet"]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "sew line mid" in line]
    doc = json.loads(out.read_text())
    (s,) = doc["seams"]
    assert s["difference_pct"] > 0.5 and len(warned) == 1 and warned[0].startswith("flatweave: warning: ")
    assert any(w.startswith("sew line mid: ") for w in doc["warnings"])


@pytest.mark.parametrize("extra, seam, says", [
    (["--seed", "0.5,0.5"], {"uv": [[0.5, 0], [0.5, 1]]}, "--seed is not taken with --seam"),
    ([], {"uv": [[0.5, 0], [0.5, 0.5]], "name": "short"}, "seam 'short' does not reach an edge or another seam"),
    ([], {"uv": [[0.5, 0], [0.501, 1]], "closed": "yes"}, '"closed" must be true or false'),
    ([], [1, 2, 3], "a seam is an object"),
    ([], {"points": [[0, 0, 9], [1, 1, 9]], "view_direction": [0, 0, 0]}, '"view_direction" must be a nonzero'),
])
def test_what_the_panels_refuse_is_one_line_and_nothing_written(tmp_path, capsys, extra, seam, says):
    path = _write(tmp_path / "seam.json", seam)
    out = tmp_path / "panels.json"
    extra = [a.replace("{t}", str(tmp_path)) for a in extra]
    code = main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", path, *extra, "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and says in err[0], err
    assert not out.exists() and not (tmp_path / "p.svg").exists()


def test_the_panels_cut_files_carry_matching_notches_on_the_astm_notch_layer(tmp_path, capsys):
    """Notches every 100 mm along both seams and at their ends, read back from the DXF with ezdxf: on
    layer 4 (ASTM D6673's notches), at the same heights on both sides of a seam within 0.1 mm."""
    import ezdxf

    left = _write(tmp_path / "left.json", {"uv": [[1 / 3, 0.0], [1 / 3, 1.0]], "name": "left"})
    top = _write(tmp_path / "top.json", {"uv": [[0.5, 0.0], [0.5, 1.0]], "name": "top"})
    dxf, svg = tmp_path / "p.dxf", tmp_path / "p.svg"
    assert main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", left, "--seam", top, "--export",
                 str(dxf), "--export", str(svg), "--notch-every", "100", "--seam-allowance", "10", "--quiet"]) == 0
    doc = ezdxf.readfile(dxf)
    blocks = {b.name: b for b in doc.blocks if not b.name.startswith("*")}
    names = sorted(blocks)
    assert names == ["half_cylinder_panel_1", "half_cylinder_panel_2", "half_cylinder_panel_3"]

    def notches(block):
        lines = [e for e in blocks[block] if e.dxf.layer == "4" and e.dxftype() == "LINE"]
        return np.array([[e.dxf.start[0], e.dxf.start[1], e.dxf.end[0], e.dxf.end[1]] for e in lines])

    n1, n2, n3 = (notches(b) for b in names)
    assert (len(n1), len(n2), len(n3)) == (16, 32, 16)  # 1.5 m: 0, 100, ..., 1400, 1500 mm on each side
    assert np.allclose(np.hypot(n1[:, 2] - n1[:, 0], n1[:, 3] - n1[:, 1]), 6.0)  # a 6 mm slit each
    # panel 2's notches on its left edge are the left seam's, on its right edge the top seam's
    mid = 0.5 * (n2[:, 0].min() + n2[:, 0].max())
    for a, b in ((n1, n2[n2[:, 0] < mid]), (n2[n2[:, 0] > mid], n3)):
        ya, yb = np.sort(a[:, 1]), np.sort(b[:, 1])
        assert np.abs((ya - ya[0]) - (yb - yb[0])).max() < 0.1  # the same heights on both sides, mm
        assert np.allclose(np.diff(ya)[:-1], 100.0, atol=0.1)
    assert svg.read_text().count('id="layer-4-notch"') == 1 and "layer-4-notch" in svg.read_text()


def test_panels_are_not_exported_in_3d_formats_yet(tmp_path, capsys):
    seam = _write(tmp_path / "s.json", {"uv": [[0.5, 0.0], [0.5, 1.0]]})
    code = main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", seam, "--export",
                 str(tmp_path / "p.vtp"), "--out", str(tmp_path / "p.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "not yet in 3D formats" in err[0]
    assert not (tmp_path / "p.json").exists()


def test_the_panels_saved_as_a_project_are_its_pieces_solved(tmp_path, capsys):
    """--out NAME.flatweave: the panels are the project's pieces, each with its region and current result
    (solved in worker processes, as solve does); the window and solve open it as any project."""
    from flatweave.document.project import load_project

    seam = _write(tmp_path / "s.json", {"uv": [[0.5, 0.0], [0.5, 1.0]], "name": "mid"})
    out = tmp_path / "panels.flatweave"
    assert main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", seam, "--out", str(out), "--quiet"]) == 0
    project = load_project(out)
    assert [p.name for p in project.pieces] == ["panel 1", "panel 2"]
    assert all(p.result is not None and p.result.status == "converged" for p in project.pieces)
    assert all(p.settings.region is not None for p in project.pieces)
    assert sum(p.result.pattern.area for p in project.pieces) == pytest.approx(np.pi * 0.5 * 1.5, rel=1e-4)


def test_a_panels_file_is_not_a_warm_start(tmp_path, capsys):
    seam = _write(tmp_path / "s.json", {"uv": [[0.5, 0.0], [0.5, 1.0]]})
    panels = tmp_path / "panels.json"
    assert main(["flatten", "half_cylinder", "--spacing", "0.05", "--seam", seam, "--out", str(panels),
                 "--quiet"]) == 0
    capsys.readouterr()
    code = main(["flatten", "half_cylinder", "--spacing", "0.05", "--warm-start", str(panels), "--out",
                 str(tmp_path / "r.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "holds panels (flatten --seam), not one result" in err[0]
    assert not (tmp_path / "r.json").exists()
