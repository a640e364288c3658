"""Deforming bodies as leaves of the two-level path (docs/spec.md §2.2, 0.8.0; docs/design/mixed-leaves.md).

Laws (the oracle: the all-tet path, ``primitive="tet"``, which extrudes every body):
- the waving flag (examples/animation/waving_flag.usda) beside a static crate, a sphere at
  0.5c and a cube moving with the flag renders on the default path (rigid, with the
  flag's tetrahedra as leaves) with the all-tet path's hit masks and object ids, and its
  event times and depths to float32 rounding; the deforming body's pixels bit for bit
  (the same tetrahedra, tested by the same function from the same origin);
- a scene of the flag alone renders bit for bit as on the all-tet path;
- shadows cast by the deforming body onto rigid ones, and by a rigid body onto it, are
  the all-tet path's;
- the database follows the deforming body: other cameras re-slice it (and reuse the
  rigid shapes), a changed flag is a new scene and a new database.
"""
import dataclasses

import numpy as np
import pytest

import warp_st
from warp_st.core.deform import PointSamples
from warp_st.rendering import database_cache
from warp_st.rendering.renderer import Renderer

from animation_stages import edge_pixels, write
from deform_stages import flag_samples, mesh_stage

W, H = 160, 90
FLAG = "examples/animation/waving_flag.usda"
#: Rigid bodies beside the flag: a static crate, a coupled sphere at 0.5c and a cube moving
#: with the banner (decoupled, 0.8c) between the sun and the flag (it shadows the flag).
EXTRA = '''
def Cube "Crate"
{
    double size = 1.2
    double3 xformOp:translate = (-2.5, 0.6, 1.5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color3f[] primvars:displayColor = [(0.7, 0.4, 0.2)]
}
def Sphere "Ball" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double4 spacetime:fourVelocity = (1.1547005383792517, -0.5773502691896258, 0, 0)
    custom double spacetime:referenceTime = 20
    double radius = 0.7
    double3 xformOp:translate = (4.5, 1.0, 2.0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color3f[] primvars:displayColor = [(0.3, 0.5, 0.8)]
}
def Cube "Shade" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double4 spacetime:fourVelocity = (1, 0.8, 0, 0)
    custom double spacetime:referenceTime = 20
    custom bool spacetime:lorentzDecoupled = true
    double size = 0.6
    double3 xformOp:translate = (2.63, 3.49, 0.75)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    color3f[] primvars:displayColor = [(0.9, 0.9, 0.9)]
}
'''


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("mixed") / "mixed.usda"
    path.write_text(open(FLAG).read() + EXTRA)
    return warp_st.load(str(path))


def _mixed(scene, frame, **options):
    """The default path (rigid with tetrahedra leaves), spheres tessellated as on the tet path."""
    renderer = Renderer(scene, frames=[frame], width=W, height=H, quadrics="tessellated", **options)
    assert renderer.primitive == "rigid" and renderer.database.tets is not None
    return renderer, renderer.render(frame)


def _tet(scene, frame, **options):
    return Renderer(scene, frames=[frame], width=W, height=H, primitive="tet", **options).render(frame)


def _banner_id(scene) -> int:
    return 1 + [b.prim_path for b in scene.bodies].index("/Banner")


