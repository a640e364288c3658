"""Test helpers: databases built straight from host dataclasses, rays cast through them."""
import numpy as np
import warp as wp

from warp_st.core import tessellate
from warp_st.core.scene import Body, Material, RenderSettings, Scene, Surface
from warp_st.kernels import get_kernels
from warp_st.rendering.device import StaticArrays, make_geometry
from warp_st.rendering.renderer import build_database, init_warp


def sphere_body(path, centre, radius, velocity=(0, 0, 0), *, segments=24, decoupled=False, lifetime=(-np.inf, np.inf), t_ref=0.0):
    pts, tris, nrm = tessellate.sphere(radius, segments)
    centre = np.asarray(centre, float)
    return Body(
        prim_path=path,
        surfaces=(Surface(path, pts + centre, tris, Material(), nrm),),
        origin=centre,
        velocity=np.asarray(velocity, float),
        reference_time=t_ref,
        lifetime=lifetime,
        decoupled=decoupled,
    )


def cube_body(path, centre, size, velocity=(0, 0, 0), *, decoupled=False, lifetime=(-np.inf, np.inf), t_ref=0.0):
    pts, tris = tessellate.cube(size)
    centre = np.asarray(centre, float)
    return Body(path, (Surface(path, pts + centre, tris, Material()),), centre, np.asarray(velocity, float), t_ref, lifetime, decoupled)


def scene_of(*bodies):
    return Scene(source="<test>", bodies=tuple(bodies), lights=(), cameras=(), settings=RenderSettings())


class Database:
    """A scene extruded over fixed windows, uploaded for one render origin."""

    def __init__(self, scene, windows, *, precision="float32", origin=(0, 0, 0, 0), primitive="tet"):
        init_warp()
        self.k = get_kernels(precision, primitive)
        self.np_scalar = np.float32 if precision == "float32" else np.float64
        self.mesh, self.bvh = build_database(scene, windows, primitive)
        self.static = StaticArrays(self.k, self.mesh, self.bvh)
        self.origin = np.asarray(origin, dtype=np.float64)
        self.geo = make_geometry(self.k, self.static, self.mesh, self.bvh, self.origin)
        self.prim_tri = self.mesh.prism_tri if primitive == "prism" else self.mesh.tet_tri
        self.prim_count = self.mesh.prim_count

    def cast(self, origins, dirs, *, finite=True, brute=False, kernel=None):
        """(primitive, s, visits) for rays with lab origins (N, 4) and unit directions (N, 3);
        primitive indices refer to ``mesh.tets`` or ``mesh.prisms`` (``self.prim_tri`` maps
        them to triangles). ``kernel``: a probe in place of ``cast_rays`` (its arguments)."""
        k = self.k
        rel = np.asarray(origins, np.float64) - self.origin
        o = wp.array(rel.astype(self.np_scalar), dtype=k.vec4, device="cpu")
        d = wp.array(np.asarray(dirs, np.float64).astype(self.np_scalar), dtype=k.vec3, device="cpu")
        n = len(rel)
        tet = wp.zeros(n, dtype=wp.int32, device="cpu")
        s = wp.zeros(n, dtype=k.scalar, device="cpu")
        if brute:
            wp.launch(k.brute_rays, dim=n, inputs=[self.geo, self.prim_count, o, d, int(finite), tet, s], device="cpu")
            return tet.numpy(), s.numpy().astype(np.float64), None
        visits = wp.zeros(n, dtype=wp.int32, device="cpu")
        wp.launch(kernel or k.cast_rays, dim=n, inputs=[self.geo, o, d, int(finite), tet, s, visits, 0], device="cpu")
        return tet.numpy(), s.numpy().astype(np.float64), visits.numpy()


