"""The rosette as the window draws and picks it: the seed's point on
the surface, the weft and warp directions the drape starts along there
(:func:`flatweave.method.fibres.reference_direction`), the weft angle towards a point
dragged from the seed, and the two arrows that show them."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from flatweave.method.fibres import reference_direction

__all__ = ["Rosette", "rosette", "angle_towards", "seed_fraction", "rosette_arrows", "zero_angle", "weft_for",
           "orientation_for"]


class Rosette(SimpleNamespace):
    """origin (3,) the seed on the surface; normal (3,) unit; weft, warp (3,)
    unit tangents (warp = normal x weft, as the drape lays it); e1, e2 the
    tangent frame the angle is measured in (angle 0 and 90 degrees)."""


def seed_fraction(surface, uv) -> tuple[float, float]:
    """(s, t) fractions of the domain of a (u, v) point (the settings' form of a seed)."""
    dom = np.asarray(surface.domain, dtype=float)
    f = (np.asarray(uv, dtype=float) - dom[:, 0]) / (dom[:, 1] - dom[:, 0])
    return float(np.clip(f[0], 0.0, 1.0)), float(np.clip(f[1], 0.0, 1.0))


def rosette(surface, seed, angle_deg: float) -> Rosette:
    """The rosette at ``seed`` (fractions of the domain) with the weft at ``angle_deg``."""
    def at(a):
        return reference_direction(surface, SimpleNamespace(seed=tuple(seed), angle_deg=float(a)))
    dom = np.asarray(surface.domain, dtype=float)
    uv = dom[:, 0] + np.asarray(seed, dtype=float) * (dom[:, 1] - dom[:, 0])
    ev = surface.evaluate(uv[None, :])
    e1, e2 = at(0.0), at(90.0)
    return Rosette(origin=ev.xyz[0], normal=ev.normal[0], weft=at(angle_deg), warp=at(angle_deg + 90.0),
                   e1=e1, e2=e2)


def angle_towards(surface, seed, point) -> float | None:
    """The weft angle (degrees, in (-180, 180]) that points the weft at the seed towards
    ``point`` (3,), seen in the seed's tangent plane; None when the point is on the
    normal through the seed (no direction)."""
    r = rosette(surface, seed, 0.0)
    d = np.asarray(point, dtype=float) - r.origin
    x, y = float(d @ r.e1), float(d @ r.e2)
    if math.hypot(x, y) <= 1e-12 * max(float(np.linalg.norm(d)), 1e-300):
        return None
    return math.degrees(math.atan2(y, x))


def zero_angle(surface, seed, zero) -> float | None:
    """The weft angle (degrees) of a tool rosette's 0-degree direction ``zero`` (3,)
    projected on the tangent plane at ``seed`` (the projection rosette of composites
    tools); None when ``zero`` is along the normal there (no direction)."""
    here = rosette(surface, seed, 0.0).origin
    return angle_towards(surface, seed, here + np.asarray(zero, dtype=float))


def _wrap(angle: float) -> float:
    """``angle`` in [-180, 180) degrees."""
    return (float(angle) + 180.0) % 360.0 - 180.0


def weft_for(surface, seed, zero, orientation_deg: float) -> float | None:
    """The weft angle that lays a ply at ``orientation_deg`` from the tool rosette's
    0-degree direction ``zero``, about the normal at ``seed``, in [-180, 180); None
    when ``zero`` sets no direction there."""
    z = zero_angle(surface, seed, zero)
    return None if z is None else _wrap(z + float(orientation_deg))


def orientation_for(surface, seed, zero, angle_deg: float) -> float | None:
    """The inverse of :func:`weft_for`: the orientation from ``zero`` of weft angle
    ``angle_deg`` at ``seed``, in [-180, 180); None when ``zero`` sets no direction there."""
    z = zero_angle(surface, seed, zero)
    return None if z is None else _wrap(float(angle_deg) - z)


def rosette_arrows(r: Rosette, length: float) -> list[np.ndarray]:
    """Two arrows from the seed, weft then warp, as polylines (k, 3) each: a shaft
    ``length`` long (the warp's 0.7 of it) and a head, in the tangent plane, lifted
    a hair along the normal so they are drawn over the surface."""
    lift = 0.01 * length * r.normal
    out = []
    for d, scale in ((r.weft, 1.0), (r.warp, 0.7)):
        side = np.cross(r.normal, d)
        tip = r.origin + lift + scale * length * d
        head = 0.18 * length
        out.append(np.array([r.origin + lift, tip, tip - head * d + 0.5 * head * side, tip,
                             tip - head * d - 0.5 * head * side]))
    return out