@pytest.mark.parametrize("frame", [28.0, 36.0])
def test_flag_among_rigid_bodies_matches_the_all_tet_path(scene, frame):
    """Masks equal except silhouette pixels (none measured), object ids equal where both
    hit. Rigid pixels: event times within 5e-5 and depths within 1e-5 relative (the rigid
    path rounds the ray in body coordinates, the tet path the events relative to the camera:
    float32 at times ~30 and depths ~15 is 2e-6 and 1e-6; measured 2.9e-5 and 3e-6 at most,
    a grazing sphere pixel). The banner's pixels (its tetrahedra) are identical."""
    renderer, a = _mixed(scene, frame)
    b = _tet(scene, frame)
    ma, mb = a.object_id > 0, b.object_id > 0
    assert not ((ma != mb) & ~edge_pixels(ma, mb)).any()
    both = ma & mb
    assert (a.object_id[both] == b.object_id[both]).all()
    seen = {int(i) for i in np.unique(a.object_id[both])}
    assert {1, 2, 3} <= seen and seen & {4, 5}  # ground, banner, crate and a moving rigid body
    assert np.abs(a.event_time[both] - b.event_time[both]).max() <= 5e-5
    assert (np.abs(a.depth[both] - b.depth[both]) / b.depth[both]).max() <= 1e-5
    # Colour off the silhouettes within 1e-4: the shading of those float32 events (measured
    # 2.3e-5 at most, the shade's facets, whose events moved by 2.9e-5 of c).
    assert np.abs(a.rgba - b.rgba)[both & ~edge_pixels(ma, mb)].max() <= 1e-4
    banner = both & (a.object_id == _banner_id(scene))
    assert banner.sum() > 1000
    for channel in ("event_time", "depth", "rgba", "doppler"):
        assert np.array_equal(getattr(a, channel)[banner], getattr(b, channel)[banner]), channel
    # Only the banner is extruded: its tetrahedra are the all-tet path's but for the others'.
    tet = Renderer(scene, frames=[frame], width=W, height=H, primitive="tet")
    banner_tets = int((tet.mesh.tri_body[tet.mesh.tet_tri] == _banner_id(scene) - 1).sum())
    assert renderer.stats.tetrahedra == banner_tets < tet.stats.tetrahedra


def test_flag_alone_renders_as_on_the_tet_path(tmp_path):
    """A stage of the flag alone (points sampled at 0 and 20): every channel bit for bit."""
    samples, counts, indices = flag_samples(20.0)
    flag = warp_st.load(write(tmp_path, "flag.usda", mesh_stage("Flag", samples, counts, indices)))
    for frame in (18.0, 26.0):
        _renderer, a = _mixed(flag, frame)
        b = _tet(flag, frame)
        assert (a.object_id > 0).sum() > 300
        for channel in ("object_id", "event_time", "depth", "rgba", "doppler", "proper_time"):
            assert np.array_equal(getattr(a, channel), getattr(b, channel), equal_nan=True), (frame, channel)


def _without(scene, path):
    return dataclasses.replace(scene, bodies=tuple(b for b in scene.bodies if b.prim_path != path))


@pytest.mark.parametrize("frame", [32.0, 36.0])
def test_shadows_by_and_onto_the_deforming_body(scene, frame):
    """Shadow pixels are those that a render without the caster shows brighter than the
    all-tet path's (by more than 0.05 in red): the flag's shadow on the ground, crate or ball (the banner removed),
    the shade's on the flag (the shade removed). There, the colour is the all-tet path's
    within 1e-5 (float32 rounding of the shading, measured 0)."""
    _r, a = _mixed(scene, frame)
    b = _tet(scene, frame)
    banner = _banner_id(scene)
    _r, no_shade = _mixed(_without(scene, "/Shade"), frame)
    no_banner = Renderer(_without(scene, "/Banner"), frames=[frame], width=W, height=H,
                         quadrics="tessellated").render(frame)
    brighter = (no_banner.rgba[..., 0] > b.rgba[..., 0] + 0.05) & (a.object_id != banner)
    by = brighter & (np.where(no_banner.object_id >= banner, no_banner.object_id + 1, no_banner.object_id)
                     == a.object_id) & (a.object_id > 0)
    onto = (a.object_id == banner) & (no_shade.object_id == banner) & (no_shade.rgba[..., 0] > b.rgba[..., 0] + 0.05)
    assert by.sum() > 100 and onto.sum() > 200, (int(by.sum()), int(onto.sum()))
    assert np.abs(a.rgba - b.rgba)[by | onto].max() <= 1e-5


