"""The 4-wide 4D BVH traversal, generic over what its leaves hold (device code).

A ray is the null line E(s) = O + s d with d = (-1, n) for finite light speed or
(0, n) for infinite light speed (docs/spec.md §1), s >= 0 the lookback, in render-origin
coordinates. The tree is bvh_wide.py's: wide node j's four child boxes axis-major
(t0..t3, x0..x3, y0..y3, z0..z3) in ``node_lo[j]`` / ``node_hi[j]``, its children's links
``first << LINK_SHIFT | count`` in ``node_link[j]`` (a leaf's range, or a wide node with
count 0; -1 for an empty slot), the root wide node 0 with its box ``root_lo``/``root_hi``.
The root's test comes first, before the per-ray set-up (``prepare``, the stack): the
visit of wide node 0, whose nearest child hit is where the traversal starts; or, for a
root of one child (``root_link``, its link; a top level of one leaf), the slab test of
the root's box, which is that child's.

The leaves are the caller's: prisms or tetrahedra (``trace.py``), rigid bodies' motion
segments (``trace_rigid.py``). ``make_traverse`` takes

- ``prepare(g, o, n, finite, inv) -> Ray``: what the leaf test needs per ray, computed once
  after the root's test (rays that miss the whole database return before it); ``inv``
  is the ray's ``null_inv``, which the traversal has computed for its slabs;
- ``leaf(g, ray, first, count, o, n, finite, s_min, best, best_prim, best_lam,
  skip_tri, skip_body, skip_dist, any_hit) -> (best, best_prim, best_lam)``: the closest
  hit so far updated by primitives first .. first + count - 1.

Traversal: nearest child first with a fixed stack; a visit tests its four child boxes
as one 16-lane slab test and carries the children's packed links, loaded beside their
boxes. A null ray meets a 4D box by the usual slab test plus the t slab (t = t_c - s).
In float32 the visit (slabs, the hit children, their order) is C++ on clang's vector
types (``wide_visit.inc``, as ``blas.py``'s query); float64 runs its Warp-language
twin (``box_quad``, ``sort4``), which the tests hold equal to it bit for bit.
"""

import warp as wp

from warp_st.kernels.layout import LINK_MASK, LINK_SHIFT, MAX_WIDE_DEPTH
from warp_st.kernels.native import float_bits, snippet

__all__ = ["make_traverse", "make_box_ops", "make_null_inv", "make_sort4", "STACK_SIZE", "SHORT_STACK", "stack_for"]

#: Traversal stack entries: a visit pushes at most three children, so three per level
#: of the wide tree (bvh_wide.MAX_WIDE_DEPTH) bound it. Zero-initialised per ray, so
#: no larger than needed.
STACK_SIZE = 3 * MAX_WIDE_DEPTH
#: The stack of a traversal whose tree is at most 8 wide levels deep (``stack_for``): Warp
#: zeroes a function's vectors where it declares them, and the full stack's 768 bytes (in
#: float32) cost 4-7 % of a ray that enters the scene on the small stages.
SHORT_STACK = 24


