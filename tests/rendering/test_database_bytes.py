"""What the rigid database holds (issue 17: <= 64 bytes per triangle, whatever speed,
lifetime or frame span; ``warp_st.rendering.database_bytes``).

Laws:

- every host and device buffer of a rigid database of a static scene, each counted once
  (a device array over a host table is the same memory), stays within the per-triangle
  layout of docs/design/database-size.md: shading tables in the kernels' float type and
  shared with the device, vertex indices per shape, one bottom level per shape;
- a float64 render of shapes made for float32 ones (a scene of exact quadrics, which the
  float64 rigid path serves) uploads tables made in float64, never float32 ones widened.

Memory is counted, not timed; speed is never asserted.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from warp_st.core import tessellate
from warp_st.core.scene import Body, CameraState, Light, Material, Surface
from warp_st.rendering.database_bytes import rigid_tables, total_bytes
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.shape_tables import rigid_shapes
from warp_st.testing import synthetic_scene

CAMERA = CameraState("/Camera", 0.0, np.zeros(3), np.eye(3), focal_length=27.0, horizontal_aperture=36.0,
                     vertical_aperture=36.0)


def instanced_spheres(segments: int, count: int = 16):
    """``count`` copies of one smooth sphere at rest in front of the camera. The points are
    multiples of 2^-20 and the centres small integers, so point - centre is exact in
    float64: every copy's rest points are bit-identical and all share one shape."""
    pts, tris, nrm = tessellate.sphere(1.0, segments)
    pts = np.round(pts * 2.0 ** 20) / 2.0 ** 20
    bodies = []
    for i in range(count):
        centre = np.array([(i % 4) * 3.0 - 4.0, (i // 4) * 3.0 - 4.0, -12.0])
        path = f"/S{i}"
        bodies.append(Body(path, (Surface(path, pts + centre, tris, Material(diffuse=(0.5, 0.5, 0.5)), nrm),),
                           centre, np.zeros(3), 0.0, (-math.inf, math.inf)))
    return synthetic_scene("instanced", bodies, [], CAMERA)


def exact_balls():
    """Two UsdGeom.Spheres as the reader makes them (a tessellation and the analytic
    shape), one moving at 0.6c, lit by a distant light (shadow rays read the sizes)."""
    pts, tris, nrm = tessellate.sphere(1.0)
    bodies = []
    for path, centre, v in (("/A", (-1.2, 0.0, -6.0), (0.0, 0.0, 0.0)), ("/B", (1.2, 0.3, -7.0), (0.6, 0.0, 0.0))):
        m = np.eye(4)
        m[3, :3] = centre
        surf = Surface(path, pts + centre, tris, Material(diffuse=(0.7, 0.4, 0.2)), nrm, sphere=(1.0, m))
        bodies.append(Body(path, (surf,), np.asarray(centre), np.asarray(v), -6.0, (-math.inf, math.inf)))
    sun = Light("distant", (1.0, 1.0, 1.0), direction=(0.3, 0.8, 0.5), prim_path="/Sun")
    return synthetic_scene("balls", bodies, [sun], dataclasses.replace(CAMERA, time=10.0))


def _rendered_bytes(scene, shapes: int):
    """(renderer, its database's tables, bytes per triangle) after one render of
    ``scene``'s 99,840 triangles held in ``shapes`` shapes."""
    r = Renderer(scene, frames=[0.0], width=16, height=16)
    r.render(0.0)
    assert r.database.shapes.triangle_count == 99_840 and r.database.bottom.count == shapes
    tables = rigid_tables(r.database)
    return r, tables, total_bytes(tables) / r.database.shapes.triangle_count


def test_static_rigid_database_stays_within_its_bytes_per_triangle():
    """16 instances of a 6,240-triangle sphere (99,840 triangles). The layout's bytes
    per triangle: normal (3 x float32) 12, size (float32) 4, smooth, body and material
    (int32) 12, and the vertex normals (3 x float32 per vertex, 0.5 vertices per triangle
    of a closed sphere) 6: 34; the one shape's bottom level, shared by 16 bodies
    (accel/blas.py: wide nodes ~19, and the shape's own vertex indices 12 and rest points
    6, which the traversal reads: one vertex store per shape) over 16, ~2.3; the per-body
    and per-segment rows (~1 KB per body over 6,240 triangles) ~0.2. Measured 36.6 (43.2
    with a leaf-order copy of the vertices and faces beside the shape's, 0.7.0; 41.6 with
    wp.Mesh). The bound, 38, leaves 1.4 B for those rows and for the pole's vertices (a
    sphere has slightly more than half a vertex per triangle), and fails for any table of
    8 bytes per triangle more (a float64 copy of the normals or sizes kept beside the
    float32 ones, or vertex indices per body) and for the leaf-order vertex copy back
    (36 bytes per shape triangle, 2.25 here)."""
    r, tables, per_triangle = _rendered_bytes(instanced_spheres(80), shapes=1)
    tris = r.database.shapes.triangle_count
    assert not r.database.shapes.body_merged.any() and len(r.database.shapes.shape_rest) == 1
    assert per_triangle <= 38.0, [(t.name, t.dtype, round(t.nbytes / tris, 1)) for t in tables[:8]]
    # The count sees the bottom level and every upload: a buffer left out would make the
    # bound meaningless.
    names = {t.name for t in tables}
    assert {"host shapes.shape_triangles", "host bottom.node_q", "host shapes.tri_normal"} <= names
    bottom = sum(t.nbytes for t in tables if t.name.startswith("host bottom."))
    assert bottom >= (tris // 16) * 8  # at least the one shape's nodes (~19 bytes per triangle)


@pytest.mark.parametrize("merged", [True, False])
def test_distinct_shapes_stay_within_64_bytes_per_triangle(merged, monkeypatch):
    """16 spheres of 6,240 triangles, each of its own radius (no instancing: 99,840
    triangles), merged into one shape (one motion class: spacetime/merge_classes.merge_plan) or
    held as 16 shapes (merging off). Issue 17's bound, 64 bytes per triangle, is the layout's: the
    shading tables 34 (see above), the shape's vertex indices 12 and rest points 6 (which
    the shading and the traversal both read: one vertex store), and the wide nodes with
    their child boxes a byte per coordinate (accel/blas.py: 64 bytes a node, ~0.17 nodes
    per triangle of these shapes, 11.1). Measured 63.4 (63.3 merged); with the boxes as float32 (112
    bytes a node, 0.7.0) 71.7, with a leaf-order copy of the vertices as well 107.7."""
    scene = instanced_spheres(80)
    bodies = []
    for i, b in enumerate(scene.bodies):
        surf = b.surfaces[0]
        pts = (surf.points - b.origin) * (1.0 + 2.0 ** -10 * (i + 1)) + b.origin  # another radius: another shape
        bodies.append(dataclasses.replace(b, surfaces=(dataclasses.replace(surf, points=pts),)))
    if not merged:
        from warp_st.spacetime import rigid

        monkeypatch.setattr(rigid, "merge_plan", lambda bodies, *a: np.arange(len(bodies), dtype=np.int32))
    r, tables, per_triangle = _rendered_bytes(dataclasses.replace(scene, bodies=tuple(bodies)),
                                              shapes=1 if merged else 16)
    tris = r.database.shapes.triangle_count
    assert per_triangle <= 64.0, [(t.name, t.dtype, round(t.nbytes / tris, 1)) for t in tables[:12]]


def test_float64_upload_of_float32_shapes_has_float64_tables():
    """A scene of exact quadrics (the float64 rigid path's) rendered in float32 first, then
    in float64 from the same cached database: the float64 upload's normals and sizes are
    those of shapes made in float64 (bit for bit), not the float32 tables widened, and
    its image equals a float64 render without the cache's float32 entry."""
    from warp_st.rendering import database_cache

    scene = exact_balls()
    Renderer(scene, frames=[10.0], width=24, height=24).render(10.0)
    r64 = Renderer(scene, frames=[10.0], width=24, height=24, precision="float64")
    assert r64.primitive == "rigid" and not r64.stats.database_built  # the float32 run's database
    exact = rigid_shapes(scene, exact_quadrics=True, dtype=np.float64)
    for name in ("tri_normal", "vert_normal", "tri_size"):
        got = getattr(r64.static, name).numpy()
        want = exact.tri_normal if name == "tri_normal" else exact.vertex_normals if name == "vert_normal" \
            else exact.tri_size
        assert got.dtype == np.float64 and np.array_equal(got, want), name
        assert not np.array_equal(got, want.astype(np.float32).astype(np.float64)), name  # float64 indeed
    img = r64.render(10.0)
    database_cache.clear(scene)
    fresh = Renderer(scene, frames=[10.0], width=24, height=24, precision="float64").render(10.0)
    for c in ("rgba", "depth", "event_time", "object_id", "doppler"):
        assert np.array_equal(getattr(img, c), getattr(fresh, c), equal_nan=True), c
