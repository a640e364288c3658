"""Adaptive UsdGeom.Sphere tessellation: the cheapest level within half a pixel.

The reader keeps each sphere's analytic shape on its Surface (``Surface.sphere``); the
Renderer, knowing the resolution, the lens and every frame's camera event, picks the
UV longitudes n with  g(n) < 2 r (1 - cos(pi / n)) <= 0.5 px x d_min x (smallest pixel
angle)  (g: the gap between the sphere and its polyhedron, twice the great-circle
sagitta; d_min: the nearest the sphere's surface comes to a frame's camera over the lab
times that frame can see) and re-tessellates before extrusion (warp_st/extrude.py).

Laws checked, each against the closed-form sphere (``warp_st.core.lorentz.sphere_hit``):

- the chosen level keeps the measured silhouette and depth error under 0.5 px, at two
  resolutions, for a sphere at rest, a coupled one at 0.9c (whose error, seen from the
  camera, is g over the camera-frame distance: no extra factor for its speed) and a
  decoupled one at 0.9c (its retarded image stretches angles by |n + v| / (1 + n.v));
- it is not wastefully fine (the measured depth error uses a fair part of the budget);
- a smaller or farther sphere, or a coarser image, gets fewer segments; a sequence gets
  the level its nearest frame needs;
- what the bound does not cover keeps the reader's tessellation or finer: mirror spheres
  (reflections can magnify) never go below the default, superluminal decoupled bodies
  (no bound on the retarded stretch) keep it; other surfaces are never touched;
- re-tessellating at the reader's default reproduces the reader's surface bit for bit.

The rule serves spheres traced as triangles: the prism and tet paths, and the rigid path
with ``quadrics="tessellated"`` (the rigid path's default traces a lone sphere exactly,
tests/rendering/test_exact_quadrics.py), which every render here asks for.

Error measures (``warp_st.testing.sphere_errors``): silhouette = the largest image-plane
distance from a pixel whose hit/miss differs from the exact sphere's to the exact outline
(located by bisection on the oracle); depth = how far each rendered hit event lies off
the exact sphere in the body frame, in pixel footprints. The polyhedron lies between the
balls R - g and R, so both are bounded by g / (distance x pixel angle) <= 0.5 px, plus
float32 rounding (1e-6 relative, negligible against a pixel here).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import warp_st
from warp_st.core import tessellate
from warp_st.core.scene import Material
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.adaptive import adapt_sphere_tessellation, retessellate_sphere
from warp_st.testing import SphereView, render_view, sphere_errors, sphere_view_scene

HALF_PIXEL = 0.5
TESSELLATED = dict(quadrics="tessellated")


def _chosen(view: SphereView, **kw) -> int:
    r = Renderer(sphere_view_scene(view), frames=[view.t_c], width=view.width, height=view.height, **TESSELLATED,
                 **kw)
    return r.sphere_segments["/Sphere"]


@pytest.mark.parametrize("size", [(96, 72), (400, 300)])
@pytest.mark.parametrize("velocity, decoupled", [((0.0, 0.0, 0.0), False), ((0.9, 0.0, 0.0), False),
                                                  ((0.6, 0.3, -0.6), True)],
                         ids=["rest", "coupled_0.9c", "decoupled_0.9c"])
def test_chosen_level_stays_within_half_a_pixel(size, velocity, decoupled):
    w, h = size
    view = SphereView(width=w, height=h, segments=None, velocity=velocity, decoupled=decoupled,
                      quadrics="tessellated")
    r, img = render_view(view)
    n = r.sphere_segments["/Sphere"]
    err = sphere_errors(img, view, segments=n)
    assert err["pixels_exact"] > 200  # the sphere covers a fair part of the image
    assert err["silhouette_px"] < HALF_PIXEL, err
    assert err["depth_px"] < HALF_PIXEL, err
    if velocity == (0.0, 0.0, 0.0):
        # Not wastefully fine: the bound is conservative (corner pixel angle, nearest
        # surface distance) by less than a factor 3 here.
        assert err["depth_px"] > HALF_PIXEL / 3, err
    # and the render is the same as rendering that fixed tessellation
    fixed = dataclasses.replace(view, segments=n)
    _r2, img2 = render_view(fixed)
    assert np.array_equal(img.depth, img2.depth, equal_nan=True)


def test_finer_images_get_more_segments():
    levels = [_chosen(SphereView(width=w, height=w * 3 // 4, segments=None)) for w in (48, 96, 400, 1600)]
    assert levels == sorted(levels) and levels[0] < levels[-1], levels
    assert all(n % 2 == 0 and 8 <= n <= 512 for n in levels)


def test_smaller_or_farther_sphere_gets_fewer_segments():
    near = _chosen(SphereView(width=400, height=300, segments=None))
    far = _chosen(SphereView(width=400, height=300, segments=None, distance=24.0))
    small = _chosen(SphereView(width=400, height=300, segments=None, radius=0.25))
    assert far < near and small < near, (near, far, small)


def test_sequence_gets_the_level_of_its_nearest_frame():
    """A sphere approaching the camera at 0.5c along the view axis: frames later in time
    see it nearer (at half the distance 20 later). One database for both frames must use
    the nearer frame's level."""
    view = SphereView(width=200, height=150, segments=None, velocity=(0.0, 0.0, 0.5), distance=40.0, hfov_deg=30.0)
    scene = sphere_view_scene(view)
    kw = dict(width=view.width, height=view.height, **TESSELLATED)
    early = Renderer(scene, frames=[view.t_c], **kw).sphere_segments["/Sphere"]
    late = Renderer(scene, frames=[view.t_c + 20.0], **kw).sphere_segments["/Sphere"]
    both = Renderer(scene, frames=[view.t_c, view.t_c + 20.0], **kw).sphere_segments["/Sphere"]
    assert early < late == both, (early, late, both)


