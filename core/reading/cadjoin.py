"""Several faces of a STEP or IGES file joined into one surface through a mesh.

The faces are tessellated in the CAD reader's child process
(:func:`flatweave.reading.cad.run_child`, Open CASCADE's ``BRepMesh``, nodes with
normals and each edge's node chain), the chains of the edges they share are
welded (:func:`flatweave.geometry.meshfit.weld_parts`), long triangles filled
(:func:`flatweave.geometry.meshfit.densify`), and the mesh is repaired, mapped and
fitted as a mesh file is (:func:`flatweave.geometry.meshfit.mesh_surface`). Kept apart
from :mod:`flatweave.reading.cad` so that its child process loads no mesh fitting.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from flatweave.errors import SettingsError
from flatweave.geometry.meshfit import NeedsRegion, SeveralParts, clean_mesh, densify, mesh_surface, weld_parts
from flatweave.reading.cad import DEFAULT_CHORD_TOL, CadFile, read_timeout, run_child

__all__ = ["join_faces", "JOIN_ANGULAR_DEFLECTION", "JOIN_LINEAR_DEFLECTION", "JOIN_EDGE_LENGTH"]

JOIN_ANGULAR_DEFLECTION = 0.08
"""Largest angle (radians) between the normals along a triangle of the
tessellation of joined faces. The nodes lie on the faces; the points
:func:`flatweave.geometry.meshfit.densify` adds are lifted off the chords by the nodes'
normals (a circle's sagitta to O(a^4))."""

JOIN_LINEAR_DEFLECTION = 2e-4
"""Largest distance of the tessellation of joined faces from them, relative
to the chosen faces' bounding-box diagonal."""

JOIN_EDGE_LENGTH = 1.0 / 50.0
"""Longest triangle edge of joined faces' mesh, relative to their diagonal:
Open CASCADE makes two triangles of a rectangle; the fit needs vertices
inside it too."""


def _joined_pieces(faces: list[dict], edges_of) -> list[list[int]]:
    """The chosen faces grouped into pieces joined through shared edges
    (positions in ``faces``)."""
    parent = list(range(len(faces)))

    def root(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k
    owner = {}
    for k, f in enumerate(faces):  # a face's few dozen edges: no hot loop
        for e in edges_of(f):
            if e in owner:
                parent[root(k)] = root(owner[e])
            else:
                owner[e] = k
    groups = {}
    for k in range(len(faces)):
        groups.setdefault(root(k), []).append(k)
    return list(groups.values())


def join_faces(cad_file: CadFile, indices, *, timeout: float | None = None,
               angular_deflection: float = JOIN_ANGULAR_DEFLECTION,
               linear_deflection: float = JOIN_LINEAR_DEFLECTION, tolerance: float | None = None):
    """Faces ``indices`` of ``cad_file`` joined into one surface by the mesh
    route: tessellated by Open CASCADE (in a child process), welded along
    the edges they share, densified, then :func:`flatweave.geometry.meshfit.mesh_surface`
    (map, fit, region). Returns its :class:`flatweave.geometry.meshfit.MeshPiece`; the
    fit records the faces (``fit.faces``).

    One-line SettingsError when an index is out of range or repeated, the
    faces do not make one connected piece, or they close up (a closed
    surface, a handle); SurfaceError from the mesh checks (three faces along
    one edge)."""

    name = Path(cad_file.path).name
    indices = tuple(indices)
    if not indices:
        raise SettingsError("--faces needs one face index or more")
    seen = set()
    for i in indices:
        cad_file.face(i)  # out of range: one line
        if int(i) in seen:
            raise SettingsError(f"face {i} is given twice")
        seen.add(int(i))
    chosen = [cad_file.face(i) for i in indices]
    box = np.array([f.bbox for f in chosen], float)
    size = float(np.linalg.norm(box[:, 3:].max(axis=0) - box[:, :3].min(axis=0)))
    if not size > 0:
        raise SettingsError(f"faces {', '.join(map(str, indices))} of {name} have no extent")
    task = ("tessellate", ",".join(str(int(i)) for i in indices), repr(linear_deflection * size),
            repr(float(angular_deflection)))
    path = Path(cad_file.path)
    result = run_child(path.resolve(), cad_file.format, DEFAULT_CHORD_TOL, read_timeout(timeout), task)
    parts = result["faces"]
    groups = _joined_pieces(parts, lambda f: [e for e, _ in f["edges"]])
    if len(groups) > 1:
        listed = "; ".join(", ".join(str(parts[k]["index"]) for k in g) for g in groups)
        raise SettingsError(f"faces {', '.join(map(str, indices))} of {name} do not make one piece: they fall "
                            f"into {len(groups)} parts that share no edge ({listed}); choose adjacent faces")
    normals = None if any(p["normals"] is None for p in parts) else [p["normals"] for p in parts]
    V, F, N = weld_parts([(p["nodes"], p["triangles"]) for p in parts],
                         [[(e, nodes) for e, nodes in p["edges"]] for p in parts], normals)
    V, F, _ = densify(V, F, JOIN_EDGE_LENGTH * size, normals=N)
    label = f"faces {', '.join(map(str, indices))} of {name}"
    try:
        V, F, repairs = clean_mesh(V, F, label)
    except SeveralParts:  # the faces share edges, but their triangles do not meet along one
        raise SettingsError(f"{label} could not be welded into one piece: their tessellations do not meet "
                            f"along the edges they share") from None
    try:
        return mesh_surface(V, F, source=os.fspath(path), name=label, repairs=repairs, faces=indices,
                            tolerance=tolerance)
    except NeedsRegion:  # its own advice (a drawn region) is not for joined faces
        raise SettingsError(f"{label} make a closed surface, or one with handles: it cannot be flattened "
                            f"whole; leave some faces out") from None
