"""A yarn stored by the point the designer picked follows that thread across
spacings; an index-only yarn keeps its index."""

import json

import numpy as np
import pytest

from flatweave.cli import main
from flatweave.method.energy import YarnConstraint, parse_yarn, resolve_yarns, yarn_nodes
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.method.result import result_to_dict
from flatweave.document.project import Project, load_project, save_project, settings_equal

COARSE, FINE = 0.08, 0.04
ROW = -3  # the picked node is M[-3, 0] of the coarse lattice


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module")
def picked(octant):
    """A weft yarn picked at node M[-3, 0] of a solved coarse octant, held to
    the great circle through that node along its thread (a plane the woven
    threads can follow)."""
    r = flatten(octant, FlattenSettings(spacing=COARSE))
    at = {tuple(ij): k for k, ij in enumerate(r.mesh.ij.tolist())}
    p = r.xyz[at[(ROW, 0)]]
    along = r.xyz[at[(ROW, 1)]] - r.xyz[at[(ROW, -1)]]
    n = np.cross(p, along)
    n /= np.linalg.norm(n)
    return YarnConstraint("weft", ROW, (*n, 0.0), 1000.0, point=tuple(p))


def _row_near(result, yarn):
    """(index, distance from the point to the row's nearest node, largest distance of a row node to the plane)."""
    nodes = yarn_nodes(result.mesh, yarn.kind, yarn.index)
    d_point = float(np.linalg.norm(result.xyz[nodes] - np.asarray(yarn.point), axis=1).min())
    off = np.abs(result.xyz[nodes] @ yarn.unit_plane()[:3] + yarn.unit_plane()[3]).max()
    return yarn.index, d_point, float(off)


def test_a_picked_yarn_follows_its_point_across_two_spacings(octant, picked):
    indices = []
    for spacing in (COARSE, FINE):
        r = flatten(octant, FlattenSettings(spacing=spacing, yarns=(picked,)))
        y = r.settings.yarns[0]
        index, d_point, off = _row_near(r, y)
        assert y.point == picked.point
        assert d_point < spacing  # the constrained row passes through the picked point ...
        assert off < 0.01 * spacing  # ... and lies in its plane
        assert r.metrics["max_thread_strain_pct"] < 1.0
        # usable; the held row shears the octant a little past the 15 deg warning angle (16-17 deg)
        assert r.usable and r.metrics["solver_status"] == "converged"
        assert all(w.startswith("shear up to") and "warning angle" in w for w in r.warnings), r.warnings
        indices.append(index)
    assert indices == [ROW, 2 * ROW]  # the same thread is another row of the finer lattice


@pytest.mark.slow
def test_an_index_only_yarn_at_the_finer_spacing_is_another_thread(octant, picked):
    """The issue's failure: the index names another thread at half the spacing, held
    to the old plane. It is what an explicit index asks for; the result now warns."""
    explicit = YarnConstraint("weft", ROW, picked.plane, picked.k)
    r = flatten(octant, FlattenSettings(spacing=FINE, yarns=(explicit,)))
    assert r.settings.yarns[0].index == ROW
    assert r.metrics["max_thread_strain_pct"] > 10.0
    assert any("thread strain" in w and "yarn" in w for w in r.warnings)


def test_labels_say_what_was_picked(picked):
    assert picked.label().startswith("weft through (") and picked.label().count(",") == 2
    assert YarnConstraint("weft", -12, (0, 0, 1, 0), 1.0).label() == "weft row -12"
    assert YarnConstraint("warp", 3, (0, 0, 1, 0), 1.0).label() == "warp column 3"
    assert YarnConstraint("weft", 0, (0, 0, 1, 0), 1.0, (0.12, 0.34, 0.56)).label() == "weft through (0.12, 0.34, 0.56)"


def test_resolution_takes_the_row_or_column_of_the_nearest_node(octant):
    r = flatten(octant, FlattenSettings(spacing=0.1, solver="none"))
    k = 17
    near = tuple(r.xyz[k] + 1e-3)
    weft = YarnConstraint("weft", 99, (0, 0, 1, 0), 1.0, near)
    warp = YarnConstraint("warp", 99, (0, 0, 1, 0), 1.0, near)
    fixed = YarnConstraint("weft", 99, (0, 0, 1, 0), 1.0)
    a, b, c = resolve_yarns((weft, warp, fixed), r.mesh, r.xyz)
    assert (a.index, b.index, c.index) == (r.mesh.ij[k, 0], r.mesh.ij[k, 1], 99)
    assert c is fixed


def test_points_in_files_and_settings_compare_by_point(octant, picked, tmp_path):
    s = FlattenSettings(spacing=COARSE, yarns=(picked,), max_iter=50)
    r = flatten(octant, s)
    doc = result_to_dict(r)
    assert doc["settings"]["yarns"][0]["point"] == list(picked.point)
    assert doc["settings"]["yarns"][0]["index"] == r.settings.yarns[0].index
    moved = YarnConstraint("weft", 7, picked.plane, picked.k, picked.point)  # another index, same point
    assert settings_equal(s, FlattenSettings(spacing=COARSE, yarns=(moved,), max_iter=50))
    other = YarnConstraint("weft", ROW, picked.plane, picked.k, (0.6, 0.3, 0.7))
    assert not settings_equal(s, FlattenSettings(spacing=COARSE, yarns=(other,), max_iter=50))
    p = Project(octant, s, name="yarn", result=r)
    assert p.result_is_current
    back = load_project(save_project(p, tmp_path / "y.flatweave"))
    assert back.settings.yarns == (picked,) and back.result.settings.yarns == r.settings.yarns
    assert back.result_is_current


def test_parse_and_bad_input():
    y = parse_yarn("weft@0.5,0.25,0.7", "0,0,1,-0.7", 100.0)
    assert (y.kind, y.point, y.k) == ("weft", (0.5, 0.25, 0.7), 100.0)
    assert parse_yarn("warp:4", "0,0,1,0", 1.0).point is None
    for bad in ("weft@1,2", "weft@a,b,c", "weft@1,2,nan", "weft", "weft:x"):
        with pytest.raises(SettingsError) as info:
            parse_yarn(bad, "0,0,1,0", 1.0)
        assert "\n" not in str(info.value)
    with pytest.raises(SettingsError):
        YarnConstraint("weft", 0, (0, 0, 1, 0), 1.0, (1.0, 2.0))
    with pytest.raises(SettingsError):
        YarnConstraint("weft", 1.5, (0, 0, 1, 0), 1.0)


def test_the_cli_takes_a_yarn_by_point(tmp_path, picked, capsys):
    out = tmp_path / "r.json"
    x, y, z = picked.point
    a, b, c, d = (float(v) for v in picked.plane)
    assert main(["flatten", "octant", "--spacing", str(FINE), "--quiet", "--out", str(out),
                 f"--yarn=weft@{x!r},{y!r},{z!r}", f"--yarn-plane={a!r},{b!r},{c!r},{d!r}"]) == 0
    doc = json.loads(out.read_text())
    yarn = doc["settings"]["yarns"][0]
    assert yarn["point"] == pytest.approx([x, y, z]) and yarn["index"] == 2 * ROW
    assert doc["metrics"]["max_thread_strain_pct"] < 1.0
    assert not any("strain" in w for w in doc["warnings"]) and "not usable" not in doc["status"]
    assert main(["flatten", "octant", "--spacing", "0.1", "--quiet", "--out", str(out),
                 "--yarn", "weft@1,2", "--yarn-plane", "0,0,1,0"]) == 2
    assert "weft@X,Y,Z" in capsys.readouterr().err
