"""Pendulum and wall geometry with netgen.occ, and meshing.

Boundary names: "hinge" (top edge of the rod, centred on the pivot),
"head" (outer circle of the ring head, where contact happens), "wall_face"
(the block's contact face x = x_max) and "wall_fixed" (the block's other
edges, clamped). Material names: "pendulum" and "wall".
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING

from netgen.occ import Circle, Compound, MoveTo, OCCGeometry, TopoDS_Shape, X, Y

from .scene import PendulumGeometry, WallBlock
from .shared_state import SHARED_STATE

if TYPE_CHECKING:
    import ngsolve


def pendulum_shape(geo: PendulumGeometry, refine_like_seed: bool = False) -> TopoDS_Shape:
    """The pendulum hanging straight down from the pivot at the origin.

    refine_like_seed reproduces the seed tutorial's local mesh sizes (hinge
    edge w/10, rod w/2, head and hole edges R/20, head face R/5), for
    comparisons on the seed's own mesh."""
    w, d, R, r = geo.rod_half_width, geo.head_centre_depth, geo.head_radius, geo.hole_radius
    rod = MoveTo(-w, -d).Rectangle(2 * w, d).Face()
    rod.edges.Max(Y).name = "hinge"
    ring = Circle((0, -d), R).Face()
    ring.edges.name = "head"
    hole = Circle((0, -d), r).Face()
    if refine_like_seed:
        rod.edges.Max(Y).maxh = w / 10
        rod.faces.maxh = w / 2
        ring.edges.maxh = R / 20
        ring.faces.maxh = R / 5
        hole.edges.maxh = R / 20
    body = (rod + ring) - hole
    body.faces.name = "pendulum"
    return body


def wall_shape(block: WallBlock) -> TopoDS_Shape:
    wall = MoveTo(block.x_min, block.y_min).Rectangle(block.x_max - block.x_min, block.y_max - block.y_min).Face()
    wall.edges.name = "wall_fixed"
    wall.edges.Max(X).name = "wall_face"
    wall.faces.name = "wall"
    return wall


@lru_cache(maxsize=8)
def make_geometry(
    geo: PendulumGeometry,
    block: WallBlock | None = None,
    head_edge_size: float | None = None,
    wall_face_size: float | None = None,
    refine_like_seed: bool = False,
) -> OCCGeometry:
    """OCC geometry of the pendulum, and of the wall block when `block` is given.

    Made once per set of arguments and process (the last 8 kept) and shared by the meshes curved on it:
    making the shape (its boolean operations and named edges) leaves about 19 kB that netgen or
    OpenCascade never frees, which every FE model made again (tests/test_fmu_memory.py). The meshes
    curved on a shared geometry are the same to the last bit. Called under shared_state.SHARED_STATE (by
    make_mesh): the shapes' names and sizes live in netgen's process-wide tables."""
    body = pendulum_shape(geo, refine_like_seed)
    if head_edge_size is not None:
        body.edges["head"].maxh = head_edge_size
    shapes = [body]
    if block is not None:
        wall = wall_shape(block)
        if wall_face_size is not None:
            wall.edges["wall_face"].maxh = wall_face_size
        shapes.append(wall)
    shape = Compound(shapes) if len(shapes) > 1 else body
    return OCCGeometry(shape, dim=2)


def make_mesh(
    geo: PendulumGeometry,
    mesh_size: float,
    order: int,
    block: WallBlock | None = None,
    head_edge_size: float | None = None,
    wall_face_size: float | None = None,
    refine_like_seed: bool = False,
) -> ngsolve.Mesh:
    """A curved NGSolve mesh of the scene (order-`order` geometry).

    The straight-sided mesh is always read back from a netgen .vol file, the
    disk cache's entry (cache.py) or a temporary one when the cache is off, so
    that a cached and a freshly generated mesh are the same to the last bit
    (the file rounds coordinates); curving is redone here."""
    import tempfile
    from dataclasses import asdict

    from netgen.meshing import Mesh as NetgenMesh
    from ngsolve import Mesh

    from .cache import cached_file

    key = {
        "geometry": asdict(geo),
        "block": asdict(block) if block else None,
        "mesh_size": mesh_size,
        "head_edge_size": head_edge_size,
        "wall_face_size": wall_face_size,
        "seed": refine_like_seed,
    }

    with SHARED_STATE:  # netgen's current mesh, geometry and meshing parameters are process-wide
        occ = make_geometry(geo, block, head_edge_size, wall_face_size, refine_like_seed)

        def write(path: Path) -> None:
            occ.GenerateMesh(maxh=mesh_size).Save(str(path))

        ngmesh = NetgenMesh(dim=2)
        path = cached_file("mesh", key, ".vol", write)
        if path is None:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "mesh.vol"
                write(path)
                ngmesh.Load(str(path))
        else:
            ngmesh.Load(str(path))
        ngmesh.SetGeometry(occ)
        mesh = Mesh(ngmesh)
        mesh.Curve(max(order, 2))
    return mesh
