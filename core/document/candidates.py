"""Candidate boundaries: a project may keep several regions drawn for
one surface, one of them active (``settings.region``, the piece being solved).

The others are kept beside it, each a :class:`Candidate` (name, region,
shown or hidden), in ``Project.candidates``; the active one's name is
``Project.region_name``. They are labels: keeping, naming, showing or hiding
one never changes a solve; making one active swaps it with the active region
(a settings edit: the piece changes and re-solves, the seed kept while it
lies inside the new region, else its point farthest from the edge). Every
function here takes a Project and returns a new one (the window makes each
one document edit); bad input is a one-line SettingsError.

In the project file they are the optional key ``"candidates"``:
``{"active_name": str, "kept": [{"name", "visible", "region": Region.to_dict()}, ...]}``,
written only when there is something to keep, so files without it (every
older file) read as before.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from flatweave.errors import SettingsError
from flatweave.geometry.region import Region, cover_for

__all__ = ["Candidate", "active_name", "keep_copy", "activate", "rename", "set_visible", "remove",
           "candidates_to_dict", "candidates_from_dict", "DEFAULT_NAME"]

DEFAULT_NAME = "region"  # the active region's name until it is given one


@dataclass(frozen=True)
class Candidate:
    """A region kept beside the active one."""

    name: str
    region: Region | None  # None: the whole surface
    visible: bool = True

    def to_dict(self) -> dict:
        return {"name": self.name, "visible": self.visible,
                "region": None if self.region is None else self.region.to_dict()}

    @classmethod
    def from_dict(cls, d: Any) -> "Candidate":
        if not isinstance(d, dict) or not isinstance(d.get("name"), str) \
                or not isinstance(d.get("visible", True), bool):
            raise SettingsError("a kept region must be an object with a name, visible and a region")
        region = d.get("region")
        return cls(d["name"], None if region is None else Region.from_dict(region), d.get("visible", True))


def active_name(project) -> str:
    return project.region_name or DEFAULT_NAME


def _name(name: Any, taken, what: str) -> str:
    if not isinstance(name, str) or not name.strip():
        raise SettingsError(f"{what} needs a name (some text)")
    name = name.strip()
    if name in taken:
        raise SettingsError(f"there is already a region called {name!r}")
    return name


def _index(project, k: Any) -> int:
    n = len(project.candidates)
    if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < n:
        raise SettingsError(f"there is no kept region {k!r} (the project keeps {n})")
    return k


def _names(project) -> list[str]:
    return [active_name(project)] + [c.name for c in project.candidates]


def keep_copy(project, name: str | None = None):
    """A copy of the active region kept as a candidate (named ``name``, or the active
    name with a number), so another can be drawn in its place."""
    taken = _names(project)
    if name is None:
        base, k = active_name(project), 2
        while f"{base} {k}" in taken:
            k += 1
        name = f"{base} {k}"
    c = Candidate(_name(name, taken, "a kept region"), project.settings.region)
    return replace(project, candidates=project.candidates + (c,), region_name=active_name(project))


def activate(project, k: int):
    """Candidate ``k`` becomes the active region (settings.region, and its seed kept while
    inside, else its default seed); the active one is kept in its place, shown."""
    k = _index(project, k)
    c = project.candidates[k]
    s = project.settings
    cover = cover_for(project.surface, c.region)
    seed = s.seed if cover.contains(cover.seed_uv(s.seed)[None])[0] else cover.default_seed
    old = Candidate(active_name(project), s.region, True)
    kept = project.candidates[:k] + (old,) + project.candidates[k + 1:]
    return replace(project.with_settings(region=c.region, seed=seed), candidates=kept, region_name=c.name)


def rename(project, k: int | None, name: str):
    """Rename candidate ``k`` (None: the active region)."""
    taken = _names(project)
    current = active_name(project) if k is None else project.candidates[_index(project, k)].name
    taken.remove(current)
    name = _name(name, taken, "a region")
    if k is None:
        return replace(project, region_name=name)
    kept = list(project.candidates)
    kept[k] = replace(kept[k], name=name)
    return replace(project, candidates=tuple(kept))


def set_visible(project, k: int, visible: bool):
    kept = list(project.candidates)
    kept[_index(project, k)] = replace(kept[k], visible=bool(visible))
    return replace(project, candidates=tuple(kept))


def remove(project, k: int):
    k = _index(project, k)
    return replace(project, candidates=project.candidates[:k] + project.candidates[k + 1:])


def candidates_to_dict(project) -> dict | None:
    """The project file's ``candidates`` entry, or None when there is nothing to keep."""
    if not project.candidates and not project.region_name:
        return None
    return {"active_name": active_name(project), "kept": [c.to_dict() for c in project.candidates]}


def candidates_from_dict(d: Any) -> tuple[str, tuple]:
    """(region_name, candidates) of a project file's ``candidates`` entry (None: none kept)."""
    if d is None:
        return "", ()
    if not isinstance(d, dict) or not isinstance(d.get("active_name", ""), str) \
            or not isinstance(d.get("kept", []), list):
        raise SettingsError("candidates must be an object with active_name and a list kept")
    kept = []
    for k, c in enumerate(d.get("kept", [])):
        try:
            kept.append(Candidate.from_dict(c))
        except SettingsError as exc:
            raise SettingsError(f"kept region {k + 1}: {exc}") from None
    return d.get("active_name", ""), tuple(kept)
