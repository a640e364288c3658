"""The bottom level (accel/blas.py, kernels/blas.py) against brute force, wp.Mesh and its twin.

Law: the closest crossing of a float32 ray p + t d (t in [0, t_max]) with a shape's
triangles. Oracles, on every shipped stage's shapes and on hand-made ones with
degenerate triangles:

- brute force in float64 over every triangle (Moeller-Trumbore, no BVH): the same rays
  hit, the same t to float32 rounding (the test itself is float32: the hit moves by a
  few ulps of the coordinates across the surface, so along the ray by that over
  cos(theta), and by the triangle's aspect ratio; |t - t64| |cos theta| <= 1e-5
  (|p| + t |d|) aspect, ~80 ulps), and the same
  triangle unless the float64 hit lies within rounding of that triangle's edge (there
  either neighbour is right);
- ``wp.Mesh`` over the same triangles, whose test is the same algorithm with fused
  products: the same hits where neither is within rounding of an edge;
- any-hit: a hit exactly when the closest-hit query finds one;
- watertightness: rays aimed exactly at the shared vertices and edge points of closed
  meshes (a tessellated sphere, a cube) never pass through;
- the Warp-language twin (``blas_twin.py``) of the C++ query: the same bits (t,
  barycentrics, face) for closest and any hits and for the merged shapes' filter.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import warp as wp
from blas_twin import make_blas_twin

from warp_st.accel.blas import BottomLevels
from warp_st.core import tessellate
from warp_st.kernels import get_kernels
from warp_st.kernels.blas import make_blas_query, ray_inv, ray_shear
from warp_st.kernels.layout import LINK_SHIFT, WIDTH
from warp_st.rendering.warp_init import init_warp

ROOT = Path(__file__).resolve().parents[2]
#: Conditioned t error bound (see the module docstring and ``_t_error``): ~80 ulps.
T_TOL = 1.0e-5
#: A float64 hit this close to an edge of its triangle (relative to the coordinates,
#: over cos(theta)) may be found on the neighbour, or missed at a silhouette, by a float32
#: test: ~8 float32 ulps.
EDGE_TOL = 1.0e-6


#: The rigid path's Geometry; only its bottom-level arrays are set here.
Blas = get_kernels("float32", "rigid").Geometry
_sheared = make_blas_query(Blas)


@wp.func
def _query(g: Blas, root: int, vert: int, tri0: int, p: wp.vec3, d: wp.vec3, t_max: float, any_hit: int,
           tri_base: int, skip_body: int, skip_t: float, skip_tri: int):
    """The query of direction ``d``, as the twin takes it: its shear and reciprocals made
    here (so the twin's own, in the Warp language, check them too)."""
    hit, t, u, v, face = _sheared(g, root, vert, tri0, p, ray_shear(d), ray_inv(d), t_max, any_hit, tri_base, skip_body,
                                  skip_t, skip_tri)
    return hit, t, u, v, face
_twin = make_blas_twin(Blas)


@wp.kernel(enable_backward=False, module="unique")
def _blas_rays(g: Blas, root: int, p: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), t_max: float,
               any_hit: int, face: wp.array(dtype=wp.int32), t: wp.array(dtype=float), uv: wp.array(dtype=wp.vec2)):
    i = wp.tid()
    hit, tt, u, v, f = _query(g, root, 0, 0, p[i], d[i], t_max, any_hit, 0, -1, 0.0, -1)
    face[i] = wp.where(hit != 0, f, -1)
    t[i] = tt
    uv[i] = wp.vec2(u, v)


@wp.kernel(enable_backward=False, module="unique")
def _pair_rays(g: Blas, root: int, p: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), t_max: float,
               any_hit: int, skip_body: int, skip_t: float, skip_tri: int, out: wp.array(dtype=wp.vec4),
               out_twin: wp.array(dtype=wp.vec4), faces: wp.array(dtype=wp.vec2i)):
    """The C++ query and its twin on the same ray, the filter's arguments at run time."""
    i = wp.tid()
    hit, tt, u, v, f = _query(g, root, 0, 0, p[i], d[i], t_max, any_hit, 0, skip_body, skip_t, skip_tri)
    hit2, tt2, u2, v2, f2 = _twin(g, root, 0, 0, p[i], d[i], t_max, any_hit, 0, skip_body, skip_t, skip_tri)
    out[i] = wp.vec4(tt, u, v, float(hit))
    out_twin[i] = wp.vec4(tt2, u2, v2, float(hit2))
    faces[i] = wp.vec2i(wp.where(hit != 0, f, -1), wp.where(hit2 != 0, f2, -1))


@wp.kernel(enable_backward=False, module="unique")
def _mesh_rays(mesh: wp.uint64, p: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), t_max: float,
               face: wp.array(dtype=wp.int32), t: wp.array(dtype=float)):
    i = wp.tid()
    q = wp.mesh_query_ray(mesh, p[i], d[i], t_max)
    face[i] = wp.where(q.result, q.face, -1)
    t[i] = wp.where(q.result, q.t, t_max)


