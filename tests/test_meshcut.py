"""A panel cut from any mesh along a loop drawn on it (flatweave.geometry.meshcut):
the outline is the drawn loop (triangles split, not the nearest edges), holes
stay holes, the inside of an open mesh is the side away from its boundary, and
bad loops are one line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from flatweave.errors import SettingsError
from flatweave.geometry.meshcut import closest_on_mesh, cut_mesh
from flatweave.geometry.meshfit import boundary_loops, lscm, map_distortion

T = np.linspace(0.0, 2.0 * np.pi, 240, endpoint=False)


def sphere(cut_below: float | None = None, subdivisions: int = 5):
    """The unit icosphere; with ``cut_below``, only its triangles above that height (an open dome)."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    V, F = np.asarray(m.vertices), np.asarray(m.faces)
    if cut_below is not None:
        F = F[V[F].mean(axis=1)[:, 2] > cut_below]
        used = np.unique(F)
        V, F = V[used], np.searchsorted(used, F)
    return V, F


def circle(a: float) -> np.ndarray:
    """The circle at angle ``a`` from the north pole of the unit sphere."""
    return np.column_stack([np.sin(a) * np.cos(T), np.sin(a) * np.sin(T), np.full_like(T, np.cos(a))])


def area(V, F) -> float:
    return float(0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum())


def polar(P) -> np.ndarray:
    return np.arctan2(np.linalg.norm(P[:, :2], axis=1), P[:, 2])


def test_closest_on_mesh_is_the_brute_force_nearest():
    V, F = sphere(subdivisions=2)
    rng = np.random.default_rng(3)
    P = rng.normal(size=(200, 3)) * 0.7
    tri, w, xyz, dist = closest_on_mesh(V, F, P)
    # brute force over every triangle: the nearest of 300 sample points of each (about 0.02 apart)
    s = rng.dirichlet(np.ones(3), size=300)
    samples = np.einsum("sj,mjd->msd", s, V[F]).reshape(-1, 3)
    brute = np.array([np.min(np.linalg.norm(samples - p, axis=1)) for p in P])
    assert np.all(dist <= brute + 1e-12) and np.all(brute - dist < 0.05)  # never farther, and as near
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", w, V[F[tri]]), xyz, atol=1e-12)
    assert np.all(w >= -1e-12) and np.allclose(w.sum(axis=1), 1.0)


def test_a_panel_of_an_open_dome_has_the_drawn_outline():
    V, F = sphere(cut_below=-0.2)
    for a in (0.5, 1.3):  # 1.3: the inside is larger than the rest, still the side away from the dome's rim
        Vc, Fc = cut_mesh(V, F, circle(a), "dome")
        loops = boundary_loops(Fc)
        assert len(loops) == 1
        # the outline is the circle itself, put on the facets (edges 0.03 long: their sagitta 1e-4 moves it)
        np.testing.assert_allclose(polar(Vc[loops[0]]), a, atol=5e-4)
        cap = 2 * np.pi * (1 - np.cos(a))
        assert area(Vc, Fc) == pytest.approx(cap, rel=1.5e-3)  # the icosphere's facets are 0.05 % short
        _, _, _, dist = closest_on_mesh(V, F, Vc)
        assert dist.max() < 1e-9  # every new point lies on the mesh
        assert polar(Vc).max() <= a + 5e-4


def test_the_piece_keeps_the_mesh_winding():
    V, F = sphere(cut_below=-0.2)
    Vc, Fc = cut_mesh(V, F, circle(0.8), "dome")
    n = np.cross(Vc[Fc[:, 1]] - Vc[Fc[:, 0]], Vc[Fc[:, 2]] - Vc[Fc[:, 0]])
    centre = Vc[Fc].mean(axis=1)
    big = np.linalg.norm(n, axis=1) > 1e-12
    assert np.all(np.einsum("ij,ij->i", n[big], centre[big]) > 0)  # outward, as the icosphere's


def test_a_hole_drawn_inside_stays_a_hole_and_a_closed_mesh_keeps_the_smaller_side():
    V, F = sphere()
    Vc, Fc = cut_mesh(V, F, circle(0.9), "ball", holes3d=[circle(0.3)])
    loops = boundary_loops(Fc)
    assert len(loops) == 2
    assert area(Vc, Fc) == pytest.approx(2 * np.pi * (np.cos(0.3) - np.cos(0.9)), rel=1.5e-3)
    Vc, Fc = cut_mesh(V, F, circle(2.0), "ball")  # the south cap is the smaller side
    assert Vc[:, 2].max() == pytest.approx(np.cos(2.0), abs=5e-4)
    assert area(Vc, Fc) == pytest.approx(2 * np.pi * (1 + np.cos(2.0)), rel=1.5e-3)


def test_a_panel_is_flatter_than_the_whole():
    V, F = sphere(cut_below=-0.2)
    Vc, Fc = cut_mesh(V, F, circle(0.6), "dome")
    whole, panel = map_distortion(V, F, lscm(V, F)), map_distortion(Vc, Fc, lscm(Vc, Fc))
    assert whole > 0.3 and panel < 0.1


@pytest.mark.parametrize("loop, holes, says", [
    (circle(0.5) * 3, (), "misses it"),
    (np.r_[circle(0.5)[:120], circle(0.5)[:120][:, [1, 0, 2]]], (), "crosses itself"),
    (circle(0.5)[:2], (), "3 or more"),
    ("not points", (), "[x, y, z] points"),
    (circle(0.5), [circle(0.9)], "crosses itself or a hole leaves it"),
])
def test_bad_loops_are_one_line(loop, holes, says):
    V, F = sphere(subdivisions=4)
    with pytest.raises(SettingsError, match=None) as err:
        cut_mesh(V, F, loop, "ball", holes3d=holes)
    assert says in str(err.value) and "\n" not in str(err.value)


def test_a_loop_round_a_torus_tube_does_not_cut_it():
    m = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3, major_sections=64, minor_sections=32)
    ring = np.column_stack([1.0 + 0.3 * np.cos(T), np.zeros_like(T), 0.3 * np.sin(T)])  # round the tube
    with pytest.raises(SettingsError, match="does not cut it in two"):
        cut_mesh(np.asarray(m.vertices), np.asarray(m.faces), ring, "torus")


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "flatweave", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


@pytest.mark.slow
def test_the_cli_warns_on_a_whole_dome_and_cuts_a_panel_with_a_hole(tmp_path):
    V, F = sphere(cut_below=-0.2)
    path = tmp_path / "dome.stl"
    trimesh.Trimesh(V * 100.0, F, process=False).export(path)
    out = tmp_path / "r.json"
    p = _cli("flatten", path, "--spacing", "8", "--out", out, "--quiet")
    assert p.returncode == 0
    first = p.stderr.splitlines()[0]
    assert first.startswith("flatweave: warning: dome.stl is far from developable") and "--region" in first
    region = tmp_path / "panel.json"
    region.write_text(json.dumps({"loop3d": (100 * circle(0.7)).tolist(), "holes3d": [(100 * circle(0.2)).tolist()]}))
    p = _cli("flatten", path, "--spacing", "5", "--region", region, "--out", out, "--quiet")
    assert p.returncode == 0 and "far from developable" not in p.stderr, p.stderr
    m = json.loads(out.read_text())["metrics"]
    assert m["area_3d"] == pytest.approx(2 * np.pi * 1e4 * (np.cos(0.2) - np.cos(0.7)), rel=5e-3)
    assert m["boundary_error_pct"] < 5.0
