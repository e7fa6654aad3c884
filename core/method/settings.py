"""The settings of one flattening (:class:`FlattenSettings`), their checks and their one encoding
in result and project files (:func:`settings_to_dict`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from flatweave.method.darts import DART_KINDS, RESULT_DART_KEYS
from flatweave.method.drape import DrapeSettings
from flatweave.method.energy import YarnConstraint
from flatweave.errors import SettingsError
from flatweave.method.lattice import MATERIALS, Material
from flatweave.geometry.region import Region
from flatweave.method.solver import SolverOptions
from flatweave.method.solvers import solver_entry, solver_names


@dataclass(frozen=True)
class FlattenSettings:
    """Everything that decides a flattening, apart from the surface.

    spacing, spacing_warp : rest lengths of weft and warp springs (warp
        defaults to the weft spacing)
    material : spring constants (presets in ``flatweave.method.lattice.MATERIALS``)
    seed : seed point as fractions of the parameter domain
    angle_deg : weft direction at the seed, from S_u towards S_v
    paths : constrained paths, "plane" (paper) or "geodesic"
    solver : "fast" (default), "paper" or "none" (the drape only)
    tol, max_iter, max_seconds : stopping rule and budgets of the solver
    yarns : yarn constraints (directional energy)
    darts : plane and curve darts (:mod:`flatweave.method.darts`)
    max_nodes : refuse meshes estimated larger than this (or than the available
        memory holds, :func:`flatweave.method.drape.node_limit`), up front
    region : the piece's region of the (u, v) domain (:class:`flatweave.geometry.region.Region`:
        a trimmed face's loops), or None for the whole domain; the seed must
        lie in it (:attr:`flatweave.geometry.region.Cover.default_seed` is a good one)
    ease : ((uv, amount), ...): sew lines ((k, 2) (u, v) points each, as tuples) along which the
        springs rest longer by ``amount`` (a fraction, |amount| <= MAX_EASE; negative: shorter), fading
        over a band of two spacings (:attr:`flatweave.method.lattice.SpringMesh.ease`): set by a matched
        seam's solve (:mod:`flatweave.document.matching`), () otherwise; the result's energy, strain and
        pattern are the fabric's own, with no ease

    Settings check themselves when made (:func:`validate_settings`): a value
    no solve can use is a one-line SettingsError, here and not mid-solve.
    """

    spacing: float
    spacing_warp: float | None = None
    material: Material = MATERIALS["woven"]
    seed: tuple[float, float] = (0.5, 0.5)
    angle_deg: float = 0.0
    paths: str = "plane"
    solver: str = "fast"
    tol: float = 1e-9
    max_iter: int = 1000
    max_seconds: float = math.inf
    yarns: tuple[YarnConstraint, ...] = ()
    darts: tuple = ()
    max_nodes: int = 2_000_000
    region: Region | None = None
    ease: tuple = ()

    def __post_init__(self):
        validate_settings(self)

    def drape_settings(self) -> DrapeSettings:
        return DrapeSettings(self.spacing, self.spacing_warp, tuple(self.seed), float(self.angle_deg),
                             self.paths, self.max_nodes)

    def solver_options(self) -> SolverOptions:
        return SolverOptions(method=self.solver, tol=self.tol, max_iter=self.max_iter,
                             max_seconds=self.max_seconds)


def validate_settings(s: FlattenSettings, job: bool = False) -> None:
    """Raise a one-line SettingsError for a setting no solve can use (every
    FlattenSettings runs this when made) or, with ``job``, that a project's
    job cannot run with: a zero time budget."""
    def positive(name, value):
        if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                and math.isfinite(value) and value > 0):
            raise SettingsError(f"{name} must be a positive number, got {value!r}")

    positive("spacing", s.spacing)
    if s.spacing_warp is not None:
        positive("warp spacing", s.spacing_warp)
    if not isinstance(s.material, Material):
        raise SettingsError(f"material must be a Material, got {type(s.material).__name__}")
    for name in ("k_weft", "k_warp", "k_diag"):
        positive(f"material {name}", getattr(s.material, name))
    w, lock = s.material.warn_deg, s.material.lock_deg
    if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in (w, lock)) \
            or not 0 < w < lock <= 90:
        raise SettingsError(f"material shear angles must be 0 < warning < lock <= 90 degrees, got {w!r} and {lock!r}")
    seed = tuple(s.seed)
    if len(seed) != 2 or not all(isinstance(x, (int, float)) and 0 <= x <= 1 for x in seed):
        raise SettingsError(f"seed must be two fractions of the domain between 0 and 1, got {s.seed!r}")
    if not (isinstance(s.angle_deg, (int, float)) and math.isfinite(s.angle_deg)):
        raise SettingsError(f"weft angle must be a number of degrees, got {s.angle_deg!r}")
    if s.paths not in ("plane", "geodesic"):
        raise SettingsError(f"paths must be 'plane' or 'geodesic', got {s.paths!r}")
    names = solver_names("spring")
    if s.solver not in names:
        raise SettingsError(f"solver {s.solver!r} is not one of {', '.join(names)}")
    entry = solver_entry(s.solver)
    if s.darts and not entry.darts:
        raise SettingsError(f"solver {s.solver!r} does not cut darts; remove them or choose another solver")
    if s.yarns and not entry.yarns:
        raise SettingsError(f"solver {s.solver!r} does not hold yarns; remove them or choose another solver")
    positive("tolerance", s.tol)
    if not (isinstance(s.max_iter, int) and not isinstance(s.max_iter, bool) and s.max_iter >= 0):
        raise SettingsError(f"max iterations must be a non-negative integer, got {s.max_iter!r}")
    # a zero budget is a run that stops at once (a project's job needs a positive one)
    if not (isinstance(s.max_seconds, (int, float)) and s.max_seconds >= 0):
        raise SettingsError(f"time budget must be a positive number of seconds, got {s.max_seconds!r}")
    if not (isinstance(s.max_nodes, int) and s.max_nodes > 0):
        raise SettingsError(f"max nodes must be a positive integer, got {s.max_nodes!r}")
    for y in s.yarns:
        if not isinstance(y, YarnConstraint):
            raise SettingsError(f"yarn constraints must be YarnConstraint, got {type(y).__name__}")
    if s.region is not None and not isinstance(s.region, Region):
        raise SettingsError(f"region must be a flatweave.geometry.region.Region or None, got {type(s.region).__name__}")
    for d in s.darts:
        if not isinstance(d, tuple(DART_KINDS.values())):
            raise SettingsError(f"darts must be {' or '.join(c.__name__ for c in DART_KINDS.values())}, "
                                f"got {type(d).__name__}")
    check_ease(s.ease)
    if job and not s.max_seconds > 0:
        raise SettingsError(f"time budget must be a positive number of seconds, got {s.max_seconds!r}")


MAX_EASE = 0.2
"""The most a matched seam eases its springs (a fifth of their length): beyond it the two sides
are too far apart to be sewn by easing, and the seam is said to be so."""


def check_ease(ease) -> None:
    """A one-line SettingsError unless ``ease`` is ((uv points, amount), ...) as FlattenSettings takes it."""
    if not isinstance(ease, tuple):
        raise SettingsError(f"ease must be a tuple of (uv points, amount), got {type(ease).__name__}")
    for entry in ease:
        if not (isinstance(entry, tuple) and len(entry) == 2):
            raise SettingsError("each ease is (uv points, amount)")
        uv, amount = entry
        if isinstance(amount, bool) or not isinstance(amount, (int, float)) or not math.isfinite(amount) \
                or abs(amount) > MAX_EASE:
            raise SettingsError(f"an ease's amount must be a fraction from -{MAX_EASE:g} to {MAX_EASE:g}, "
                                f"got {amount!r:.40}")
        if not (isinstance(uv, tuple) and len(uv) >= 2 and all(
                isinstance(p, tuple) and len(p) == 2 and all(isinstance(x, float) and math.isfinite(x) for x in p)
                for p in uv)):
            raise SettingsError("an ease's line must be two or more finite (u, v) points")


def ease_to_list(ease) -> list:
    """The settings' ease in files: [{"uv": [[u, v], ...], "amount": a}, ...]."""
    return [{"uv": [list(p) for p in uv], "amount": float(amount)} for uv, amount in ease]