def test_database_follows_the_deforming_body(scene):
    """Another resolution re-slices the flag (the half-pixel rule, §2.2: more tetrahedra
    at 640 x 360) in a new database whose tetrahedra are the all-tet path's there, while the
    rigid shapes and bottom levels are reused (the ball left out: its tessellation follows
    the resolution too). A flag with other samples is a new scene: its own database, and its
    image changes where the flag is."""
    scene = _without(scene, "/Ball")
    small = Renderer(scene, frames=[28.0], width=W, height=H, quadrics="tessellated")
    small.render(28.0)
    big = Renderer(scene, frames=[28.0], width=4 * W, height=4 * H, quadrics="tessellated")
    assert big.database is not small.database and big.database.bottom is small.database.bottom
    tet = Renderer(scene, frames=[28.0], width=4 * W, height=4 * H, primitive="tet")
    banner_tets = int((tet.mesh.tri_body[tet.mesh.tet_tri] == _banner_id(scene) - 1).sum())
    assert big.stats.tetrahedra == banner_tets > small.stats.tetrahedra
    builds = database_cache.builds()
    Renderer(scene, frames=[28.0], width=W, height=H, quadrics="tessellated")
    assert database_cache.builds() == builds  # the same frames again: nothing built
    i = _banner_id(scene) - 1
    body = scene.bodies[i]
    flag = next(s for s in body.surfaces if s.samples is not None)
    lifted = dataclasses.replace(flag, samples=PointSamples(times=flag.samples.times,
                                                            points=flag.samples.points + np.array([0.0, 0.5, 0.0])))
    moved = dataclasses.replace(scene, bodies=scene.bodies[:i] + (dataclasses.replace(
        body, surfaces=tuple(lifted if s is flag else s for s in body.surfaces)),) + scene.bodies[i + 1:])
    _r, before = _mixed(scene, 28.0)
    _r, after = _mixed(moved, 28.0)
    assert database_cache.builds() > builds
    assert ((before.object_id == i + 1) != (after.object_id == i + 1)).sum() > 100
    expected = _tet(moved, 28.0)
    assert np.array_equal(after.object_id, expected.object_id)


def test_textured_deforming_body_beside_a_textured_rigid_one(tmp_path):
    """test_textures' textured quad at rest (camera at the origin, the quad at z = -6) made
    0.4 as large twice: on the left its points time-sampled to slide 0.2 along x over time
    codes -20..0 (a deforming body), on the right a rigid copy. On the mixed path each shows
    the colours it shows on the all-tet path (texels read through each path's own corner
    order, ``prim_corner``): bit for bit on the deforming quad (the same tetrahedra), within
    1/255 on the rigid one off 1 % of its pixels (its float32 hits differ by rounding and can
    pick the neighbouring texel at an edge; measured: none)."""
    from test_textures import random_texture, textured_quad_stage

    random_texture(tmp_path)
    base = warp_st.load(textured_quad_stage(tmp_path, 0.0))
    body = base.bodies[0]
    surface = body.surfaces[0]
    pts = np.asarray(surface.points, dtype=np.float64)
    small = (pts - pts.mean(axis=0)) * 0.4 + pts.mean(axis=0)
    left, right = small - [0.55, 0.0, 0.0], small + [0.55, 0.0, 0.0]
    slid = dataclasses.replace(surface, points=left, samples=PointSamples(
        times=np.array([-20.0, 0.0]), points=np.stack([left - [0.2, 0.0, 0.0], left])))
    rigid = dataclasses.replace(body, prim_path="/Copy", surfaces=(dataclasses.replace(
        surface, prim_path="/Copy/Quad", points=right),))
    scene = dataclasses.replace(base, bodies=(dataclasses.replace(body, surfaces=(slid,), decoupled=True), rigid))
    renderer, a = _mixed(scene, 0.0)
    b = _tet(scene, 0.0)
    deforming, copy = a.object_id == 1, a.object_id == 2
    assert deforming.sum() > 200 and copy.sum() > 200
    assert np.array_equal(a.object_id, b.object_id)
    assert np.array_equal(a.rgba[deforming], b.rgba[deforming])
    assert np.abs(a.rgba[copy] - b.rgba[copy]).max() <= 1.0 / 255.0 or (
        (np.abs(a.rgba - b.rgba).max(axis=-1) > 1.0 / 255.0) & copy).sum() <= 0.01 * copy.sum()
    assert len(np.unique(a.rgba[deforming][:, :3], axis=0)) > 20  # the texture is seen


