"""Energy (equation 4) and its gradient, checked by finite differences."""

import numpy as np
import pytest

from flatweave.method.drape import DrapeSettings, drape
from flatweave.method.energy import Energy, YarnConstraint, parse_yarn
from flatweave.errors import SettingsError
from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS


@pytest.mark.parametrize("material", ["woven", "isotropic"])
@pytest.mark.parametrize("name", ["octant", "garment"])
def test_gradient_matches_finite_differences(material, name):
    s = load_example(name)
    r = drape(s, DrapeSettings(0.1 if name == "octant" else 0.05), MATERIALS[material])
    yarns = [YarnConstraint("warp", 1, (1.0, 0.3, 0.2, -0.3), 50.0),
             YarnConstraint("weft", -1, (0.0, 1.0, 0.0, 0.1), 7.0)]
    E = Energy(s, r.mesh, yarns)
    assert len(E.dir_nodes) > 0
    rng = np.random.default_rng(0)
    uv = r.uv + 2e-3 * rng.standard_normal(r.uv.shape)
    uv = np.clip(uv, s.domain[:, 0], s.domain[:, 1])
    e, g = E.value_and_grad(uv)
    assert e == pytest.approx(E.value(uv), rel=1e-12)
    h = 1e-6
    for i in rng.choice(r.mesh.n_nodes, 25, replace=False):
        for c in range(2):
            up, um = uv.copy(), uv.copy()
            up[i, c] += h
            um[i, c] -= h
            fd = (E.value(up) - E.value(um)) / (2 * h)
            assert g[i, c] == pytest.approx(fd, rel=1e-5, abs=1e-7 * max(1.0, abs(e)))


def test_energy_is_half_k_dl_squared_plus_yarn_term():
    s = load_example("octant")
    r = drape(s, DrapeSettings(0.2), MATERIALS["isotropic"])
    xyz = r.xyz.copy()
    E0 = Energy(s, r.mesh)
    xyz[0] += [0.01, 0, 0]
    L = np.linalg.norm(xyz[r.mesh.ends[:, 0]] - xyz[r.mesh.ends[:, 1]], axis=1)
    assert E0.value_xyz(xyz) == pytest.approx(0.5 * np.sum(r.mesh.k * (L - r.mesh.rest) ** 2))
    y = YarnConstraint("weft", 0, (0, 0, 2.0, -1.0), 3.0)  # plane z = 0.5, normal scaled by 2
    idx = y.nodes(r.mesh)
    assert np.all(r.mesh.ij[idx, 0] == 0)
    E1 = Energy(s, r.mesh, [y])
    dist = xyz[idx, 2] - 0.5
    assert E1.value_xyz(xyz) - E0.value_xyz(xyz) == pytest.approx(0.5 * 3.0 * np.sum(dist ** 2))


def test_masked_energy_switches_springs_off():
    s = load_example("octant")
    r = drape(s, DrapeSettings(0.2), MATERIALS["isotropic"])
    E = Energy(s, r.mesh)
    on = np.arange(r.mesh.n_springs) % 2 == 0
    xyz = r.xyz * 1.01
    per = E.spring_energy(xyz)
    assert E.masked(on, np.ones(r.mesh.n_nodes, bool)).value_xyz(xyz) == pytest.approx(per[on].sum())


@pytest.mark.parametrize("spec, plane", [("weft", "1,0,0,0"), ("weft:x", "1,0,0,0"), ("bias:3", "1,0,0,0"),
                                         ("warp:2", "1,0,0"), ("warp:2", "0,0,0,1")])
def test_parse_yarn_rejects(spec, plane):
    with pytest.raises(SettingsError):
        parse_yarn(spec, plane, 10.0)
