"""Meshing a :class:`~sailforce.solid.layout.Layout` with gmsh: 6-node plane-stress triangles.

Each part is a rectangle with its holes cut out; the parts of one body are
fragmented together so that they share nodes on their interfaces, and nothing
else is (bodies overlap at the joints and must not fuse there).  Every hole
rim is meshed with equally spaced nodes (a transfinite curve), so the mean of
its nodes is its centre: forces spread evenly over a rim then have no moment
about the joint, and a pin passes force only.

The result is plain arrays (:class:`Mesh`): gmsh is initialised and finalised
inside :func:`mesh_layout`, so nothing of it leaks into the caller's process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._extras import require
from ..errors import MeshError, SailError
from .layout import Layout, Part

#: Fewest nodes on a hole rim (corners and mid-side nodes together): enough for a round hole and an even spread.
RIM_MIN_SEGMENTS = 16
#: Elements across the load cell's depth at most this many times smaller than the mesh size: >= 3 quadratic
#: elements through the cell, which bends.
CELL_ELEMENTS_ACROSS = 3
#: gmsh's "Frontal-Delaunay for quads", here without recombining: right-angled triangles aligned with the bars,
#: 14 % fewer nodes than its default (Delaunay-frontal, 6) at the same element size (68 k against 79 k DOF at 2 mm).
MESH_ALGORITHM = 8
#: Tolerance [m] on locating an interface or a rim from gmsh's geometry (a micron on a robot arm).
LOCATE_TOL = 1e-6



@dataclass(frozen=True)
class Mesh:
    """Nodes, elements by part, and named node sets.

    - ``nodes``: ``(n, 3)`` coordinates [m] (z = 0), row k is node ``ids[k]``;
    - ``elements``: part name -> ``(m, 6)`` node ids of CPS6 triangles;
    - ``sets``: set name -> node ids (hole rims; cell faces).
    """

    ids: np.ndarray
    nodes: np.ndarray
    elements: dict[str, np.ndarray]
    sets: dict[str, np.ndarray]

    @property
    def dofs(self) -> int:
        return self.nodes.shape[0] * 2

    def coordinates(self, ids: np.ndarray) -> np.ndarray:
        """``(k, 3)`` coordinates of the nodes ``ids``."""
        order = np.argsort(self.ids)
        return self.nodes[order[np.searchsorted(self.ids, ids, sorter=order)]]


def mesh_layout(layout: Layout, size: float) -> Mesh:
    """Mesh every part at element size ``size`` [m] (finer in the cells)."""
    gmsh = require("gmsh", "solid", "the solid model")
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("sail")
        return _mesh(gmsh, layout, size)
    except Exception as exc:  # gmsh raises plain Exceptions with its log line
        if isinstance(exc, SailError):
            raise
        raise MeshError(f"gmsh could not mesh the arm at {size * 1e3:g} mm: {exc}") from None
    finally:
        gmsh.finalize()


def _mesh(gmsh, layout: Layout, size: float) -> Mesh:
    occ = gmsh.model.occ
    surfaces: dict[str, int] = {}
    for body in dict.fromkeys(p.body for p in layout.parts):
        parts = [p for p in layout.parts if p.body == body]
        tags = [_part_surface(occ, p) for p in parts]
        if len(tags) > 1:
            _, mapping = occ.fragment([(2, tags[0])], [(2, t) for t in tags[1:]])
            tags = [next(t for d, t in m if d == 2) for m in mapping]
        surfaces.update({p.name: t for p, t in zip(parts, tags)})
    occ.synchronize()

    rims = _rims(gmsh, layout, surfaces)
    faces = {f.name: _curve_at(gmsh, surfaces[f.part], layout.part(f.part).point(f.at), f.depth, f.name)
             for f in layout.faces}  # fmt: skip
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size / 20)
    gmsh.option.setNumber("Mesh.Algorithm", MESH_ALGORITHM)
    gmsh.option.setNumber("Mesh.ElementOrder", 2)
    gmsh.option.setNumber("Mesh.SecondOrderLinear", 0)
    for part in layout.parts:
        fine = min(size, part.depth / CELL_ELEMENTS_ACROSS)
        if fine < size:
            points = gmsh.model.getBoundary([(2, surfaces[part.name])], combined=False, recursive=True)
            gmsh.model.mesh.setSize(points, fine)
    for curve, radius in rims.values():
        segments = max(RIM_MIN_SEGMENTS // 2, math.ceil(2 * math.pi * radius / size))
        gmsh.model.mesh.setTransfiniteCurve(curve, segments + 1)
    gmsh.model.mesh.generate(2)
    ids, xyz, _ = gmsh.model.mesh.getNodes()
    nodes = np.asarray(xyz).reshape(-1, 3)
    elements = {}
    for name, tag in surfaces.items():
        types, _, conn = gmsh.model.mesh.getElements(2, tag)
        if list(types) != [9]:
            raise MeshError(f"part {name}: expected 6-node triangles from gmsh, got element types {list(types)}")
        elements[name] = _counter_clockwise(np.asarray(conn[0], dtype=np.int64).reshape(-1, 6), np.asarray(ids), nodes)
    sets = {name: _curve_nodes(gmsh, curve) for name, (curve, _) in rims.items()}
    sets.update({name: _curve_nodes(gmsh, curve) for name, curve in faces.items()})
    return Mesh(np.asarray(ids, dtype=np.int64), nodes, elements, sets)


def _part_surface(occ, part: Part) -> int:
    """The part's rectangle, its holes cut out, placed at its pose."""
    rect = occ.addRectangle(part.start, -part.depth / 2, 0.0, part.stop - part.start, part.depth)
    if part.holes:
        disks = [(2, occ.addDisk(h.at, 0.0, 0.0, h.radius, h.radius)) for h in part.holes]
        for (_, disk), hole in zip(disks, part.holes):  # every rim's seam at global angle 0: bonded rims pair node to node
            occ.rotate([(2, disk)], hole.at, 0.0, 0.0, 0.0, 0.0, 1.0, -part.angle)
        out, _ = occ.cut([(2, rect)], disks)
        if len(out) != 1:
            raise MeshError(f"part {part.name}: its joint holes split it in {len(out)} pieces")
        rect = out[0][1]
    occ.rotate([(2, rect)], 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, part.angle)
    occ.translate([(2, rect)], part.origin[0], part.origin[1], 0.0)
    return rect


