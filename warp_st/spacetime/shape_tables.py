"""The rigid shapes' per-triangle tables joined: in the bottom levels' leaf order, or in
another float type.

``spacetime.rigid.shape_parts`` makes every body's rows; ``assembled`` joins them, each
shape's triangles in the order its bottom level's leaves hold them (``accel.blas``), so a
hit's triangle slot is its row in every table. ``renumbered`` puts the tables of joined
shapes into such an order afterwards (the bottom levels of shapes made apart), and
``shading_tables`` makes the tables again in another float type.
"""
from __future__ import annotations

import dataclasses
import os

import numpy as np

from warp_st.core.scene import Scene
from warp_st.core.thread_pool import thread_pool
from warp_st.spacetime.rigid import RigidShapes, ShapeParts, shape_parts

__all__ = ["assembled", "renumbered", "rigid_shapes", "shading_tables", "triangle_order"]


def rigid_shapes(scene: Scene, exact_quadrics: bool = False, dtype=np.float32) -> RigidShapes:
    """The shapes and shading tables of every body of ``scene`` (``shape_parts``, which
    says how bodies share shapes and in which frames), the tables joined in the bodies'
    order. With ``exact_quadrics`` a body whose one surface is a UsdGeom.Sphere,
    Cylinder, Cone or Capsule is traced as that exact shape."""
    return assembled(shape_parts(tuple(scene.bodies), exact_quadrics, dtype))


def shading_tables(shapes: RigidShapes, dtype) -> RigidShapes:
    """``shapes`` with its shading tables' floats in ``dtype``: itself when they are, else
    made again from its bodies (a float64 render of shapes made for float32 ones: the
    tables are never rounded to float32 and back)."""
    if shapes.tri_normal.dtype == np.dtype(dtype):
        return shapes
    made = shape_parts(shapes.bodies, False, dtype, plan=shapes.body_holder)
    if shapes.reorder is None:
        return assembled(made)
    # The shapes renumbered are those a body traced as triangles uses (BottomLevels).
    traced = set(shapes.body_shape[(shapes.body_shape >= 0) & (shapes.body_quadric == 0)].tolist())
    orders = [shapes.reorder(rest, tris) if s in traced and len(tris) else None
              for s, (rest, tris) in enumerate(zip(made.shape_rest, made.shape_triangles))]
    return assembled(made, orders, reorder=shapes.reorder)


def triangle_order(shapes: RigidShapes, orders: list) -> np.ndarray:
    """The global triangles of ``shapes`` in the order ``renumbered`` gives them: row k
    of a renumbered table is row ``triangle_order[k]`` of the table before."""
    perm = np.arange(shapes.triangle_count)
    for b in np.flatnonzero(shapes.body_shape >= 0):
        order = orders[shapes.body_shape[b]]
        if order is not None:
            base = int(shapes.body_tri_base[b])
            perm[base:base + len(order)] = base + order
    return perm


def renumbered(shapes: RigidShapes, orders: list, vidx, points, reorder) -> RigidShapes:
    """``shapes`` with shape s's triangles in the order ``orders[s]`` (indices into them;
    None: kept): its rows of ``shape_vidx`` and every body's rows of the per-triangle
    tables follow, so a body's triangle k is still its shape's triangle k. ``vidx`` and
    ``points``: the renumbered ``shape_vidx`` and the shapes' points one after another,
    when the caller holds them already (the bottom levels' arrays: the shapes take
    views of them), else None. ``reorder``: what made the orders (``RigidShapes``)."""
    vidx, triangles, rest = _ordered(shapes.shape_vidx, shapes.shape_triangles, shapes.shape_rest, orders, vidx,
                                     points)
    perm = triangle_order(shapes, orders)
    names = ("tri_normal", "tri_smooth", "tri_size", "tri_body", "tri_material") + (("tri_st",) if len(shapes.tri_st)
                                                                                     else ())
    # Gathers of every triangle's rows, on the pool (NumPy releases the GIL in them). np.take,
    # not a[perm]: NumPy's fancy index of a 2D array's rows took 4.5 ms on 258k (T, 3) rows,
    # np.take 0.65 (the same rows).
    tables = dict(zip(names, thread_pool(os.cpu_count() or 1).map(
        lambda name: np.take(getattr(shapes, name), perm, axis=0), names)))
    return dataclasses.replace(shapes, shape_vidx=vidx, shape_rest=rest, shape_triangles=triangles,
                               reorder=reorder, **tables)


