"""Doppler colour shift and searchlight: off by default, identity at D = 1, twin-checked."""
import numpy as np
import pytest
import warp as wp
from tracing_helpers import sphere_body

from warp_st.core.scene import CameraState, Material, RenderSettings, Scene
from warp_st.kernels.spectrum import PRIMARY_NM, cmf_rgb_np, doppler_transform_np, make_spectrum, spectral_basis_inverse
from warp_st.rendering.renderer import Renderer, init_warp


def test_kernel_transform_matches_float64_twin():
    """The Warp function equals its float64 NumPy twin on 2,000 seeded random colours and
    Doppler factors 0.2..5 (all flag combinations). Tolerance 1e-5 relative: float32
    evaluation of exp() lobes and a 3x3 product, values O(1) (times D^4 <= 625)."""
    init_warp()
    vec3, mat33 = wp.types.vector(3, wp.float32), wp.types.matrix((3, 3), wp.float32)
    transform = make_spectrum(wp.float32, vec3, mat33)

    @wp.kernel(enable_backward=False, module="unique")
    def run(rgb: wp.array(dtype=vec3), d: wp.array(dtype=wp.float32), basis: mat33, cs: int, sl: int,
            out: wp.array(dtype=vec3)):
        i = wp.tid()
        out[i] = transform(rgb[i], d[i], basis, cs, sl)

    rng = np.random.default_rng(5)
    rgb = rng.uniform(0, 1, (2000, 3)).astype(np.float32)
    d = np.exp(rng.uniform(np.log(0.2), np.log(5.0), 2000)).astype(np.float32)
    basis = mat33(*spectral_basis_inverse().reshape(-1).tolist())
    for cs in (0, 1):
        for sl in (0, 1):
            out = wp.zeros(2000, dtype=vec3)
            wp.launch(run, dim=2000, inputs=[wp.array(rgb, dtype=vec3), wp.array(d), basis, cs, sl, out])
            want = doppler_transform_np(rgb, d, color_shift=bool(cs), searchlight=bool(sl))
            np.testing.assert_allclose(out.numpy(), want, rtol=1e-5, atol=1e-5 * np.abs(want).max())


def test_identity_at_unit_doppler():
    """D = 1 exactly (body and camera at rest): both effects on give the bit-identical
    image; with the primaries D = 1 is the identity of the basis by construction."""
    scene = _scene((0, 0, 0))
    a = Renderer(scene, frames=[0.0], width=48, height=36).render(0.0)
    b = Renderer(scene, frames=[0.0], width=48, height=36, doppler_color=True, searchlight=True).render(0.0)
    assert np.array_equal(a.rgba, b.rgba)
    assert np.all(a.doppler[a.object_id > 0] == 1.0)
    lines = np.stack([cmf_rgb_np(l) for l in PRIMARY_NM], axis=1)
    np.testing.assert_allclose(spectral_basis_inverse() @ lines, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("beta", [-0.5, 0.3])
def test_rendered_pixels_follow_their_doppler_aov(beta):
    """For an unlit (emissive-free albedo) sphere approaching (beta < 0 along z, towards the
    camera) or receding, every hit pixel's beauty equals the twin transform of the plain
    render's colour at that pixel's own Doppler AOV: searchlight D^4 and colour shift.
    Off by default: the default render is the untransformed albedo. Tolerance 2e-4
    relative: float32 kernels."""
    scene = _scene((0, 0, beta))
    plain = Renderer(scene, frames=[0.0], width=48, height=36).render(0.0)
    hit = plain.object_id > 0
    np.testing.assert_allclose(plain.rgba[hit][:, :3], np.tile([0.2, 0.7, 0.3], (hit.sum(), 1)), rtol=1e-6)
    assert (np.abs(plain.doppler[hit] - 1) > 0.1).all()
    for cs, sl in ((True, False), (False, True), (True, True)):
        img = Renderer(scene, frames=[0.0], width=48, height=36, doppler_color=cs, searchlight=sl).render(0.0)
        want = doppler_transform_np(plain.rgba[hit][:, :3], plain.doppler[hit], color_shift=cs, searchlight=sl)
        np.testing.assert_allclose(img.rgba[hit][:, :3], want, rtol=2e-4, atol=2e-4 * np.abs(want).max())


def _scene(velocity):
    body = sphere_body("/S", (0, 0, -6), 1.0, velocity)
    body = type(body)(body.prim_path, (type(body.surfaces[0])(
        "/S", body.surfaces[0].points, body.surfaces[0].triangles, Material((0.2, 0.7, 0.3)), body.surfaces[0].normals),),
        body.origin, body.velocity, -6.0, body.lifetime, body.decoupled)

    def camera_state(path, frame):
        return CameraState("/Camera", float(frame), np.zeros(3), np.eye(3), 35.0, 24.0, 18.0)

    return Scene("<test>", (body,), (), ("/Camera",), RenderSettings(), camera_state, default_camera="/Camera")
