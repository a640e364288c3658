"""The extrusion of a deforming body (docs/spec.md §2.2, spacetime/deform.py).

Laws, checked by brute force on the tetrahedra ``extrude_scene`` writes:
- every tetrahedron event at lab time t lies within DEFORM_TOLERANCE x the body's size of
  the triangle its corners' worldlines span at t (samples linearly interpolated, plus the
  body's uniform ``spacetime:fourVelocity`` motion v (t - t_ref));
- the slices hold the sample times, and a uniform translation is not subdivided beyond the
  sweep rule (the bound is exact for it: all corners move alike);
- with the render's cameras (``slice_view``, the half-pixel rule) every tetrahedron event is
  within half a pixel of that triangle as the camera sees it (0.5 x pixel angle x its
  distance from the camera), and a finer resolution gives more slices.
"""
import numpy as np

from warp_st.core.deform import PointSamples
from warp_st.core.scene import Body, CameraState, RenderSettings, Scene, Surface
from warp_st.spacetime.adaptive import min_pixel_angle
from warp_st.spacetime.deform import DEFORM_TOLERANCE, deform_slices, slice_view
from warp_st.spacetime.extrude import body_slices, extrude_scene

from deform_stages import flag_samples, point_triangle_distance


def _flag_body(velocity=(0.0, 0.0, 0.0), t_ref=0.0):
    samples, counts, indices = flag_samples(20.0)
    quads = np.array(indices).reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    s = PointSamples(times=np.array([0.0, 20.0]), points=np.stack([samples[0.0], samples[20.0]]))
    surface = Surface("/Flag", samples[0.0], tris, samples=s)
    body = Body("/Flag", (surface,), velocity=np.array(velocity), reference_time=t_ref, decoupled=True)
    return body, s, tris


def _worst_offsets(mesh, s, tris, v, t_ref, camera=None, count=4000):
    """The largest distance of random tetrahedron points (Dirichlet weights over their four
    events) from the triangle of their prism at the point's time; with a ``camera``
    position, divided by the point's distance from it."""
    events = mesh.vertices[mesh.tets]  # (N, 4, 4)
    rng = np.random.default_rng(7)
    pick = rng.integers(0, len(events), count)
    weights = rng.dirichlet(np.ones(4), len(pick))
    worst = 0.0
    for e, w, tri in zip(events[pick], weights, mesh.tet_tri[pick]):
        point = w @ e
        t = point[0]
        corners = s.at(t)[tris[tri]] + v * (t - t_ref)
        error = float(point_triangle_distance(point[1:], corners[None])[0])
        worst = max(worst, error if camera is None else error / float(np.linalg.norm(point[1:] - camera)))
    return worst


def test_tetrahedra_follow_the_interpolated_triangles():
    """Window [-3, 26] (held before 0 and after 20), v = (0.3, 0, 0.1) from t_ref 5: 4000
    random points of the tetrahedra (Dirichlet weights over their four events) against the
    triangle of their prism at the point's time. Bound DEFORM_TOLERANCE x size, plus 1e-12
    of float64 rounding."""
    v = np.array([0.3, 0.0, 0.1])
    body, s, tris = _flag_body(v, 5.0)
    scene = Scene(source="t", bodies=(body,), lights=(), cameras=(), settings=RenderSettings())
    mesh = extrude_scene(scene, [(-3.0, 26.0)])
    size = float(np.ptp(np.concatenate([s.points[0], s.points[1]]), axis=0).max())
    worst = _worst_offsets(mesh, s, tris, v, 5.0)
    assert worst <= DEFORM_TOLERANCE * size + 1e-12, worst
    assert worst > 0.1 * DEFORM_TOLERANCE * size  # the corners do move apart: the bound is nearly met


def test_slices_hold_the_samples_and_a_translation_is_not_refined():
    body, s, _ = _flag_body()
    slices = body_slices(body, (-3.0, 26.0))
    assert {-3.0, 0.0, 20.0, 26.0} <= set(slices.tolist())
    assert np.all(np.diff(slices) > 0.0) and len(slices) > 50  # refined between 0 and 20
    shifted = PointSamples(times=s.times, points=np.stack([s.points[0], s.points[0] + (8.0, 0.0, 0.0)]))
    moving = Body("/Flag", (Surface("/Flag", s.points[0], body.surfaces[0].triangles, samples=shifted),),
                  decoupled=True)
    # 8 units in 20 time codes, sweep 4 per slice: two parts, whatever the tolerance
    assert deform_slices(moving, (0.0, 20.0), 4.0).tolist() == [0.0, 10.0, 20.0]


def _camera(position, time=20.0):
    """A camera at rest at ``position`` looking down -Z (USD's default lens)."""
    return CameraState("/Cam", time, np.array(position, dtype=np.float64), np.eye(3))


def test_half_pixel_rule_bounds_the_offset_as_seen():
    """The flag with v = (0.3, 0, 0.1) from t_ref 5, seen from 14 in front at 640 x 480:
    every tetrahedron point's distance from its triangle at its time, over its distance
    from the camera, is within half the smallest pixel angle (the rule uses the nearer
    box of the interval's points and divides by the points' and camera's magnification,
    both >= 1, so it is stricter), plus 1e-12 of float64 rounding."""
    v = np.array([0.3, 0.0, 0.1])
    body, s, tris = _flag_body(v, 5.0)
    scene = Scene(source="t", bodies=(body,), lights=(), cameras=(), settings=RenderSettings())
    cam = _camera((0.0, 0.0, 14.0))
    view = slice_view([cam], width=640, height=480)
    mesh = extrude_scene(scene, [(-3.0, 26.0)], view=view)
    half = 0.5 * min_pixel_angle(cam, 640, 480)
    worst = _worst_offsets(mesh, s, tris, v, 5.0, camera=cam.position)
    assert worst <= half + 1e-12, (worst, half)
    assert worst > 0.1 * half  # the corners move apart: the rule is nearly met


def test_half_pixel_rule_refines_with_the_resolution():
    """The flag's slices over [0, 20] seen from 14 in front: 4 x the resolution halves the
    pixel angle 4 times, so the tolerance, and more slices than at the coarse one (each
    interval's parts scale as 1 / tolerance until the sweep rule's floor); a camera 4 x
    further away needs fewer. Without a view: the fixed DEFORM_TOLERANCE rule."""
    body, _s, _ = _flag_body()
    near = _camera((0.0, 0.0, 14.0))

    def count(cams, width, height):
        return len(deform_slices(body, (0.0, 20.0), 1e9, view=slice_view(cams, width=width, height=height)))

    coarse, fine = count([near], 160, 120), count([near], 640, 480)
    assert fine >= 3 * coarse and coarse >= 2, (coarse, fine)
    assert count([_camera((0.0, 0.0, 56.0))], 640, 480) < fine
    # two cameras: the stricter one rules
    assert count([_camera((0.0, 0.0, 56.0)), near], 640, 480) == fine
