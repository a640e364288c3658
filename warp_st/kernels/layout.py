"""The node layout the host build writes and the device traversal reads, and the
primitive kinds a database can hold.

Shared by :mod:`warp_st.accel` (which builds the trees) and :mod:`warp_st.kernels.trace`
(which walks them); it lives with the kernels so that device code imports nothing above it.
"""
from __future__ import annotations

__all__ = ["PRIMITIVES", "SAH_FREE_DEPTH", "MAX_DEPTH", "WIDTH", "LINK_SHIFT", "LINK_MASK", "MAX_WIDE_DEPTH"]

#: What the geometry of a database holds: rigid bodies as instances (two levels,
#: ``trace_rigid.py``; float32, the renderer's default there), or their 4D extrusion
#: into prisms or tetrahedra (``trace.py``; the exact oracle and the float64 path).
PRIMITIVES = ("rigid", "prism", "tet")
#: Below this depth the SAH builder splits freely; deeper nodes are halved, so the
#: depth stays below SAH_FREE_DEPTH + log2 N (the benchmark trees are 26-30 deep).
SAH_FREE_DEPTH = 32
#: Depth bound of the binary build (log2 N <= 32).
MAX_DEPTH = SAH_FREE_DEPTH + 32
#: Children per traced (wide) node.
WIDTH = 4
#: Node links pack (first, count) as first << LINK_SHIFT | count.
LINK_SHIFT = 3
LINK_MASK = (1 << LINK_SHIFT) - 1
#: Depth bound of the wide tree (two binary levels per wide level); the traversal stack size.
MAX_WIDE_DEPTH = (MAX_DEPTH + 1) // 2

#: The 4th "barycentric" of an analytic hit (kernels/trace_rigid.py), whose first three are
#: then the unit lab normal; barycentrics lie in [0, 1], so any value above ANALYTIC_TEST
#: marks one (shade.shading_normal, the mirror's facet fallback).
ANALYTIC = 2.0
ANALYTIC_TEST = 1.5