def _ordered(shape_vidx, shape_triangles, shape_rest, orders: list, vidx, points):
    """(all shapes' triangles, each shape's triangles, each shape's points) with shape s's
    triangles in the order ``orders[s]`` (None: kept): ``vidx`` / ``points`` when the
    caller holds them (the bottom levels' arrays: the shapes are views of them), else
    made here (``shape_vidx`` itself when no shape is reordered)."""
    if vidx is None:
        vidx = shape_vidx if all(o is None for o in orders) else np.concatenate(
            [t if o is None else np.take(t, o, axis=0) for t, o in zip(shape_triangles, orders)])
    first = np.cumsum([0] + [len(t) for t in shape_triangles])
    rest = tuple(shape_rest)
    if points is not None:
        vfirst = np.cumsum([0] + [len(r) for r in rest])
        rest = tuple(points[a:b] for a, b in zip(vfirst[:-1], vfirst[1:]))
    return vidx, tuple(vidx[a:b] for a, b in zip(first[:-1], first[1:])), rest


def assembled(parts: ShapeParts, orders: list | None = None, vidx=None, points=None, reorder=None) -> RigidShapes:
    """The ``RigidShapes`` of ``parts``, shape s's triangles in the order ``orders[s]``
    (indices into them; None, or no ``orders``: as made): ``renumbered``'s result, each
    run of rows taken in its shape's order as the tables are joined. ``vidx`` /
    ``points``: the renumbered triangles and the shapes' points one after another when
    the caller holds them (the bottom levels' arrays: the shapes take views of them);
    ``reorder``: what made the orders."""
    orders = orders if orders is not None else [None] * len(parts.shape_rest)
    vidx, triangles, rest = _ordered(parts.fields["shape_vidx"], parts.shape_triangles, parts.shape_rest, orders,
                                     vidx, points)
    spans: list = []  # [first part, end part, shape, run]: the parts of one run
    for k, (run, shape) in enumerate(parts.runs):
        if spans and spans[-1][3] == run:
            spans[-1][1] = k + 1
        else:
            spans.append([k, k + 1, shape, run])
    dtypes = {"normals": parts.dtype, "tri_normal": parts.dtype, "tri_smooth": np.int32, "tri_size": parts.dtype,
              "tri_body": np.int32, "tri_material": np.int32, "tri_st": parts.dtype}
    empty = {"normals": (0, 3), "tri_normal": (0, 3), "tri_st": (0, 3, 2)}

    def joined(name):
        pieces = [np.asarray(p, dtype=dtypes[name]) for p in parts.tables[name]]
        if not pieces:
            return np.zeros(empty.get(name, (0,)), dtypes[name])
        if name == "normals":  # per vertex: the vertices keep their order
            return np.concatenate(pieces)
        out = np.empty((sum(len(p) for p in pieces), *pieces[0].shape[1:]), dtypes[name])
        row = 0
        for a, b, shape, _ in spans:
            src = pieces[a] if b == a + 1 else np.concatenate(pieces[a:b])
            order = orders[shape] if shape >= 0 else None
            if order is None:
                out[row:row + len(src)] = src
            else:  # mode "clip": the result written into out, not buffered (the indices are in range)
                np.take(src, order, axis=0, out=out[row:row + len(src)], mode="clip")
            row += len(src)
        return out

    # The joins on the pool, one table each (NumPy releases the GIL in the copies).
    tables = dict(zip(dtypes, thread_pool(os.cpu_count() or 1).map(joined, dtypes)))
    return RigidShapes(
        **parts.fields | dict(shape_vidx=vidx), shape_rest=rest, shape_triangles=triangles, body_shape=parts.body_shape,
        body_quadric=parts.body_quadric, vertex_normals=tables["normals"], tri_normal=tables["tri_normal"],
        tri_smooth=tables["tri_smooth"], tri_size=tables["tri_size"], tri_body=tables["tri_body"],
        tri_material=tables["tri_material"], tri_st=tables["tri_st"], reorder=reorder)
