"""Rigid bodies as instances: one shape at rest per body, motion segments over what the frames see.

A body moving uniformly with velocity v is static in its comoving coordinates. A point
with rest offset r from the pivot o follows x(t) = o + v (t - t_ref) + A r (A the
contraction for coupled bodies, docs/spec.md §2; the identity for decoupled ones). The
past null ray E(s) = (o_t - s, o_x + s n) meets it where

    A r = o_x + s n - x_o(o_t - s) = w + s (n + v),   w = o_x - x_o(o_t),

x_o(t) the pivot's worldline: in body coordinates the ray is the straight 3D line
r(s) = A^-1 (w + s D), D = n + v (D = n with infinite light speed, where t = o_t), and
s is its own parameter. So one 3D structure over the triangles at rest serves every
time, speed and frame (the bottom level, ``accel.instances``); only the s-interval
comes from the 4D side: the lab times t = o_t - s of the segment the ray is tested in.

``shape_parts`` gathers each body's triangles once (frame-independent: the bottom
levels and the shading tables); ``motion_segments`` cuts each body's visible windows
into segments whose 4D boxes the top level bounds (frame-dependent, cheap).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from warp_st.core.extent import column_max, column_min, shifted
from warp_st.core.lorentz import contraction_matrix
from warp_st.core.scene import Scene
from warp_st.kernels.quadrics import QUADRIC_CAPSULE, QUADRIC_CONE, QUADRIC_CYLINDER, QUADRIC_SPHERE
from warp_st.spacetime.extrude import TriangleTables, _body_size, bodies_triangles, once_per_array
from warp_st.spacetime.merge_classes import merge_plan, merged_bodies, motion_group, pivot_offset
from warp_st.spacetime.start_boxes import start_boxes
from warp_st.spacetime.visibility import intervals, union

__all__ = ["RigidShapes", "ShapeParts", "shape_parts", "analytic_shape", "quadric_body", "all_exact_quadrics", "MotionSegments", "motion_segments", "SEGMENT_SWEEP", "REST_BOX_PAD"]


@dataclass(frozen=True, eq=False)
class RigidShapes(TriangleTables):
    """Every body's triangles at rest and the shading tables (``TriangleTables``, one
    row per global vertex and triangle), lab frame where not said.

    The shading tables' floats (``vertex_normals``, ``tri_normal``, ``tri_size``,
    ``tri_st``) are computed in float64 and stored in the float type of the kernels they
    are made for (``shape_parts``'s ``dtype``, float32 by default), so the upload
    (``rendering.device.ShadingTables``) shares their memory instead of copying them;
    ``shape_tables.shading_tables`` makes them in another type when a render needs it.

    shape_rest / shape_triangles: per shape, rest-frame points (P_s, 3) float32 in the
        coordinates of the shape's frame (as the bottom level takes them: computed in
        float64, then rounded), and triangles (T_s, 3) int32 (views of ``shape_vidx``,
        all shapes' triangles one after another); bodies whose
        points relative to their pivots and triangles are identical share one shape (one
        bottom level; see ``shape_parts`` for the frames).
    body_shape: shape index of each body, (B,), -1 for a body without triangles.
    body_tri_base, body_vert_base: the body's first global triangle / vertex, (B,).
    body_box_lo, body_box_hi: box of the contracted body at its reference time, (B, 3) (a
        merged class's holder: of every member, moved to its reference time).
    body_frame: the event (t, x) about which each body's shape is held, (B, 4): its own
        reference event, or its motion group's.
    body_rest_lo, body_rest_hi: box of the body's shape at rest in its frame's
        coordinates, (B, 3), padded by REST_BOX_PAD of its size (which covers the float32
        mesh's rounding); body_start_lo, body_start_hi: the box of the bodies held in
        that frame that it may touch (queries start where a ray enters it:
        ``spacetime/start_boxes.py``).
    rest_from_lab: A^-1 per body, (B, 3, 3) (identity for decoupled bodies).
    body_shape_tri: the row of ``shape_vidx`` where the body's shape starts, (B,) int32:
        a body's triangle k is its shape's, so its global vertex indices are
        shape_vidx[body_shape_tri + k] + body_vert_base (one table of vertex indices per
        shape, not per body: ``kernels/prim_lookup.py``).
    body_quadric: the analytic shape a body is traced as (``shape_parts``'s
        ``exact_quadrics``; ``kernels.quadrics`` codes), else 0, (B,); quadric_inv /
        quadric_centre / quadric_param: the shape is the canonical solid of that code in
        q = quadric_inv (r - quadric_centre), r in the shape frame's coordinates, with
        (radius, half height, 0), (B, 3, 3), (B, 3), (B, 3) (identity, zeros otherwise).
    tri_st: as ``TriangleTables`` says, but empty, (0, 3, 2), when no material is textured.
    body_mapped: 1 where the body's shape is held in other coordinates than its frame's,
        (B,) int32: the pieces of an animated body share one shape, the body's unrotated
        rest shape (``Body.piece_linear``), and a ray r(s) in the piece's frame
        coordinates meets it as body_map (r(s) - body_map_shift), (B, 3, 3) and (B, 3)
        (identity and zeros where not mapped; see ``shape_parts``).
    body_holder: the body whose shape and motion segments hold each body, (B,) int32:
        itself, or (bodies merged into one shape: ``merge_plan``) the first body of its
        merge class, which holds the whole class's triangles in one bottom level and
        one set of segments (``body_merged``: 1 for every body of a merged class).
    reorder: None, or (after ``shape_tables.renumbered``: each shape's triangles in its bottom
        level's leaf order) the function that gave a shape's order, which a remake of
        the tables in another float type applies again (``shading_tables``).
    """

    shape_rest: tuple
    shape_triangles: tuple
    body_shape: np.ndarray
    body_tri_base: np.ndarray
    body_vert_base: np.ndarray
    body_box_lo: np.ndarray
    body_box_hi: np.ndarray
    body_frame: np.ndarray
    body_rest_lo: np.ndarray
    body_rest_hi: np.ndarray
    body_start_lo: np.ndarray
    body_start_hi: np.ndarray
    rest_from_lab: np.ndarray
    shape_vidx: np.ndarray
    body_shape_tri: np.ndarray
    body_quadric: np.ndarray
    quadric_inv: np.ndarray
    quadric_centre: np.ndarray
    quadric_param: np.ndarray
    body_mapped: np.ndarray
    body_map: np.ndarray
    body_map_shift: np.ndarray
    body_holder: np.ndarray
    reorder: object = None

    @property
    def triangle_count(self) -> int:
        return int(len(self.tri_body))

    @property
    def body_merged(self) -> np.ndarray:
        return merged_bodies(self.body_holder)


#: Rest boxes are padded by this fraction of the shape's extent from its pivot (plus
#: the same absolutely): the float32 mesh points lie within 2^-24 of it of the float64 ones.
REST_BOX_PAD = 1.0e-6


#: Canonical coordinates (kernels/quadrics.py) put a shape's axis along z: the rows of
#: the permutation that does it for each USD axis.
_AXIS_TO_Z = {"X": [1, 2, 0], "Y": [2, 0, 1], "Z": [0, 1, 2]}
_KINDS = {"sphere": QUADRIC_SPHERE, "cylinder": QUADRIC_CYLINDER, "cone": QUADRIC_CONE, "capsule": QUADRIC_CAPSULE}


def analytic_shape(surface):
    """(kind code, M, t, param) of a surface's analytic shape, or None: its points are
    M q + t for q in the canonical solid of ``kernels/quadrics.py`` (column vectors; the
    reader's matrices act on row vectors), param = (radius, half height, 0)."""
    if surface.sphere is not None:
        radius, m = surface.sphere
        m = np.asarray(m, dtype=np.float64).reshape(4, 4)
        return QUADRIC_SPHERE, radius * m[:3, :3].T, m[3, :3].copy(), np.zeros(3)
    if surface.quadric is not None:
        kind, axis, radius, height, m = surface.quadric
        m = np.asarray(m, dtype=np.float64).reshape(4, 4)
        to_z = np.eye(3)[_AXIS_TO_Z[axis]]  # q = to_z @ local
        return _KINDS[kind], m[:3, :3].T @ to_z.T, m[3, :3].copy(), np.array([radius, 0.5 * height, 0.0])
    return None


def _canonical_half_extent(kind: int, param: np.ndarray) -> np.ndarray:
    r, h = param[0], param[1]
    if kind == QUADRIC_SPHERE:
        return np.ones(3)
    return np.array([r, r, h + r if kind == QUADRIC_CAPSULE else h])


def quadric_body(body, exact: bool) -> bool:
    """True when ``body`` is traced as its exact analytic shape: quadrics asked for and the
    body's one surface an untextured UsdGeom.Sphere, Cylinder, Cone or Capsule of one
    material with an invertible transform."""
    if not exact or len(body.surfaces) != 1:
        return False
    surface = body.surfaces[0]
    if any(t is not None for t in surface.material.textures) or surface.triangle_material is not None:
        return False  # an analytic hit has no st and no face: textured or per-face shading keeps triangles
    shape = analytic_shape(surface)
    return shape is not None and abs(float(np.linalg.det(shape[1]))) > 1e-300


def all_exact_quadrics(scene: Scene) -> bool:
    """True when ``scene`` has bodies with surfaces and each is an exact quadric."""
    shaped = [b for b in scene.bodies if b.surfaces]
    return bool(shaped) and all(quadric_body(b, True) for b in shaped)


def _held(bt, dtype):
    """``bt`` (a ``BodyTriangles`` or None) as held until its rows are taken: triangles
    int32, the shading floats already in ``dtype``, texture coordinates that are all
    zeros (untextured surfaces) left out (None): every body's triangles are held at once,
    and this holds ~80 bytes per triangle less (the host's peak over ``rigid_shapes`` fell
    from 175 to 147 bytes per triangle, docs/design/database-size.md)."""
    if bt is None:
        return None
    return dataclasses.replace(bt, triangles=bt.triangles.astype(np.int32), normals=bt.normals.astype(dtype),
                               tri_normal=bt.tri_normal.astype(dtype), tri_size=bt.tri_size.astype(dtype),
                               tri_st=bt.tri_st.astype(dtype) if bt.tri_st.any() else None)


def _held_triangles(bodies: tuple, materials: list, mat_index: dict, dtype) -> list:
    """Every body's ``_held`` triangles (None: none). With float32 tables, instances
    (``extrude.bodies_triangles``, shared: the same surfaces about their pivots in float32) share
    their held tables, each with its own ``rest``, ``local`` and materials."""
    held: dict = {}  # id of a shared triangle table -> (that table, its held triangles)
    found = []
    for bt in bodies_triangles(bodies, materials, mat_index, shared=np.dtype(dtype) == np.float32):
        if bt is None:
            found.append(None)
            continue
        if id(bt.triangles) not in held:
            held[id(bt.triangles)] = (bt.triangles, _held(bt, dtype))
        found.append(dataclasses.replace(held[id(bt.triangles)][1], rest=bt.rest, local=bt.local,
                                         tri_material=bt.tri_material.astype(np.int32)))
    return found


@dataclass(frozen=True, eq=False)
class ShapeParts:
    """A ``RigidShapes`` before its per-triangle tables are joined (``shape_parts``):
    the bottom levels are built from its shapes first, and ``shape_tables.assembled``
    joins the tables in their leaf order in one pass (a join, then ``renumbered``'s gathers, took
    two passes over every table).

    shape_rest, shape_triangles, body_shape, body_quadric: as ``RigidShapes``' (what
    ``accel.blas.BottomLevels`` reads); tables: per table name, each body's rows in
    emission order (``normals``: its vertices'); runs: per part, (its run, its shape):
    the parts of one run are the rows one shape order permutes (a body's, or a merged
    class's members' one after another); fields: ``RigidShapes``' other fields; dtype:
    the tables' float type.
    """

    shape_rest: list
    shape_triangles: list
    body_shape: np.ndarray
    body_quadric: np.ndarray
    tables: dict
    runs: list
    fields: dict
    dtype: np.dtype


def shape_parts(bodies: tuple, exact_quadrics: bool = False, dtype=np.float32, plan=None) -> ShapeParts:
    """The shapes and shading tables of ``bodies`` (no frame enters) before the
    per-triangle tables are joined (``ShapeParts``; ``spacetime.shape_tables.assembled``
    joins them), the tables' floats in ``dtype`` (the kernels' float type, see
    ``RigidShapes``); ``plan``: the ``merge_plan`` to follow (a remake of the tables in
    another float type follows the first make's), else made here.

    With ``exact_quadrics`` a body whose one surface is a UsdGeom.Sphere, Cylinder, Cone
    or Capsule is traced as that exact shape (``body_quadric``): its boxes are the
    shape's, and its triangles serve only its shading tables (material, body).

    Frames. A shape used by several bodies (instances: the same triangles at the same
    place relative to each body's pivot) is held once, in body coordinates about the
    body's reference event. Every other body is held in the coordinates of its motion
    group (the bodies with its velocity and coupling), about the group's first body's
    reference event: r' = r + A^-1 (o - o_g - v (t_ref - t_g)), the same worldlines. All
    bodies of a group then see a ray as the same float32 line, and those whose rest boxes
    meet from the same start (the entry into their cluster's rest box:
    ``spacetime/start_boxes.py``), so bodies in contact (the walls of a room) meet
    without cracks, as triangles of one mesh do; in body coordinates each would round
    the ray on its own and a ray through their seam could pass between them.

    Pieces of an animated body (``Body.piece_linear`` = L, not instances of each other:
    the body turns) are held in their motion groups' frames like any body, r_f = r_0 L + c
    (row vectors; r_0 the body's static rest offsets, c the group shift), but share one
    shape, r_0 (the first piece's r_f - c, taken back by L^-1), so a rotating body's
    thousands of pieces cost one bottom level: a ray meets it as L^-T (r_f(s) - c)
    (``body_map``), the same lookback s.

    Merge classes (``merge_plan``: bodies of one motion whose boxes overlap or touch,
    and copies of small instanced shapes) are one shape each: the members' points and
    triangles one after another (their global triangles and vertices one run, so the
    members are emitted right after their holder), every member's rest box the shape's.
    """
    materials: list = []
    mat_index: dict = {}
    n_bodies = len(bodies)
    found = _held_triangles(bodies, materials, mat_index, dtype)
    # Texture coordinates only serve textured materials (rendering/device_textures.py):
    # without any, the table of zeros (48 bytes per triangle) is left out.
    textured = any(t is not None for m in materials for t in m.textures)
    seen: dict = {}  # the triangle tables instances share: their bytes made and hashed once
    keys = [None if bt is None else (bt.rest.astype(np.float32).tobytes(),
                                     once_per_array(seen, bt.triangles, lambda a: a.astype(np.int32).tobytes()))
            for bt in found]
    uses: dict = {}
    for key in keys:
        if key is not None:
            uses[key] = uses.get(key, 0) + 1
    exact = [quadric_body(b, exact_quadrics) for b in bodies]
    holder = merge_plan(bodies, found, keys, uses, exact) if plan is None else np.asarray(plan, np.int32)
    merged = merged_bodies(holder)
    # Bodies in emission order: a merged class's members right after its holder, so their
    # global triangles and vertices are one run, in the merged shape's order.
    members_of: dict = {}
    for i, h in enumerate(holder.tolist()):
        members_of.setdefault(h, []).append(i)  # a holder is its class's first body
    emitted = [i for h in sorted(members_of) for i in members_of[h]]
    shapes: dict = {}
    shape_rest, shape_tris = [], []
    body_shape = np.full(n_bodies, -1, np.int32)
    tri_base = np.zeros(n_bodies, np.int64)
    vert_base = np.zeros(n_bodies, np.int64)
    box_lo, box_hi = np.zeros((n_bodies, 3)), np.zeros((n_bodies, 3))
    rest_lo, rest_hi = np.zeros((n_bodies, 3)), np.zeros((n_bodies, 3))
    frame = np.array([[b.reference_time, *b.origin] for b in bodies], dtype=np.float64).reshape(-1, 4)
    frame_of = np.arange(n_bodies)  # the body whose frame a body's shape is held in
    groups: dict = {}
    rest_from_lab = np.tile(np.eye(3), (n_bodies, 1, 1))
    quadric = np.zeros(n_bodies, np.int32)
    quadric_inv = np.tile(np.eye(3), (n_bodies, 1, 1))
    quadric_centre = np.zeros((n_bodies, 3))
    quadric_param = np.zeros((n_bodies, 3))
    mapped = np.zeros(n_bodies, np.int32)
    body_map = np.tile(np.eye(3), (n_bodies, 1, 1))
    map_shift = np.zeros((n_bodies, 3))
    tables = {k: [] for k in ("normals", "tri_normal", "tri_smooth", "tri_size", "tri_body", "tri_material",
                              "tri_st")}
    runs = []  # per part of the tables: (its run, its shape)
    inverses: dict = {}  # A^-1 per (velocity, decoupled)
    n_tri = n_vert = 0
    for i in emitted:
        body, bt, key = bodies[i], found[i], keys[i]
        found[i] = None  # each body's triangles freed once its rows are taken
        tri_base[i], vert_base[i] = n_tri, n_vert
        motion = (np.asarray(body.velocity, dtype=np.float64).tobytes(), bool(body.decoupled))
        if motion not in inverses:  # bodies of one velocity share it (the same bits)
            inverses[motion] = np.linalg.inv(contraction_matrix(body.velocity, body.decoupled))
        rest_from_lab[i] = inverses[motion]
        if bt is None:
            continue
        rest = bt.rest
        piece = (body.piece_linear is not None and uses[key] < 2  # a turned piece of an animated body
                 and abs(float(np.linalg.det(body.piece_linear))) > 1e-300)
        if uses[key] < 2 or merged[i]:
            # Held in its motion group's frame; copies of instances in their holder's.
            g = groups.setdefault(motion_group(body), i) if uses[key] < 2 else holder[i]
            frame_of[i] = g
            shift = rest_from_lab[i] @ pivot_offset(body, bodies[g])
            rest = shifted(rest, shift)
            key = ("piece", body.prim_path, key[1], len(rest)) if piece else (i,)
        if piece:
            unturn = np.linalg.inv(np.asarray(body.piece_linear, dtype=np.float64))
            mapped[i], body_map[i], map_shift[i] = 1, unturn.T, shift
        if merged[i]:  # the class's one shape: each member's points and triangles appended
            key = ("merged", int(holder[i]))
            if key not in shapes:
                shapes[key] = len(shape_rest)
                shape_rest.append([])
                shape_tris.append([])
            shape_tris[shapes[key]].append(bt.triangles.astype(np.int32) + (n_vert - vert_base[holder[i]]))
            shape_rest[shapes[key]].append(rest.astype(np.float32))
            tri_base[i], vert_base[i] = tri_base[holder[i]], vert_base[holder[i]]
        elif key not in shapes:
            shapes[key] = len(shape_rest)
            shape_rest.append((bt.rest @ unturn if piece else rest).astype(np.float32))
            shape_tris.append(bt.triangles.astype(np.int32))
        body_shape[i] = shapes[key]
        box_lo[i], box_hi[i] = column_min(bt.local), column_max(bt.local)
        pad = REST_BOX_PAD * (1.0 + float(np.abs(rest).max()))
        rest_lo[i], rest_hi[i] = column_min(rest) - pad, column_max(rest) + pad
        if exact[i]:
            # The shape M q + t, held in the shape's frame: its centre moves as the points
            # did. Boxes: the extent of M q over the canonical box |q_k| <= e_k along axis
            # k is sum_j |M_kj| e_j (the sphere's exact: |row k of M|).
            kind, m, t, param = analytic_shape(body.surfaces[0])
            origin = np.asarray(body.origin, dtype=np.float64)
            centre = t - origin + (rest[0] - bt.rest[0])
            quadric[i], quadric_inv[i], quadric_centre[i], quadric_param[i] = kind, np.linalg.inv(m), centre, param
            a = np.linalg.inv(rest_from_lab[i])
            if kind == QUADRIC_SPHERE:
                half, lab_half = np.linalg.norm(m, axis=1), np.linalg.norm(a @ m, axis=1)
            else:
                e = _canonical_half_extent(kind, param)
                half, lab_half = np.abs(m) @ e, np.abs(a @ m) @ e
            pad = REST_BOX_PAD * (1.0 + float(np.abs(centre).max() + half.max()))
            rest_lo[i], rest_hi[i] = centre - half - pad, centre + half + pad
            lab_centre = origin + a @ (t - origin)
            box_lo[i], box_hi[i] = lab_centre - lab_half, lab_centre + lab_half
        tables["normals"].append(bt.normals)
        tables["tri_normal"].append(bt.tri_normal)
        tables["tri_smooth"].append(bt.tri_smooth)
        tables["tri_size"].append(bt.tri_size)
        tables["tri_body"].append(np.full(len(bt.triangles), i, np.int32))
        tables["tri_material"].append(bt.tri_material)
        if textured:
            tables["tri_st"].append(np.zeros((len(bt.triangles), 3, 2), dtype) if bt.tri_st is None else bt.tri_st)
        # The run of rows the body's shape's order permutes: a merged class's members' rows are one run.
        runs.append((int(holder[i]) if merged[i] else i, int(body_shape[i])))
        n_tri += len(bt.triangles)
        n_vert += len(bt.local)
    for h in np.flatnonzero(merged & (holder == np.arange(n_bodies))):
        # A merged class: every member's rest box is the shape's, and the holder's lab box
        # (at its reference time) holds every member's, each moved to that time.
        members = np.flatnonzero(holder == h)
        rest_lo[members], rest_hi[members] = rest_lo[members].min(axis=0), rest_hi[members].max(axis=0)
        v = np.asarray(bodies[h].velocity, np.float64)
        moved = np.array([v * (bodies[h].reference_time - bodies[m].reference_time) for m in members])
        box_lo[h], box_hi[h] = (box_lo[members] + moved).min(axis=0), (box_hi[members] + moved).max(axis=0)
    shape_rest = [np.concatenate(r) if isinstance(r, list) else r for r in shape_rest]
    shape_tris = [np.concatenate(t) if isinstance(t, list) else t for t in shape_tris]
    # Each body's queries start where the ray enters the rest box of the bodies of its
    # frame it may touch (spacetime/start_boxes.py).
    start_lo, start_hi = start_boxes(rest_lo, rest_hi, frame_of, body_shape >= 0)

    shape_vidx = np.concatenate(shape_tris) if shape_tris else np.zeros((0, 3), np.int32)
    shape_first = np.cumsum([0] + [len(t) for t in shape_tris])
    body_shape_tri = np.where(body_shape >= 0, shape_first[np.maximum(body_shape, 0)], 0).astype(np.int32)
    return ShapeParts(
        shape_rest=shape_rest, shape_triangles=[shape_vidx[a:b] for a, b in zip(shape_first[:-1], shape_first[1:])],
        body_shape=body_shape, body_quadric=quadric, tables=tables, runs=runs, dtype=np.dtype(dtype),
        fields=dict(
            shape_vidx=shape_vidx, body_shape_tri=body_shape_tri, body_tri_base=tri_base, body_vert_base=vert_base,
            body_box_lo=box_lo, body_box_hi=box_hi, body_frame=frame[frame_of], body_rest_lo=rest_lo,
            body_rest_hi=rest_hi, body_start_lo=start_lo, body_start_hi=start_hi, rest_from_lab=rest_from_lab,
            quadric_inv=quadric_inv, quadric_centre=quadric_centre, quadric_param=quadric_param,
            body_mapped=mapped, body_map=body_map, body_map_shift=map_shift, body_holder=holder,
            materials=tuple(materials), bodies=bodies))


#: A segment's box is the body's box swept over the segment: a body moving by more than
#: SEGMENT_SWEEP x its size within one visible window is cut into several segments, so
#: the top level's boxes stay within a few body sizes of the body (a ray entering a
#: loose box costs one bottom-level query that misses).
SEGMENT_SWEEP = 1.0
#: Most segments per window: a window longer than this many sweeps gets longer ones.
MAX_SEGMENTS = 64


@dataclass(frozen=True, eq=False)
class MotionSegments:
    """The top level's primitives: each a body over a lab-time interval.

    body: (S,) int32; span: lab times (t_lo, t_hi), (S, 2); lo, hi: 4D boxes
    (t, x, y, z) holding the body over its span, (S, 4) each.
    """

    body: np.ndarray
    span: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @property
    def count(self) -> int:
        return int(len(self.body))


def motion_segments(scene: Scene, shapes: RigidShapes, windows: list) -> MotionSegments:
    """Each body's visible ``windows`` (per body: None, an interval or a tuple of
    intervals, already clipped to its lifetime) cut into motion segments. A merged class
    (``merge_plan``) gets its holder's segments over the union of its members' windows,
    cut by the class's size."""
    windows = list(windows)
    holder, merged = shapes.body_holder, shapes.body_merged
    for i in np.flatnonzero(holder != np.arange(len(holder))):
        windows[holder[i]] = union(windows[holder[i]], windows[i])
    rows = []
    for i, (body, window) in enumerate(zip(scene.bodies, windows)):
        if shapes.body_shape[i] < 0 or holder[i] != i:
            continue
        size = _body_size(body)
        if merged[i]:
            size = max(float(np.max(shapes.body_box_hi[i] - shapes.body_box_lo[i])), size)
        for t0, t1 in intervals(window):
            k = int(min(max(np.ceil(body.speed * (t1 - t0) / (SEGMENT_SWEEP * size)), 1), MAX_SEGMENTS))
            cuts = np.linspace(t0, t1, k + 1)
            cuts[0], cuts[-1] = t0, t1
            for a, b in zip(cuts[:-1], cuts[1:]):
                rows.append((i, a, b))
    if not rows:
        z = np.zeros((0, 4))
        return MotionSegments(np.zeros(0, np.int32), np.zeros((0, 2)), z, z.copy())
    body = np.array([r[0] for r in rows], dtype=np.int32)
    span = np.array([(r[1], r[2]) for r in rows], dtype=np.float64)
    v = np.array([scene.bodies[b].velocity for b in body], dtype=np.float64).reshape(-1, 3)
    t_ref = np.array([scene.bodies[b].reference_time for b in body], dtype=np.float64)
    blo, bhi = shapes.body_box_lo[body], shapes.body_box_hi[body]
    ends = [v * (span[:, j:j + 1] - t_ref[:, None]) for j in (0, 1)]  # the pivot's motion at both ends
    lo = np.column_stack([span[:, 0], np.minimum(blo + ends[0], blo + ends[1])])
    hi = np.column_stack([span[:, 1], np.maximum(bhi + ends[0], bhi + ends[1])])
    return MotionSegments(body=body, span=span, lo=lo, hi=hi)
