"""The single NumPy -> Warp crossing.

Static arrays (topology, BVH links, materials) are uploaded once per database; the
float arrays that carry positions are recentred on the render origin (the camera
event) in float64 on the host and only then rounded to the kernel's precision, so
absolute times of 1e6 or 1e9 cost no accuracy. Node boxes are rounded outward so a
rounded box always contains its rounded primitives.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.accel.bvh import FlatBVH
from warp_st.accel.bvh_wide import collapse, wide_boxes
from warp_st.core.conventions import BOX_PAD_ULPS
from warp_st.core.doppler_colour import cached_doppler_table
from warp_st.core.light_samples import area_samples
from warp_st.core.scene import Light
from warp_st.kernels import Kernels
from warp_st.kernels.struct_ref import seal
from warp_st.rendering.device_lights import light_track
from warp_st.rendering.device_textures import sky_struct, tet_corners, texture_tables
from warp_st.spacetime.extrude import SpacetimeMesh

__all__ = ["ShadingTables", "StaticArrays", "shared", "make_geometry", "set_nodes", "outward", "make_shading"]

_DEVICE = "cpu"
#: Light.kind -> the shading kernel's light_kind (kernels/shade.py).
_LIGHT_KIND = {"sphere": 0, "distant": 1, "rect": 2, "disk": 2}


class ShadingTables:
    """Frame-independent shading arrays: vertex normals, per-triangle tables, materials,
    bodies. ``tables`` is a ``SpacetimeMesh`` or a ``RigidShapes`` (the same fields).
    A table already in the kernels' type is shared, not copied (``shared``: the device
    is the CPU): the device array is the host table's memory."""

    def __init__(self, k: Kernels, tables):
        np_scalar = np.float32 if k.scalar == wp.float32 else np.float64
        self.np_scalar = np_scalar
        self.vert_normal = shared(tables.vertex_normals, np_scalar, k.vec3)
        self.tri_normal = shared(tables.tri_normal, np_scalar, k.vec3)
        self.tri_smooth = shared(tables.tri_smooth, np.int32, wp.int32)
        self.tri_size = shared(tables.tri_size, np_scalar, k.scalar)
        self.tri_body = shared(tables.tri_body, np.int32, wp.int32)
        self.tri_material = shared(tables.tri_material, np.int32, wp.int32)
        mats = tables.materials or ()
        diffuse = np.array([m.diffuse for m in mats], dtype=np_scalar).reshape(-1, 3)
        emissive = np.array([m.emissive for m in mats], dtype=np_scalar).reshape(-1, 3)
        self.mat_diffuse = wp.array(diffuse, dtype=k.vec3, device=_DEVICE)
        self.mat_emissive = wp.array(emissive, dtype=k.vec3, device=_DEVICE)
        metallic = np.array([m.metallic for m in mats], dtype=np_scalar).reshape(-1)
        self.mat_metallic = wp.array(metallic, dtype=k.scalar, device=_DEVICE)
        self.textures = texture_tables(k, tables)
        bodies = tables.bodies
        self.body_velocity = wp.array(
            np.array([b.velocity for b in bodies], dtype=np_scalar).reshape(-1, 3), dtype=k.vec3, device=_DEVICE
        )
        # A rest-frame body (§2.1) is traced decoupled, but its proper time is the event's t' in S'
        # (the coupled formula), and as a coupled deforming body its points emit with gamma of
        # their own velocity (kernels/shade.py point_velocity; 0.7.0 gave them gamma 1).
        gammas = [1.0 / np.sqrt(1.0 - b.speed**2) if b.rest_frame else b.gamma for b in bodies]
        self.body_gamma = wp.array(np.array(gammas, dtype=np_scalar), dtype=k.scalar, device=_DEVICE)
        self.body_decoupled = wp.array(
            np.array([1 if b.decoupled and not b.rest_frame else 0 for b in bodies], dtype=np.int32),
            dtype=wp.int32, device=_DEVICE
        )
        spins = [np.zeros((3, 3)) if b.spin is None else np.asarray(b.spin, dtype=np.float64) for b in bodies]
        self.body_spins = wp.array(np.array([b.spin is not None for b in bodies], dtype=np.int32), dtype=wp.int32,
                                   device=_DEVICE)
        self.body_spin = wp.array(np.array(spins, dtype=np_scalar).reshape(-1, 3, 3),
                                  dtype=wp.types.matrix((3, 3), k.scalar), device=_DEVICE)
        self.body_seam = wp.array(np.array([b.seam for b in bodies], dtype=np_scalar), dtype=k.scalar, device=_DEVICE)
        self.body_events = np.array([[b.reference_time, *b.origin] for b in bodies], dtype=np.float64).reshape(-1, 4)
        # An animated body's pieces (spacetime/animation.py) keep its prim path: one object.
        first = {}
        objects = np.array([first.setdefault(b.prim_path, i) for i, b in enumerate(bodies)], dtype=np.int32)
        self.body_object = wp.array(objects, dtype=wp.int32, device=_DEVICE)
        # Deforming bodies' point velocities (the tet path, ``StaticArrays``): none here.
        self.body_points = wp.zeros(len(bodies), dtype=wp.int32, device=_DEVICE)
        self.vert_velocity = wp.zeros(0, dtype=k.vec3, device=_DEVICE)
        self.vert_clock = wp.zeros(0, dtype=k.scalar, device=_DEVICE)  # none: §2's proper time for every body


