"""Doppler colour shift and searchlight: off by default, identity at D = 1, twin-checked
(the twin integrates against the tabulated CIE data, core/doppler_colour.py)."""
import numpy as np
import pytest
import warp as wp
from tracing_helpers import sphere_body

from warp_st.core.scene import CameraState, Material, RenderSettings, Scene
from warp_st.core.doppler_colour import INTERPOLATION_ERROR, doppler_table, doppler_transform_np
from warp_st.kernels.spectrum import make_spectrum
from warp_st.rendering.renderer import Renderer, init_warp


def _run_transform(rgb, d, cs, sl, scalar=wp.float32):
    """The Warp ``doppler_transform`` in ``scalar`` on colours (n, 3) and Doppler factors (n,)."""
    init_warp()
    vec3 = wp.types.vector(3, scalar)
    transform = make_spectrum(scalar, vec3)

    @wp.kernel(enable_backward=False, module="unique")
    def run(rgb: wp.array(dtype=vec3), d: wp.array(dtype=scalar), table: wp.array(dtype=vec3), cs: int, sl: int,
            out: wp.array(dtype=vec3)):
        i = wp.tid()
        out[i] = transform(rgb[i], d[i], table, cs, sl)

    ns = np.float32 if scalar == wp.float32 else np.float64
    table = wp.array(doppler_table().reshape(-1, 3).astype(ns), dtype=vec3)
    out = wp.zeros(len(d), dtype=vec3)
    wp.launch(run, dim=len(d), inputs=[wp.array(rgb.astype(ns), dtype=vec3), wp.array(d.astype(ns), dtype=scalar),
                                       table, cs, sl, out])
    return out.numpy()


@pytest.mark.parametrize("scalar", [wp.float32, wp.float64])
def test_kernel_transform_matches_float64_twin(scalar):
    """The Warp function (float32, and float64 as ``--precision float64`` compiles it)
    equals its float64 NumPy twin, which integrates the Smits spectrum
    against the tabulated CIE CMFs directly (no table), on 2,000 seeded random colours and
    Doppler factors 0.05..20 (past both ends of the table, all flag combinations).
    Tolerance: INTERPOLATION_ERROR (2e-4) + 1e-5 absolute after dividing by max(1, D^4):
    the table's linear interpolation in log2 D errs by at most that per unit basis weight
    (tests/core/test_doppler_colour.py; the Smits bases' kinks make the response curved),
    the weights of a colour in [0, 1] sum to its largest component <= 1; float32 adds
    ~1e-6 on values O(1)."""
    rng = np.random.default_rng(5)
    rgb = rng.uniform(0, 1, (2000, 3)).astype(np.float32)
    d = np.exp(rng.uniform(np.log(0.05), np.log(20.0), 2000)).astype(np.float32)
    for cs in (0, 1):
        for sl in (0, 1):
            got = _run_transform(rgb, d, cs, sl, scalar)
            want = doppler_transform_np(rgb, d, color_shift=bool(cs), searchlight=bool(sl))
            scale = np.maximum(1.0, d.astype(np.float64) ** 4 * sl)[:, None]
            np.testing.assert_allclose(got / scale, want / scale, rtol=0, atol=INTERPOLATION_ERROR + 1e-5)


def test_identity_at_unit_doppler():
    """D = 1 exactly (body and camera at rest): both effects on give the bit-identical
    image. And the table path itself is the identity at D = 1: at D one float32 ulp
    above 1 (which skips the kernel's D == 1 shortcut) every random colour is unchanged
    to 1e-5 (float32 rounding of the O(1) mix plus the shift over one ulp, ~1e-7)."""
    scene = _scene((0, 0, 0))
    a = Renderer(scene, frames=[0.0], width=48, height=36).render(0.0)
    b = Renderer(scene, frames=[0.0], width=48, height=36, doppler_color=True, searchlight=True).render(0.0)
    assert np.array_equal(a.rgba, b.rgba)
    assert np.all(a.doppler[a.object_id > 0] == 1.0)
    rgb = np.random.default_rng(9).uniform(-0.2, 2.0, (500, 3)).astype(np.float32)
    d = np.full(500, np.nextafter(np.float32(1.0), np.float32(2.0)))
    np.testing.assert_allclose(_run_transform(rgb, d, 1, 0), rgb, rtol=0, atol=1e-5)


@pytest.mark.parametrize("beta", [-0.5, 0.3])
def test_rendered_pixels_follow_their_doppler_aov(beta):
    """For an unlit (emissive-free albedo) sphere approaching (beta < 0 along z, towards the
    camera) or receding, every hit pixel's beauty equals the twin transform of the plain
    render's colour at that pixel's own Doppler AOV: searchlight D^4 and colour shift.
    Off by default: the default render is the untransformed albedo. Tolerance 2e-4
    relative (float32 kernels) plus, with the colour shift, the table's interpolation
    bound times the largest component (0.7) and D^4 when the searchlight is on."""
    scene = _scene((0, 0, beta))
    plain = Renderer(scene, frames=[0.0], width=48, height=36).render(0.0)
    hit = plain.object_id > 0
    np.testing.assert_allclose(plain.rgba[hit][:, :3], np.tile([0.2, 0.7, 0.3], (hit.sum(), 1)), rtol=1e-6)
    assert (np.abs(plain.doppler[hit] - 1) > 0.1).all()
    for cs, sl in ((True, False), (False, True), (True, True)):
        img = Renderer(scene, frames=[0.0], width=48, height=36, doppler_color=cs, searchlight=sl).render(0.0)
        want = doppler_transform_np(plain.rgba[hit][:, :3], plain.doppler[hit], color_shift=cs, searchlight=sl)
        table = INTERPOLATION_ERROR * 0.7 * (plain.doppler[hit] ** 4 if sl else 1.0) if cs else 0.0
        np.testing.assert_allclose(img.rgba[hit][:, :3], want, rtol=2e-4,
                                   atol=2e-4 * np.abs(want).max() + np.max(table))


def _scene(velocity):
    body = sphere_body("/S", (0, 0, -6), 1.0, velocity)
    body = type(body)(body.prim_path, (type(body.surfaces[0])(
        "/S", body.surfaces[0].points, body.surfaces[0].triangles, Material((0.2, 0.7, 0.3)), body.surfaces[0].normals),),
        body.origin, body.velocity, -6.0, body.lifetime, body.decoupled)

    def camera_state(path, frame):
        return CameraState("/Camera", float(frame), np.zeros(3), np.eye(3), 35.0, 24.0, 18.0)

    return Scene("<test>", (body,), (), ("/Camera",), RenderSettings(), camera_state, default_camera="/Camera")