def _rims(gmsh, layout: Layout, surfaces: dict[str, int]) -> dict[str, tuple[int, float]]:
    """Rim name -> (gmsh curve, radius) of every hole."""
    rims = {}
    for part in layout.parts:
        for hole in part.holes:
            rims[hole.name] = (_curve_at(gmsh, surfaces[part.name], part.point(hole.at), 2 * math.pi * hole.radius,
                                         hole.name), hole.radius)  # fmt: skip
    return rims


def _curve_at(gmsh, surface: int, centre: tuple[float, float], length: float, name: str) -> int:
    """The boundary curve of ``surface`` whose centre of mass is ``centre`` and whose length is ``length``."""
    for _, curve in gmsh.model.getBoundary([(2, surface)], combined=False, oriented=False):
        x, y, _ = gmsh.model.occ.getCenterOfMass(1, curve)
        if math.hypot(x - centre[0], y - centre[1]) < LOCATE_TOL and abs(gmsh.model.occ.getMass(1, curve) - length) < LOCATE_TOL:
            return curve
    raise MeshError(f"cannot find {name} on the meshed geometry: a part is too small for its holes or its cell face")


def _curve_nodes(gmsh, curve: int, dim: int = 1) -> np.ndarray:
    ids, _, _ = gmsh.model.mesh.getNodes(dim, curve, includeBoundary=True)
    return np.unique(np.asarray(ids, dtype=np.int64))


def _counter_clockwise(conn: np.ndarray, ids: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Triangles turned counter-clockwise where gmsh gave them clockwise (CalculiX refuses negative areas)."""
    order = np.argsort(ids)
    xy = nodes[order[np.searchsorted(ids, conn[:, :3], sorter=order)], :2]  # (m, 3, 2)
    a, b, c = xy[:, 0], xy[:, 1], xy[:, 2]
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    flipped = conn.copy()
    flipped[area < 0] = conn[area < 0][:, [0, 2, 1, 5, 4, 3]]
    return flipped