def test_mirror_spheres_never_go_below_the_default():
    view = SphereView(width=48, height=36, segments=None, distance=30.0)
    scene = sphere_view_scene(view)
    body = scene.bodies[0]
    mirror = dataclasses.replace(body, surfaces=(dataclasses.replace(body.surfaces[0], material=Material(metallic=1.0)),))
    scene = dataclasses.replace(scene, bodies=(mirror,))
    kw = dict(frames=[view.t_c], width=view.width, height=view.height, **TESSELLATED)
    assert Renderer(scene, max_depth=0, **kw).sphere_segments["/Sphere"] < tessellate.DEFAULT_SPHERE_SEGMENTS
    assert Renderer(scene, max_depth=4, **kw).sphere_segments["/Sphere"] == tessellate.DEFAULT_SPHERE_SEGMENTS


def test_superluminal_decoupled_sphere_keeps_the_reader_tessellation():
    view = SphereView(width=48, height=36, segments=None, velocity=(1.5, 0.0, 0.0), decoupled=True)
    r = Renderer(sphere_view_scene(view), frames=[view.t_c], width=48, height=36, **TESSELLATED)
    assert "/Sphere" not in r.sphere_segments
    n = tessellate.DEFAULT_SPHERE_SEGMENTS
    assert r.stats.tetrahedra % (3 * n * (n - 2)) == 0  # whole prisms of the 64-segment mesh


def test_surfaces_without_an_analytic_sphere_are_untouched():
    fixed = sphere_view_scene(SphereView(segments=32))  # a tessellated mesh, no analytic sphere
    out, chosen = adapt_sphere_tessellation(fixed, [fixed.camera_state("/Camera", 6.0)], width=64, height=36)
    assert out is fixed and chosen == {}
    assert Renderer(fixed, frames=[6.0], width=32, height=24).sphere_segments == {}


USD = """#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 10)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 35
    float horizontalAperture = 36
}
def Xform "X"
{
    double3 xformOp:translate = (1, 0.5, -2)
    float xformOp:rotateY = 30
    float3 xformOp:scale = (%s)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY", "xformOp:scale"]
    def Sphere "Ball"
    {
        double radius = 0.75
    }
}
"""


@pytest.mark.parametrize("scale", ["2, 2, 2", "-1.5, 1.5, 1.5"], ids=["uniform", "mirrored"])
def test_reader_records_the_sphere_and_retessellation_reproduces_it(tmp_path, scale):
    path = tmp_path / "ball.usda"
    path.write_text(USD % scale)
    scene = warp_st.load(str(path))
    surf = scene.bodies[0].surfaces[0]
    radius, m = surf.sphere
    assert radius == 0.75 and m.shape == (4, 4)
    np.testing.assert_allclose(m[3, :3], [1.0, 0.5, -2.0], atol=1e-12)
    again = retessellate_sphere(surf, tessellate.DEFAULT_SPHERE_SEGMENTS)
    assert np.array_equal(again.points, surf.points)
    assert np.array_equal(again.triangles, surf.triangles)
    assert np.array_equal(again.normals, surf.normals)
    # and the renderer adapts it: more segments for a bigger image
    lo = Renderer(scene, width=64, height=48, **TESSELLATED).sphere_segments["/X/Ball"]
    hi = Renderer(scene, width=1024, height=768, **TESSELLATED).sphere_segments["/X/Ball"]
    assert lo < hi
    scale_max = abs(float(scale.split(",")[0]))
    r_world = radius * scale_max
    assert math.isclose(np.linalg.norm(retessellate_sphere(surf, hi).points - m[3, :3], axis=1).max(), r_world,
                        rel_tol=1e-12)