class StaticArrays(ShadingTables):
    """Frame-independent device arrays of one 4D database (prisms or tetrahedra)."""

    def __init__(self, k: Kernels, mesh: SpacetimeMesh, bvh: FlatBVH):
        super().__init__(k, mesh)
        if mesh.primitive == "prism":
            # The shading reads four vertex indices with barycentrics (b0, b1, b2, 0).
            vidx, tri = mesh.prisms[:, [0, 1, 2, 0]], mesh.prism_tri
            velocity = np.array([b.velocity for b in mesh.bodies], dtype=np.float64).reshape(-1, 3)
            self.prism_velocity = velocity[mesh.tri_body[tri]] if len(tri) else np.zeros((0, 3))
        else:
            vidx, tri = mesh.tets, mesh.tet_tri
            if self.textures.info.shape[0]:  # which triangle corner each tetrahedron vertex is
                self.textures.prim_corner = wp.array(tet_corners(mesh.tets), dtype=wp.int32, device=_DEVICE)
            if len(mesh.vertex_velocity):  # a body deforms: its points' own velocities (kernels/shade.py)
                self.body_points = wp.array(mesh.body_points, dtype=wp.int32, device=_DEVICE)
                self.vert_velocity = wp.array(mesh.vertex_velocity.astype(self.np_scalar), dtype=k.vec3, device=_DEVICE)
            if len(mesh.vertex_clock):  # a turning coupled body's pivot clock (spacetime/turning.py)
                self.vert_clock = wp.array(mesh.vertex_clock.astype(self.np_scalar), dtype=k.scalar, device=_DEVICE)
        self.prim_vidx = wp.array(vidx.astype(np.int32), dtype=wp.vec4i, device=_DEVICE)
        self.prim_tri = wp.array(tri.astype(np.int32), dtype=wp.int32, device=_DEVICE)
        # The kernel traces the 4-wide form of the BVH (bvh_wide.py).
        self.wide = collapse(bvh)
        self.node_link = wp.array(self.wide.link, dtype=wp.vec4i, device=_DEVICE)


def shared(table: np.ndarray, np_dtype, dtype) -> wp.array:
    """``table`` on the device as ``dtype``: over the table's own memory when it is
    contiguous and of ``np_dtype`` already (the arrays are read-only there), else over a
    converted copy."""
    return wp.array(np.ascontiguousarray(table, dtype=np_dtype), dtype=dtype, device=_DEVICE, copy=False)


def outward(values64: np.ndarray, np_scalar, direction: float) -> np.ndarray:
    """Round float64 values to ``np_scalar``, then BOX_PAD_ULPS ulps towards ``direction``.

    The pad also covers the kernel's per-face rounding tolerance at box corners.
    """
    out = values64.astype(np_scalar)
    for _ in range(BOX_PAD_ULPS):
        out = np.nextafter(out, np_scalar(direction))
    return out


def make_geometry(k: Kernels, static: StaticArrays, mesh: SpacetimeMesh, bvh: FlatBVH, origin: np.ndarray,
                  geometry=None):
    """Geometry struct with vertices and boxes recentred on ``origin`` = (t_c, c);
    ``geometry``: the struct type when not ``k.Geometry`` (the rigid path's nested tetrahedra)."""
    g = (geometry or k.Geometry)()
    ns = static.np_scalar
    vert = (mesh.vertices - origin).astype(ns)
    g.vert = wp.array(vert, dtype=k.vec4, device=_DEVICE)
    if mesh.primitive == "prism":
        # Per prism: its three bottom events at t0, then (t_hi, velocity); the second
        # event's time slot (a copy of t0) carries t_lo instead (see extrude.prism_spans).
        events = np.empty((len(mesh.prisms), 4, 4), dtype=ns)
        events[:, :3] = vert[mesh.prisms[:, :3]]
        span = (mesh.prism_span - origin[0]).astype(ns)
        events[:, 1, 0] = span[:, 0]
        events[:, 3, 0] = span[:, 1]
        events[:, 3, 1:] = static.prism_velocity.astype(ns)
        g.prim_event = wp.array(events.reshape(-1, 4), dtype=k.vec4, device=_DEVICE)
    else:
        g.prim_event = wp.array(vert[mesh.tets.reshape(-1)], dtype=k.vec4, device=_DEVICE)
    g.prim_f = g.prim_event.view(k.scalar)
    g.prim_vidx = static.prim_vidx
    g.prim_tri = static.prim_tri
    g.tri_body = static.tri_body
    g.body_object = static.body_object
    set_nodes(k, g, static.wide, static.node_link, bvh, origin, ns)
    seal(g)
    return g


