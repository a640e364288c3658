"""Bottom levels of the two-level rigid path: one 3D 4-wide BVH per shape at rest.

Every distinct shape of ``spacetime.rigid.RigidShapes`` gets a bounding volume hierarchy
over its float32 triangles in body coordinates, built by our binned SAH builder
(``bvh.build_bvh``, a Warp kernel building the tree depth first; each node also weighs the
split by the triangles' longest axis, ``oriented``) and collapsed to 4-wide nodes
(``bvh_wide.collapse``), the same trees the top level uses. The builder is 4D: a
triangle's box gets the time extent [0, L] with L a thousand times the shape's size,
so its "surface" e_t (e_x e_y + e_y e_z + e_z e_x) + e_x e_y e_z is the 3D surface area
times L to within 0.1 %, and the SAH orders splits as a 3D one does.

All shapes share one set of arrays (``kernels/blas.py`` traverses them):

- ``node_q`` (W, 24) uint8 and ``node_frame`` (W, 6) float32: a wide node's four child
  boxes, axis-major (x0..x3, y0..y3, z0..z3 of the lower corners, then of the upper),
  quantised to a byte per coordinate in the node's frame (origin and step per axis:
  ``quantised``; 64 bytes a node with the links, 112 as float32 boxes); an empty slot's
  link is -1;
- ``node_link`` (W, 4) int32: ``first << LINK_SHIFT | count``, a leaf's range of
  triangle slots or (count 0) a wide node, global over the shapes;
- ``vidx`` (T, 3) int32: every shape's triangles (vertex indices in the shape), shape
  after shape, each shape's in its tree's leaf order (a leaf's triangles are
  contiguous): slot i is row i. It is the shapes' own table too: ``bottom_levels``
  renumbers each shape's triangles into this order once (``spacetime.shape_tables.renumbered``),
  so the shading reads the same rows (``shape_vidx``) and a hit's slot minus its shape's
  first row is the triangle's index in its shape (one vertex store per shape, issue 17);
- ``points`` (P, 3) float32: every shape's rest points, shape after shape (the shapes'
  ``shape_rest`` are views of it); ``body_vert`` (B,) int32: where each body's shape's
  points start in it;
- ``body_root`` (B,) int32: the root wide node of each body's shape (-1: no triangles,
  or a shape only exact quadrics use: they are traced as quadrics, ``trace_rigid.py``,
  and keep their triangles' order).
"""
from __future__ import annotations

import os
import time

import numpy as np

from warp_st.accel.bvh import build_bvh, load_builder
from warp_st.accel.bvh_wide import collapse
from warp_st.core.extent import column_max, column_min
from warp_st.core.thread_pool import thread_pool
from warp_st.kernels.layout import LINK_SHIFT, WIDTH
from warp_st.spacetime.rigid import RigidShapes, shape_parts
from warp_st.spacetime.shape_tables import assembled, renumbered

__all__ = ["BottomLevels", "bottom_levels", "shapes_and_bottom_levels", "leaf_order", "quantised_boxes", "shape_tree"]

#: Ranges of up to 4 triangles always become leaves: two levels fewer to build (a third
#: of the build), queries as fast within the spread of single runs.
SHAPE_LEAF = 4


def shape_tree(points: np.ndarray, triangles: np.ndarray, threads: int = 2):
    """The 4-wide tree of one shape: (q (W, 24) uint8 and frame (W, 6) float32, the
    quantised child boxes (``quantised_boxes``), link (W, 4) local, order (T,) the
    triangles in leaf order). ``points`` float32 (P, 3); ``threads``: ``bvh.build_bvh``'s."""
    import warp as wp

    from warp_st.kernels.blas_build import tri_boxes

    n = len(triangles)
    plo, phi, centre = (wp.empty(n, dtype=wp.vec4, device="cpu") for _ in range(3))
    wp.launch(tri_boxes, dim=n, inputs=[wp.array(points, dtype=wp.vec3, device="cpu"),
                                        wp.array(triangles, dtype=wp.vec3i, device="cpu"), plo, phi, centre],
              device="cpu")
    lo, hi, mid = plo.numpy(), phi.numpy(), centre.numpy()  # views
    size = float(np.max(column_max(hi[:, 1:]) - column_min(lo[:, 1:]))) if n else 1.0
    hi[:, 0] = 1.0e3 * max(size, 1.0e-30)
    mid[:, 0] = 0.5 * hi[:, 0]  # the float32 (lo + hi) / 2 of the other axes
    bvh = build_bvh(plo, phi, "tri", leaf_size=SHAPE_LEAF, uniform_t=True, oriented=True, threads=threads,
                    float32_boxes=True, centre=centre)
    e = np.maximum(bvh.node_hi[:, 1:].astype(np.float64) - bvh.node_lo[:, 1:], 0.0)
    wide = collapse(bvh, area=e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0])  # the largest opened
    q, frame = quantised_boxes(bvh.node_lo, bvh.node_hi, wide.slot_node)
    return q, frame, wide.link, bvh.order


