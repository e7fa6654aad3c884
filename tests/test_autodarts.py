"""Suggested darts: they lower the strain at least as much as the
hand-placed darts of the paper's examples, start on the edge, and are ordinary darts."""

import json

import numpy as np
import pytest

from flatweave.studies.autodarts import candidate_darts, dart_sites, suggest_darts
from flatweave.cli import main
from flatweave.method.darts import CurveDart, PlaneDart
from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS
from flatweave.method.metrics import metric_limits
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import flatten
from flatweave.geometry.region import cover_for

SPACING = 0.05  # Table 1's is 0.025 (benchmarks/autodarts.py); the comparison holds here too

# the paper's Table 1 plane dart as benchmarks/paper_tables.py places it: the symmetry plane x = y up to z = 0.55
HAND_DART = PlaneDart((1.0, -1.0, 0.0, 0.0), (-2, 2, -2, 2, -2, 0.55), name="plane dart")


@pytest.fixture(scope="module")
def octant():
    return load_example("octant")


@pytest.fixture(scope="module", params=["woven", "isotropic"])
def base(request, octant):
    return flatten(octant, FlattenSettings(SPACING, material=MATERIALS[request.param]))


def paper_limits(result) -> dict:
    """The piece's own limits, but a 0.1 % boundary error warning: the octant's 5.4 % and the
    garment's 0.5 % are within their own limits, where no dart is suggested; the paper's
    examples ask for darts all the same, and these tests measure the darts found."""
    limits = metric_limits(result.settings.material, total_curvature=result.metrics["total_curvature"])
    return {**limits, "boundary_error_pct": (0.1, limits["boundary_error_pct"][1])}


@pytest.fixture(scope="module")
def suggested(base):
    return suggest_darts(base, count=2, workers=2, limits=paper_limits(base))


def test_sites_lie_on_the_edge_where_the_energy_is(base):
    sites = dart_sites(base, 3)
    cover = cover_for(base.surface, None)
    assert len(sites) == 3
    assert np.allclose(cover.edge_distance(sites), 0.0, atol=1e-9)
    cands = candidate_darts(base, sites)
    assert len(cands) == 3 * 3
    for _, d in cands:  # from the edge inwards, inside the domain
        assert cover.edge_distance(d.uv[:1])[0] < 1e-9 and cover.edge_distance(d.uv[-1:])[0] > 0.05
        assert base.surface.in_domain(d.uv).all()


@pytest.mark.slow
def test_one_suggested_dart_beats_the_hand_placed_one(base, suggested, octant):
    hand = flatten(octant, FlattenSettings(SPACING, material=base.settings.material, darts=(HAND_DART,)))
    one = suggested[0].metrics
    assert one["boundary_error_pct"] <= hand.metrics["boundary_error_pct"]
    assert one["area_error_pct"] <= hand.metrics["area_error_pct"]
    assert one["energy"] < base.metrics["energy"]
    assert 0.03 <= suggested[0].gain < 1.0


def test_two_suggested_darts_lower_them_further(suggested, base):
    assert len(suggested) == 2
    one, two = suggested[0].metrics, suggested[1].metrics
    assert two["boundary_error_pct"] < one["boundary_error_pct"]
    assert two["area_error_pct"] <= one["area_error_pct"]
    assert two["energy"] < one["energy"]
    # the second was looked for with the first in place, and both are in its solve
    assert [d.name for d in suggested[1].result.settings.darts] == [p.dart.name for p in suggested]
    assert all(p.result.surface is base.surface for p in suggested)  # not a worker's copy


def test_a_suggested_dart_is_an_ordinary_dart(suggested, base):
    from flatweave.document.project import _darts_to_list, settings_from_dict
    from flatweave.method.settings import settings_to_dict

    d = suggested[0].dart
    assert isinstance(d, CurveDart) and d.auto and d.name.startswith("suggested dart")
    settings = suggested[0].result.settings
    doc = json.loads(json.dumps(settings_to_dict(settings, "project")))
    back = settings_from_dict(doc, json.loads(json.dumps(_darts_to_list(settings.darts))))
    assert back.darts[0].auto and np.array_equal(back.darts[0].uv, d.uv)
    # re-solving the piece with the suggested dart given by hand gives its metrics
    again = flatten(base.surface, FlattenSettings(SPACING, material=base.settings.material, darts=(d,)),
                    initial=base.state())
    assert again.metrics["energy"] == pytest.approx(suggested[0].metrics["energy"], rel=1e-6)


@pytest.mark.slow
def test_garment_one_suggested_dart_is_as_good_as_the_collar_dart():
    """The paper's Example V (benchmarks/planar_compare.collar_dart): the collar dart, a slit down the centre line."""
    g = load_example("garment")
    collar = PlaneDart((1.0, 0.0, 0.0, -0.02), (-1, 1, 0.42, 1, -1, 1), name="collar dart")
    base = flatten(g, FlattenSettings(0.02))
    hand = flatten(g, FlattenSettings(0.02, darts=(collar,)))
    assert base.warnings == ()  # within its own limits: no dart unless asked by the paper's
    one = suggest_darts(base, count=1, workers=2, limits=paper_limits(base))
    assert one, "no dart suggested on the garment"
    m = one[0].metrics
    assert m["energy"] <= hand.metrics["energy"]
    assert m["boundary_error_pct"] <= hand.metrics["boundary_error_pct"]
    assert m["area_error_pct"] <= hand.metrics["area_error_pct"]


def test_stops_when_no_dart_helps():
    """A developable piece flattens without strain: no dart lowers anything."""
    s = load_example("half_cylinder")
    r = flatten(s, FlattenSettings(0.1))
    assert suggest_darts(r, count=2, workers=1) == []
    # asked by a boundary limit no pattern meets, darts are tried, and none lowers the energy beyond noise
    # (EN 2e-11, the bent springs' precision, which a dart moves by 1 %)
    limits = paper_limits(r)
    limits["boundary_error_pct"] = (-1.0, limits["boundary_error_pct"][1])
    got = suggest_darts(r, count=2, workers=1, limits=limits)
    assert got == [] and got.reason.startswith("no dart tried helps: of ")


@pytest.mark.slow
def test_cli_auto_darts(tmp_path, capsys):
    out = tmp_path / "r.json"
    # a 5 degree warning angle: the octant's 9.5 degree shear warns (within the presets' 15 no dart is wanted)
    assert main(["flatten", "octant", "--spacing", "0.1", "--shear-angles", "5,30", "--auto-darts", "1",
                 "--out", str(out)]) == 0
    d = json.loads(out.read_text())
    autos = [x for x in d["darts"] if x.get("auto")]
    assert len(autos) == 1 and len(d["suggested_darts"]) == 1
    assert d["metrics"]["energy"] == pytest.approx(d["suggested_darts"][0]["metrics"]["energy"])
    assert "suggested" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:  # refused by the option's range
        main(["flatten", "octant", "--spacing", "0.1", "--auto-darts", "-1", "--out", str(out)])
    assert e.value.code == 2
