"""What the rigid shapes keep on the host (spacetime/rigid.py, issue 17's bytes per triangle).

Law: texture coordinates are kept only for a scene with a textured material (the device
reads them only then, rendering/device_textures.py; tests/rendering/test_textures.py
renders textured stages through them): an untextured scene's table is empty.
"""
import warp_st
from warp_st.spacetime.shape_tables import rigid_shapes

from animation_stages import HEADER, write


def test_an_untextured_scene_keeps_no_texture_coordinates(tmp_path):
    stage = HEADER + '''def Cube "A"
{
    double size = 2
}
def Sphere "B"
{
    double radius = 1
    double3 xformOp:translate = (3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''
    shapes = rigid_shapes(warp_st.load(write(tmp_path, "plain.usda", stage)))
    assert shapes.triangle_count > 12
    assert shapes.tri_st.shape == (0, 3, 2)


def _copies():
    """Four translated copies of one tessellated sphere (points on a 1/1024 grid and whole
    offsets, so every copy's points about its pivot are the same bits: instances), each
    its own material; the last two move at 0.6c (coupled: contracted)."""
    import numpy as np

    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Material, RenderSettings, Scene, Surface

    pts, tris, nrm = tessellate.sphere(1.0, 12)
    pts = np.round(pts * 1024.0) / 1024.0
    bodies = []
    for i in range(4):
        centre = np.array([3.0 * i - 5.0, 1.0 * i, -12.0 - 2.0 * i])
        v = np.array([0.6, 0.0, 0.0]) if i >= 2 else np.zeros(3)
        surf = Surface(f"/S{i}", pts + centre, tris, Material(diffuse=(0.1 + 0.2 * i, 0.5, 0.5)), nrm)
        bodies.append(Body(f"/S{i}", (surf,), centre, v, 0.0))
    return Scene(source="<copies>", bodies=tuple(bodies), lights=(), cameras=(), settings=RenderSettings())


def test_instances_share_their_shading_tables_but_not_their_materials(monkeypatch):
    """Law: bodies whose surfaces agree about their pivots in float32 and that share a
    contraction share one computation of the shading tables (extrude.bodies_triangles,
    shared): their facet normals and sizes are the same rows bit for bit, and within float32
    rounding of each body's own (float64 tables: no memo); each keeps its own material.
    Bodies with another contraction get their own (contracted) tables."""
    import numpy as np

    from warp_st.spacetime import extrude

    scene = _copies()
    made = []
    compute = extrude._body_triangles
    monkeypatch.setattr(extrude, "_body_triangles", lambda body, *a: made.append(body.prim_path) or compute(body, *a))
    shared = rigid_shapes(scene)
    assert sorted(made) == ["/S0", "/S2"]  # one computation per contraction (on the pool: any order)
    own = rigid_shapes(scene, dtype=np.float64)  # every body computed on its own
    assert len(made) == 6
    n = len(scene.bodies[0].surfaces[0].triangles)
    rows = [np.flatnonzero(shared.tri_body == b) for b in range(4)]  # (merged classes share a base)
    assert all(len(r) == n for r in rows)

    assert np.array_equal(shared.tri_normal[rows[0]], shared.tri_normal[rows[1]])
    assert np.array_equal(shared.tri_normal[rows[2]], shared.tri_normal[rows[3]])
    assert not np.allclose(shared.tri_normal[rows[0]], shared.tri_normal[rows[2]], atol=1e-3)
    for b in range(4):
        # float32 rounding of unit vectors and sizes ~1: a few 1e-7.
        np.testing.assert_allclose(shared.tri_normal[rows[b]], own.tri_normal[rows[b]], rtol=0, atol=1e-6)
        np.testing.assert_allclose(shared.tri_size[rows[b]], own.tri_size[rows[b]], rtol=1e-6)
    materials = [shared.materials[m].diffuse for m in shared.tri_material[[r[0] for r in rows]]]
    assert [round(c[0], 3) for c in materials] == [0.1, 0.3, 0.5, 0.7]
    # Each body's lab box is its own: the copies are 3 apart along x.
    np.testing.assert_allclose(shared.body_box_lo[[1, 3], 0] - shared.body_box_lo[[0, 2], 0], 3.0, rtol=0, atol=1e-12)


def _mixed_bodies():
    """``_copies`` and bodies whose materials appear first in later bodies: two surfaces
    with per-face subset materials, a surface of degenerate triangles only (its
    materials are never used), a body without surfaces, a material shared with a copy."""
    import numpy as np

    from warp_st.core import tessellate
    from warp_st.core.scene import Body, Material, Surface

    copies = _copies().bodies
    pts, tris, nrm = tessellate.sphere(0.5, 6)
    red, green, blue, unused = (Material(diffuse=(c, 0.2, 0.3)) for c in (0.9, 0.8, 0.7, 0.6))
    faces = np.arange(len(tris)) % 3
    two = (Surface("/M/a", pts + [0.0, 4.0, -9.0], tris, green, nrm, subset_materials=(red, blue),
                   triangle_material=faces),
           Surface("/M/b", pts + [1.0, 4.0, -9.0], tris, blue, None, subset_materials=(copies[3].surfaces[0].material,),
                   triangle_material=faces % 2))
    dead = Surface("/D/a", pts, np.zeros((4, 3), np.int64), unused)
    return (Body("/M", two, np.array([0.5, 4.0, -9.0]), np.array([0.0, 0.3, 0.0]), 0.0),
            Body("/E", (), np.zeros(3), np.zeros(3), 0.0), copies[0], copies[3],
            Body("/D", (dead, copies[1].surfaces[0]), copies[1].origin, np.zeros(3), 0.0), copies[1], copies[2])


def test_bodies_triangles_are_the_calls_in_body_order():
    """Law: ``extrude.bodies_triangles`` (the distinct triangle sets made on the thread
    pool) gives the materials in the order ``body_triangles`` called body after body gives
    them (so the same indices) and each body's tables as that call gives them; with
    ``shared``, instances (here /S0 and /S1 at rest, /S3 and /S2 at 0.6c) hold one triangle
    table, the first one's, and keep their own points and materials. Oracle: those calls
    (exact: the same NumPy operations on the same inputs)."""
    import numpy as np

    from warp_st.spacetime.extrude import bodies_triangles, body_triangles

    bodies = _mixed_bodies()  # /M, /E (no surfaces), /S0, /S3, /D, /S1, /S2
    first = [0, None, 2, 3, 4, 2, 3]  # the first body of each one's instances
    shading = ("normals", "triangles", "tri_normal", "tri_smooth", "tri_size", "tri_st")
    own = ("rest", "local", "tri_material")
    want_m, want_i = [], {}
    want = [body_triangles(b, want_m, want_i) if b.surfaces else None for b in bodies]
    assert len(want_m) == 7
    assert not any(m is bodies[4].surfaces[0].material for m in want_m)  # degenerate triangles only: unused
    for shared in (True, False):
        got_m, got_i = [], {}
        got = bodies_triangles(bodies, got_m, got_i, shared=shared)
        assert got_m == want_m
        assert [g is None for g in got] == [w is None for w in want] == [False, True] + [False] * 5
        for i, (g, w) in enumerate(zip(got, want)):
            if w is None:
                continue
            source = want[first[i]] if shared else w
            for name in shading:
                np.testing.assert_array_equal(getattr(g, name), getattr(source, name), err_msg=name)
            for name in own:
                np.testing.assert_array_equal(getattr(g, name), getattr(w, name), err_msg=name)
        tables = [None if g is None else id(g.triangles) for g in got]
        groups = first if shared else [i if w is not None else None for i, w in enumerate(want)]
        assert [tables.index(t) for t in tables] == [groups.index(f) for f in groups]


def test_bodies_that_differ_in_triangles_or_normals_alone_get_their_own_tables(monkeypatch):
    """Law: the instance key holds the triangles and the vertex normals, not only the
    points about the pivot: a copy whose triangles wind the other way, or whose normals
    are others, computes its own tables (its facet normals point the other way, or its
    smooth normals are its own), while a true copy (the same arrays) shares."""
    import dataclasses

    import numpy as np

    from warp_st.core.scene import Body, RenderSettings, Scene
    from warp_st.spacetime import extrude

    base = _copies().bodies[0]
    surf = base.surfaces[0]

    def copy(name, shift, **changes):
        s = dataclasses.replace(surf, prim_path=f"/{name}", points=surf.points + shift, **changes)
        return Body(f"/{name}", (s,), base.origin + shift, np.zeros(3), 0.0)

    bodies = (base, copy("Same", [4.0, 0.0, 0.0]), copy("Flipped", [8.0, 0.0, 0.0], triangles=surf.triangles[:, ::-1]),
              copy("Normals", [12.0, 0.0, 0.0], normals=-surf.normals))
    made = []
    compute = extrude._body_triangles
    monkeypatch.setattr(extrude, "_body_triangles", lambda body, *a: made.append(body.prim_path) or compute(body, *a))
    shapes = rigid_shapes(Scene(source="<copies>", bodies=bodies, lights=(), cameras=(), settings=RenderSettings()))
    assert sorted(made) == ["/Flipped", "/Normals", "/S0"]
    rows = [np.flatnonzero(shapes.tri_body == b) for b in range(4)]
    np.testing.assert_array_equal(shapes.tri_normal[rows[2]], -shapes.tri_normal[rows[0]])


def test_facet_normals_and_sizes_are_numpys_cross_and_norm_to_the_bit():
    """Oracle: each triangle's unit normal is np.cross(b - a, c - a) / np.linalg.norm of it
    (floored at 1e-300, so a degenerate triangle's is 0), and its size the longest of its
    three edges' np.linalg.norm, bit for bit, on random points over twelve decades of
    scale and offset, with degenerate (repeated corner) triangles. Exact equality: the
    tables are computed in float64 by the same operations; any other order of them would
    round differently (the extrusion path and the rigid path share ``_facets``)."""
    import numpy as np

    from warp_st.spacetime.extrude import _facets

    rng = np.random.default_rng(7)
    for _ in range(40):
        n = int(rng.integers(3, 3000))
        pts = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-4, 4) + rng.normal(size=3) * 10.0 ** rng.uniform(-2, 4)
        tris = rng.integers(0, n, size=(int(rng.integers(1, 5000)), 3))
        tris[::11, 2] = tris[::11, 0]  # degenerate: a repeated corner
        a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        cross = np.cross(b - a, c - a)
        normal = cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300)
        size = np.max([np.linalg.norm(e, axis=1) for e in (b - a, c - a, c - b)], axis=0)
        got_normal, got_size = _facets(pts, tris)
        assert got_normal.shape == (len(tris), 3) and got_size.shape == (len(tris),)
        assert np.array_equal(got_normal, normal)
        assert np.array_equal(got_size, size)
