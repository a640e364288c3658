"""Where the top level's traversal starts (``Geometry.root_link``, ``rendering.device.set_nodes``).

A top level of one leaf (a scene of one segment) has a root wide node with one child,
whose box is the root's: the root box test has just tested it, so the traversal starts
at that child. The hits must be the same bits as from the root node, with one node
visit fewer for every ray that enters the box; a root of several children starts at
the root.
"""
import numpy as np
import pytest
import warp as wp

from tracing_helpers import RigidDatabase, cube_body, random_rays, scene_of, sphere_body, Database, tube_windows
from warp_st.kernels.struct_ref import seal


def _cast_from_root(db, origins, dirs, finite):
    """``db.cast`` with the traversal started at wide node 0."""
    start = db.geo.root_link
    db.geo.root_link = 0
    seal(db.geo)
    try:
        return db.cast(origins, dirs, finite=finite)
    finally:
        db.geo.root_link = start
        seal(db.geo)


@pytest.mark.parametrize("finite", [True, False])
def test_a_one_leaf_top_level_starts_at_its_leaf(finite):
    scene = scene_of(sphere_body("/Ball", (0.5, -0.2, -4.0), 1.0, lifetime=(-30.0, 1.0)))
    db = RigidDatabase(scene, tube_windows(scene), origin=(-1.0, 0.0, 0.5, -1.0))
    assert db.geo.root_link > 0 and db.geo.root_link & 7 > 0  # a leaf's link (a count in its low bits)
    rng = np.random.default_rng(3)
    origins, dirs = random_rays(rng, 4000, Database(scene, tube_windows(scene), primitive="tet"), finite)
    tri, s, visits = db.cast(origins, dirs, finite=finite)
    tri0, s0, visits0 = _cast_from_root(db, origins, dirs, finite)
    assert (tri >= 0).sum() > 500
    assert np.array_equal(tri, tri0) and s.tobytes() == s0.tobytes()
    entered = visits0 > 0
    assert np.array_equal(visits[entered], visits0[entered] - 1) and entered.sum() > 1000


def test_a_root_of_several_children_starts_at_the_root():
    scene = scene_of(sphere_body("/Ball", (0.5, -0.2, -4.0), 1.0), cube_body("/Box", (-2.0, 1.0, -6.0), 1.0))
    db = RigidDatabase(scene, tube_windows(scene))
    assert db.geo.root_link == 0
