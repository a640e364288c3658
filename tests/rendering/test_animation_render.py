"""Bodies USD animates render their motion (docs/spec.md §2.1, issue 18).

Laws:
- uniform motion authored as two linear translate samples renders as the same body with
  ``spacetime:fourVelocity`` (while the events seen lie between the samples);
- every hit event, carried back through USD's own ComputeLocalToWorldTransform at its
  (fractional) event time, lies on the authored surface: a decoupled orbit at 0.8c and a
  spinning rod whose tips reach 0.7c;
- a sphere on a circular orbit: eventTime per pixel against the closed form of each piece
  of uniform motion (the quadratic of core.lorentz.sphere_hit);
- both tracing paths (rigid, and the prism oracle in float64) render the pieces alike.
"""
import numpy as np
import pytest

import warp_st
from warp_st.core import lorentz
from warp_st.rendering.camera import pixel_directions
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.adaptive import min_pixel_angle
from warp_st.spacetime.animation import animated_bodies, animation_cuts

from animation_stages import CUBE, HEADER, cube_surface_distance, hit_events, orbit, spinning_rod, write

W, H = 256, 192


def _translating(body_ops: str) -> str:
    return HEADER + f'''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    {body_ops}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cube "C"
    {{
        double size = 1.5
    }}
}}
'''


def test_two_translate_samples_render_as_four_velocity(tmp_path):
    """A coupled body at 0.6c: translate samples (-30, 0, 0) at 0 and (30, 0, 0) at 100
    against spacetime:fourVelocity (1, 0.6, 0, 0) from (-30, 0, 0) at t_ref 0. Frames whose
    events lie inside [0, 100]. Tolerances (the target of issue 18): masks equal except
    silhouette pixels (the two databases round the same surface differently: a pixel whose
    centre grazes an edge may flip), |dZ| <= 1e-4 relative, |d eventTime| <= 1e-3 (float32
    rounding of both is ~1e-6 of values ~50)."""
    animated = warp_st.load(write(tmp_path, "a.usda", _translating(
        "double3 xformOp:translate.timeSamples = { 0: (-30, 0, 0), 100: (30, 0, 0) }")))
    uniform = warp_st.load(write(tmp_path, "u.usda", _translating(
        "custom double4 spacetime:fourVelocity = (1, 0.6, 0, 0)\n    double3 xformOp:translate = (-30, 0, 0)")))
    assert animated.bodies[0].motion is not None and uniform.bodies[0].motion is None
    seen = 0
    for frame in (55.0, 62.0, 70.0):
        a = warp_st.render(animated, frame=frame, width=W, height=H)
        u = warp_st.render(uniform, frame=frame, width=W, height=H)
        ma, mu = a.object_id > 0, u.object_id > 0
        differ = ma != mu
        edge = np.zeros_like(mu)
        for mask in (ma, mu):
            for axis in (0, 1):
                edge |= (mask != np.roll(mask, 1, axis)) | (mask != np.roll(mask, -1, axis))
        assert not (differ & ~edge).any(), frame
        both = ma & mu
        seen += int(both.sum())
        assert set(np.unique(a.object_id).tolist()) <= {0, 1}  # the pieces are the stage's one body (objectId 1)
        assert np.abs(a.depth[both] - u.depth[both]).max() <= 1e-4 * np.abs(u.depth[both]).max()
        assert np.abs(a.event_time[both] - u.event_time[both]).max() <= 1e-3
        assert np.abs(a.proper_time[both] - u.proper_time[both]).max() <= 1e-3
        assert np.abs(a.doppler[both] - u.doppler[both]).max() <= 1e-5
    assert seen > 1000  # the body is in view


