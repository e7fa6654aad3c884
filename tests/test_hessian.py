"""The fast solver's exact Hessian (flatweave.method.solver._hessian_blocks, assembled by
_Normal) against central finite differences of the analytic gradient, and the
pinned node's Lagrangian term against the energy's second derivative along
the pin's plane.

Steps: the gradient is differenced with h = 1e-6 in (u, v) (domains are
[0, 1]^2): truncation ~ h^2 |g'''| ~ 1e-12 and round-off ~ eps |g| / h ~ 1e-10
of the Hessian's size, both far below the 1e-6 tolerance; a 1 % change of the
surface-curvature term alone moves the error to about 1e-5 (see
docs/decisions/0003-levenberg-marquardt-with-the-exact-hessian.md, for the perturbations that
were checked to fail these tests).
"""

import numpy as np
import pytest

from flatweave.method.drape import drape
from flatweave.method.energy import Energy, YarnConstraint
from flatweave.reading.examples import load_example
from flatweave.method.lattice import MATERIALS
from flatweave.method.settings import FlattenSettings
from flatweave.method.pipeline import make_problem
from flatweave.method.solver import (SolverOptions, _anchors, _hessian_blocks, _node_at, _Normal, _pin_block,
                         _residuals)

H_GRAD = 1e-6  # central-difference step of the gradient, (u, v) units
H_ENERGY = 1e-4  # second-difference step of the energy along the pin's plane
TOL = 1e-6  # relative Frobenius error allowed


def _perturbed(name, spacing, material, yarns=(), scale=2e-2, seed=0):
    surface = load_example(name)
    settings = FlattenSettings(spacing, material=MATERIALS[material], yarns=tuple(yarns))
    d = drape(surface, settings.drape_settings(), settings.material)
    rng = np.random.default_rng(seed)
    uv = d.uv + scale * spacing * rng.standard_normal(d.uv.shape)  # springs stretched and compressed
    dom = surface.domain
    uv = np.clip(uv, dom[:, 0] + 1e-3, dom[:, 1] - 1e-3)
    return surface, settings, d.mesh, uv


def assembled_hessian(surface, energy, uv):
    """The fast solver's undamped Newton matrix at ``uv`` (every node free),
    in node order (2n, 2n), and the blocks it came from."""
    ev = surface.evaluate(uv, second=True, normals=False)
    rs, Q, rd, Jd = _residuals(energy, ev.xyz, ev.su, ev.sv)
    Hs, Hn, G = _hessian_blocks(energy, ev.xyz, ev.su, ev.sv, Q, ev.suu, ev.suv, ev.svv)
    normal = _Normal(energy, fixed=None)
    A, damp = normal.assemble(Hs, Jd, Hn, 0.0)
    assert not damp.any()
    idx = (2 * normal.order[:, None] + np.arange(2)).ravel()
    H = np.zeros((2 * energy.n, 2 * energy.n))
    H[np.ix_(idx, idx)] = A.toarray()
    return H, ev, G


def fd_hessian(energy, uv, h=H_GRAD):
    """Central differences of the analytic gradient, column by column."""
    n = energy.n
    H = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        up, um = uv.copy(), uv.copy()
        up.flat[j] += h
        um.flat[j] -= h
        H[:, j] = (energy.value_and_grad(up)[1].ravel() - energy.value_and_grad(um)[1].ravel()) / (2 * h)
    return H


CASES = [("octant", 0.25, "woven"), ("octant", 0.25, "isotropic"),
         ("saddle", 0.4, "woven"), ("saddle", 0.4, "isotropic")]