def ease_from_list(value) -> tuple:
    """:func:`ease_to_list`'s inverse; a one-line SettingsError on a malformed entry."""
    if not isinstance(value, list):
        raise SettingsError("ease must be a list of {\"uv\": [[u, v], ...], \"amount\": a}")
    out = []
    for item in value:
        if not isinstance(item, dict) or not isinstance(item.get("uv"), list):
            raise SettingsError("each ease is {\"uv\": [[u, v], ...], \"amount\": a}")
        try:
            uv = tuple(tuple(float(x) for x in p) for p in item["uv"])
        except (TypeError, ValueError):
            raise SettingsError("an ease's uv must be [u, v] number pairs") from None
        out.append((uv, item.get("amount")))
    out = tuple(out)
    check_ease(out)
    return out


SETTINGS_KEYS = ("spacing", "spacing_warp", "material", "seed", "angle_deg", "paths", "solver", "tol",
                 "max_iter", "max_seconds", "max_nodes")


def settings_to_dict(s: FlattenSettings, form: str = "result") -> dict:
    """The settings as a JSON object: the one encoding of settings, darts
    (:meth:`flatweave.method.darts.Dart.to_dict`), yarns and material.

    form "result" (a result file's ``settings``): every field, in field
    order, ``spacing_warp`` filled in from the weft spacing, the darts without
    their labels beyond the name (:data:`~flatweave.method.darts.RESULT_DART_KEYS`) and the
    yarns inline. form "project": :data:`SETTINGS_KEYS` only (darts and yarns
    are listed beside them), ``spacing_warp`` null when it follows the weft
    spacing, and ``region`` (null for the whole domain). Either way an
    infinite time budget is null; a result's settings have ``region`` only
    when there is one (:meth:`flatweave.geometry.region.Region.to_dict`).
    """
    if form not in ("result", "project"):
        raise ValueError(f"form must be 'result' or 'project', got {form!r}")
    out = {
        "spacing": s.spacing,
        "spacing_warp": s.spacing_warp if s.spacing_warp is not None or form == "project" else s.spacing,
        "material": s.material.to_dict(),
        "seed": list(s.seed),
        "angle_deg": s.angle_deg,
        "paths": s.paths,
        "solver": s.solver,
        "tol": s.tol,
        "max_iter": s.max_iter,
        "max_seconds": s.max_seconds if math.isfinite(s.max_seconds) else None,
        "yarns": [y.to_dict() for y in s.yarns],
        "darts": [d.to_dict(RESULT_DART_KEYS) for d in s.darts],
        "max_nodes": s.max_nodes,
    }
    region = None if s.region is None else s.region.to_dict()
    ease = {"ease": ease_to_list(s.ease)} if s.ease else {}  # only when a matched seam eased it
    if form == "result":
        if region is not None:
            out["region"] = region
        return {**out, **ease}
    return {**{k: out[k] for k in SETTINGS_KEYS}, "region": region, **ease}