@pytest.mark.parametrize("case", ["orbit", "rod"])
def test_hit_events_lie_on_the_usd_surface(tmp_path, case):
    """Each hit event (t, c + depth n) carried back through USD at time code t lies on the
    authored box. Bound: the pieces stay within half a pixel of USD's surface (the rule),
    i.e. 0.5 x pixel angle x distance (1.7e-3 of the distance here, under issue 18's 2e-3),
    plus float32 rounding of the hit (1e-5 of the distance, generous)."""
    if case == "orbit":
        path, gprim, half = write(tmp_path, "orbit.usda", orbit(CUBE, speed=0.8)), "/Orbit/Moon/Box", 0.6
    else:
        path, gprim, half = write(tmp_path, "rod.usda", spinning_rod(0.7)), "/Rod/Bar", 0.5
    scene = warp_st.load(path)
    for frame in (40.0, 63.0):
        renderer = Renderer(scene, frames=[frame], width=W, height=H)
        image = renderer.render(frame)
        assert renderer.describe()["animated_segments"] > 10
        times, points, s = hit_events(scene, image, frame, W, H)
        assert len(times) > 200, frame
        error = cube_surface_distance(path, gprim, times, points, half)
        bound = 0.5 * min_pixel_angle(scene.camera_state(None, frame), W, H) + 1e-5
        assert bound < 2e-3
        assert (error / s).max() <= bound, (frame, float((error / s).max()))


@pytest.mark.parametrize("quadrics", ["tessellated", "exact"])
def test_orbit_event_time_against_per_piece_closed_form(tmp_path, quadrics):
    """A decoupled sphere (radius 1) on a circular orbit at 0.8c, 512 x 384: per pixel, the
    first hit of the pixel-centre ray with the pieces the renderer chose, each a sphere in
    uniform motion over its lifetime (closed form, core.lorentz.sphere_hit). Traced as
    triangles, or as exact spheres (docs/spec.md §2: then the gap g below is 0 and every
    hit is the closed form's to float32 rounding, 1e-4 here).

    - The tessellated sphere lies between the balls of radius R - g and R (g its gap,
      spacetime/adaptive.py): every hit lies between their closed-form hits (1e-3 of slack
      for float32). This holds at the seams too: the pieces overlap in time, so a ray
      crossing a seam where two pieces' tessellations (rotated with the moon) differ meets
      the later one's surface instead of entering the earlier one through its cap (without
      the overlap 0.19 % of the pixels saw the far side, docs/design/animation.md).
    - Target of issue 18: eventTime p99 within 0.02 of the closed form, over the pixels
      whose ray meets the inner ball (the silhouette band g wide, where a grazing ray's time
      changes fastest, left out: there the tessellation, not the motion, decides)."""
    path = write(tmp_path, "moon.usda", orbit('def Sphere "S"\n        {\n            double radius = 1\n        }'))
    scene = warp_st.load(path)
    frame, width, height = 50.0, 512, 384
    cam = scene.camera_state(None, frame)
    renderer = Renderer(scene, frames=[frame], width=width, height=height, quadrics=quadrics)
    image = renderer.render(frame)
    if quadrics == "exact":
        assert renderer.sphere_segments == {}
        gap = 0.0
    else:
        (segments,) = renderer.sphere_segments.values()
        gap = 1.0 - np.cos(np.sqrt(2.0) * np.pi / segments)
    bodies, _ = animated_bodies(scene, animation_cuts(scene, [cam], width=width, height=height))
    rendered = image.object_id > 0
    s = cam.time - image.event_time.astype(np.float64)
    # The oracle runs over the pieces the lookbacks seen can reach (2 of slack) and the
    # pixels near the rendered ones (a box 8 pixels wider): the rest is checked empty below.
    seen = [b for b in bodies if b.lifetime[1] >= cam.time - np.nanmax(s) - 2.0
            and b.lifetime[0] <= cam.time - np.nanmin(s) + 2.0]
    rows, cols = np.nonzero(rendered)
    y0, y1, x0, x1 = max(rows.min() - 8, 0), rows.max() + 9, max(cols.min() - 8, 0), cols.max() + 9
    box = np.zeros_like(rendered)
    box[y0:y1, x0:x1] = True
    assert not box.all()
    dirs = pixel_directions(cam, width, height, frame="lab")[y0:y1, x0:x1]

    def first_hit(radius):
        best = np.full(dirs.shape[:2], np.inf)
        for body in seen:
            centre = body.surfaces[0].sphere[1][3, :3]
            hit = lorentz.sphere_hit(cam.time, cam.position, dirs, centre, radius, body.velocity, body.reference_time,
                                     decoupled=True, lifetime=body.lifetime)
            best = np.fmin(best, np.where(np.isfinite(hit.s), hit.s, np.inf))
        whole = np.full((height, width), np.inf)
        whole[y0:y1, x0:x1] = best
        return whole

    outer, inner = first_hit(1.0), first_hit(1.0 - gap)
    assert not np.isfinite(outer[~box]).any()  # the box holds the whole oracle image (its edge is empty)
    assert not (rendered & ~np.isfinite(outer)).any() and not (~rendered & np.isfinite(inner)).any()
    assert (s[rendered] >= outer[rendered] - 1e-3).all()
    core = rendered & np.isfinite(inner)
    assert core.sum() > 3000
    assert (s[core] <= inner[core] + 1e-3).all(), int((s[core] > inner[core] + 1e-3).sum())
    dt = np.abs(s - outer)[core]
    assert np.percentile(dt, 99) <= 0.02, float(np.percentile(dt, 99))
    if quadrics == "exact":
        assert dt.max() <= 1e-4, float(dt.max())


