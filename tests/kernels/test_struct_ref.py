"""The pointer twin of a struct of arrays (``warp_st.kernels.struct_ref``).

The traversal takes the Geometry's ``ref`` and rebuilds the struct from it, so every
array, 2-d array, nested struct and plain field read through the rebuilt struct must be the
one read through the struct itself. The oracle is the struct passed by value, the way Warp
passes it, read in the same kernel: equal bit for bit (the same loads, no arithmetic)."""
import numpy as np
import pytest

from warp_st.kernels.struct_ref import referenced, seal
from warp_st.rendering.warp_init import init_warp

wp = init_warp()


@referenced
class Inner:
    values: wp.array(dtype=wp.float64)
    scale: wp.float32


@referenced
class Outer:
    points: wp.array(dtype=wp.vec3)
    index: wp.array(dtype=wp.int32)
    rows: wp.array2d(dtype=wp.float32)
    lo: wp.vec4
    count: int
    inner: Inner


@wp.func
def read(g: Outer, i: int) -> wp.vec4:
    j = g.index[i]
    return wp.vec4(g.points[j][1] + g.lo[2], g.rows[i, 2] * g.inner.scale, wp.float32(g.inner.values[j]),
                   wp.float32(g.count))


@wp.kernel(enable_backward=False, module="unique")
def both(g: Outer, by_value: wp.array(dtype=wp.vec4), by_ref: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    by_value[i] = read(g, i)
    by_ref[i] = read(Outer.expand(g.ref), i)


def _outer(n: int, rng):
    inner = Inner()
    inner.values = wp.array(rng.normal(size=n), dtype=wp.float64)
    inner.scale = 3.0
    g = Outer()
    g.points = wp.array(rng.normal(size=(n, 3)).astype(np.float32), dtype=wp.vec3)
    g.index = wp.array(rng.permutation(n).astype(np.int32), dtype=wp.int32)
    g.rows = wp.array(rng.normal(size=(n, 5)).astype(np.float32), dtype=wp.float32)
    g.lo = wp.vec4(1.0, 2.0, 100.0, 4.0)
    g.count = n
    g.inner = inner
    return g


def test_the_rebuilt_struct_reads_what_the_struct_reads():
    n = 257
    g = _outer(n, np.random.default_rng(5))
    seal(g)
    by_value, by_ref = wp.zeros(n, dtype=wp.vec4), wp.zeros(n, dtype=wp.vec4)
    wp.launch(both, dim=n, inputs=[g, by_value, by_ref])
    expected = by_value.numpy()
    assert np.all(expected[:, 0] != 0.0) and np.all(expected[:, 3] == n)  # the oracle read real data
    np.testing.assert_array_equal(by_ref.numpy(), expected)


def test_a_strided_array_is_refused():
    g = _outer(8, np.random.default_rng(6))
    g.points = wp.array(np.zeros((16, 3), np.float32), dtype=wp.vec3)[::2]
    with pytest.raises(ValueError, match="contiguous"):
        seal(g)


def test_empty_arrays_seal_whatever_their_strides():
    """An empty table (a scene without rigid bodies) comes as a zero-stride view or an
    array without memory; nothing reads it, so sealing takes it (pointer 0 when it has none)."""
    g = _outer(8, np.random.default_rng(7))
    g.points = wp.array(np.zeros((0, 3), np.float32), dtype=wp.vec3, copy=False)  # strides (0,)
    g.index = wp.zeros(0, dtype=wp.int32)  # no memory: ptr None
    seal(g)
    assert g.ref.index == 0 and g.ref.rows != 0