class Shape:
    """One shape's bottom level (as the renderer builds it) and its float32 triangles,
    renumbered into the tree's leaf order as the renderer's shapes are
    (``accel.blas.bottom_levels``): the faces the query returns index ``triangles``."""

    def __init__(self, points, triangles):
        init_warp()
        self.points = np.asarray(points, np.float32)
        triangles = np.asarray(triangles, np.int64).reshape(-1, 3)

        class _Shapes:  # what BottomLevels reads of spacetime.rigid.RigidShapes
            shape_rest = [self.points]
            shape_triangles = [triangles]
            body_shape = np.array([0])

        self.bottom = BottomLevels(_Shapes)
        self.order = self.bottom.orders[0]  # leaf slot -> the triangle's index in ``triangles`` given
        self.triangles = triangles[self.order]
        assert np.array_equal(self.bottom.vidx, self.triangles)
        self.g = Blas()
        for name, attr, dtype in (("blas_q", "node_q", wp.types.vector(24, wp.uint8)),
                                  ("blas_frame", "node_frame", wp.types.vector(6, wp.float32)),
                                  ("blas_link", "node_link", wp.vec4i), ("shape_vidx", "vidx", wp.vec3i),
                                  ("blas_points", "points", wp.vec3)):
            setattr(self.g, name, wp.array(getattr(self.bottom, attr), dtype=dtype, device="cpu"))

    def query(self, p, d, t_max=1.0e30, any_hit=False):
        n = len(p)
        face = wp.zeros(n, dtype=wp.int32, device="cpu")
        t = wp.zeros(n, dtype=float, device="cpu")
        uv = wp.zeros(n, dtype=wp.vec2, device="cpu")
        wp.launch(_blas_rays, dim=n, inputs=[self.g, int(self.bottom.body_root[0]), _vec3(p), _vec3(d),
                                              float(t_max), int(any_hit), face, t, uv], device="cpu")
        return face.numpy(), t.numpy().astype(np.float64), uv.numpy()

    def pair_query(self, p, d, t_max=1.0e30, any_hit=False, skip=(-1, 0.0, -1)):
        """(C++ (t, u, v, hit), twin's, faces (N, 2)) of the same rays."""
        n = len(p)
        out = [wp.zeros(n, dtype=wp.vec4, device="cpu") for _ in range(2)]
        faces = wp.zeros(n, dtype=wp.vec2i, device="cpu")
        wp.launch(_pair_rays, dim=n, inputs=[self.g, int(self.bottom.body_root[0]), _vec3(p), _vec3(d), float(t_max),
                                              int(any_hit), int(skip[0]), float(skip[1]), int(skip[2]), *out, faces],
                  device="cpu")
        return out[0].numpy(), out[1].numpy(), faces.numpy()

    def mesh_query(self, p, d, t_max=1.0e30):
        mesh = wp.Mesh(points=wp.array(self.points, dtype=wp.vec3, device="cpu"),
                       indices=wp.array(self.triangles.reshape(-1).astype(np.int32), dtype=wp.int32, device="cpu"))
        n = len(p)
        face = wp.zeros(n, dtype=wp.int32, device="cpu")
        t = wp.zeros(n, dtype=float, device="cpu")
        wp.launch(_mesh_rays, dim=n, inputs=[mesh.id, _vec3(p), _vec3(d), float(t_max), face, t], device="cpu")
        return face.numpy(), t.numpy().astype(np.float64)

    def brute(self, p, d, t_max=1.0e30):
        """float64 closest hit over every triangle: (face or -1, t, barycentrics (N, 3))."""
        tri = self.points.astype(np.float64)[self.triangles]  # (T, 3, 3)
        a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        p = np.asarray(p, np.float32).astype(np.float64)
        d = np.asarray(d, np.float32).astype(np.float64)
        face = np.full(len(p), -1)
        best = np.full(len(p), float(t_max))
        bary = np.zeros((len(p), 3))
        for lo in range(0, len(p), 256):
            pp, dd = p[lo:lo + 256, None], d[lo:lo + 256, None]
            h = np.cross(dd, e2[None])
            det = np.sum(e1[None] * h, axis=-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / det
                s = pp - a[None]
                u = np.sum(s * h, axis=-1) * inv
                q = np.cross(s, e1[None])
                v = np.sum(dd * q, axis=-1) * inv
                t = np.sum(e2[None] * q, axis=-1) * inv
            ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= t_max)
            t = np.where(ok, t, np.inf)
            j = np.argmin(t, axis=1)
            rows = np.arange(len(j))
            hit = np.isfinite(t[rows, j])
            face[lo:lo + 256] = np.where(hit, j, -1)
            best[lo:lo + 256] = np.where(hit, t[rows, j], t_max)
            bary[lo:lo + 256] = np.stack([1 - u[rows, j] - v[rows, j], u[rows, j], v[rows, j]], axis=1)
        return face, best, bary

    def cos(self, face, d):
        tri = self.points.astype(np.float64)[self.triangles[face]]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return np.abs(np.sum(n * d, axis=1)) / np.linalg.norm(d, axis=1)


def _vec3(x):
    return wp.array(np.ascontiguousarray(x, np.float32), dtype=wp.vec3, device="cpu")