@pytest.mark.parametrize("name, spacing, material", CASES)
def test_exact_hessian_matches_finite_differences_of_the_gradient(name, spacing, material):
    yarn = YarnConstraint("weft", 1, (0.0, 1.0, 0.3, -0.2), 40.0)
    surface, settings, mesh, uv = _perturbed(name, spacing, material, [yarn])
    energy = Energy(surface, mesh, settings.yarns)
    assert len(energy.dir_nodes) > 0  # the yarn term is in the test
    H, ev, G = assembled_hessian(surface, energy, uv)
    # the springs are off their rest lengths both ways: the geometric stiffness matters
    strain = np.linalg.norm(ev.xyz[energy.a] - ev.xyz[energy.b], axis=1) / energy.rest - 1
    assert strain.min() < -1e-3 and strain.max() > 1e-3
    F = fd_hessian(energy, uv)
    assert np.abs(F - F.T).max() <= 1e-6 * np.abs(F).max()  # the differences are clean
    err = np.linalg.norm(H - F) / np.linalg.norm(F)
    assert err < TOL, f"relative Frobenius error {err:.3g}"
    # the surface-curvature term on its own: the diagonal 2 x 2 blocks with
    # it removed must miss by the curvature term, which is not negligible here
    n = energy.n
    Hn = np.empty((n, 2, 2))
    Hn[:, 0, 0] = np.einsum("ij,ij->i", G, ev.suu)
    Hn[:, 0, 1] = Hn[:, 1, 0] = np.einsum("ij,ij->i", G, ev.suv)
    Hn[:, 1, 1] = np.einsum("ij,ij->i", G, ev.svv)
    blocks = lambda M: M.reshape(n, 2, n, 2)[np.arange(n), :, np.arange(n), :]  # noqa: E731
    miss = blocks(F) - (blocks(H) - Hn)
    assert np.linalg.norm(miss - Hn) < TOL * np.linalg.norm(F)
    assert np.linalg.norm(Hn) > 100 * TOL * np.linalg.norm(F)


@pytest.mark.parametrize("name, spacing, material", [("octant", 0.25, "woven"), ("saddle", 0.4, "isotropic")])
def test_pinned_node_term_matches_the_energy_along_its_plane(name, spacing, material):
    """With every other node held, EN along a curve in the pin's plane
    (uv(s) = x + s t + alpha(s) n, t tangent to the plane in (u, v), n its
    unit normal there) has second derivative t^T (H - mu H_c) t: the pinned
    node's Newton block (energy block + :func:`_pin_block`) along t."""
    surface, settings, mesh, uv = _perturbed(name, spacing, material, scale=0.1)
    problem = make_problem(surface, settings)
    _, pin = _anchors(problem, mesh, uv, SolverOptions())
    assert pin is not None
    p = _node_at(mesh, pin.ij)
    energy = Energy(surface, mesh)
    uv[p] = _on_plane(pin, uv[p], pin.off_plane_uv(uv[p]))  # start on the plane
    H, ev, G = assembled_hessian(surface, energy, uv)
    big = float(np.abs(H).max())
    block = H[2 * p:2 * p + 2, 2 * p:2 * p + 2] + _pin_block(pin, uv[p], G[p], ev.su[p], ev.sv[p], big)
    cg, _ = pin.constraint(uv[p])
    nrm = cg / np.linalg.norm(cg)
    t = np.array([-nrm[1], nrm[0]])

    def E_along(s):
        x = uv.copy()
        x[p] = _on_plane(pin, uv[p] + s * t, nrm)
        return energy.value(x)

    h = H_ENERGY
    fd = (E_along(h) - 2 * E_along(0.0) + E_along(-h)) / (h * h)
    exact = float(t @ block @ t)
    energy_part = float(t @ H[2 * p:2 * p + 2, 2 * p:2 * p + 2] @ t)
    term = exact - energy_part  # -mu t^T H_c t (the penalty is zero along t)
    assert abs(term) > 1e-4 * abs(exact)  # the constraint's curvature is felt here
    assert exact == pytest.approx(fd, rel=1e-6)
    assert term == pytest.approx(fd - energy_part, rel=1e-3)


def _on_plane(pin, x, direction):
    """x + alpha direction on the pin's plane (scalar Newton on alpha)."""
    x = np.array(x, dtype=float)
    for _ in range(30):
        S = surface_points(pin, x)
        f = float(pin.normal @ S) + pin.d
        cg, _ = pin.constraint(x)
        slope = float(cg @ direction)
        if abs(f) < 1e-16:
            break
        x = x - f / slope * direction
    return x


def surface_points(pin, x):
    return pin.surface.points(x[None, :])[0]
