"""The float32 null ray's reciprocals in C++ (kernels/null_inv.inc: one vector division)
against their Warp-language twin (traverse.make_null_inv(native=False), safe_inv per axis).

Law: the same four float32 values bit for bit, for every direction component: ordinary
values of either sign, zeros of both signs, the guard's boundary 1e-30 and its float32
neighbours, subnormals, infinities and NaN, with finite and infinite light speed.
"""
from __future__ import annotations

import numpy as np
import warp as wp

from warp_st.kernels.traverse import make_null_inv
from warp_st.rendering.warp_init import init_warp

init_warp()

_native = make_null_inv(wp.float32)
_twin = make_null_inv(wp.float32, native=False)


@wp.kernel(enable_backward=False, module="unique")
def _both(n: wp.array(dtype=wp.vec3), finite: wp.array(dtype=wp.int32), a: wp.array(dtype=wp.vec4),
          b: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    a[i] = _native(n[i], finite[i])
    b[i] = _twin(n[i], finite[i])


def _special() -> np.ndarray:
    tiny = np.float32(1.0e-30)
    values = [0.0, -0.0, 1.0, -1.0, -3.0, 0.1, 7.5e5, tiny, -tiny, np.nextafter(tiny, np.float32(0)),
              np.nextafter(tiny, np.float32(1)), -np.nextafter(tiny, np.float32(0)), 1.0e-38, -1.0e-38, 1.0e-45,
              -1.0e-45, 3.0e38, np.inf, -np.inf, np.nan]
    return np.array(values, dtype=np.float32)


def test_the_cpp_reciprocals_are_their_warp_twin_bit_for_bit():
    rng = np.random.default_rng(5)
    special = _special()
    # every special value in every lane, beside random directions and random magnitudes
    grid = np.stack(np.meshgrid(special, special, special[::3], indexing="ij"), axis=-1).reshape(-1, 3)
    random = rng.normal(size=(4000, 3)).astype(np.float32) * np.float32(10.0) ** rng.integers(-35, 35, (4000, 1))
    n = np.concatenate([grid, random.astype(np.float32)])
    finite = np.tile(np.array([0, 1], np.int32), len(n) // 2 + 1)[:len(n)]
    a, b = (wp.zeros(len(n), dtype=wp.vec4, device="cpu") for _ in range(2))
    wp.launch(_both, dim=len(n), inputs=[wp.array(n, dtype=wp.vec3, device="cpu"),
                                         wp.array(finite, dtype=wp.int32, device="cpu"), a, b], device="cpu")
    a, b = a.numpy(), b.numpy()
    assert np.array_equal(a.view(np.uint32), b.view(np.uint32))
    # and they are the reciprocals: +-1e30 for |x| < 1e-30, else 1 / x; -1 or 1e30 in lane 0
    big = np.float32(1.0e30)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # 1 / subnormal is inf
        want = np.where(np.abs(n) < np.float32(1.0e-30), np.where(n < 0, -big, big), np.float32(1.0) / n)
    assert np.array_equal(a[:, 1:].view(np.uint32), want.astype(np.float32).view(np.uint32))
    assert np.array_equal(a[:, 0], np.where(finite != 0, np.float32(-1.0), big))