def _rays(shape: Shape, n: int, seed: int):
    """Random rays from around the shape's box towards random points of it, plus rays
    aimed at random points of random triangles, edges and vertices, and rays in a
    triangle's plane (edge-on)."""
    rng = np.random.default_rng(seed)
    lo, hi = shape.points.min(axis=0), shape.points.max(axis=0)
    size = float(np.max(hi - lo)) or 1.0
    centre = 0.5 * (lo + hi)
    tri = shape.points.astype(np.float64)[shape.triangles]
    k = n // 4
    origins = centre + rng.normal(size=(n, 3)) * size
    targets = np.empty((n, 3))
    targets[:k] = lo + rng.uniform(size=(k, 3)) * (hi - lo)
    pick = rng.integers(0, len(tri), size=n - k)
    w = rng.dirichlet(np.ones(3), size=n - k)
    w[: (n - k) // 3, 0] = 0.0  # on an edge
    w[: (n - k) // 3] /= w[: (n - k) // 3].sum(axis=1, keepdims=True)
    w[(n - k) // 3: (n - k) // 2] = np.eye(3)[rng.integers(0, 3, size=(n - k) // 2 - (n - k) // 3)]  # a vertex
    targets[k:] = np.einsum("nk,nkj->nj", w, tri[pick])
    # Grazing: half of the aimed rays come along an edge of their triangle, 1e-3 rad
    # out of its plane (exactly in the plane, a hit is undefined: the float64 test sees
    # det = 0, a float32 one the rounding's sign).
    m = k + (n - k) // 2
    t3 = tri[pick[m - k:]]
    e = t3[:, 1] - t3[:, 0]
    normal = np.cross(e, t3[:, 2] - t3[:, 0])
    normal *= (np.linalg.norm(e, axis=1) / np.maximum(np.linalg.norm(normal, axis=1), 1e-300))[:, None]
    lift = 1.0e-3 * rng.choice([-1.0, 1.0], size=(n - m, 1))
    origins[m:] = targets[m:] - (e + lift * normal) * rng.uniform(1.0, 3.0, size=(n - m, 1))
    d = targets - origins
    return origins.astype(np.float32), d.astype(np.float32)


def _near_edge(shape: Shape, face, p, d):
    """Rays whose float64 crossing of the plane of triangle ``face`` (-1: none) lies
    within rounding of that triangle's boundary, inside or out: closer to it than
    EDGE_TOL times the coordinates' scale, over cos(theta) (a grazing ray's crossing
    moves farther along the surface). There a float32 test may pick the neighbour, or
    hit where float64 misses, or miss."""
    out = np.zeros(len(face), bool)
    hit = face >= 0
    tri = shape.points.astype(np.float64)[shape.triangles[face[hit]]]
    pp = np.asarray(p, np.float32).astype(np.float64)[hit]
    dd = np.asarray(d, np.float32).astype(np.float64)[hit]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    h = np.cross(dd, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.sum(e1 * h, axis=1)
        s = pp - tri[:, 0]
        u = np.sum(s * h, axis=1) * inv
        q = np.cross(s, e1)
        v = np.sum(dd * q, axis=1) * inv
        t = np.sum(e2 * q, axis=1) * inv
    bary = np.stack([1 - u - v, u, v], axis=1)
    twice_area = np.linalg.norm(np.cross(e1, e2), axis=1)
    # Height over the edge opposite vertex i: 2 area / |edge i|.
    edges = np.stack([tri[:, 2] - tri[:, 1], tri[:, 0] - tri[:, 2], e1], axis=1)
    height = twice_area[:, None] / np.maximum(np.linalg.norm(edges, axis=2), 1e-300)
    dist = np.min(np.abs(bary) * height, axis=1)
    t = np.where(np.isfinite(t), np.abs(t), 0.0)
    scale = np.abs(pp).max(axis=1) + t * np.abs(dd).max(axis=1) + np.abs(tri).max(axis=(1, 2))
    cos = np.maximum(shape.cos(face[hit], dd), 1e-3)
    out[hit] = ~(dist > EDGE_TOL * scale / cos)  # NaN (a ray in the plane): near
    return out


def _t_error(shape: Shape, face, t, t_ref, p, d):
    """|t - t_ref| conditioned (see T_TOL): times cos(theta) (a grazing ray slides along
    the surface), over the coordinates' scale |p| + t |d| and over the triangle's aspect
    (its longest edge over its smallest height: a float32 test's barycentric weights
    carry ulps of the edges over the height)."""
    tri = shape.points.astype(np.float64)[shape.triangles[np.maximum(face, 0)]]
    edges = np.stack([tri[:, 2] - tri[:, 1], tri[:, 0] - tri[:, 2], tri[:, 1] - tri[:, 0]], axis=1)
    length = np.linalg.norm(edges, axis=2)
    twice_area = np.linalg.norm(np.cross(edges[:, 2], -edges[:, 1]), axis=1)
    aspect = length.max(axis=1) ** 2 / np.maximum(twice_area, 1e-300)
    scale = np.linalg.norm(p, axis=1) + np.abs(t_ref) * np.linalg.norm(d, axis=1)
    return np.abs(t - t_ref) * shape.cos(np.maximum(face, 0), d) / (np.maximum(scale, 1e-30) * aspect)


def _stage_shapes():
    import warp_st
    from warp_st.spacetime.shape_tables import rigid_shapes

    out = []
    for stage in sorted((ROOT / "usd_scenes").rglob("*.usda")):
        try:
            scene = warp_st.load(str(stage))
        except Exception:  # stages that need more than a load (layers, errors on purpose)
            continue
        shapes = rigid_shapes(scene)
        for rest, tris in zip(shapes.shape_rest, shapes.shape_triangles):
            if len(tris):
                out.append((f"{stage.relative_to(ROOT / 'usd_scenes')}:{len(tris)}", rest, tris))
    return out


def _degenerate_shape():
    """A strip of triangles with collapsed ones: repeated vertices, collinear ones, and
    zero-area slivers, next to ordinary ones."""
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0], [3, 0, 0], [2, 1, 0],
                    [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
    tris = np.array([[0, 1, 2], [1, 3, 2], [1, 1, 3], [4, 5, 5], [4, 5, 1], [2, 2, 2], [1, 4, 6],
                     [7, 8, 9], [0, 1, 4]])
    return pts, tris


def test_closest_hits_equal_brute_force_on_the_shipped_shapes():
    shapes = _stage_shapes()
    assert len(shapes) >= 20
    for i, (name, rest, tris) in enumerate(shapes):
        shape = Shape(rest, tris)
        p, d = _rays(shape, 1200, seed=i)
        face, t, _uv = shape.query(p, d)
        ref, t_ref, bary = shape.brute(p, d)
        near_edge = _near_edge(shape, ref, p, d) | _near_edge(shape, face, p, d)
        # Hit or miss: the same, except rays through an edge of the silhouette (there
        # the float64 hit is within rounding of leaving the shape).
        assert np.array_equal((face >= 0)[~near_edge], (ref >= 0)[~near_edge]), name
        # The same triangle at the same t (to float32 rounding); another triangle only
        # where the hit is within rounding of an edge, or where two lie at the same t
        # (a fold, a duplicate).
        both = (face >= 0) & (ref >= 0)
        err = _t_error(shape, ref, t, t_ref, p, d)
        alike = both & (face == ref)
        assert alike.sum() > 0.3 * len(p), name
        assert err[alike].max(initial=0.0) <= T_TOL, (name, float(err[alike].max()))
        other = both & (face != ref) & ~near_edge
        assert err[other].max(initial=0.0) <= T_TOL, (name, float(err[other].max()))


def test_closest_hits_equal_wp_mesh():
    for i, (name, rest, tris) in enumerate(_stage_shapes()[::3]):
        shape = Shape(rest, tris)
        p, d = _rays(shape, 800, seed=100 + i)
        face, t, _uv = shape.query(p, d)
        m_face, m_t = shape.mesh_query(p, d)
        ref, t_ref, bary = shape.brute(p, d)
        clear = ~(_near_edge(shape, ref, p, d) | _near_edge(shape, face, p, d) | _near_edge(shape, m_face, p, d))
        assert np.array_equal(face[clear] >= 0, m_face[clear] >= 0), name
        # The same t to float32 rounding (the triangle may differ where two lie at that
        # t: the flanges hold coincident faces).
        both = clear & (face >= 0)
        err = _t_error(shape, face, t, m_t, p, d)
        assert err[both].max(initial=0.0) <= T_TOL, (name, float(err[both].max()))


def test_the_cpp_query_is_its_warp_twin_bit_for_bit():
    """Every shipped shape (and the degenerate strip), closest and any hits, a short and
    an unbounded t_max, and a merged shape's filter (each triangle given one of three
    bodies; one body and one triangle left out below a lookback): t, barycentrics and
    face bit for bit, as the two compute the same float32 and float64 operations in the
    same order (a different rounding, lane or tie order shows here)."""
    cases = [(name, rest, tris) for name, rest, tris in _stage_shapes()] + [("degenerate", *_degenerate_shape())]
    hits = 0
    for i, (name, rest, tris) in enumerate(cases):
        shape = Shape(rest, tris)
        shape.g.tri_body = wp.array(np.arange(len(shape.triangles), dtype=np.int32) % 3, dtype=wp.int32, device="cpu")
        p, d = _rays(shape, 600, seed=300 + i)
        size = float(np.max(np.ptp(shape.points, axis=0))) or 1.0
        for t_max, any_hit, skip in ((1.0e30, False, (-1, 0.0, -1)), (0.7, False, (-1, 0.0, -1)),
                                     (1.0e30, True, (-1, 0.0, -1)), (1.0e30, False, (1, 2.0 * size, 5))):
            ours, twin, faces = shape.pair_query(p, d, t_max, any_hit, skip)
            assert np.array_equal(faces[:, 0], faces[:, 1]), (name, t_max, any_hit, skip)
            assert np.array_equal(ours.view(np.uint32), twin.view(np.uint32)), (name, t_max, any_hit, skip)
            hits += int((faces[:, 0] >= 0).sum())
    assert hits > 20000  # the rays do meet the shapes


def test_any_hit_finds_a_hit_exactly_when_the_closest_hit_does():
    rng = np.random.default_rng(7)
    pts, tris, _n = tessellate.sphere(1.0, 24)
    shape = Shape(pts, tris)
    p, d = _rays(shape, 2000, seed=3)
    for t_max in (0.3, 1.0, 1.0e30):
        face, t, _uv = shape.query(p, d, t_max=t_max)
        any_face, any_t, _ = shape.query(p, d, t_max=t_max, any_hit=True)
        assert np.array_equal(face >= 0, any_face >= 0), t_max
        assert np.all(any_t[any_face >= 0] <= t_max)
        assert np.all(any_t[any_face >= 0] >= t[any_face >= 0])  # any hit: not nearer than the closest
    del rng


def test_degenerate_triangles_are_never_hit_and_do_not_hide_others():
    pts, tris = _degenerate_shape()
    shape = Shape(pts, tris)
    p, d = _rays(shape, 3000, seed=11)
    face, t, _uv = shape.query(p, d)
    ref, t_ref, bary = shape.brute(p, d)
    degenerate = np.array([2, 3, 5, 4])  # zero area: repeated or collinear vertices (_degenerate_shape's rows)
    assert not np.isin(shape.order[face[face >= 0]], degenerate[:3]).any()
    near_edge = _near_edge(shape, ref, p, d) | _near_edge(shape, face, p, d)
    assert np.array_equal((face >= 0)[~near_edge], (ref >= 0)[~near_edge])


@pytest.mark.parametrize("segments", [8, 24])
def test_rays_through_shared_edges_and_vertices_of_a_closed_mesh_hit(segments):
    """Watertight: a ray through a vertex or a point of an edge of a closed convex mesh
    into its inside (from outside, towards the centre, within 6 degrees) always hits,
    however the float32 target rounds: it cannot pass between the triangles that meet
    there. (Such rays hit the triangles at their edges, where a test that rounds the two
    neighbours' edge functions differently misses both.)"""
    rng = np.random.default_rng(segments)
    for pts, tris in (tessellate.sphere(1.0, segments)[:2], tessellate.cube(1.0)):
        shape = Shape(pts, tris)
        tri = shape.points[shape.triangles]
        centre = shape.points.astype(np.float64).mean(axis=0)
        pick = rng.integers(0, len(tri), size=3000)
        w = np.zeros((3000, 3))
        w[:1000] = np.eye(3)[rng.integers(0, 3, size=1000)]  # vertices
        f = rng.uniform(size=2000)
        w[1000:, 0], w[1000:, 1] = f, 1 - f  # edges
        target = np.einsum("nk,nkj->nj", w, tri[pick].astype(np.float64))
        out = target - centre
        size = np.linalg.norm(out, axis=1, keepdims=True)
        origin = target + out * rng.uniform(1.0, 3.0, size=(3000, 1)) + 0.1 * size * rng.uniform(-1, 1, (3000, 3))
        origin, target = origin.astype(np.float32), target.astype(np.float32)
        face, t, _uv = shape.query(origin, target - origin)
        assert (face >= 0).all(), (segments, len(tri), int((face < 0).sum()))


def test_axis_rays_through_the_diagonals_and_edges_of_a_cube_hit():
    """Watertight, exactly: rays along the axes through points of a cube face's diagonal
    (the edge its two triangles share) and of its border, at binary fractions (so the
    ray meets the edge exactly: an edge function is exactly 0 there), always hit."""
    pts, tris = tessellate.cube(1.0)
    shape = Shape(pts, tris)
    t = np.arange(-8, 9) / 16.0  # -0.5 .. 0.5: the border at the ends
    origins, dirs = [], []
    for axis in range(3):
        u_axis, v_axis = [k for k in range(3) if k != axis]
        for sign in (1.0, -1.0):
            for u in t:
                for v in (u, -u, 0.5, -0.5):
                    p = np.zeros(3)
                    p[u_axis], p[v_axis], p[axis] = u, v, 5.0 * sign
                    d = np.zeros(3)
                    d[axis] = -sign
                    origins.append(p)
                    dirs.append(d)
    face, t_hit, _uv = shape.query(np.array(origins), np.array(dirs))
    assert (face >= 0).all(), int((face < 0).sum())
    assert np.allclose(t_hit, 4.5)  # the face at 0.5, exactly 4.5 from the origin plane


def test_renumbered_shapes_keep_every_table_with_its_triangle():
    """``bottom_levels`` renumbers each shape's triangles into its leaf order: every
    per-triangle table moves with its triangle (the row a hit returns shades as before),
    the shapes' vertex indices are the rows the traversal reads, and a remake of the
    tables in float64 (``shading_tables``) follows the same order. Oracle: the tables of
    ``rigid_shapes`` before renumbering, permuted by ``triangle_order``."""
    import warp_st
    from warp_st.accel.blas import bottom_levels
    from warp_st.spacetime.shape_tables import rigid_shapes, shading_tables, triangle_order

    scene = warp_st.load(str(ROOT / "usd_scenes" / "thesis" / "stage.usda"))
    before = rigid_shapes(scene)
    kept = BottomLevels(before)
    perm = triangle_order(before, kept.orders)
    shapes, bottom = bottom_levels(before)
    assert bottom.orders is None and not np.array_equal(perm, np.arange(len(perm)))  # renumbered indeed
    for name in ("tri_normal", "tri_smooth", "tri_size", "tri_body", "tri_material"):
        assert np.array_equal(getattr(shapes, name), getattr(before, name)[perm]), name
    assert shapes.shape_vidx is bottom.vidx
    for b in np.flatnonzero(before.body_shape >= 0):  # body b's triangle k is its shape's row k
        s, base, first = before.body_shape[b], before.body_tri_base[b], before.body_shape_tri[b]
        n = len(before.shape_triangles[s])
        assert np.array_equal(shapes.shape_vidx[first:first + n], before.shape_triangles[s][perm[base:base + n] - base])
    wide = shading_tables(shapes, np.float64)
    assert wide.tri_normal.dtype == np.float64
    # float64 normals against the float32 ones: within float32 rounding (unit vectors).
    assert np.abs(wide.tri_normal - shapes.tri_normal).max() < 1e-6
    assert np.array_equal(wide.tri_material, shapes.tri_material) and np.array_equal(wide.tri_body, shapes.tri_body)


def _mixed_bodies():
    """Bodies for every kind of run ``spacetime.shape_tables.assembled`` joins: two instances
    (one sphere's triangles about their pivots) with materials per face (GeomSubsets),
    a contracted copy, two overlapping cubes of one motion (a merged class: one run over
    two bodies), a textured two-surface body, and a body without triangles."""
    from warp_st.core.scene import Body, Material, RenderSettings, Scene, Surface, Texture

    pts, tris, nrm = tessellate.sphere(1.0, 10)
    pts = np.round(pts * 1024.0) / 1024.0
    red, blue = Material(diffuse=(0.8, 0.1, 0.1)), Material(diffuse=(0.1, 0.1, 0.8))
    faces = (np.arange(len(tris)) % 3 == 0).astype(np.int64)  # 0: the surface's material, 1: its subset's
    texture = Texture(file="t.png", texels=np.random.default_rng(5).random((4, 4, 4), dtype=np.float32))
    bodies = []
    for i, v in enumerate(((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.6, 0.0, 0.0))):
        c = np.array([4.0 * i, 0.0, -10.0])
        bodies.append(Body(f"/S{i}", (Surface(f"/S{i}/m", pts + c, tris, red, nrm, subset_materials=(blue,),
                                              triangle_material=faces),), c, np.array(v), 0.0))
    cube, ctris = tessellate.cube(2.0)[:2]
    for i, x in enumerate((0.0, 1.5)):  # touching: one merged class
        c = np.array([x, 5.0, -10.0])
        bodies.append(Body(f"/C{i}", (Surface(f"/C{i}/m", cube + c, ctris, blue),), c, np.array([0.0, 0.3, 0.0]), 0.0))
    st = np.random.default_rng(6).random((len(tris), 3, 2))
    c = np.array([-5.0, 0.0, -10.0])
    bodies.append(Body("/T", (Surface("/T/a", pts + c, tris, Material(diffuse_texture=texture), nrm, st=st),
                              Surface("/T/b", cube + c + 2.0, ctris, red)), c, np.zeros(3), 0.0))
    bodies.append(Body("/E", (), np.zeros(3), np.zeros(3), 0.0))
    return Scene(source="<mixed>", bodies=tuple(bodies), lights=(), cameras=(), settings=RenderSettings())


def _shipped_and_mixed():
    import warp_st

    for path in sorted((ROOT / "usd_scenes").rglob("*.usda")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield path.name, warp_st.load(str(path))
    yield "mixed", _mixed_bodies()


def test_the_tables_joined_in_leaf_order_are_the_renumbered_tables():
    """``shapes_and_bottom_levels`` (the renderer's: trees first, then each run of table
    rows taken in its shape's leaf order as the tables are joined) gives the arrays of
    ``bottom_levels(rigid_shapes(...))`` (the tables joined, then renumbered), bit for
    bit: every shipped stage with tessellated and exact quadrics (merged classes,
    instances, shapes only quadrics use) and bodies with per-face materials, a texture,
    a merged class, a contraction and no triangles at all. Exact equality: both take the
    same rows into the same places, with no arithmetic on them."""
    import dataclasses

    from warp_st.accel.blas import bottom_levels, shapes_and_bottom_levels
    from warp_st.spacetime.rigid import RigidShapes
    from warp_st.spacetime.shape_tables import rigid_shapes

    checked = set()
    for name, scene in _shipped_and_mixed():
        for exact in (False, True):
            want, want_bottom = bottom_levels(rigid_shapes(scene, exact_quadrics=exact))
            got, got_bottom = shapes_and_bottom_levels(tuple(scene.bodies), exact)
            for f in dataclasses.fields(RigidShapes):
                a, b = getattr(want, f.name), getattr(got, f.name)
                if isinstance(a, np.ndarray):
                    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), (name, f.name)
                    checked.add(f.name)
                elif isinstance(a, tuple) and a and isinstance(a[0], np.ndarray):
                    assert [x.tobytes() for x in a] == [y.tobytes() for y in b], (name, f.name)
            for k in ("node_q", "node_frame", "node_link", "vidx", "points", "body_root", "body_vert"):
                assert np.array_equal(getattr(want_bottom, k), getattr(got_bottom, k)), (name, k)
            assert got.reorder is want.reorder and got_bottom.orders is None
    assert {"tri_normal", "tri_material", "tri_body", "tri_st", "vertex_normals", "shape_vidx"} <= checked
    mixed = rigid_shapes(_mixed_bodies())
    assert mixed.tri_st.shape[0] == mixed.triangle_count and mixed.body_merged.sum() == 2
    assert len(np.unique(mixed.tri_material)) == 3  # red, blue and the textured material


def _quantised_twin(lo16: np.ndarray, hi16: np.ndarray, empty: np.ndarray):
    """NumPy twin of the rule of ``accel.blas.quantised_boxes``: the child boxes
    ``lo16`` / ``hi16`` (W, 12) float32, axis-major, ``empty`` (W, 4) -> (q, frame)."""
    lo = np.nextafter(lo16, np.float32(-np.inf))
    hi = np.nextafter(hi16, np.float32(np.inf))
    w = len(lo)
    lo3 = lo.astype(np.float64).reshape(w, 3, WIDTH)
    hi3 = hi.astype(np.float64).reshape(w, 3, WIDTH)
    full = np.repeat(empty[:, None, :], 3, axis=1)
    low = np.where(full, np.inf, lo3).min(axis=2)  # (W, 3)
    high = np.where(full, -np.inf, hi3).max(axis=2)
    margin = 4.0 * np.spacing(np.maximum(np.abs(low), np.abs(high)).astype(np.float32)).astype(np.float64) + 1.0e-30
    origin = (low - margin).astype(np.float32)
    origin = np.where(origin > low - margin, np.nextafter(origin, np.float32(-np.inf)), origin)
    step64 = (high + margin - origin) / 255
    step = step64.astype(np.float32)
    step = np.where(step < step64, np.nextafter(step, np.float32(np.inf)), step)
    o, st = origin.astype(np.float64)[:, :, None], step.astype(np.float64)[:, :, None]
    q_lo = np.clip(np.floor((lo3 - margin[:, :, None] - o) / st), 0, 255)
    q_hi = np.clip(np.ceil((hi3 + margin[:, :, None] - o) / st), 0, 255)
    q_lo[full] = 0
    q_hi[full] = 0
    q = np.concatenate([q_lo.reshape(w, 12), q_hi.reshape(w, 12)], axis=1).astype(np.uint8)
    return q, np.concatenate([origin, step], axis=1)


def _quantised(lo: np.ndarray, hi: np.ndarray, empty: np.ndarray):
    """``quantised_boxes`` of wide nodes whose child boxes are ``lo`` / ``hi`` (W, 12),
    axis-major (each slot a binary node of its own)."""
    from warp_st.accel.blas import quantised_boxes

    w = len(lo)
    node = np.zeros((w * WIDTH, 2, 4), np.float32)
    node[:, 0, 1:] = lo.reshape(w, 3, WIDTH).transpose(0, 2, 1).reshape(-1, 3)
    node[:, 1, 1:] = hi.reshape(w, 3, WIDTH).transpose(0, 2, 1).reshape(-1, 3)
    slots = np.where(empty, -1, np.arange(w * WIDTH).reshape(w, WIDTH))
    return quantised_boxes(node[:, 0], node[:, 1], slots)


def _quantise_cases():
    """Child boxes (lo, hi, empty), W nodes of 12 coordinates: random boxes far from the
    coordinates' origin relative to their size (1e4 away, 1e-3 small, where a float32 ulp
    of the node is a large part of the step; 1e-30 small, subnormal steps; exact zeros and
    powers of two, where the float32 steps change) with empty slots, and the triangles'
    boxes of shipped shapes, four to a node."""
    rng = np.random.default_rng(5)
    cases = []
    for offset, size in ((0.0, 1.0), (1.0e4, 1.0e-3), (-3.0e4, 5.0e-2), (0.0, 1.0e-30)):
        w = 4000
        lo = (offset + size * rng.uniform(-1, 1, (w, 3, 1)) + size * rng.uniform(0, 1, (w, 3, 4))).astype(np.float32)
        hi = (lo + size * rng.uniform(0, 1, (w, 3, 4))).astype(np.float32)
        empty = rng.uniform(size=(w, 4)) < 0.2
        empty[:, 0] = False
        cases.append((lo.reshape(w, 12), hi.reshape(w, 12), empty))
    w = 500
    exact = np.float32(2.0) ** rng.integers(-130, 20, (w, 12)) * rng.choice([-1, 0, 1, 0.75], (w, 12))
    cases.append((exact.astype(np.float32), (exact + np.abs(exact)).astype(np.float32), np.zeros((w, 4), bool)))
    for name, rest, tris in _stage_shapes()[::4]:
        pts = np.asarray(rest, np.float32)
        t = np.asarray(tris, np.int64).reshape(-1, 3)
        a, b, c = (pts[t[:, k]] for k in range(3))
        box_lo, box_hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        n = len(t) // 4 * 4
        if n:  # four triangles a node, axis-major
            cases.append((box_lo[:n].reshape(-1, 4, 3).transpose(0, 2, 1).reshape(-1, 12),
                          box_hi[:n].reshape(-1, 4, 3).transpose(0, 2, 1).reshape(-1, 12),
                          np.zeros((n // 4, 4), bool)))
    return cases


def test_quantised_boxes_contain_the_exact_ones():
    """A wide node's byte-quantised child boxes (``accel.blas.quantised_boxes``), decoded
    as the traversal decodes them, origin + q step in float32 (rounded after the product
    and after the sum, or from the exact product as a fused multiply-add: either may be
    compiled), contain the float32 boxes they stand for (``_quantise_cases``). Exact
    oracle: comparisons of float32 values. (The ray tests above do not see a missing
    margin; this one fails without it.)"""
    for lo, hi, empty in _quantise_cases():
        q, frame = _quantised(lo, hi, empty)
        origin = np.repeat(frame[:, :3], 4, axis=1)
        step = np.repeat(frame[:, 3:], 4, axis=1)
        full = np.tile(empty, (1, 3))
        for k, corner, below in ((0, lo, True), (12, hi, False)):
            qk = q[:, k:k + 12].astype(np.float32)
            separate = origin + (qk * step).astype(np.float32)  # float32 throughout
            fused = (origin.astype(np.float64) + qk.astype(np.float64) * step.astype(np.float64)).astype(np.float32)
            for decoded in (separate, fused):
                ok = decoded <= corner if below else decoded >= corner
                assert (ok | full).all(), (k, int((~ok & ~full).sum()))


def test_the_quantise_kernel_is_its_numpy_twin():
    """Law: the kernel's bytes and frames (``kernels/blas_build.quantise``: float64
    arithmetic, and ``nextafter`` and ``spacing`` made from powers of two) are the NumPy
    twin's of the same rule, bit for bit, on every case of ``_quantise_cases``."""
    for lo, hi, empty in _quantise_cases():
        q, frame = _quantised(lo, hi, empty)
        q_twin, frame_twin = _quantised_twin(lo, hi, empty)
        assert np.array_equal(frame, frame_twin), int((frame != frame_twin).sum())
        assert np.array_equal(q, q_twin), int((q != q_twin).sum())


def _distinct_shapes(count: int):
    """``count`` shapes no two alike (spheres of other tessellations and radii, a cube), as
    ``BottomLevels`` reads them, with a shape without triangles and an untraced one between."""
    rest, tris = [], []
    for i in range(count):
        p, t = tessellate.sphere(1.0 + 0.1 * i, 8 + 4 * i)[:2] if i % 3 else tessellate.cube(1.0 + i)
        rest.append(np.asarray(p, np.float32))
        tris.append(np.asarray(t, np.int32).reshape(-1, 3))

    class _Shapes:
        shape_rest = rest + [np.zeros((0, 3), np.float32)]
        shape_triangles = tris + [np.zeros((0, 3), np.int32)]
        body_shape = np.array([*range(count), count, 1])
        body_quadric = np.array([0] * count + [0, 0])

    return _Shapes


def _two_workers(monkeypatch) -> list:
    """Two cores for ``BottomLevels``, even on a machine of one: the list of the pool
    sizes it asks ``core.thread_pool`` for."""
    from warp_st.accel import blas

    asked: list = []
    real = blas.thread_pool

    def recording(n_threads):
        asked.append(n_threads)
        return real(n_threads)

    monkeypatch.setattr(blas.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(blas, "thread_pool", recording)
    return asked


def test_shapes_built_on_threads_are_the_serial_builds(monkeypatch):
    """``BottomLevels`` builds the shapes' trees on a pool of one thread per core: every
    table equals the one-after-another build's (each shape's ``shape_tree`` alone), byte
    for byte, with two workers even on a machine of one core."""
    from warp_st.accel import blas

    shapes = _distinct_shapes(7)
    serial = [blas.shape_tree(p, t) for p, t in zip(shapes.shape_rest[:7], shapes.shape_triangles[:7])]
    asked = _two_workers(monkeypatch)
    built = BottomLevels(shapes)
    assert asked == [2], "the pool was not used"
    node = tri = 0
    for s, (q, frame, link, order) in enumerate(serial):
        w = len(q)
        assert built.body_root[s] == node and built.orders[s] is not None
        np.testing.assert_array_equal(built.orders[s], order)
        np.testing.assert_array_equal(built.node_q[node:node + w], q)
        np.testing.assert_array_equal(built.node_frame[node:node + w], frame)
        np.testing.assert_array_equal(built.vidx[tri:tri + len(order)], shapes.shape_triangles[s][order])
        local = built.node_link[node:node + w].astype(np.int64)
        is_leaf = (link >= 0) & ((link & ((1 << LINK_SHIFT) - 1)) > 0)
        base = np.where(is_leaf, tri, node) << LINK_SHIFT
        np.testing.assert_array_equal(local, np.where(link >= 0, link + base, -1))
        node, tri = node + w, tri + len(order)
    assert built.body_root[7] == -1 and built.body_root[8] == built.body_root[1]  # no triangles; a shared shape


def test_the_tree_kernel_is_made_on_the_calling_thread(monkeypatch):
    """In a new process the tree kernel is made and loaded on the calling thread
    (``bvh.load_builder``) before the pool's threads build shapes: two threads making it
    at once broke Warp's code generation (docs/design/two-level.md). Oracle: the thread of
    every ``make_sah_build`` call, from an empty kernel cache."""
    import threading

    from warp_st.accel import bvh
    from warp_st.kernels import bvh_build

    made = []
    real = bvh_build.make_sah_build

    def recording(*args, **kwargs):
        made.append(threading.current_thread())
        return real(*args, **kwargs)

    monkeypatch.setattr(bvh_build, "make_sah_build", recording)
    monkeypatch.setattr(bvh, "_SAH_KERNELS", {})  # as in a new process
    asked = _two_workers(monkeypatch)
    built = BottomLevels(_distinct_shapes(7))
    assert (built.body_root[:7] >= 0).all() and asked == [2]
    assert made == [threading.current_thread()]