def set_nodes(k: Kernels, g, wide, node_link, bvh: FlatBVH, origin: np.ndarray, ns) -> None:
    """The BVH's node boxes on ``g``, recentred on ``origin`` and rounded outward."""
    node_lo, node_hi = outward(bvh.node_lo - origin, ns, -np.inf), outward(bvh.node_hi - origin, ns, np.inf)
    g.root_lo = k.vec4(*node_lo[0].tolist())
    g.root_hi = k.vec4(*node_hi[0].tolist())
    lo, hi = wide_boxes(wide, node_lo, node_hi)
    g.node_lo = wp.array(lo, dtype=k.vec16, device=_DEVICE)
    g.node_hi = wp.array(hi, dtype=k.vec16, device=_DEVICE)
    g.node_link = node_link
    # A root of one child (a one-leaf tree) has that child's box, which the root box test
    # has just tested: the traversal starts at the child.
    slots = wide.link[0]
    g.root_link = int(slots[0]) if (slots[1:] < 0).all() else 0


def make_shading(
    k: Kernels,
    static: StaticArrays,
    lights: tuple[Light, ...],
    origin: np.ndarray,
    background,
    max_depth: int,
    *,
    doppler_color: bool = False,
    searchlight: bool = False,
    dome=None,
    camera_event=None,
):
    """Shading struct: materials, bodies and lights, positions recentred on ``origin``;
    ``dome``: the scene's sky (a ``Dome``) or None; ``camera_event``: (t_c, c), the proper
    time's bodies' reference events are taken from it, as the film's events are (None: ``origin``)."""
    ns = static.np_scalar
    s = k.Shading()
    s.vert_normal = static.vert_normal
    s.tri_normal = static.tri_normal
    s.tri_smooth = static.tri_smooth
    s.tri_size = static.tri_size
    s.tri_body = static.tri_body
    s.tri_material = static.tri_material
    s.mat_diffuse = static.mat_diffuse
    s.mat_emissive = static.mat_emissive
    s.mat_metallic = static.mat_metallic
    s.tex = static.textures
    s.body_origin = wp.array((static.body_events - origin).astype(ns).reshape(-1, 4), dtype=k.vec4, device=_DEVICE)
    clock = origin if camera_event is None else np.asarray(camera_event, dtype=np.float64)
    s.body_clock = wp.array((static.body_events - clock).astype(ns).reshape(-1, 4), dtype=k.vec4, device=_DEVICE)
    s.body_velocity = static.body_velocity
    s.body_gamma = static.body_gamma
    s.body_decoupled = static.body_decoupled
    s.body_spins = static.body_spins
    s.body_spin = static.body_spin
    s.body_seam = static.body_seam
    s.body_points = static.body_points
    s.vert_velocity = static.vert_velocity
    s.vert_clock = static.vert_clock
    kinds = np.array([_LIGHT_KIND[l.kind] for l in lights], dtype=np.int32)
    pos = np.array([l.position for l in lights], dtype=np.float64).reshape(-1, 3) - origin[1:]
    dirs = np.array([l.direction for l in lights], dtype=np.float64).reshape(-1, 3)
    rad = np.array([l.radiance for l in lights], dtype=np.float64).reshape(-1, 3)
    s.light_kind = wp.array(kinds, dtype=wp.int32, device=_DEVICE)
    s.light_pos = wp.array(pos.astype(ns), dtype=k.vec3, device=_DEVICE)
    s.light_dir = wp.array(dirs.astype(ns), dtype=k.vec3, device=_DEVICE)
    s.light_radiance = wp.array(rad.astype(ns), dtype=k.vec3, device=_DEVICE)
    s.light_radius = wp.array(np.array([l.radius for l in lights], dtype=ns), dtype=k.scalar, device=_DEVICE)
    samples = [area_samples(l) for l in lights]
    counts = np.array([len(w) for _, w in samples], dtype=np.int32)
    s.light_samples = wp.array(counts, dtype=wp.int32, device=_DEVICE)
    points = np.concatenate([np.zeros((1, 3))] + [p - origin[1:] for p, _ in samples])  # one pad: never empty
    weights = np.concatenate([np.zeros(1)] + [w for _, w in samples])
    s.light_first = wp.array((1 + np.cumsum(counts) - counts).astype(np.int32), dtype=wp.int32, device=_DEVICE)
    s.sample_pos = wp.array(points.astype(ns), dtype=k.vec3, device=_DEVICE)
    s.sample_weight = wp.array(weights.astype(ns), dtype=k.scalar, device=_DEVICE)
    s.track = light_track(k, lights, origin)
    s.light_count = len(lights)
    s.background = k.vec3(*[float(x) for x in background])
    s.sky = sky_struct(k, dome)
    s.max_depth = int(max_depth)
    # the colour table is read (or built, importing the colour library) only when it is used
    table = cached_doppler_table(wp.config.kernel_cache_dir).reshape(-1, 3) if doppler_color else np.zeros((1, 3))
    s.doppler_table = wp.array(table.astype(ns), dtype=k.vec3, device=_DEVICE)
    s.color_shift = 1 if doppler_color else 0
    s.searchlight = 1 if searchlight else 0
    return s
