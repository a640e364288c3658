"""Writes rolling_wheel_08c.usda beside this file: issue 18's wheel rolling without slipping
at 0.8c, Born-rigid in its own frame (``spacetime:animationFrame = "rest"``, docs/spec.md
§2.1, addition 0.7.0). In the frame moving with the axle (``spacetime:fourVelocity`` 0.8c
along +x) it spins rigidly at w' = v / R (rim speed v); the lab sees the boost of that: the
contact point at rest on the ground, the top at 2v / (1 + v^2) = 0.976c, the spokes bent by
the relativity of simultaneity. The meshes are fine (edges <= 0.1 R; the reader cuts them further) because a lab slice of
a straight rest edge is curved and the renderer draws it straight between vertices.

    python examples/animation/rolling_wheel_08c.py && warp-st render examples/animation/rolling_wheel_08c.usda --frame 10
"""
from pathlib import Path

import numpy as np

V, R = 0.8, 1.0  # the axle's speed (c) and the wheel's rest radius
INNER, THICK = 0.85, 0.25  # the tyre's inner radius and thickness
SEGMENTS, RINGS, BANDS = 96, 2, 3  # the tyre's angular, radial (caps) and axial (treads) divisions
SPOKE_WIDTH, SPOKE_DEPTH, SPOKE_PARTS = 0.08, 0.1, 17
REST_CODES = range(-10, 11)  # rest-frame time codes sampled (t'; held outside: the wheel slides)


def _grid(u: int, v: int, point, closed_u: bool = False):
    """Points point(i / u, j / v) of a (u + 1) x (v + 1) grid (u columns wrapped when
    ``closed_u``) and its quads."""
    cols = u if closed_u else u + 1
    pts = [point(i / u, j / v) for j in range(v + 1) for i in range(cols)]
    quads = [[j * cols + i, j * cols + (i + 1) % cols, (j + 1) * cols + (i + 1) % cols, (j + 1) * cols + i]
             for j in range(v) for i in range(u)]
    return np.array(pts), quads


def _merge(parts):
    points, faces, base = [], [], 0
    for pts, quads in parts:
        points.append(pts)
        faces += [[base + k for k in q] for q in quads]
        base += len(pts)
    return np.concatenate(points), faces


def tyre():
    """A closed annulus: outer and inner treads, front and back caps."""
    def ring(radius, z):
        return lambda a, b: (radius * np.cos(2 * np.pi * a), radius * np.sin(2 * np.pi * a), z)

    def tread(radius, sign):
        return _grid(SEGMENTS, BANDS, lambda a, b: (radius * np.cos(2 * np.pi * a * sign),
                                                     radius * np.sin(2 * np.pi * a * sign), THICK * (b - 0.5)), True)

    def cap(z, sign):
        return _grid(SEGMENTS, RINGS, lambda a, b: ((INNER + (R - INNER) * b) * np.cos(2 * np.pi * a * sign),
                                                     (INNER + (R - INNER) * b) * np.sin(2 * np.pi * a * sign), z), True)

    return _merge([tread(R, 1), tread(INNER, -1), cap(THICK / 2, -1), cap(-THICK / 2, 1)])


def spoke(angle: float):
    """A bar across the wheel through its centre at ``angle`` (degrees), cut along its length."""
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    half = INNER + 0.02

    def side(dw, dz):
        return _grid(SPOKE_PARTS, 1, lambda a, b: tuple(np.array([c, s, 0.0]) * half * (2 * a - 1)
                                                        + np.array([-s, c, 0.0]) * SPOKE_WIDTH / 2 * dw(b)
                                                        + np.array([0, 0, SPOKE_DEPTH / 2]) * dz(b)))

    sides = [side(lambda b: 1.0, lambda b: 1 - 2 * b), side(lambda b: 1 - 2 * b, lambda b: -1.0),
             side(lambda b: -1.0, lambda b: 2 * b - 1), side(lambda b: 2 * b - 1, lambda b: 1.0)]
    return _merge(sides)


def _mesh(name: str, points, faces, colour) -> str:
    pts = ", ".join(f"({x:.6f}, {y:.6f}, {z:.6f})" for x, y, z in points)
    return f'''    def Mesh "{name}"
    {{
        point3f[] points = [{pts}]
        int[] faceVertexCounts = {[len(f) for f in faces]}
        int[] faceVertexIndices = {[i for f in faces for i in f]}
        color3f[] primvars:displayColor = [{colour}]
    }}
'''


def stage_text() -> str:
    omega = V / R  # rad per rest time code
    spin = ", ".join(f"{t}: {-np.degrees(omega * t):.9g}" for t in REST_CODES)
    meshes = _mesh("Tyre", *tyre(), "(0.8, 0.8, 0.75)")
    for k, colour in enumerate(["(0.2, 0.3, 0.9)", "(0.9, 0.3, 0.2)", "(0.2, 0.3, 0.9)", "(0.9, 0.3, 0.2)"]):
        meshes += _mesh(f"Spoke{k}", *spoke(45.0 * k), colour)
    return f'''#usda 1.0
(
    doc = "Written by rolling_wheel_08c.py. A wheel of rest radius 1 rolling without slipping at 0.8c (issue 18; Weiskopf, Mueller), Born-rigid in its own frame: spacetime:animationFrame rest makes its xformOps its motion in the frame moving with its fourVelocity, their time codes that frame's time (docs/spec.md 2.1, addition 0.7.0). It spins there at 0.8 rad per time code (rim speed 0.8c; sampled from t' = -10 to 10, held outside); the lab sees the contact point at rest, the top at 0.976c and the spokes bent by the relativity of simultaneity. The camera (lab time = time code) sees it pass around frame 10. Lit by a uniform sky (no shadow rays: the wheel's visible time window stays short)."
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = 0
    endTimeCode = 20
    timeCodesPerSecond = 24
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"])
{{
    double3 xformOp:translate = (0, 1.5, 9)
    float3 xformOp:rotateXYZ = (-5, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    float focalLength = 24
    custom token spacetime:lightSpeed = "finite"
}}
def DomeLight "Sky"
{{
    float inputs:intensity = 1
    color3f inputs:color = (0.9, 0.95, 1)
}}
def Mesh "Ground"
{{
    point3f[] points = [(-30, 0, -20), (30, 0, -20), (30, 0, 8), (-30, 0, 8)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 3, 2, 1]
    color3f[] primvars:displayColor = [(0.35, 0.35, 0.38)]
}}
def Xform "Wheel" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    custom uniform token spacetime:animationFrame = "rest"
    custom double4 spacetime:fourVelocity = (1, {V}, 0, 0)
    custom double spacetime:referenceTime = 0
    double3 xformOp:translate = (0, {R}, 0)
    double xformOp:rotateZ.timeSamples = {{ {spin} }}
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ"]
{meshes}}}
'''


if __name__ == "__main__":
    (Path(__file__).resolve().parent / "rolling_wheel_08c.usda").write_text(stage_text())
