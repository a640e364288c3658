"""Merge classes of the two-level rigid path: which bodies one bottom level holds together.

``spacetime.rigid.shape_parts`` holds each body's triangles at rest; a merge class's
bodies (``merge_plan``) share one shape, one bottom level and one set of motion segments
(docs/design/two-level.md, "Merge classes share one shape"). Inputs are the bodies and
``rigid``'s held triangles (``found``: per body, with ``rest`` about the pivot and ``local``
in the lab at the reference time), their shape keys and how many bodies use each key.
"""
from __future__ import annotations

import numpy as np

from warp_st.core.extent import column_max, column_min

__all__ = ["merge_plan", "merged_bodies", "motion_group", "pivot_offset", "MERGE_TRIANGLES", "COPY_REACH"]


#: Bodies of at most this many triangles join their merge class's one shape; a larger
#: body keeps its own bottom level (its own query costs little beside its triangles', and
#: one shape of many large bodies builds slowly: its SAH's upper levels are serial).
#: Instances of a shared shape are copied into one only while all of their class's copies
#: hold at most this many together (beyond, one small shared shape stays in the caches
#: where a copy of each does not).
MERGE_TRIANGLES = 1 << 14
#: Copies of instances are held about the first one's pivot: only those within this many
#: of their sizes of it, so their float32 points round by at most 2^-18 of their size
#: (2^-24 about their own pivots).
COPY_REACH = 64.0


def motion_group(body) -> tuple:
    """The (velocity, coupling) that puts bodies in one motion group (one frame)."""
    return tuple(np.asarray(body.velocity, np.float64).tolist()), bool(body.decoupled)


def merge_plan(bodies: tuple, found: list, keys: list, uses: dict, quadric: list) -> np.ndarray:
    """Which bodies share one merged shape: (B,) int32, each body's holder (itself, or the
    first body of its merge class).

    A merge class is the bodies with the same velocity, coupling and lifetime (so the
    same frame, ray map and s-interval: the segment's body enters the trace only through
    these) that are traced as triangles, are not instances of a shared shape, hold at
    most ``MERGE_TRIANGLES`` triangles and are objects of their own (not an animated
    body's pieces, not exact quadrics). Their triangles, already held in the class's
    motion-group frame, become one shape: one bottom level and one set of segments, as
    one ``wp.Mesh`` holds them, instead of a top-level leaf, a float64 ray map and a
    bottom-level query per body; where that shape's box would grow past the members'
    boxes, the groups of them whose boxes do not (``_no_larger_groups``).

    Instances of shared shapes form classes of their own: when all copies of a class
    hold at most ``MERGE_TRIANGLES`` triangles, those within ``COPY_REACH`` of their
    sizes of the first one are copied into one shape held in that one's frame (its
    ``holder``), and so on for the rest. Larger ones stay shared: copied, 16 instanced
    spheres of 16k triangles traced 15 % slower (a bottom level of all their triangles
    does not stay in the caches as one small shape does: docs/design/two-level.md)."""
    holder = np.arange(len(bodies), dtype=np.int32)
    paths: dict = {}
    for b in bodies:
        paths[b.prim_path] = paths.get(b.prim_path, 0) + 1
    classes: dict = {}
    for i, (b, bt) in enumerate(zip(bodies, found)):
        if (bt is None or len(bt.triangles) > MERGE_TRIANGLES or b.piece_linear is not None
                or paths[b.prim_path] > 1 or quadric[i]):
            continue
        classes.setdefault((*motion_group(b), tuple(float(t) for t in b.lifetime), uses[keys[i]] > 1), []).append(i)
    for (*_, copies), members in classes.items():
        if not copies:
            clusters = [members]
        elif sum(len(found[i].triangles) for i in members) > MERGE_TRIANGLES:
            clusters = []
        else:
            clusters, left = [], members
            while left:
                head = bodies[left[0]]
                near = [i for i in left if float(np.max(np.abs(pivot_offset(bodies[i], head)))) <= COPY_REACH * max(
                    float(np.max(np.abs(found[i].rest))), 1e-30)]
                clusters.append(near)
                taken = set(near)
                left = [i for i in left if i not in taken]
        for cluster in clusters:
            for group in _no_larger_groups(cluster, bodies, found):
                holder[group] = group[0]
    return holder


#: Clusters of more members than this are merged whole or not at all (the pairwise
#: merging below compares every pair at each step).
PAIRWISE_MEMBERS = 64


def _area(e):
    return 2.0 * (e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0])


def _no_larger_groups(members: list, bodies: tuple, found: list) -> list:
    """The groups of ``members`` (indices, ascending) to merge, each of two or more: all
    of them when the box of all (lab boxes at the first one's reference time) has no more
    surface area than their boxes together, as a ray then enters the merged shape's box
    no more often than it enters the members' boxes, each a bottom-level query of its own
    (the SAH's measure; spread bodies keep their own boxes: four cubes round a sphere,
    merged, cost every ray that hits the sphere one more query). Otherwise (clusters of
    up to ``PAIRWISE_MEMBERS``) the pairs of groups for which the same holds are merged,
    the one whose box grows least first (its merged area against the two areas), until
    no pair is left: a stage's two interleaved checker meshes become one shape though the
    mirror behind them keeps its own."""
    if len(members) < 2:
        return []
    h = bodies[members[0]]
    lo, hi = [], []
    for i in members:
        moved = np.asarray(h.velocity, np.float64) * (h.reference_time - bodies[i].reference_time)
        lo.append(column_min(found[i].local) + moved)
        hi.append(column_max(found[i].local) + moved)
    lo, hi = np.array(lo), np.array(hi)
    area = _area(hi - lo)
    if float(_area(hi.max(axis=0) - lo.min(axis=0))) <= float(area.sum()):
        return [list(members)]
    if len(members) > PAIRWISE_MEMBERS:
        return []
    groups = [[i] for i in members]
    while len(groups) > 1:
        merged = _area(np.maximum(hi[:, None], hi[None]) - np.minimum(lo[:, None], lo[None]))  # (G, G)
        ratio = merged / np.maximum(area[:, None] + area[None], 1e-300)
        ratio[np.tri(len(groups), dtype=bool)] = np.inf  # pairs a < b only
        a, b = np.unravel_index(int(np.argmin(ratio)), ratio.shape)
        if not ratio[a, b] <= 1.0:
            break
        groups[a] = sorted(groups[a] + groups[b])
        lo[a], hi[a], area[a] = np.minimum(lo[a], lo[b]), np.maximum(hi[a], hi[b]), merged[a, b]
        keep = np.arange(len(groups)) != b
        groups, lo, hi, area = [g for g, k in zip(groups, keep) if k], lo[keep], hi[keep], area[keep]
    return [g for g in groups if len(g) > 1]


def pivot_offset(body, other) -> np.ndarray:
    """The pivot of ``body`` relative to ``other``'s reference event (same velocity): o -
    o_other - v (t_ref - t_other), in the lab."""
    return (np.asarray(body.origin, np.float64) - np.asarray(other.origin, np.float64)
            - np.asarray(body.velocity, np.float64) * (body.reference_time - other.reference_time))


def merged_bodies(holder: np.ndarray) -> np.ndarray:
    """1 for every body of a merge class of several (a holder of others, or held), (B,) int32."""
    merged = holder != np.arange(len(holder))
    merged[holder[merged]] = True
    return merged.astype(np.int32)