def test_prism_path_renders_the_pieces(tmp_path):
    """The float64 prism oracle renders an animated body as the rigid path does (same
    pieces): same objects except at silhouettes, event times within 1e-4. (The rod turns
    on a pivot at rest: by default it is traced as per-vertex worldlines on the tet path,
    spacetime/turning.py; asked for rigid, it is cut into the pieces.)"""
    scene = warp_st.load(write(tmp_path, "rod.usda", spinning_rod(0.7)))
    frame = 40.0
    rigid = warp_st.render(scene, frame=frame, width=96, height=72, primitive="rigid")
    prism = warp_st.render(scene, frame=frame, width=96, height=72, primitive="prism", precision="float64")
    both = (rigid.object_id > 0) & (prism.object_id > 0)
    assert both.sum() > 50
    assert ((rigid.object_id > 0) != (prism.object_id > 0)).sum() <= 0.05 * both.sum()
    assert np.abs(rigid.event_time[both] - prism.event_time[both]).max() <= 1e-4


def _camera_stage(camera_ops: str) -> str:
    return f'''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 100
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    {camera_ops}
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float focalLength = 24
}}
def Cube "A"
{{
    double size = 2
    double3 xformOp:translate = (-3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def Sphere "B"
{{
    double radius = 1.5
    double3 xformOp:translate = (4, 1, -3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
'''


def test_camera_with_two_translate_samples_equals_four_velocity(tmp_path):
    """A camera moving at 0.5c along +x: translate samples (-15, 0, 14) at 0 and (35, 0, 14)
    at 100 against spacetime:fourVelocity (1, 0.5, 0, 0) from (-15, 0, 14) at t_ref 0. Its
    position and velocity (aberration, Doppler, rest-frame depth) agree: the same image to
    float32 rounding (tolerances as in the body test above)."""
    animated = warp_st.load(write(tmp_path, "a.usda", _camera_stage(
        "double3 xformOp:translate.timeSamples = { 0: (-15, 0, 14), 100: (35, 0, 14) }")))
    uniform = warp_st.load(write(tmp_path, "u.usda", _camera_stage(
        "custom double4 spacetime:fourVelocity = (1, 0.5, 0, 0)\n    double3 xformOp:translate = (-15, 0, 14)")))
    for frame in (30.0, 38.0):
        ca, cu = animated.camera_state(None, frame), uniform.camera_state(None, frame)
        assert np.allclose(ca.velocity, cu.velocity, rtol=0, atol=1e-6) and np.linalg.norm(cu.velocity) == 0.5
        a = warp_st.render(animated, frame=frame, width=128, height=96)
        u = warp_st.render(uniform, frame=frame, width=128, height=96)
        ma, mu = a.object_id > 0, u.object_id > 0
        assert mu.sum() > 500
        edge = np.zeros_like(mu)
        for axis in (0, 1):
            edge |= (mu != np.roll(mu, 1, axis)) | (mu != np.roll(mu, -1, axis))
        assert not ((ma != mu) & ~edge).any()
        both = ma & mu
        assert np.abs(a.depth[both] - u.depth[both]).max() <= 1e-4 * np.abs(u.depth[both]).max()
        assert np.abs(a.event_time[both] - u.event_time[both]).max() <= 1e-3
        assert np.abs(a.doppler[both] - u.doppler[both]).max() <= 1e-5
        assert np.abs(a.doppler[both] - 1.0).max() > 0.05  # the camera's motion shows (0.077 here)