@pytest.mark.parametrize("frame", [28.0, 36.0])
def test_rigid_bodies_beside_the_flag_are_the_rigid_paths(scene, frame):
    """With exact quadrics (the default), the crate, ball and shade of the mixed render hit
    exactly where a render without the banner (all rigid, no tetrahedra) hits them: the
    same instances, the same float32 rays; event times and depths bit for bit."""
    renderer = Renderer(scene, frames=[frame], width=W, height=H)
    assert renderer.exact_quadrics and renderer.database.tets is not None
    a = renderer.render(frame)
    rigid = Renderer(_without(scene, "/Banner"), frames=[frame], width=W, height=H)
    assert rigid.database.tets is None
    c = rigid.render(frame)
    banner = _banner_id(scene)
    ids = np.where(c.object_id >= banner, c.object_id + 1, c.object_id)  # the ids without the banner
    same = (a.object_id == ids) & (a.object_id > banner)
    seen = {int(i) for i in np.unique(a.object_id[same])}
    assert 3 in seen and seen & {4, 5}, seen  # the crate and a moving body (the ball at 36, the shade at 28)
    for channel in ("event_time", "depth"):
        assert np.array_equal(getattr(a, channel)[same], getattr(c, channel)[same]), channel


def test_memory_limit_counts_both_parts(scene):
    """``max_memory`` one byte below the database's estimate (the rigid part's and the
    tetrahedra's, and the frame's pixels) refuses before building, though the tetrahedra's
    own estimate fits under it: the limit holds for the database as a whole; at the
    estimate it renders."""
    from warp_st.rendering.budget import MemoryRefusal, check_resources
    from warp_st.spacetime.mixed import deforming_windows

    probe = Renderer(scene, frames=[28.0], width=W, height=H, quadrics="tessellated")
    total = probe.memory_estimate
    tets = check_resources(scene, deforming_windows(scene, probe.database.windows), view=probe.slice_view,
                           width=W, height=H, max_depth=probe.max_depth)
    assert tets < total - 1
    database_cache.clear(scene)
    with pytest.raises(MemoryRefusal, match="the render needs about"):
        Renderer(scene, frames=[28.0], width=W, height=H, quadrics="tessellated", max_memory=total - 1)
    Renderer(scene, frames=[28.0], width=W, height=H, quadrics="tessellated", max_memory=total)


def _mirror(scene, path):
    """``scene`` with body ``path``'s surfaces perfect mirrors (metallic 1, diffuse 0.9)."""
    def metal(s):
        return dataclasses.replace(s, material=dataclasses.replace(s.material, metallic=1.0, diffuse=(0.9, 0.9, 0.9)))
    return dataclasses.replace(scene, bodies=tuple(
        dataclasses.replace(b, surfaces=tuple(metal(s) for s in b.surfaces)) if b.prim_path == path else b
        for b in scene.bodies))


@pytest.mark.parametrize("mirror, seen", [("/Ground", "/Banner"), ("/Banner", "/Ground")])
def test_mirror_bounces_between_rigid_and_deforming_bodies(scene, mirror, seen):
    """The ground as a mirror shows the flag (reflected rays from rigid hits into the
    tetrahedra), the banner as a mirror shows the ground (from tetrahedron hits into the
    instances): the mirror's pixels whose colour changes when ``seen`` is removed (141 and
    196 measured) and all its others are the all-tet path's within 1e-4 (the reflected
    rays start at float32 hit events; measured 3.6e-6)."""
    frame = 36.0
    sc = _mirror(scene, mirror)
    _r, a = _mixed(sc, frame, max_depth=1)  # one bounce: what the law needs (and a smaller database)
    b = _tet(sc, frame, max_depth=1)
    gone = Renderer(_without(sc, seen), frames=[frame], width=W, height=H, quadrics="tessellated",
                    max_depth=1).render(frame)
    body = 1 + [x.prim_path for x in sc.bodies].index(mirror)
    on = (a.object_id == body) & (b.object_id == body)
    shows = on & (np.abs(b.rgba - gone.rgba).max(axis=-1) > 0.05)
    assert shows.sum() > 100, int(shows.sum())
    assert np.abs(a.rgba - b.rgba)[on].max() <= 1e-4
