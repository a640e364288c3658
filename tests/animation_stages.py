"""Helpers (not tests): small stages whose bodies USD animates (docs/spec.md §2.1), and the
oracle that carries a hit event back through USD's own transform at its event time."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom

from warp_st.rendering.camera import pixel_directions

#: A camera at rest at (0, 3, 14) looking down -Z, tilted 12 degrees down; time codes 0-100.
HEADER = '''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 100
)
def Camera "Cam"
{
    double3 xformOp:translate = (0, 3, 14)
    float3 xformOp:rotateXYZ = (-12, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    float focalLength = 24
}
'''

#: A camera at rest at (0, 10, 0) looking straight down at the floor y = 0 (finite light speed;
#: time codes 0-100): a floor pixel's hit is 10 / -n_y along its ray (lit-floor tests).
DOWN_CAMERA = '''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 100
)
def Camera "Cam"
{
    float focalLength = 20
    float horizontalAperture = 24
    double3 xformOp:translate = (0, 10, 0)
    float xformOp:rotateX = -90
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
    custom token spacetime:lightSpeed = "finite"
}
'''


#: A pure mirror (metallic 1, diffuse 1): bind </Chrome>.
CHROME = '''def Material "Chrome"
{
    token outputs:surface.connect = </Chrome/Surface.outputs:surface>
    def Shader "Surface"
    {
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor = (1, 1, 1)
        float inputs:metallic = 1
        token outputs:surface
    }
}
'''

#: A uniform white dome (radiance 1) and /Chrome.
CHROME_DOME = '''def DomeLight "Sky"
{
    float inputs:intensity = 1
}
''' + CHROME


def orbit_degrees(speed: float, radius: float, duration: float) -> float:
    """The rotateY angle (degrees) after ``duration`` of a pivot at ``radius`` moving at ``speed``."""
    return float(np.degrees(speed / radius * duration))


def orbit(gprim: str, *, speed: float = 0.8, radius: float = 5.0, decoupled: bool = True) -> str:
    """/Orbit turns about +Y (time samples 0 and 100) carrying the body /Orbit/Moon at
    ``radius`` on +X: its pivot moves at ``speed`` on a circle. ``gprim``: the body's gprim."""
    coupling = "custom bool spacetime:lorentzDecoupled = true" if decoupled else ""
    return HEADER + f'''def Xform "Orbit"
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {orbit_degrees(speed, radius, 100.0)!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Xform "Moon" (prepend apiSchemas = ["SpacetimeBodyAPI"])
    {{
        {coupling}
        double3 xformOp:translate = ({radius!r}, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        {gprim}
    }}
}}
'''


#: A cube gprim of edge 1.2 (exact triangles: the surface test measures motion only).
CUBE = '''def Cube "Box"
    {
        double size = 1.2
    }'''


def spinning_rod(tip_speed: float = 0.7, half_length: float = 2.0) -> str:
    """/Rod (SpacetimeBodyAPI, coupled, pivot at rest at the origin) spins about +Y; its
    gprim /Rod/Bar is a 2 x half_length by 0.4 by 0.4 box whose tips move at ``tip_speed``."""
    return HEADER + f'''def Xform "Rod" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double xformOp:rotateY.timeSamples = {{ 0: 0, 100: {orbit_degrees(tip_speed, half_length, 100.0)!r} }}
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Cube "Bar"
    {{
        double size = 1
        double3 xformOp:scale = ({2 * half_length!r}, 0.4, 0.4)
        uniform token[] xformOpOrder = ["xformOp:scale"]
    }}
}}
'''


def edge_pixels(*masks) -> np.ndarray:
    """Pixels next to a silhouette of any mask."""
    edge = np.zeros_like(masks[0])
    for mask in masks:
        for axis in (0, 1):
            edge |= (mask != np.roll(mask, 1, axis)) | (mask != np.roll(mask, -1, axis))
    return edge


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def hit_events(scene, image, frame: float, width: int, height: int):
    """Lab events (t, x) (float64) of every hit pixel of a camera at rest: x = c + depth n."""
    cam = scene.camera_state(None, frame)
    n = pixel_directions(cam, width, height, frame="lab")
    hit = image.object_id > 0
    s = image.depth[hit].astype(np.float64)
    return image.event_time[hit].astype(np.float64), cam.position + s[:, None] * n[hit], s


def cube_surface_distance(path: str, gprim: str, times, points, half_extent) -> np.ndarray:
    """Distance of each lab point from the surface of the box gprim ``gprim`` (authored
    half extents ``half_extent`` in its local frame, scaled to the world by the transform),
    the point carried back through USD's ComputeLocalToWorldTransform at its time code."""
    stage = Usd.Stage.Open(path)  # held: a prim of a freed stage is invalid
    prim = stage.GetPrimAtPath(gprim)
    xformable = UsdGeom.Xformable(prim)
    out = []
    for t, x in zip(times, points):
        m = np.array(xformable.ComputeLocalToWorldTransform(Usd.TimeCode(float(t))), dtype=np.float64)
        q = (np.append(x, 1.0) @ np.linalg.inv(m))[:3]
        scale = np.linalg.norm(m[:3, :3], axis=1)  # world length of each local axis
        out.append(float(((half_extent - np.abs(q)) * scale).min()) if np.all(np.abs(q) <= half_extent)
                   else float(np.linalg.norm(np.maximum(np.abs(q) - half_extent, 0.0) * scale)))
    return np.array(out)
