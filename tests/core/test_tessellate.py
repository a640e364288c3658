"""Sphere tessellation counts (core/tessellate.py)."""
import math

from warp_st.core.tessellate import sphere_segments_for_sagitta


def test_sagitta_rule_meets_its_bound():
    for radius, sagitta in ((1.0, 1e-3), (2.5, 1e-2), (10.0, 0.3)):
        n = sphere_segments_for_sagitta(radius, sagitta)
        assert radius * (1.0 - math.cos(math.pi / n)) <= sagitta
        assert n == 8 or radius * (1.0 - math.cos(math.pi / (n - 1))) > sagitta  # the fewest


def test_sagitta_below_float_resolution_is_the_finest():
    """1 - 1e-17 == 1 in float64, so acos gives 0: the finest tessellation, not a division
    by zero (the fuzz test's camera with horizontalApertureOffset = 1e15, seed 849667981)."""
    assert sphere_segments_for_sagitta(1.0, 1e-17) == 512
    assert sphere_segments_for_sagitta(1.0, 1e-17, hi=100) == 100
