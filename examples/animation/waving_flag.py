"""Writes waving_flag.usda beside this file: a flag whose points are time-sampled (a wave
running along it, docs/spec.md §2.2) on a pole, both carried past the camera at 0.8c by
``spacetime:fourVelocity`` (Lorentz-decoupled: a deforming body's points are lab positions).

    python examples/animation/waving_flag.py && warp-st render examples/animation/waving_flag.usda --frames 20,32
"""
from pathlib import Path

import numpy as np

NX, NY, WIDTH, HEIGHT = 13, 7, 4.0, 2.4
PERIOD, STEP, END = 20.0, 2.0, 40.0  # the wave's period and the samples' spacing (time codes)


def flag_points(t: float) -> np.ndarray:
    """The flag at time code t: hung at x = 0 from y = 1.6 to 4, a wave of wavelength 3
    running towards its free end, growing from the pole."""
    x, y = np.meshgrid(np.linspace(0.0, WIDTH, NX), np.linspace(4.0 - HEIGHT, 4.0, NY))
    phase = 2.0 * np.pi * (x / 3.0 - t / PERIOD)
    z = 0.45 * (x / WIDTH) * np.sin(phase)
    sag = -0.15 * (x / WIDTH) ** 2 * (1.0 + 0.5 * np.cos(phase))
    return np.stack([x.ravel(), (y + sag).ravel(), z.ravel()], axis=1)


def _array(points: np.ndarray) -> str:
    return "[" + ", ".join(f"({x:.5f}, {y:.5f}, {z:.5f})" for x, y, z in points) + "]"


def stage_text() -> str:
    counts, indices = [], []
    for j in range(NY - 1):
        for i in range(NX - 1):
            a = j * NX + i
            counts.append(4)
            indices += [a, a + 1, a + NX + 1, a + NX]
    samples = ",\n                ".join(f"{t:g}: {_array(flag_points(t))}" for t in np.arange(0.0, END + STEP / 2, STEP))
    return f'''#usda 1.0
(
    doc = "Written by waving_flag.py. A flag whose points are time-sampled (a wave runs along it) on a pole, carried past the camera at 0.8c by spacetime:fourVelocity; a deforming body is Lorentz-decoupled: its points are lab positions (docs/spec.md 2.2)."
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = 0
    endTimeCode = {END:g}
    timeCodesPerSecond = 24
)
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 3, 12)
    float3 xformOp:rotateXYZ = (-8, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    float focalLength = 24
}}
def DistantLight "Sun"
{{
    float inputs:intensity = 2.5
    bool inputs:normalize = true
    float3 xformOp:rotateXYZ = (-35, 40, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}}
def Mesh "Ground"
{{
    point3f[] points = [(-80, 0, -30), (80, 0, -30), (80, 0, 30), (-80, 0, 30)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 3, 2, 1]
    color3f[] primvars:displayColor = [(0.35, 0.35, 0.38)]
}}
def Xform "Banner" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    custom double4 spacetime:fourVelocity = (1, 0.8, 0, 0)
    custom double spacetime:referenceTime = 20
    custom bool spacetime:lorentzDecoupled = true
    def Cylinder "Pole"
    {{
        double radius = 0.06
        double height = 4.2
        uniform token axis = "Y"
        double3 xformOp:translate = (0, 2.1, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        color3f[] primvars:displayColor = [(0.8, 0.8, 0.75)]
    }}
    def Mesh "Flag"
    {{
        point3f[] points.timeSamples = {{
                {samples}
        }}
        int[] faceVertexCounts = {counts}
        int[] faceVertexIndices = {indices}
        color3f[] primvars:displayColor = [(0.85, 0.2, 0.15)]
    }}
}}
'''


if __name__ == "__main__":
    out = Path(__file__).with_suffix(".usda")
    out.write_text(stage_text())
    print(out)
