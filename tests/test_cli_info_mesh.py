"""``python -m flatweave info`` on a mesh that cannot be covered whole: described, not refused."""

from __future__ import annotations

import json
import math
import re

import pytest
import trimesh

from flatweave.cli import main


def _write(mesh: trimesh.Trimesh, path) -> str:
    mesh.export(path)
    return str(path)


def test_info_describes_a_closed_mesh(tmp_path, capsys):
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
    path = _write(sphere, tmp_path / "ball.stl")
    assert main(["info", path]) == 0
    out = capsys.readouterr().out
    # the STL repeats each vertex per triangle: the counts are the welded mesh's, as the window reads it
    assert f"mesh of {len(sphere.vertices)} vertices and {len(sphere.faces)} triangles" in out
    assert "closed (no boundary), genus 0" in out
    assert f"size {math.sqrt(3):.6g}" in out  # the bounding-box diagonal of a ball of diameter 1
    area = re.search(r"area ([\d.]+)", out)
    assert area and float(area.group(1)) == pytest.approx(sphere.area, rel=1e-6)  # STL keeps float32 points
    assert "needs a region to flatten" in out

    assert main(["info", path, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert (d["vertices"], d["triangles"]) == (len(sphere.vertices), len(sphere.faces))
    assert d["closed"] and d["boundary_loops"] == 0 and d["genus"] == 0
    assert d["size"] == pytest.approx(math.sqrt(3)) and d["area"] == pytest.approx(sphere.area, rel=1e-6)
    assert "needs a region" in d["needs_region"]


def test_info_counts_the_handles_of_a_torus(tmp_path, capsys):
    path = _write(trimesh.creation.torus(0.5, 0.2), tmp_path / "ring.stl")
    assert main(["info", path, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["closed"] and d["genus"] == 1
    assert main(["info", path]) == 0
    assert "genus 1 (1 handle)" in capsys.readouterr().out


def test_flatten_still_asks_a_closed_mesh_for_a_region(tmp_path, capsys):
    path = _write(trimesh.creation.icosphere(subdivisions=1), tmp_path / "ball.stl")
    assert main(["flatten", path, "--spacing", "0.2", "--out", str(tmp_path / "r.json"), "--quiet"]) == 2
    assert "needs a region" in capsys.readouterr().err
