"""The rigid leaf's fast path for bodies at rest (``trace_rigid``'s AT_REST bit).

A body with v = 0, A^-1 = I and its bottom level in its own coordinates sees the lab ray
moved: p = o - anchor, d = n, so the leaf takes d, 1 / d and the bottom level's shear
from the ray (computed once in ``prepare``) instead of per segment. Every value is the one
the general path computes (a product with 1 and 0, a sum with 0, the same divisions), so
the hits must be the same bits with the bit cleared: no tolerance.
"""
import numpy as np
import pytest
import warp as wp

from tracing_helpers import Database, RigidDatabase, cube_body, mixed_scene, random_rays, scene_of, sphere_body, tube_windows
from warp_st.rendering.device_rigid import make_rigid_geometry

AT_REST = 2  # kernels/trace_rigid.py's body_flags bit


def _scene():
    """mixed_scene's bodies (one at rest among moving, coupled, decoupled, short-lived)
    and two more at rest, one with a finite lifetime."""
    return scene_of(*mixed_scene().bodies, cube_body("/StillCube", (-1, 2, -7), 1.2),
                    sphere_body("/StillShort", (3, -1, -4), 0.6, lifetime=(-12.0, 1.0)))


def test_the_bit_marks_exactly_the_bodies_at_rest():
    db = RigidDatabase(_scene(), tube_windows(_scene()))
    flags = db.static.body_flags.numpy()
    at_rest = [not np.any(b.velocity) for b in db.shapes.bodies]
    assert sum(at_rest) == 3
    assert np.array_equal((flags & AT_REST) != 0, at_rest)


@pytest.mark.parametrize("finite", [True, False])
def test_at_rest_hits_are_the_general_paths_bit_for_bit(finite):
    scene = _scene()
    db = RigidDatabase(scene, tube_windows(scene), origin=(-3.0, 0.5, 0.0, -2.0))
    rng = np.random.default_rng(17)
    tets = Database(scene, tube_windows(scene), primitive="tet")  # the rays' targets; its triangle numbering
    origins, dirs = random_rays(rng, 8000, tets, finite)
    fast = db.cast(origins, dirs, finite=finite)
    flags = db.static.body_flags.numpy()
    db.static.body_flags = wp.array(flags & ~AT_REST, dtype=wp.int32, device="cpu")
    db.geo = make_rigid_geometry(db.k, db.static, db.segments, db.bvh, db.origin)
    general = db.cast(origins, dirs, finite=finite)
    at_rest = np.flatnonzero([not np.any(b.velocity) for b in scene.bodies])
    still = np.isin(tets.mesh.tri_body[np.maximum(fast[0], 0)], at_rest)
    assert (still & (fast[0] >= 0)).sum() > 300  # the fast path is taken, and hits
    assert np.array_equal(fast[0], general[0])
    assert fast[1].tobytes() == general[1].tobytes()