def stack_for(levels: int) -> int:
    """The stack a traversal of a tree of ``levels`` binary levels needs: SHORT_STACK when
    it holds three entries per wide level (the wide nodes are the binary inner nodes at
    even depths, at most (levels + 1) // 2 on a path), else STACK_SIZE."""
    return SHORT_STACK if 3 * ((int(levels) + 1) // 2) <= SHORT_STACK else STACK_SIZE


def make_box_ops(scalar):
    """(fmin, fmax, safe_inv, slab_grow): the slab test's scalar helpers."""
    BIG = 1.0e30
    # pbrt's gamma(3)-style widening of the slab interval against rounding.
    EPS = 6.0e-8 if wp.types.type_size_in_bytes(scalar) == 4 else 1.12e-16
    SLAB_GROW = 1.0 + 32.0 * EPS

    # min/max as single compare-selects (x86 minss/maxss). wp.min/wp.max guard NaN
    # arguments with a second compare each, which doubled the slab test's cost; the
    # slab values here are never NaN (safe_inv keeps 1/d finite and non-zero, box
    # corners are finite or t = +inf).
    @wp.func
    def fmin(a: scalar, b: scalar) -> scalar:
        return wp.where(a < b, a, b)

    @wp.func
    def fmax(a: scalar, b: scalar) -> scalar:
        return wp.where(a > b, a, b)

    @wp.func
    def safe_inv(x: scalar) -> scalar:
        if wp.abs(x) < scalar(1.0e-30):
            if x < scalar(0.0):
                return -scalar(BIG)
            return scalar(BIG)
        return scalar(1.0) / x

    return fmin, fmax, safe_inv, SLAB_GROW


@wp.func_native(snippet("null_inv.inc", TINY=1.0e-30, BIG=1.0e30))
def native_null_inv(n: wp.vec3, finite: int) -> wp.vec4:
    """The float32 ``null_inv`` in C++ (``null_inv.inc``): the three reciprocals as one
    vector division, the same bits as ``safe_inv``'s."""


def make_null_inv(scalar, native: bool | None = None):
    """``null_inv(n, finite)``: 1 / d per axis of the null ray's d = (-1, n), or (0, n)
    with infinite light speed (whose t slab then takes 1e30): what the slab tests multiply by.
    ``native``: in float32 (None: the default) ``native_null_inv``, one vector division
    instead of three (every ray's first work); False, or float64: the Warp-language twin,
    which the tests hold equal to it bit for bit."""
    if scalar == wp.float32 and native is not False:
        return native_null_inv
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    safe_inv = make_box_ops(scalar)[2]
    BIG = 1.0e30

    @wp.func
    def null_inv(n: vec3, finite: int) -> vec4:
        inv_t = scalar(BIG)
        if finite != 0:
            inv_t = scalar(-1.0)
        return vec4(inv_t, safe_inv(n[0]), safe_inv(n[1]), safe_inv(n[2]))

    return null_inv


def make_sort4(scalar):
    """``sort4(entries, links)``: a wide node's four children in ascending order of
    entry, their links alongside (a 5-exchange network)."""
    vec4 = wp.types.vector(4, scalar)

    @wp.func
    def order2(e: vec4, l: wp.vec4i, i: int, j: int):
        """Compare-exchange of entries i < j (with their links) into ascending order."""
        if e[j] < e[i]:
            t = e[i]
            e[i] = e[j]
            e[j] = t
            m = l[i]
            l[i] = l[j]
            l[j] = m
        return e, l

    @wp.func
    def sort4(e: vec4, l: wp.vec4i):
        e, l = order2(e, l, 0, 1)
        e, l = order2(e, l, 2, 3)
        e, l = order2(e, l, 0, 2)
        e, l = order2(e, l, 1, 3)
        e, l = order2(e, l, 1, 2)
        return e, l

    return sort4


@wp.func_native(snippet("wide_visit.inc", GROW=make_box_ops(wp.float32)[3]))
def native_visit(lo: wp.types.vector(16, wp.float32), hi: wp.types.vector(16, wp.float32), o: wp.vec4, inv: wp.vec4,
                 s_min: wp.float32, s_max: wp.float32, links: wp.vec4i) -> wp.types.vector(9, wp.float32):
    """A float32 node visit in C++ (``wide_visit.inc``): the children's entries in
    ascending order (+inf for the missed) in lanes 0-3, their links' int32 bits in 4-7,
    the number hit in 8."""


def make_traverse(scalar, Geometry, prepare, leaf, inline: bool | None = None, native: bool | None = None,
                  stack_size: int = STACK_SIZE):
    """``trace(g, o, n, finite, s_min, s_max, skip_tri, skip_body, skip_dist, any_hit)``
    over ``Geometry``'s 4-wide BVH with the leaf test ``leaf`` (see the module docstring).
    ``inline``: Warp's inlining of ``trace`` (None: the compiler's choice; True: into every
    call site, where the caller's constant arguments then fold its branches away).

    ``native``: the float32 node visit and ``null_inv`` in C++ (``wide_visit.inc``,
    ``null_inv.inc``; None: for float32, the default; False: the Warp-language ``box_quad``,
    ``sort4`` and ``null_inv``, their twins in the tests; float64 always takes those).

    ``stack_size``: the traversal stack's entries (``stack_for`` the tree; STACK_SIZE holds
    any tree the builder makes).

    Returns (primitive index or -1, s, barycentrics, nodes visited, stack overflowed).
    """
    use_native = scalar == wp.float32 and native is not False
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    vec16 = wp.types.vector(16, scalar)
    stack_i = wp.types.vector(stack_size, wp.int32)
    stack_s = wp.types.vector(stack_size, scalar)
    INF = float("inf")
    fmin, fmax, _, SLAB_GROW = make_box_ops(scalar)
    null_inv = make_null_inv(scalar, native)

    @wp.func
    def box_quad(g: Geometry, node: int, o16: vec16, inv16: vec16, s_min: scalar, s_max: scalar):
        """Slab tests of wide node ``node``'s four child boxes at once: (entries, exits).
        Child k is hit when entries[k] <= exits[k]. The t slab is t = t_c - s.

        All sixteen slabs as vector ops (the compiler packs them into SIMD lanes), the
        reductions over the four axes as trees. The far exit widens once at the end,
        as pbrt's does per slab (the scale is positive, so min and scale commute; a
        negative exit misses either way)."""
        a = wp.cw_mul(g.node_lo[node] - o16, inv16)
        b = wp.cw_mul(g.node_hi[node] - o16, inv16)
        n = vec16()
        f = vec16()
        for k in range(16):
            n[k] = fmin(a[k], b[k])
            f[k] = fmax(a[k], b[k])
        near = vec4()
        far = vec4()
        for k in range(4):
            near[k] = fmax(fmax(fmax(n[k], n[4 + k]), fmax(n[8 + k], n[12 + k])), s_min)
            far[k] = fmin(fmin(fmin(f[k], f[4 + k]), fmin(f[8 + k], f[12 + k])) * scalar(SLAB_GROW), s_max)
        return near, far

    sort4 = make_sort4(scalar)

    @wp.func(inline=True)
    def visit(g: Geometry, first: int, o: vec4, inv: vec4, s_min: scalar, best: scalar):
        """Wide node ``first``'s children: their entries in ascending order (+inf for the
        missed), their links alongside, and how many are hit. (Inlined by force: a call
        would copy the Geometry struct, which Warp passes by value.)"""
        e = vec4()
        links = g.node_link[first]
        hits = int(0)
        if wp.static(use_native):
            r9 = native_visit(g.node_lo[first], g.node_hi[first], o, inv, s_min, best, links)
            for k in range(4):
                e[k] = r9[k]
                links[k] = float_bits(r9[4 + k])
            hits = int(r9[8])
        else:
            o16 = vec16()  # box_quad's broadcasts (the C++ visit splats its own)
            inv16 = vec16()
            for k in range(16):
                o16[k] = o[k // 4]
                inv16[k] = inv[k // 4]
            near, far = box_quad(g, first, o16, inv16, s_min, best)
            for k in range(4):
                if near[k] <= far[k]:
                    e[k] = near[k]
                    hits += 1
                else:
                    e[k] = scalar(INF)
            e, links = sort4(e, links)
        return e, links, hits

    GeometryRef, expand = Geometry.Ref, Geometry.expand

    @wp.func(inline=inline)
    def trace(
        r: GeometryRef,
        o: vec4,
        n: vec3,
        finite: int,
        s_min: scalar,
        s_max: scalar,
        skip_tri: int,
        skip_body: int,
        skip_dist: scalar,
        any_hit: int,
    ):
        """Closest (or, with any_hit, any) hit with lookback in (s_min, s_max).

        Hits on triangle ``skip_tri``, and on body ``skip_body`` nearer than
        ``skip_dist``, are ignored (secondary rays leaving a tessellated surface).
        Near child first with a fixed stack; an overflow is reported, never silent.
        """
        g = expand(r)  # the pointers to the struct (see kernels/struct_ref.py)
        inv = null_inv(n, finite)  # dt = -1 on the past lightcone, 0 with infinite light speed
        best = s_max
        best_prim = int(-1)
        visits = int(0)
        overflow = int(0)
        # The traversal carries packed links (first << LINK_SHIFT | count), not node
        # indices: children's links are loaded beside their boxes, so a visit needs
        # no dependent load before its children's boxes.
        cur = g.root_link
        e0 = vec4()
        links0 = wp.vec4i()
        hits0 = int(0)
        if cur != 0:
            # The root's one child, whose box is the root's: rays that miss it (sky) return
            # before any other set-up.
            ra = wp.cw_mul(g.root_lo - o, inv)
            rb = wp.cw_mul(g.root_hi - o, inv)
            r_near = s_min
            r_far = s_max
            for k in range(4):
                r_near = fmax(r_near, fmin(ra[k], rb[k]))
                r_far = fmin(r_far, fmax(ra[k], rb[k]) * scalar(SLAB_GROW))
            if r_near > r_far:
                return int(-1), s_max, vec4(scalar(0.0)), int(0), int(0)
        else:
            # The root node's visit first: rays that miss its children (sky) return before
            # any other set-up; the nearest child hit is the start, the others are pushed.
            visits = 1
            e0, links0, hits0 = visit(g, 0, o, inv, s_min, best)
            if hits0 == 0:
                return int(-1), s_max, vec4(scalar(0.0)), visits, int(0)
            cur = links0[0]
        st_node = stack_i()
        st_s = stack_s()
        sp = int(0)
        # The root's other hits pushed as the loop pushes a visit's (one loop taking the
        # root's visit as its first measured 3-7 % slower).
        for k in range(3):
            j = 3 - k
            if j < hits0:
                st_node[sp] = links0[j]
                st_s[sp] = e0[j]
                sp += 1
        ray = prepare(g, o, n, finite, inv)
        # The hit's barycentrics as four scalars, not a vec4: Warp merges a variable assigned
        # under a branch with wp.where, which for a vector copies it through memory, and the
        # 8-byte loads of a vector just stored as 4-byte pieces wait for the stores (a failed
        # store-to-load forwarding at every leaf visit).
        lam0 = scalar(0.0)
        lam1 = scalar(0.0)
        lam2 = scalar(0.0)
        lam3 = scalar(0.0)
        while cur >= 0:
            visits += 1
            first = cur >> LINK_SHIFT
            count = cur & LINK_MASK
            next_link = int(-1)
            if count > 0:
                best, best_prim, lam = leaf(g, ray, first, count, o, n, finite, s_min, best, best_prim,
                                            vec4(lam0, lam1, lam2, lam3), skip_tri, skip_body, skip_dist, any_hit)
                lam0 = lam[0]
                lam1 = lam[1]
                lam2 = lam[2]
                lam3 = lam[3]
                if any_hit != 0 and best_prim >= 0:
                    break
            else:
                # Children missed get entry +inf; sorted by entry, go to the nearest hit,
                # push the other hits farthest first.
                e, links, hits = visit(g, first, o, inv, s_min, best)
                if hits > 0:
                    next_link = links[0]
                    if sp + hits - 1 <= stack_size:
                        for k in range(3):
                            j = 3 - k
                            if j < hits:
                                st_node[sp] = links[j]
                                st_s[sp] = e[j]
                                sp += 1
                    else:
                        overflow = 1
            # Pop until a node whose entry is still nearer than the best hit.
            while next_link < 0 and sp > 0:
                sp -= 1
                if st_s[sp] <= best:
                    next_link = st_node[sp]
            cur = next_link
        return best_prim, best, vec4(lam0, lam1, lam2, lam3), visits, overflow

    return trace