class RigidDatabase(Database):
    """The two-level rigid database of a scene (bottom levels per shape, a top level over
    the motion segments of fixed windows), uploaded for one render origin. ``cast``
    returns global triangle indices (``prim_tri`` is the identity), numbered as the
    extrusion numbers them when every body has a window: the database's own are each
    shape's triangles in its bottom level's leaf order (``accel.blas.bottom_levels``),
    ``original`` maps them back."""

    def __init__(self, scene, windows, *, origin=(0, 0, 0, 0)):
        from warp_st.accel.blas import leaf_order
        from warp_st.accel.instances import BottomLevels, build_top_level
        from warp_st.rendering.device_rigid import RigidArrays, make_rigid_geometry
        from warp_st.spacetime.rigid import motion_segments
        from warp_st.spacetime.shape_tables import renumbered, rigid_shapes, triangle_order

        init_warp()
        self.k = get_kernels("float32", "rigid")
        self.np_scalar = np.float32
        shapes = rigid_shapes(scene)
        self.bottom = BottomLevels(shapes)  # as accel.blas.bottom_levels, keeping the orders
        self.original = triangle_order(shapes, self.bottom.orders)
        self.shapes = renumbered(shapes, self.bottom.orders, self.bottom.vidx, self.bottom.points, leaf_order)
        self.segments = motion_segments(scene, self.shapes, windows)
        self.bvh = build_top_level(self.segments)
        self.static = RigidArrays(self.k, self.shapes, self.bottom, self.segments, self.bvh)
        self.origin = np.asarray(origin, dtype=np.float64)
        self.geo = make_rigid_geometry(self.k, self.static, self.segments, self.bvh, self.origin)
        self.prim_tri = np.arange(self.shapes.triangle_count)
        self.prim_count = self.segments.count

    def cast(self, origins, dirs, *, finite=True, brute=False, kernel=None):
        tri, s, visits = super().cast(origins, dirs, finite=finite, brute=brute, kernel=kernel)
        return np.where(tri >= 0, self.original[np.maximum(tri, 0)], tri), s, visits


def solve_tets_f64(events, origin, direction, finite=True):
    """Float64 oracle: solve O + s d = V0 + a e1 + b e2 + c e3 for every tetrahedron.

    events: (N, 4, 4) tetrahedron events; returns (s (N,), barycentrics (N, 4)) with
    NaN where the 4x4 system is singular (ray parallel to the tetrahedron's hyperplane).
    """
    d4 = np.array([-1.0 if finite else 0.0, *direction])
    v0 = events[:, 0, :]
    m = np.stack([events[:, 1] - v0, events[:, 2] - v0, events[:, 3] - v0, np.broadcast_to(-d4, v0.shape)], axis=2)
    rhs = np.asarray(origin, float)[None, :] - v0
    det = np.linalg.det(m)
    ok = np.abs(det) > 1e-12 * np.abs(m).max(axis=(1, 2)) ** 4
    sol = np.full((len(events), 4), np.nan)
    if ok.any():
        sol[ok] = np.linalg.solve(m[ok], rhs[ok][..., None])[..., 0]
    abc, s = sol[:, :3], sol[:, 3]
    lam = np.concatenate([1.0 - abc.sum(axis=1, keepdims=True), abc], axis=1)
    return s, lam


def mixed_scene():
    """Bodies at rest and moving, coupled and decoupled (2c), with finite lifetimes
    (the scene of tests/accel/test_tracing.py and tests/spacetime/test_prisms.py)."""
    return scene_of(
        sphere_body("/Coupled", (0, 0, -4), 1.0, (0.9, 0, 0), lifetime=(-20.0, 2.0)),
        cube_body("/Superluminal", (2, 1, -6), 1.5, (-2.0, 0, 0.3), decoupled=True),
        sphere_body("/Still", (-2, -1, -5), 0.7),
        cube_body("/Fast", (1, -2, -3), 0.8, (0, 0.99, 0), lifetime=(-15.0, -3.0)),
    )


def tube_windows(scene, lo=-25.0, hi=5.0):
    """Each body's extrusion window: its lifetime cut to [lo, hi]."""
    return [(max(lo, b.lifetime[0]), min(hi, b.lifetime[1])) for b in scene.bodies]


def random_rays(rng, n, db, finite=True):
    """Half aimed at random events on the world-tubes (from 0.5-8 units away, so
    lifetimes and windows are crossed), half random from random events (mostly misses)."""
    events = db.mesh.tet_events()
    pick = rng.integers(0, len(events), n)
    lam = rng.dirichlet(np.ones(4), n)
    targets = np.einsum("nk,nkj->nj", lam, events[pick])
    view = rng.normal(size=(n, 3))
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    dist = rng.uniform(0.5, 8.0, n)
    origins = np.column_stack([targets[:, 0] + (dist if finite else 0.0), targets[:, 1:] + dist[:, None] * view])
    dirs = -view
    half = n // 2
    origins[half:] = np.column_stack([rng.uniform(-20, 4, n - half), rng.uniform(-4, 4, (n - half, 2)), rng.uniform(-8, 2, n - half)])
    return origins, dirs
