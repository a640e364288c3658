"""End-to-end physics of the spine: animation emerges, contraction, clipping, errors.

Scenes are built from the host dataclasses so each law is isolated from USD reading.
"""
import numpy as np
import pytest
from tracing_helpers import cube_body

import warp_st
from warp_st.core.scene import CameraState, Light, RenderSettings, Scene
from warp_st.rendering.renderer import Renderer

FOCAL, H_AP = 50.0, 20.0  # horizontal field of view 2 atan(10/50) = 22.6 deg


def _scene(*bodies, lights=(), light_speed="finite"):
    def camera_state(path, frame):
        return CameraState(
            prim_path="/Camera", time=float(frame), position=np.zeros(3), rotation=np.eye(3),
            focal_length=FOCAL, horizontal_aperture=H_AP, vertical_aperture=H_AP, light_speed=light_speed,
        )

    return Scene(source="<test>", bodies=tuple(bodies), lights=tuple(lights), cameras=("/Camera",),
                 settings=RenderSettings(), camera_state=camera_state, default_camera="/Camera")


def _hit_events(img, width, height):
    """World positions of the hit events: camera at the origin, x = s n (s = Z here)."""
    i = (np.arange(width) + 0.5) / width * 2 - 1
    j = 1 - (np.arange(height) + 0.5) / height * 2
    d = np.stack(np.broadcast_arrays(i[None, :] * H_AP / 2 / FOCAL, j[:, None] * H_AP * height / width / 2 / FOCAL, -1.0), -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d * img.depth[..., None]


def test_animation_emerges_from_camera_time():
    """One unchanged 4D database, two camera times 100 apart: a body at v = 0.01 appears
    displaced by v dt = 1 unit. Measured on the world x of the cube's trailing face,
    from the hit events (x = s n) of its leftmost visible column. The light delay
    changes slightly as the body moves, so the displacement is v times the change of
    event time (~100), and the comoving position x - v t of that face is the same in
    both frames. Tolerance: the pixel footprint at the cube, 2 * 10 * 0.2 / 200 = 0.02."""
    v = 0.01
    scene = _scene(cube_body("/Cube", (-0.5, 0, -10), 1.0, (v, 0, 0)))
    renderer = Renderer(scene, frames=[0.0, 100.0], width=200, height=100)
    edge_x, edge_t = [], []
    for frame in (0.0, 100.0):
        img = renderer.render(frame)
        x = _hit_events(img, 200, 100)[..., 0]
        hit = img.object_id > 0
        col = int(np.nonzero(hit.any(axis=0))[0][0])
        edge_x.append(x[hit[:, col], col].mean())
        edge_t.append(img.event_time[hit[:, col], col].mean())
    assert abs((edge_x[1] - edge_x[0]) - v * 100.0) < 0.02 + v * abs(edge_t[1] - edge_t[0] - 100.0)
    assert abs((edge_x[1] - v * edge_t[1]) - (edge_x[0] - v * edge_t[0])) < 0.02


@pytest.mark.parametrize("decoupled, expected", [(False, 1.0), (True, 2.0)])
def test_infinite_light_speed_shows_lorentz_contraction(decoupled, expected):
    """With infinite light speed (no retardation) a coupled cube of proper length 2 at
    beta = 0.866 measures exactly half its length along the motion (gamma = 2.0), the
    decoupled one its authored 2. Measured as the width of the hit mask in pixels along
    the centre row, compared with the projection of the front face at depth 9:
    2 * 50 / 20 * length / 9 * 100 px; +-1 px for the pixel grid."""
    beta = np.sqrt(3) / 2
    scene = _scene(cube_body("/Cube", (0, 0, -10), 2.0, (beta, 0, 0), decoupled=decoupled), light_speed="infinite")
    img = warp_st.render(scene, frame=0.0, width=200, height=101)
    width_px = (img.object_id[50] > 0).sum()
    expected_px = expected / 9.0 * FOCAL / (H_AP / 2) * 100
    assert abs(width_px - expected_px) <= 1.0


def test_clipping_never_changes_the_image():
    """Unbounded lifetimes are clipped to what the frames' lightcones (and shadow rays)
    can reach. Rendering the same frame with a database prepared for a much wider set
    of frames (so much longer extrusions) gives the bit-identical image."""
    scene = _scene(
        cube_body("/Fast", (0.0, 0, -8), 1.0, (0.8, 0, 0)),
        cube_body("/Floor", (0, -3, -8), 4.0),
        lights=(Light("distant", (1.0, 1.0, 1.0), direction=(0.3, 0.9, 0.3)),),
    )
    a = Renderer(scene, frames=[3.0], width=64, height=48).render(3.0)
    b = Renderer(scene, frames=[-40.0, 3.0, 60.0], width=64, height=48).render(3.0)
    assert (a.object_id > 0).any()
    for name in ("rgba", "depth", "event_time", "proper_time", "doppler", "object_id"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


def test_shadow_windows_per_frame_and_body_are_enough(monkeypatch):
    """Lit frames far apart get their shadow windows frame by frame and piece by piece of
    each visible body, each cut to the times the piece is seen and the occluder is near
    the shadow rays' axis (visibility._extension_parts, _extend_for_shadows,
    body_pieces, _near_axis_windows). Rendered from that smaller database, each frame
    equals, bit for bit, its render from a database for every frame in between, from
    one bounded by a single ball per visible body, and from one whose shadow windows
    use a single ball for all and no axis bound (all wider): the retarded shadow of the
    fast cube on the floor is kept."""
    from warp_st.spacetime import visibility

    # The cube passes 6 above the floor's top at 0.8c under a light straight above: at
    # frame 3 its shadow falls on the floor from lab times ~6 before the floor's hit
    # events, outside the cube's own direct window (so that window alone would lose it).
    scene = _scene(
        cube_body("/Fast", (9.2, 5.0, -8), 1.0, (0.8, 0, 0)),
        cube_body("/Floor", (0, -3, -8), 4.0),
        lights=(Light("distant", (1.0, 1.0, 1.0), direction=(0.0, 1.0, 0.0)),),
    )
    frames = [3.0, 45.0]
    kw = dict(width=64, height=48, primitive="prism")  # the extrusion's size is what the windows decide
    sparse = Renderer(scene, frames=frames, **kw)
    dense = Renderer(scene, frames=[float(f) for f in range(0, 49)], **kw)
    assert sparse.stats.tetrahedra < dense.stats.tetrahedra
    lit = Renderer(_scene(*scene.bodies[1:], lights=scene.lights), frames=[3.0], **kw).render(3.0)
    monkeypatch.setattr(visibility, "_MAX_PIECES", 1)  # one ball per visible body
    per_body = Renderer(scene, frames=frames, **kw)
    assert sparse.stats.tetrahedra < per_body.stats.tetrahedra
    monkeypatch.setattr(visibility, "_PER_FRAME_BUDGET", 0)
    monkeypatch.setattr(visibility, "_PAIR_BUDGET", 0)
    monkeypatch.setattr(visibility, "_near_axis_windows",
                        lambda m0, v, t_ref, centre, axis, radius: (np.full(len(centre), -np.inf), np.full(len(centre), np.inf)))
    wide = Renderer(scene, frames=frames, **kw)
    assert sparse.stats.tetrahedra < wide.stats.tetrahedra
    for f in frames:
        a = sparse.render(f)
        assert (a.object_id > 0).any()
        if f == 3.0:  # the shadow is there: the floor is darker than without the cube
            assert (a.rgba[..., :3].sum(-1) < lit.rgba[..., :3].sum(-1) - 1e-3).sum() > 10
        for b in (dense.render(f), per_body.render(f), wide.render(f)):
            for name in ("rgba", "depth", "event_time", "object_id"):
                assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), (f, name)


def test_threads_do_not_change_the_image():
    """Tiles launched from a thread pool write disjoint pixels: 1 and 2 threads give
    bit-identical images."""
    scene = _scene(cube_body("/C", (0.3, 0.2, -6), 1.0, (0.5, 0.1, 0)))
    r = Renderer(scene, frames=[0.0], width=160, height=120)
    a, b = r.render(0.0, threads=1), r.render(0.0, threads=2)
    for name in ("rgba", "depth", "event_time", "object_id"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


def _over_the_floor(rng, light, v, height):
    """Where a cube moving with v must be, and when, so that its shadow falls on a random
    visible floor point P (y = -1, 13 to 22 ahead of the camera, within 2 of the view axis)
    at the lab time the camera (at t = 0) sees P: the point C at ``height`` on the segment
    from P to the light, passed at t_P - |C - P| (the retarded shadow: the light that
    grazes the cube then reaches P when P is seen). Returns the cube's pivot at t_ref = 0."""
    p = np.array([rng.uniform(-2, 2), -1.0, rng.uniform(-22, -13)])
    if light.kind == "distant":
        d = np.asarray(light.direction, float) / np.linalg.norm(light.direction)
        c = p + d * (height - p[1]) / d[1]
    else:
        lp = np.asarray(light.position, float)
        c = lp + (p - lp) * (lp[1] - height) / (lp[1] - p[1])
    t_seen = -np.linalg.norm(p) - np.linalg.norm(c - p)
    return c - v * t_seen


@pytest.mark.parametrize("seed", range(8))
def test_shadow_windows_random_lit_scenes_lose_no_shadow(seed, monkeypatch):
    """Random lit scenes: three fast cubes above the view (never seen directly, so only
    the shadow windows put them in the database) cast shadows on a tiled floor in view,
    under a distant or a point light, at frames spread in time. Each cube is placed so
    that its retarded shadow falls on a random visible floor point at frame 0
    (_over_the_floor; at frames up to 4 away it moves by up to 3.8, about its size), so
    every seed has shadows to lose. The database bounded piece by piece renders what one
    bounded by a single ball for every visible body renders (a far wider one), and the
    shadows are there (the floor is darker than without the cubes). The two databases cut
    time into different segments, so values may differ by float32 rounding; a shadow
    lost changes a patch, so at most 2 pixels may differ by more than 1e-3 in colour."""
    from warp_st.core.scene import Body, Surface
    from warp_st.rendering import database_cache
    from warp_st.spacetime import visibility

    rng = np.random.default_rng(1000 + seed)
    gx, gz = np.arange(9) * 2.0 - 8.0, np.arange(13) * 2.0 - 32.0
    pts = np.array([(x, -1.0, z) for z in gz for x in gx])
    quads = [(9 * j + i, 9 * (j + 1) + i, 9 * (j + 1) + i + 1, 9 * j + i + 1) for j in range(12) for i in range(8)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    floor = Body("/Floor", (Surface("/Floor", pts, tris),), np.zeros(3))
    light = (Light("distant", (1.0, 1.0, 1.0), direction=tuple(rng.normal(size=3) * [0.3, 0, 0.3] + [0, 1, 0]))
             if seed % 2 else Light("sphere", (60.0, 60.0, 60.0), position=(rng.uniform(-3, 3), 12.0, -18.0)))
    cubes = []
    for k in range(3):
        v = rng.normal(size=3) * [1.0, 0.1, 0.5]
        v *= rng.uniform(0.3, 0.95) / np.linalg.norm(v)
        pivot = _over_the_floor(rng, light, v, rng.uniform(5.2, 6.2))
        cubes.append(cube_body(f"/C{k}", pivot, rng.uniform(1.5, 2.5), tuple(v)))
    frames = sorted(float(f) for f in rng.uniform(-4, 4, 3))
    lit = _scene(floor, *cubes, lights=(light,))
    pieces = Renderer(lit, frames=frames, width=64, height=48)
    bare = Renderer(_scene(floor, lights=(light,)), frames=frames, width=64, height=48)
    monkeypatch.setattr(visibility, "_PAIR_BUDGET", 0)
    wide = Renderer(lit, frames=frames, width=64, height=48)
    assert database_cache.covers(wide.database.windows, pieces.database.windows)  # the pieces bound is tighter
    shadowed = 0
    for f in frames:
        a, b, c = pieces.render(f), wide.render(f), bare.render(f)
        assert set(np.unique(a.object_id)) <= {0, 1}, "a cube is seen directly"
        floor_px = (a.object_id == c.object_id) & (c.object_id > 0)
        shadowed += int((floor_px & (a.rgba[..., :3].sum(-1) < c.rgba[..., :3].sum(-1) - 1e-3)).sum())
        differ = np.abs(a.rgba[..., :3] - b.rgba[..., :3]).max(axis=-1) > 1e-3
        assert differ.sum() <= 2, (f, int(differ.sum()))
    assert shadowed > 0
