"""A float32 render's kernel writes the Image's planes itself (film_planes.film_into).

Law: every plane is bit for bit what copying a film of the kernel's own out of it gives
(``Renderer._film_into = False``: film_planes.copy_film, whose time codes are NumPy's
``output.film.quantize_relative``, the kernel's ``time_code`` twin) — with mirrors and two
lights, with a stage of the physical light speed (lab time per time code != 1), with an
animated body's pieces mapped to their object, with several samples per pixel, and at a
camera time of 1e11 (the absolute times on a float64 grid of 1.5e-5, coarser than the
relative times' float32 one).
"""
import numpy as np
import pytest

import warp_st
from warp_st.rendering.renderer import Renderer

from animation_stages import write
from test_shared_pieces import STAGES  # its spinning rod: an animated body's pieces

ROOT = warp_st.__file__.rsplit("/warp_st/", 1)[0]
PLANES = ("rgba", "depth", "event_time", "source_time", "proper_time", "doppler", "object_id", "bounces")


def _scene(tmp_path, case):
    if case == "spinning":
        return warp_st.load(write(tmp_path, "spinning.usda", STAGES["spinning"]))
    return warp_st.load(f"{ROOT}/usd_scenes/{case}")


@pytest.mark.parametrize("case,frame,options", [
    ("mirrors/flanges_coupled.usda", 0.0, {}),
    ("relativistic_parade.usda", 0.0, {"samples": 4}),
    ("thesis/colour_cube.usda", 0.0, {}),
    ("thesis/sphere_and_cubes.usda", 1.0e11, {}),
    ("spinning", 40.0, {}),
])
def test_the_kernels_own_planes_are_the_copied_film(tmp_path, monkeypatch, case, frame, options):
    scene = _scene(tmp_path, case)
    into = Renderer(scene, frames=[frame], width=96, height=64, **options)
    assert into.precision.value == "float32"
    if case == "thesis/colour_cube.usda":
        assert float(scene.light_speed) != 1.0  # time codes are lab time / the light speed
    if case == "spinning":
        assert into.object_of is not None  # the pieces' ids become the rod's
    a = into.render(frame)
    monkeypatch.setattr(Renderer, "_film_into", False)
    b = Renderer(scene, frames=[frame], width=96, height=64, **options).render(frame)
    for name in PLANES:
        pa, pb = getattr(a, name), getattr(b, name)
        assert pa.dtype == pb.dtype and pa.shape == pb.shape, name
        assert pa.tobytes() == pb.tobytes(), f"{name}: {np.count_nonzero(pa != pb)} values differ"
    for image in (a, b):  # the kernel counts the covered pixels per thread (frame_inputs.film_covered)
        assert image.metadata["coverage"] == f"{np.count_nonzero(image.object_id)}/{image.object_id.size}"
    hit = a.object_id > 0
    assert hit.any() and (~hit).any() and np.isfinite(a.event_time[hit]).all()
    if frame > 1e10:
        assert np.abs(a.event_time[hit] - frame).max() > 0  # times about the camera's, not 0
    assert a.extra.keys() == b.extra.keys()
