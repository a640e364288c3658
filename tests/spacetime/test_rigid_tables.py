"""What the rigid shapes keep on the host (spacetime/rigid.py, issue 17's bytes per triangle).

Law: texture coordinates are kept only for a scene with a textured material (the device
reads them only then, rendering/device_textures.py; tests/rendering/test_textures.py
renders textured stages through them): an untextured scene's table is empty.
"""
import warp_st
from warp_st.spacetime.rigid import rigid_shapes

from animation_stages import HEADER, write


def test_an_untextured_scene_keeps_no_texture_coordinates(tmp_path):
    stage = HEADER + '''def Cube "A"
{
    double size = 2
}
def Sphere "B"
{
    double radius = 1
    double3 xformOp:translate = (3, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''
    shapes = rigid_shapes(warp_st.load(write(tmp_path, "plain.usda", stage)))
    assert shapes.triangle_count > 12
    assert shapes.tri_st.shape == (0, 3, 2)