def quantised_boxes(node_lo: np.ndarray, node_hi: np.ndarray, slot_node: np.ndarray):
    """Wide nodes' child boxes as one byte per coordinate in the node's frame: (q (W, 24)
    uint8, the children's lower corners then upper ones, axis-major; frame (W, 6)
    float32, the origin and step per axis), from the binary nodes' float32 boxes
    ``node_lo`` / ``node_hi`` (M, 4), (t, x, y, z), the time unused, and the binary node
    in each slot ``slot_node`` (W, 4) (-1: empty; its q is 0, and the traversal tests
    its link, -1). The rule (``kernels/blas_build.quantise``, float64):

    - each corner first moves one float32 step outward: a ray along a box's face with a
      zero direction component (an axis-aligned camera's centre column) would get the
      exit (hi - o) / d = 0 x 1e30 = 0 there, not +inf, and miss the box; widened, the
      face lies strictly outside every ray that meets the triangles;
    - a child's box is origin + q step (``kernels/blas.py`` decodes it in float32) and
      contains the widened one: lower corners round down, upper ones up, past a margin of
      4 float32 ulps of the node's coordinates (the decode's rounding is below 1.5 of
      them)."""
    import warp as wp

    from warp_st.kernels.blas_build import quantise

    w = len(slot_node)
    q = wp.empty((w, 6 * WIDTH), dtype=wp.uint8, device="cpu")
    frame = wp.empty((w, 6), dtype=wp.float32, device="cpu")
    wp.launch(quantise, dim=w, inputs=[wp.array(np.asarray(node_lo, np.float32), dtype=wp.vec4, device="cpu"),
                                       wp.array(np.asarray(node_hi, np.float32), dtype=wp.vec4, device="cpu"),
                                       wp.array(np.asarray(slot_node, np.int32), dtype=wp.int32, device="cpu"), q,
                                       frame], device="cpu")
    return q.numpy(), frame.numpy()


class BottomLevels:
    """The bottom levels of ``shapes`` (a ``RigidShapes`` or ``ShapeParts``: its
    ``shape_rest``, ``shape_triangles``, ``body_shape`` and ``body_quadric``; see the
    module docstring), NumPy arrays, built over the shapes' triangles in their given order.

    ``orders``: each shape's leaf order (its triangles' indices in the order of
    ``vidx``; None for a shape without a tree) until ``bottom_levels`` has renumbered the
    shapes and drops them; ``build_seconds``: the build's wall time; ``nbytes``: what
    the arrays hold; ``count``: the number of shapes.
    """

    def __init__(self, shapes):
        t0 = time.perf_counter()
        body_shape = np.asarray(shapes.body_shape)
        quadric = np.asarray(getattr(shapes, "body_quadric", np.zeros(len(body_shape), np.int32)))
        n_shapes = len(shapes.shape_rest)
        # A shape only exact quadrics use is never queried: no tree, its order kept.
        traced = np.zeros(n_shapes + 1, bool)
        traced[body_shape[(body_shape >= 0) & (quadric == 0)]] = True
        qs, frames, links, vidx, points, roots, firsts, self.orders = [], [], [], [], [], [], [], []
        node_base = tri_base = vert_base = 0
        shapes_in = [(np.asarray(rest, dtype=np.float64).astype(np.float32),
                      np.asarray(tris, dtype=np.int32).reshape(-1, 3))
                     for rest, tris in zip(shapes.shape_rest, shapes.shape_triangles)]
        trees = _build_trees(shapes_in, [s for s, (_, tris) in enumerate(shapes_in) if len(tris) and traced[s]])
        for s, (pts, tris) in enumerate(shapes_in):
            firsts.append(vert_base)
            points.append(pts)
            vert_base += len(pts)
            if s not in trees:
                roots.append(-1)
                self.orders.append(None)
                vidx.append(tris)
                tri_base += len(tris)
                continue
            q, frame, link, order = trees[s]
            is_leaf = (link >= 0) & ((link & ((1 << LINK_SHIFT) - 1)) > 0)
            base = np.where(is_leaf, tri_base, node_base).astype(np.int64) << LINK_SHIFT
            links.append(np.where(link >= 0, link.astype(np.int64) + base, -1))
            qs.append(q)
            frames.append(frame)
            vidx.append(np.take(tris, order, axis=0))
            self.orders.append(order)
            roots.append(node_base)
            node_base += len(q)
            tri_base += len(tris)
        if (node_base | tri_base) >= 2 ** (31 - LINK_SHIFT):
            raise ValueError("bottom levels too large for packed node links")
        self.count = len(roots)
        self.node_q = np.concatenate(qs) if qs else np.zeros((1, 6 * WIDTH), np.uint8)
        self.node_frame = np.concatenate(frames) if frames else np.zeros((1, 6), np.float32)
        self.node_link = np.concatenate(links).astype(np.int32) if links else np.full((1, WIDTH), -1, np.int32)
        self.vidx = np.concatenate(vidx) if vidx else np.zeros((0, 3), np.int32)
        self.points = np.concatenate(points) if points else np.zeros((0, 3), np.float32)
        root_of_shape = np.array(roots + [-1], dtype=np.int32)
        first_of_shape = np.array(firsts + [0], dtype=np.int32)
        self.body_root = root_of_shape[body_shape]  # -1 (no shape) picks the trailing -1
        self.body_vert = first_of_shape[body_shape]
        self.build_seconds = time.perf_counter() - t0
        self.nbytes = int(self.node_q.nbytes + self.node_frame.nbytes + self.node_link.nbytes + self.vidx.nbytes
                          + self.points.nbytes)