_SUN = '''def DistantLight "Sun"
{
    float inputs:intensity = 2
    float3 xformOp:rotateXYZ = (-30, 50, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
'''


def _ball(rotation: str) -> str:
    return HEADER + _SUN + f'''def Xform "Ball" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate = (0, 1, 0)
    {rotation}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    def Sphere "S"
    {{
        double radius = 2
    }}
}}
'''


@pytest.mark.parametrize("primitive", ["rigid", "prism"])
def test_lit_sphere_spinning_about_its_centre_shades_as_at_rest(tmp_path, primitive):
    """A smooth lit sphere spinning about its centre (pivot at rest: nothing contracts, its
    surface moves at up to 0.35c) looks as at rest: its shape is the same at every time,
    and the pieces of one body do not shadow each other near the terminator (the
    self-shadow skip of smooth surfaces covers the whole animated object; per piece, 25 of
    2,148 pixels darkened by > 0.1). Tolerance 0.02 per colour channel: the pieces'
    tessellations are rotated copies, whose interpolated normals differ within ~4e-3; a
    speck is >= 0.1. The rotational part of the velocity is not in the Doppler factor yet
    (docs/design/animation.md), so colours, unshifted, compare."""
    options = dict(width=160, height=120, primitive=primitive)
    if primitive == "prism":
        options["precision"] = "float64"
    spin = warp_st.load(write(tmp_path, "spin.usda", _ball("double xformOp:rotateY.timeSamples = { 0: 0, 100: 1000 }")))
    rest = warp_st.load(write(tmp_path, "rest.usda", _ball("double xformOp:rotateY = 0")))
    a = warp_st.render(spin, frame=50.0, **options)
    b = warp_st.render(rest, frame=50.0, **options)
    hit = (a.object_id > 0) & (b.object_id > 0)
    assert hit.sum() > 1500 and ((a.object_id > 0) != (b.object_id > 0)).sum() <= 0.02 * hit.sum()
    assert np.abs(a.rgba[..., :3] - b.rgba[..., :3]).max(axis=-1)[hit].max() <= 0.02


def test_an_animated_exact_cylinder_moves_with_its_pieces(tmp_path):
    """A lone Cylinder is traced as its exact solid (docs/spec.md §2) on the rigid path; the
    pieces of an animated one carry the solid with them. A path bent at t = 20 (0.6c along
    +x, then 0.6c along +y), seen at frames whose events lie on either leg, against the same
    pieces tessellated (whose points the pieces move): the same pixels except at the
    silhouette, and event times within the 64-segment tessellation's sagitta (r (1 - cos(pi/64))
    = 1e-3 here, and as much again in lookback: 5e-3 is the bound) but at rim pixels, where a
    ray grazing the exact rim meets the polygon's side farther back (at most 2 %)."""
    stage = HEADER + '''def Xform "Can" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double3 xformOp:translate.timeSamples = { 0: (-12, 0, 0), 20: (0, 0, 0), 40: (0, 12, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Cylinder "C"
    {
        double radius = 0.8
        double height = 2.0
        token axis = "Y"
    }
}
'''
    scene = warp_st.load(write(tmp_path, "a.usda", stage))
    for frame in (28.0, 40.0):
        r = Renderer(scene, frames=[frame], width=W, height=H)
        assert r.describe()["quadrics"] == "exact" and r.database.shapes.body_quadric.all()
        a = r.render(frame)
        t = warp_st.render(scene, frame=frame, width=W, height=H, quadrics="tessellated")
        hit = t.object_id > 0
        assert hit.sum() > 300
        assert ((a.object_id > 0) != hit).sum() <= 0.02 * hit.sum()  # silhouette pixels may flip
        both = hit & (a.object_id > 0)
        assert (np.abs(a.event_time[both] - t.event_time[both]) > 5e-3).mean() <= 0.02
