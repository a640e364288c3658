"""The 4D top level's float32 node visit in C++ (kernels/wide_visit.inc) against its
Warp-language twin (traverse.py's box_quad and sort4, which the float64 path runs).

Law: the same closest hit, bit for bit (primitive, lookback s) and the same node visits,
for every float32 database (the rigid two levels, prisms, tetrahedra), finite and
infinite light speed: the two compute the same float32 operations in the same order, so
their entries, orders and pushes agree exactly (a different rounding, order of the
children or count of the hit ones changes the visits here).
"""
from __future__ import annotations

import numpy as np
import pytest
from tracing_helpers import (
    Database,
    RigidDatabase,
    mixed_scene,
    random_rays,
    tube_windows,
)

from warp_st.kernels.probe import make_probe
from warp_st.kernels.traverse import make_traverse

_TWINS: dict = {}


def _twin_probe(k):
    """The probe kernel of ``k`` with the Warp-language node visit."""
    if id(k) not in _TWINS:
        scalar, vec3, vec4, Geometry, prepare, leaf = k._probe_parts
        trace = make_traverse(scalar, Geometry, prepare, leaf, inline=True, native=False)
        _TWINS[id(k)] = make_probe(scalar, vec3, vec4, Geometry, trace, prepare, leaf)[0]
    return _TWINS[id(k)]


@pytest.mark.parametrize("primitive", ["rigid", "prism", "tet"])
@pytest.mark.parametrize("finite", [True, False])
def test_the_cpp_node_visit_is_its_warp_twin_bit_for_bit(primitive, finite):
    scene = mixed_scene()
    windows = tube_windows(scene)
    if primitive == "rigid":
        db = RigidDatabase(scene, windows, origin=(-3.0, 0.5, 0.0, -4.0))
    else:
        db = Database(scene, windows, primitive=primitive, origin=(-3.0, 0.5, 0.0, -4.0))
    rng = np.random.default_rng(17)
    origins, dirs = random_rays(rng, 4000, Database(scene, windows, primitive="tet"), finite)
    ours = db.cast(origins, dirs, finite=finite)
    twin = db.cast(origins, dirs, finite=finite, kernel=_twin_probe(db.k))
    assert np.array_equal(ours[0], twin[0])
    assert np.array_equal(ours[1], twin[1])  # float32 lookbacks, exactly (float64 copies)
    assert np.array_equal(ours[2], twin[2])
    assert (ours[0] >= 0).sum() > 1000  # the rays do meet the bodies
    assert ours[2].max() > 3  # and the traversal goes past the root