def _build_trees(shapes_in: list, built: list) -> dict:
    """``shape_tree`` of each shape in ``built`` (indices into ``shapes_in``, (points,
    triangles) pairs), by shape index, on a thread pool of one thread per core
    (``core.thread_pool``), largest first. The kernels are made and loaded first, on the
    calling thread (``bvh.load_builder``, ``kernels/blas_build``). Each tree depends on its shape alone, so
    the trees are the serial build's whatever the thread count. A shape builds its
    subtrees on two threads of its own only when it holds more than its share of a core's
    triangles (the other shapes cannot keep the cores busy beside it): with every core
    building shapes, those threads only compete (16 distinct 65k-triangle spheres built
    in 387-409 ms without them against 446-467 with them, medians of 9)."""
    cores = os.cpu_count() or 1
    if min(len(built), cores) <= 1:
        return {s: shape_tree(*shapes_in[s]) for s in built}
    load_builder("tri", leaf_size=SHAPE_LEAF, uniform_t=True, oriented=True)  # the same kernel as shape_tree's builds
    import warp as wp

    from warp_st.kernels import blas_build

    wp.load_module(blas_build, device="cpu")  # shape_tree's other kernels
    order = sorted(built, key=lambda s: -len(shapes_in[s][1]))  # the small ones fill in at the end
    total = sum(len(shapes_in[s][1]) for s in built)

    def tree(s):
        return shape_tree(*shapes_in[s], threads=2 if len(shapes_in[s][1]) * cores > total else 1)

    return dict(zip(order, thread_pool(cores).map(tree, order)))


def leaf_order(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The leaf order ``BottomLevels`` gives one shape's triangles (the build is
    deterministic: the same points and triangles give the same tree)."""
    return shape_tree(np.asarray(points, np.float32), np.asarray(triangles, np.int32).reshape(-1, 3))[3]


def shapes_and_bottom_levels(bodies: tuple, exact_quadrics: bool = False) -> tuple[RigidShapes, BottomLevels]:
    """``bottom_levels(rigid_shapes(...))`` of ``bodies``, the same arrays, with the
    shading tables joined once, in the leaf order (``spacetime.shape_tables.assembled``): the
    trees are built from the shapes (``shape_parts``) before the tables are joined."""
    parts = shape_parts(bodies, exact_quadrics)
    bottom = BottomLevels(parts)
    shapes = assembled(parts, bottom.orders, bottom.vidx, bottom.points, leaf_order)
    bottom.orders = None
    return shapes, bottom


def bottom_levels(shapes: RigidShapes) -> tuple[RigidShapes, BottomLevels]:
    """The bottom levels of ``shapes`` and the shapes renumbered into their leaf order
    (``spacetime.shape_tables.renumbered``: every per-triangle table follows, so the images are
    the same; the shapes' triangles and points are the bottom levels' arrays)."""
    bottom = BottomLevels(shapes)
    ordered = renumbered(shapes, bottom.orders, bottom.vidx, bottom.points, leaf_order)
    bottom.orders = None
    return ordered, bottom
