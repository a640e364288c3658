"""An animated body's pieces share one bottom level on the rigid path (issue 18).

Laws:
- the pieces of a turning body (``spacetime.animation.piece_bodies``) use one shape, the
  body's unturned rest shape, and so one ``wp.Mesh``; each piece's orientation goes into
  the map that takes the ray into it (``spacetime.rigid.shape_parts`` ``body_map``);
- the shared bottom level renders as each piece's own turned copy did (the pieces with
  ``Body.piece_linear`` dropped: the per-piece path), primary and shadow rays, for a
  body held in another body's frame (the map's shift) and for a coupled body moving at
  0.6c (the map after the contraction).
"""
import dataclasses

import numpy as np
import pytest

import warp_st
from warp_st.rendering.renderer import Renderer
from warp_st.spacetime.animation import animated_bodies

from animation_stages import HEADER, orbit_degrees, write

W, H = 128, 96

#: A lit floor, the first body at rest: a body at rest turning about another pivot is held
#: in the floor's frame, so its map has a shift (spacetime/rigid.py).
_FLOOR = HEADER + '''def DistantLight "Sun"
{
    float inputs:intensity = 2.5
    float3 xformOp:rotateXYZ = (-50, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}
def Cube "Floor"
{
    double size = 1
    double3 xformOp:translate = (0, -1.5, -2)
    double3 xformOp:scale = (14, 0.2, 10)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
}
'''

STAGES = {
    # A bar spinning about +Y at rest (tips at 0.7c): every piece in the floor's frame.
    "spinning": _FLOOR + f'''def Xform "Rod" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {orbit_degrees(0.7, 2.0, 100.0)!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Cube "Bar"
    {{
        double size = 1
        double3 xformOp:scale = (4, 0.4, 0.4)
        uniform token[] xformOpOrder = ["xformOp:scale"]
    }}
}}
''',
    # A coupled box moving along +x at 0.6c and turning at 0.3 rad per time code: each piece
    # contracted along its chord (its corners at up to ~0.94c: points at >= c are bad input).
    "rolling": _FLOOR + '''def Xform "Box" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    double3 xformOp:translate.timeSamples = { 0: (-30, 0, 0), 100: (30, 0, 0) }
    double xformOp:rotateZ.timeSamples = { 0: 0, 100: -1718.8733853924698 }
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
    def Cube "C"
    {
        double size = 1.6
    }
}
''',
}
FRAMES = {"spinning": 40.0, "rolling": 64.0}


def _pieces(tmp_path, name):
    """The stage's scene, and the same with its animated body replaced by the pieces the
    renderer cuts it into at W x H (bodies now, so no renderer cuts them again)."""
    scene = warp_st.load(write(tmp_path, f"{name}.usda", STAGES[name]))
    cuts = Renderer(scene, frames=[FRAMES[name]], width=W, height=H, primitive="rigid").animation
    bodies, _ = animated_bodies(scene, cuts)
    return scene, dataclasses.replace(scene, bodies=bodies)


@pytest.mark.parametrize("name", sorted(STAGES))
def test_a_turning_body_pieces_share_one_bottom_level(tmp_path, name):
    """Every piece of the animated body holds the same shape: one wp.Mesh for the body and
    one for the floor, whatever the piece count (hundreds here)."""
    scene, _ = _pieces(tmp_path, name)
    db = Renderer(scene, frames=[FRAMES[name]], width=W, height=H, primitive="rigid").database
    path = "/Rod" if name == "spinning" else "/Box"
    pieces = [i for i, b in enumerate(db.shapes.bodies) if b.prim_path == path]
    assert len(pieces) > 100
    assert len(set(db.shapes.body_shape[pieces].tolist())) == 1
    assert db.bottom.count == 2


@pytest.mark.parametrize("name", sorted(STAGES))
def test_the_shared_bottom_level_renders_as_per_piece_copies(tmp_path, name):
    """The pieces traced through the shared bottom level against the same pieces each with
    its own turned bottom level (``piece_linear`` dropped). The two differ only in which
    coordinates the float32 mesh and ray are rounded in (~1e-7 of the frame's size, against
    a pixel's ~1e-2 rad here): the same objects but for rays that graze an edge within that
    (at most 3 pixels of ~thousands), event times within 1e-5 (a few float32 ulps of
    lookbacks ~15) and colours within 1e-3 of the brightest elsewhere (shadow rays as well: the floor is lit)."""
    _, shared = _pieces(tmp_path, name)
    own = dataclasses.replace(shared, bodies=tuple(dataclasses.replace(b, piece_linear=None) for b in shared.bodies))
    frame = FRAMES[name]
    a = Renderer(shared, frames=[frame], width=W, height=H, primitive="rigid")
    b = Renderer(own, frames=[frame], width=W, height=H, primitive="rigid")
    assert a.database.bottom.count == 2 and b.database.bottom.count > 100
    ia, ib = a.render(frame), b.render(frame)
    moving = (ia.object_id > 1) | (ib.object_id > 1)  # the pieces' pixels: ids past the floor's (1)
    assert moving.sum() > 100
    same = ia.object_id == ib.object_id
    # Where two touching pieces meet, a ray along the seam hits both at one depth (to
    # float32 rounding) and either may win: a tie, not an error (which one depends on the
    # bottom level's traversal order). Seams cross most of the pieces' pixels here (hundreds
    # of pieces over ~170 pixels), a ray within rounding of one is rare: ties stay a few.
    tie = ~same & (np.abs(ia.depth - ib.depth) <= 1e-5 * np.maximum(np.abs(ib.depth), 1.0))
    assert (~same & ~tie).sum() <= 3, int((~same & ~tie).sum())
    assert tie.sum() <= 0.05 * moving.sum(), int(tie.sum())
    hit = same & (ia.object_id > 0)
    assert np.abs(ia.event_time[hit] - ib.event_time[hit]).max() <= 1e-5
    scale = float(ib.rgba[..., :3].max())  # UsdLux units: the lit floor's radiance is ~1e-5
    assert scale > 0.0 and np.abs(ia.rgba[hit][:, :3] - ib.rgba[hit][:, :3]).max() <= 1e-3 * scale
