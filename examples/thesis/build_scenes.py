"""Write the thesis scenes (``usd_scenes/thesis/*.usda``) from the thesis's dimensions.

The .usda files are shipped, hand-readable and commented; this script is how their
numbers were produced (every bar, rung, gore and observer), so they can be audited and
regenerated. ``--check`` verifies that the shipped files are what this script writes.

    python examples/thesis/build_scenes.py            # (re)write usd_scenes/thesis/
    python examples/thesis/build_scenes.py --check    # exit 1 if a shipped file differs

Dimensions (Black 2005, "Spacetime ray tracing", §4.4; c = 1, l.unit = t.unit):

- stage: a 12 x 12 grid of bars of square cross-section 1/20 on 1-unit centres in the
  x-z plane (y = 0), green X and Z axis bars, two green rails 4 units above the stage
  with red rungs 1 unit apart (§4.4, §4.4.6); camera at (0, 9, 15) looking at the origin.
- flange: a right-angle bracket 4 high, 2 wide, 2 deep, of two-sided planes (§4.4.1).
- aberration: a cube 1e5 on a side 1.5e5 from the observer, a 20 x 20 reticle 10 units
  away (§4.4.3).
- sphere and four cubes (§2.2.1, Figs. 2.1-2.2).
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "usd_scenes" / "thesis"

BETA_SLOW = 17.32 / 2000.0  # thesis Eq. 4.3: 0.00866
BETA_FAST = math.sqrt(3.0) / 2.0  # "0.866c", read as sqrt(3)/2 so that gamma = 2 exactly
CAMERA = (0.0, 9.0, 15.0)
SQRT194 = math.sqrt(194.0)  # |(0, 9, 15) - (0, 4, 2)|: camera to the flange's trailing upper corner


def f(x: float) -> str:
    """A float as USD text: shortest round-trip repr, integers without a decimal point."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return repr(x)


def vec(v) -> str:
    return "(" + ", ".join(f(x) for x in v) + ")"


# --------------------------------------------------------------------------- mesh helpers


def box(x0, x1, y0, y1, z0, z1):
    """8 corners and 6 quads of an axis-aligned box."""
    pts = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return pts, quads


def merge(parts):
    """[(points, quads, label)] -> (points, quads, [(label, first point, first quad)])."""
    pts, quads, index = [], [], []
    for p, q, label in parts:
        base = len(pts)
        index.append((label, base, len(quads)))
        pts.extend(p)
        quads.extend(tuple(i + base for i in quad) for quad in q)
    return pts, quads, index


def mesh_text(name, pts, faces, *, indent, color=None, doc=None, normals=None, extra=()):
    """A UsdGeom.Mesh prim, one box / face per line."""
    pad = " " * indent
    out = []
    out.append(f'{pad}def Mesh "{name}"' + (f' (\n{pad}    doc = "{doc}"\n{pad})' if doc else ""))
    out.append(f"{pad}{{")
    out.append(f"{pad}    uniform token subdivisionScheme = \"none\"")
    out.append(f"{pad}    uniform bool doubleSided = 1")
    counts = ", ".join(str(len(q)) for q in faces)
    out.append(f"{pad}    int[] faceVertexCounts = [{counts}]")
    out.append(f"{pad}    int[] faceVertexIndices = [")
    for k in range(0, len(faces), 6):
        chunk = faces[k:k + 6]
        out.append(f"{pad}        " + ",  ".join(", ".join(str(i) for i in q) for q in chunk) + ",")
    out[-1] = out[-1].rstrip(",")
    out.append(f"{pad}    ]")
    out.append(f"{pad}    point3f[] points = [")
    per = 4
    for k in range(0, len(pts), per):
        out.append(f"{pad}        " + ", ".join(vec(p) for p in pts[k:k + per]) + ",")
    out[-1] = out[-1].rstrip(",")
    out.append(f"{pad}    ]")
    if normals is not None:
        out.append(f"{pad}    normal3f[] normals = [")
        for k in range(0, len(normals), 4):
            out.append(f"{pad}        " + ", ".join(vec(n) for n in normals[k:k + 4]) + ",")
        out[-1] = out[-1].rstrip(",")
        out.append(f"{pad}    ] (")
        out.append(f"{pad}        interpolation = \"vertex\"")
        out.append(f"{pad}    )")
    if color is not None:
        out.append(f"{pad}    color3f[] primvars:displayColor = [{vec(color)}]")
    for line in extra:
        out.append(f"{pad}    {line}")
    out.append(f"{pad}}}")
    return "\n".join(out)


def bars_mesh(name, bars, *, indent, color, doc):
    """bars: [(label, (x0, x1, y0, y1, z0, z1))] -> one Mesh with a comment per bar."""
    pts, quads, index = merge([(*box(*b), label) for label, b in bars])
    text = mesh_text(name, pts, quads, indent=indent, color=color, doc=doc)
    legend = ", ".join(f"{label} (points {base}-{base + 7})" for label, base, _ in index)
    pad = " " * indent
    return f"{pad}# {name}: {len(bars)} boxes, 8 points and 6 quads each: " + _wrap(legend, pad + "#   ") + "\n" + text


def _wrap(text, prefix, width=92):
    words, lines, line = text.split(" "), [], ""
    for w in words:
        if len(line) + len(w) + 1 > width - len(prefix):
            lines.append(line)
            line = w
        else:
            line = (line + " " + w).strip()
    lines.append(line)
    return ("\n" + prefix).join([lines[0]] + lines[1:]) if len(lines) > 1 else lines[0]


HEADER = "#usda 1.0\n"


# --------------------------------------------------------------------------- stage


def stage_usda() -> str:
    h = 0.025  # half the bar cross-section (1/20)
    red_bars, green_bars, rails, rungs = [], [], [], []
    for k in range(-6, 7):
        along_z = (f"x={k}", (k - h, k + h, -h, h, -6 - h, 6 + h))
        along_x = (f"z={k}", (-6 - h, 6 + h, -h, h, k - h, k + h))
        if k == 0:
            # the axes stand 0.002 proud of the red bars so that they win where they cross
            green_bars.append(("Z axis x=0", (k - h, k + h, -h, h + 0.002, -6 - h, 6 + h)))
            green_bars.append(("X axis z=0", (-6 - h, 6 + h, -h, h + 0.002, k - h, k + h)))
        else:
            red_bars.extend([along_z, along_x])
    for z in (0, 2):
        rails.append((f"rail z={z}", (-6 - h, 6 + h, 4.0, 4.0 + 2 * h, z - h, z + h)))
    for k in range(-6, 7):
        rungs.append((f"rung x={k}", (k - h, k + h, 4.0, 4.0 + 2 * h, h, 2 - h)))
    floor_pts = [(-6.5, -h, -6.5), (6.5, -h, -6.5), (6.5, -h, 6.5), (-6.5, -h, 6.5)]
    hfov = 60.0
    focal = 0.5 * 20.955 / math.tan(math.radians(hfov / 2))
    pitch = -math.degrees(math.atan2(CAMERA[1], CAMERA[2]))
    return HEADER + f'''(
    doc = """The thesis's Visual Software Test Fixture stage (Black 2005, section 4.4, Figs. 4.7-4.8
    and 4.14-4.15), built to its dimensions. Units: c = 1, one l.unit = one t.unit.

    - A 12 x 12 grid of red bars of square cross-section 1/20 on 1-unit centres in the
      x-z plane (bar centres at y = 0; x and z from -6 to 6); the X and Z axes (z = 0 and
      x = 0) are green. The origin is where the green lines cross.
    - Two green rails 4 units above the stage (bottoms at y = 4) over z = 0 and z = 2 (the
      flange's depth), with red rungs between them every unit (x = -6 ... 6): they mark
      the flange's top edges (section 4.4.6).
    - A dark floor plate just under the bars (y = -0.025), so that every pixel of the
      stage has an event (the thesis shows the grid only).
    - /World/Camera at (0, 9, 15) looking at the origin (sections 4.4.2 and 4.4.6), at
      rest, finite light speed, 60 degrees horizontal field of view (not given in the
      thesis; it frames the stage and the rails at 4:3). Its time is the time code unless
      a scene that uses this stage says otherwise.
    - /World/CameraNoDelay: the same view with infinite light speed (the thesis's
      "contemporary rendering", Fig. 4.6 top row).

    The thesis also quotes (t, x, y, z)_cam = (940, 0, 6, 15) for video-frame 920: we
    keep (0, 9, 15), stated twice in the text relative to the crossing green lines; the
    y = 6 of the video tuple is in the VSTF's own coordinates or a slip. Nothing in this
    file moves: scenes add bodies by sublayering it (flange_*.usda).

    No light: every surface shows its unlit colour, as in the thesis's figures."""
    upAxis = "Y"
    metersPerUnit = 1
    defaultPrim = "World"
    renderSettingsPrimPath = "/Render/Settings"
)

def Xform "World"
{{
    def Camera "Camera" (
        prepend apiSchemas = ["SpacetimeCameraAPI"]
    )
    {{
        # rotateX = -atan(9/15) = {pitch:.6f} degrees aims the camera's -Z at the origin
        double3 xformOp:translate = {vec(CAMERA)}
        float xformOp:rotateX = {f(round(pitch, 6))}
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
        float focalLength = {f(round(focal, 6))}
        float horizontalAperture = 20.955
        float verticalAperture = 15.71625
        token spacetime:lightSpeed = "finite"
    }}

    def Camera "CameraNoDelay" (
        prepend apiSchemas = ["SpacetimeCameraAPI"]
    )
    {{
        double3 xformOp:translate = {vec(CAMERA)}
        float xformOp:rotateX = {f(round(pitch, 6))}
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
        float focalLength = {f(round(focal, 6))}
        float horizontalAperture = 20.955
        float verticalAperture = 15.71625
        token spacetime:lightSpeed = "infinite"
    }}

    # Gprims with no SpacetimeBodyAPI are bodies at rest with unbounded lifetimes: one
    # body (objectId) per Mesh prim below.
    def Xform "Stage"
    {{
{mesh_text("Floor", floor_pts, [(0, 3, 2, 1)], indent=8, color=(0.025, 0.025, 0.03),
           doc="dark floor plate 13 x 13 under the bars")}

{bars_mesh("GridBars", red_bars, indent=8, color=(0.75, 0.08, 0.06),
           doc="the 24 red grid bars x = k and z = k, k = -6..6 but 0")}

{bars_mesh("Axes", green_bars, indent=8, color=(0.1, 0.8, 0.15),
           doc="the green X and Z axes")}

{bars_mesh("Rails", rails, indent=8, color=(0.1, 0.8, 0.15),
           doc="two green rails at y = 4 over z = 0 and z = 2")}

{bars_mesh("Rungs", rungs, indent=8, color=(0.75, 0.08, 0.06),
           doc="13 red rungs between the rails, x = -6..6")}
    }}
}}

def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        uniform int2 resolution = (640, 480)
        rel camera = </World/Camera>
        custom token spacetime:precision = "float32"
        custom color3f spacetime:background = (0, 0, 0)
    }}
}}
'''


# --------------------------------------------------------------------------- flange


def flange_usda() -> str:
    front = [(0, 0, 2), (2, 0, 2), (2, 4, 2), (0, 4, 2)]
    side = [(0, 0, 0), (0, 0, 2), (0, 4, 2), (0, 4, 0)]
    return HEADER + f'''(
    doc = """The thesis's right-angle flange (Black 2005, section 4.4.1): 4 high, 2 wide, 2 deep,
    two two-sided planes sharing a vertical edge, at rest, in its own (rest) frame.

    Local frame: the pivot (the origin of /Flange) is the bottom of the trailing edge line
    x = 0, z = 0. The front plane spans x 0..2, y 0..4 at z = 2 (facing the camera of
    stage.usda); the side plane spans z 0..2, y 0..4 at x = 0 (the trailing edge of a
    flange moving along +x). The trailing upper corner is (0, 4, 2), the lower (0, 0, 2),
    the far upper corner (0, 4, 0), as in section 4.4.6.

    Scenes reference this prim and add SpacetimeBodyAPI; a Lorentz-coupled flange is
    contracted about the pivot, so its trailing edge keeps its worldline."""
    defaultPrim = "Flange"
    upAxis = "Y"
    metersPerUnit = 1
)

def Xform "Flange"
{{
{mesh_text("Front", front, [(0, 1, 2, 3)], indent=4, color=(0.95, 0.78, 0.2),
           doc="front plane, z = 2, x 0..2 (yellow)")}

{mesh_text("Side", side, [(0, 1, 2, 3)], indent=4, color=(0.25, 0.55, 0.95),
           doc="side plane at the trailing edge, x = 0, z 0..2 (blue)")}
}}
'''


def flange_slow_usda() -> str:
    return HEADER + f'''(
    doc = """Figs. 4.7-4.8 (section 4.4.2, retarded time / animation): the flange moving along +x
    at 0.00866c past the stage, seen with light delay.

    - spacetime:fourVelocity = (2000, 17.32, 0, 0): the thesis's extrusion vector,
      "a dx of 17.32 l.units for an elapsed time dt of 2000 t.units" (Eq. 4.3), v = 0.00866.
      Lorentz coupled (gamma - 1 = 3.7e-5: invisible).
    - Its right edge is at x = 0 (the flange between x = -2 and 0) at lab time 920 =
      video-frame 920, and the lifetime is the thesis's 2000 t.units, t = 0..2000.
    - The camera runs one t.unit per video-frame, "moved ahead 20 frames to allow enough
      time for the light to reach the camera": spacetime:time = frame + 20, so frame 920
      is camera time 940 and frame 1151 is 1171 (the thesis's camera times).

    So frame 920 shows the flange as it was 14.8 t.units before t = 940 (the light
    delay from the middle of its right edge): 5.2 t.units after it reached x = 0, i.e.
    0.045 to the right of the green line, "within 0.05 l.units" as the thesis says; frame
    1151 shows its right edge at x = 2.045. Measured by examples/thesis/flange_speed.py."""
    subLayers = [
        @./stage.usda@
    ]
    defaultPrim = "World"
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = 920
    endTimeCode = 1151
    timeCodesPerSecond = 24
)

over "World"
{{
    over "Camera"
    {{
        # camera time = frame + 20 (linear between the samples, exact for integer frames)
        double spacetime:time.timeSamples = {{
            0: 20,
            4096: 4116,
        }}
    }}

    over "CameraNoDelay"
    {{
        # no light delay: camera time = frame, the flange where it is at that lab time
        double spacetime:time.timeSamples = {{
            0: 0,
            4096: 4096,
        }}
    }}

    def Xform "Flange" (
        prepend references = @./flange.usda@
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {{
        # pivot = trailing edge: x = -2 at t = 920, so the right edge is at x = 0
        double3 xformOp:translate = (-2, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        double4 spacetime:fourVelocity = (2000, 17.32, 0, 0)
        double spacetime:referenceTime = 920
        double2 spacetime:lifetime = (0, 2000)
    }}
}}
'''


def flange_fast_usda(decoupled: bool) -> str:
    if decoupled:
        return HEADER + f'''(
    doc = """Fig. 4.14 (section 4.4.6): the flange at 0.866c, Lorentz DECOUPLED (classical: its
    authored 2-wide shape, no contraction), otherwise identical to
    flange_0866c_coupled.usda (sublayered below): same worldline of the trailing edge, same
    cameras and frames. Frame 0: the trailing upper corner is seen at (0, 4, 2)."""
    subLayers = [
        @./flange_0866c_coupled.usda@
    ]
    defaultPrim = "World"
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = -100
    endTimeCode = 100
    timeCodesPerSecond = 24
)

over "World"
{{
    over "Flange"
    {{
        bool spacetime:lorentzDecoupled = 1
    }}
}}
'''
    t0 = SQRT194
    return HEADER + f'''(
    doc = """Fig. 4.15 (section 4.4.6): the flange moving along +x at 0.866c, Lorentz COUPLED:
    contracted to half its proper width (gamma = 2) about its trailing edge, and Terrell
    rotated. flange_0866c_decoupled.usda (Fig. 4.14) sublayers this file and only
    decouples the flange.

    - "0.866c" is sqrt(3)/2 = 0.8660254 so that gamma = 2 exactly ("at 86.6% of lightspeed
      the Lorentz factor is 2.0"); spacetime:fourVelocity = gamma (1, v) = (2, sqrt 3, 0, 0).
    - The trailing edge (the pivot) crosses x = 0 at lab time 0 (referenceTime 0).
    - /World/Camera (finite light speed, at (0, 9, 15)): camera time = frame / 10 + sqrt(194)
      (10 video-frames per t.unit, as the thesis's animations). sqrt(194) = 13.928 is the
      light delay from the trailing upper corner (0, 4, 2), so frame 0 is the thesis's
      figure: "when the flange's trailing edge is coincident with the X = 0 plane, the
      trailing upper left corner is at (0, 4, 2)". Light from the lower corner (0, 0, 2)
      and from the far upper corner (0, 4, 0) is sqrt(250) = 15.811 old, so they are seen
      about 0.866 x 1.9 = 1.66 l.units behind (the thesis); exactly, with the corner's
      own motion during that delay, 1.711 (examples/thesis/flange_terrell.py).
    - /World/CameraNoDelay (infinite light speed): camera time = frame / 10, so frame 0
      shows the flange with its trailing edge on x = 0 at lab time 0, no light delay.
    The lifetime is unbounded (the renderer clips it to what the frames can see)."""
    subLayers = [
        @./stage.usda@
    ]
    defaultPrim = "World"
    upAxis = "Y"
    metersPerUnit = 1
    startTimeCode = -100
    endTimeCode = 100
    timeCodesPerSecond = 24
)

over "World"
{{
    over "Camera"
    {{
        # camera time = frame / 10 + sqrt(194)
        double spacetime:time.timeSamples = {{
            -4096: {f(-409.6 + t0)},
            4096: {f(409.6 + t0)},
        }}
    }}

    over "CameraNoDelay"
    {{
        # camera time = frame / 10
        double spacetime:time.timeSamples = {{
            -4096: -409.6,
            4096: 409.6,
        }}
    }}

    def Xform "Flange" (
        prepend references = @./flange.usda@
        prepend apiSchemas = ["SpacetimeBodyAPI"]
    )
    {{
        # pivot = trailing edge line x = 0, z = 0 at lab time 0
        double3 xformOp:translate = (0, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        double4 spacetime:fourVelocity = (2, {f(2 * BETA_FAST)}, 0, 0)
        double spacetime:referenceTime = 0
        bool spacetime:lorentzDecoupled = 0
    }}
}}
'''


# --------------------------------------------------------------------------- aberration

ABERRATION_DIRECTIONS = {  # unit velocity of the observer; the observer looks down -z at the star
    "Towards": (0.0, 0.0, -1.0),
    "Away": (0.0, 0.0, 1.0),
    "Left": (-1.0, 0.0, 0.0),
    "Right": (1.0, 0.0, 0.0),
}
ABERRATION_SPEEDS = {"0500": 0.5, "0866": BETA_FAST}
STAR_SIZE = 1.0e5
STAR_DISTANCE = 1.5e5
MARKER_RADIUS = 2500.0


def aberration_observers():
    """[(name, velocity, classical, time)], the rest observer first."""
    obs = [("Rest", (0.0, 0.0, 0.0), False, 0.0)]
    k = 1
    for dname, d in ABERRATION_DIRECTIONS.items():
        for sname, beta in ABERRATION_SPEEDS.items():
            for model in ("Classical", "Relativistic"):
                v = tuple(beta * x + 0.0 for x in d)
                obs.append((f"{dname}_{sname}_{model}", v, model == "Classical", 1000.0 * k))
                k += 1
    return obs


def reticle_mesh():
    """20 x 20 reticle of 1-unit squares at z = -10 (lines 0.12 wide) and the red cross-hairs.

    At 240 pixels over 90 degrees the lines x = k fall exactly on pixel boundaries, so a
    line must be wider than a pixel (0.083 units at the centre) to show in every row."""
    w, W = 0.06, 0.1
    lines, cross = [], []
    for k in range(-10, 11):
        if k == 0:
            continue
        lines.append(([(k - w, -10, -10), (k + w, -10, -10), (k + w, 10, -10), (k - w, 10, -10)], f"x={k}"))
        lines.append(([(-10, k - w, -10), (10, k - w, -10), (10, k + w, -10), (-10, k + w, -10)], f"y={k}"))
    frame = [(-10 - w, -10 - w), (10 + w, -10 - w), (10 + w, 10 + w), (-10 - w, 10 + w)]
    cross.append(([(-W, -10, -10.01), (W, -10, -10.01), (W, 10, -10.01), (-W, 10, -10.01)], "x=0"))
    cross.append(([(-10, -W, -10.01), (10, -W, -10.01), (10, W, -10.01), (-10, W, -10.01)], "y=0"))

    def quads(items):
        pts, faces = [], []
        for p, _ in items:
            faces.append(tuple(range(len(pts), len(pts) + 4)))
            pts.extend(p)
        return pts, faces

    return quads(lines), quads(cross), frame


def aberration_usda() -> str:
    (lp, lf), (cp, cf), _ = reticle_mesh()
    observers = []
    for name, v, classical, t in aberration_observers():
        moving = any(v)
        lines = []
        lines.append(f'        def Xform "{name}"')
        lines.append("        {")
        api = '"SpacetimeCameraAPI", "SpacetimeBodyAPI"' if moving else '"SpacetimeCameraAPI"'
        lines.append('            def Camera "Camera" (')
        lines.append(f"                prepend apiSchemas = [{api}]")
        lines.append("            )")
        lines.append("            {")
        lines.append("                float focalLength = 10.4775")
        lines.append("                float horizontalAperture = 20.955")
        lines.append("                float verticalAperture = 20.955")
        lines.append(f"                double spacetime:time = {f(t)}")
        if moving:
            lines.append(f"                double4 spacetime:fourVelocity = (1, {', '.join(f(x) for x in v)})")
            lines.append(f"                double spacetime:referenceTime = {f(t)}")
            lines.append(f"                bool spacetime:lorentzDecoupled = {1 if classical else 0}")
        lines.append("            }")
        lines.append("")
        lines.append('            def Xform "Reticle" (')
        lines.append("                prepend references = </Reticle>")
        lines.append('                prepend apiSchemas = ["SpacetimeBodyAPI"]')
        lines.append("            )")
        lines.append("            {")
        lines.append(f"                double4 spacetime:fourVelocity = (1, {', '.join(f(x) for x in v)})")
        lines.append(f"                double spacetime:referenceTime = {f(t)}")
        lines.append(f"                double2 spacetime:lifetime = ({f(t - 50)}, {f(t + 50)})")
        if moving:
            lines.append(f"                bool spacetime:lorentzDecoupled = {1 if classical else 0}")
        lines.append("            }")
        lines.append("        }")
        observers.append("\n".join(lines))
    obs_text = "\n\n".join(observers)
    names = ", ".join(n for n, *_ in aberration_observers())
    return HEADER + f'''(
    doc = """Figs. 4.9-4.13 (sections 4.4.3-4.4.4): classical and relativistic aberration of a
    distant "star" seen by an observer moving at 0.5c and 0.866c in the four seasonal
    directions of Fig. 4.9: towards the star, away from it, to the left and to the right.

    - The star: a cube 1e5 on a side whose centre is 1.5e5 from the observer (its near
      face is 1e5 away, so at rest it subtends arctan(0.5e5 / 1e5) = 26.565 degrees each
      side of the view axis and "projects a 10 x 10 silhouette onto the grid" 10 units
      away). At rest in the lab, unbounded lifetime. A red marker sphere (radius 2500)
      on the middle of its near face marks the direction perpendicular to a sideways
      motion: the thesis's 26.565 / 30.0 degree shifts are the shifts of that direction.
    - /World/Observers/<Name>/Camera: looks down -z at the star from the origin, 90 degree
      field of view (the 20 x 20 reticle at 10 units fills it), square. Moving observers
      carry SpacetimeBodyAPI: relativistic (Lorentz boost of the pixel directions) or
      classical (spacetime:lorentzDecoupled = 1: Galilean addition, thesis Eq. 2.1).
      Observers: {names}.
      "0866" is sqrt(3)/2 = 0.8660254 (gamma = 2).
    - /World/Observers/<Name>/Reticle: the 20 x 20 reticle of 1-unit squares with red
      cross-hairs, 10 units in front of its observer and moving with it (at rest in the
      observer's frame, Lorentz coupled or decoupled like it), so it shows the observer's
      own angles: a mark k units from the centre is arctan(k / 10) off the view axis.
    - Each observer has its own camera time (spacetime:time, 1000 apart; any frame
      renders it) and passes the origin at that time; its reticle exists only for 100
      t.units around it, so no camera sees another's reticle. Pick a view with --camera:

        warp-st render usd_scenes/thesis/aberration.usda --camera /World/Observers/Left_0500_Relativistic/Camera

    No light: unlit colours."""
    upAxis = "Y"
    metersPerUnit = 1
    defaultPrim = "World"
    renderSettingsPrimPath = "/Render/Settings"
)

def Xform "World"
{{
    def Cube "Star"
    {{
        double size = {f(STAR_SIZE)}
        double3 xformOp:translate = (0, 0, {f(-STAR_DISTANCE)})
        uniform token[] xformOpOrder = ["xformOp:translate"]
        color3f[] primvars:displayColor = [(1, 0.85, 0.35)]
    }}

    def Sphere "StarCentre" (
        doc = "marks the centre of the star's near face, just in front of it"
    )
    {{
        double radius = {f(MARKER_RADIUS)}
        double3 xformOp:translate = (0, 0, {f(-(STAR_DISTANCE - STAR_SIZE / 2) + MARKER_RADIUS + 100)})
        uniform token[] xformOpOrder = ["xformOp:translate"]
        color3f[] primvars:displayColor = [(0.9, 0.1, 0.05)]
    }}

    def Xform "Observers"
    {{
{obs_text}
    }}
}}

# The reticle, referenced by every observer: lines at x, y = -10..10 (0.12 wide) in the
# plane z = -10 of its observer, and red cross-hairs (0.2 wide) 0.01 in front of them.
class Xform "Reticle"
{{
{mesh_text("Lines", lp, lf, indent=4, color=(0.45, 0.45, 0.5), doc="20 x 20 grid lines, 1 unit apart")}

{mesh_text("CrossHairs", cp, cf, indent=4, color=(0.85, 0.1, 0.1), doc="red cross-hairs x = 0, y = 0")}
}}

def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        uniform int2 resolution = (480, 480)
        rel camera = </World/Observers/Rest/Camera>
        custom token spacetime:precision = "float32"
        custom color3f spacetime:background = (0, 0, 0)
    }}
}}
'''


# --------------------------------------------------------------------------- sphere and cubes

SPHERE_CUBES = {  # name: (centre, colour)
    "CubeUpperLeft": ((-2.5, 2.0, 0.0), (0.2, 0.5, 0.95)),
    "CubeUpperRight": ((2.5, 2.0, 0.0), (0.2, 0.8, 0.3)),
    "CubeLowerLeft": ((-2.5, -2.0, 0.0), (0.95, 0.6, 0.1)),
    "CubeLowerRight": ((2.5, -2.0, 0.0), (0.7, 0.3, 0.85)),
}
NEAR_CAMERA = (0.0, 0.0, 10.0)
FAR_CAMERA = (0.0, 0.0, 200.0)
GORES, LON_PER_GORE, LAT_BANDS = 16, 4, 32


def gore(k):
    """Gore k of a beach-ball sphere of radius 1 (vertical axis): points, quads/tris, normals.

    It spans longitudes [k, k+1] x 2 pi / GORES widened by 0.1 step each side, so that
    neighbouring gores overlap and no ray slips between them."""
    step = 2 * math.pi / (GORES * LON_PER_GORE)
    phis = [k * LON_PER_GORE * step - 0.1 * step]
    phis += [(k * LON_PER_GORE + j) * step for j in range(LON_PER_GORE + 1)]
    phis += [((k + 1) * LON_PER_GORE) * step + 0.1 * step]
    thetas = [math.pi * i / LAT_BANDS for i in range(1, LAT_BANDS)]
    pts = [(0.0, 1.0, 0.0)]
    for th in thetas:
        for ph in phis:
            pts.append((round(math.sin(th) * math.cos(ph), 7), round(math.cos(th), 7), round(math.sin(th) * math.sin(ph), 7)))
    pts.append((0.0, -1.0, 0.0))
    n = len(phis)
    faces = []
    for j in range(n - 1):
        faces.append((0, 1 + j + 1, 1 + j))
    for i in range(len(thetas) - 1):
        for j in range(n - 1):
            a, b = 1 + i * n + j, 1 + i * n + j + 1
            c, d = a + n, b + n
            faces.append((a, b, d, c))
    last = 1 + (len(thetas) - 1) * n
    for j in range(n - 1):
        faces.append((last + j, last + j + 1, len(pts) - 1))
    return pts, faces, pts


def beach_ball_usda() -> str:
    gores = []
    for k in range(GORES):
        pts, faces, nrm = gore(k)
        color = (0.92, 0.92, 0.9) if k % 2 == 0 else (0.85, 0.12, 0.1)
        if k == GORES // 4:  # the gore facing +z (the cameras) is blue
            color = (0.15, 0.3, 0.9)
        gores.append(mesh_text(f"Gore{k:02d}", pts, faces, indent=4, color=color))
    gore_text = "\n\n".join(gores)
    return HEADER + f'''(
    doc = """A beach ball: a sphere of radius 1 about the origin (vertical axis) made of {GORES}
    gores of alternating colour, {LON_PER_GORE} longitude steps each ({GORES * LON_PER_GORE} longitudes, as the
    renderer's own spheres) x {LAT_BANDS} latitude bands; the gore facing +z is blue. Each gore is
    widened by a tenth of a step on both sides so that neighbours overlap and no ray can
    slip between them. Flat shaded (no normals). Generated by
    examples/thesis/build_scenes.py; referenced by sphere_and_cubes.usda."""
    defaultPrim = "BeachBall"
    upAxis = "Y"
    metersPerUnit = 1
)

def Xform "BeachBall"
{{
{gore_text}
}}
'''


CUBE_FACES = {  # name: (outward normal, colour)
    "Front": ((0, 0, 1), (0.95, 0.8, 0.2)),
    "Back": ((0, 0, -1), (0.2, 0.8, 0.8)),
    "Trailing": ((-1, 0, 0), (0.85, 0.15, 0.1)),
    "Leading": ((1, 0, 0), (0.2, 0.75, 0.25)),
    "Top": ((0, 1, 0), (0.9, 0.9, 0.9)),
    "Bottom": ((0, -1, 0), (0.35, 0.35, 0.4)),
}


def colour_cube_usda() -> str:
    faces = []
    for name, (nrm, col) in CUBE_FACES.items():
        axis = [i for i in range(3) if nrm[i]][0]
        u, w = [i for i in range(3) if i != axis]
        pts = []
        for a, b in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)):
            p = [0.0, 0.0, 0.0]
            p[axis], p[u], p[w] = 0.5 * nrm[axis], a, b
            pts.append(tuple(p))
        faces.append(mesh_text(name, pts, [(0, 1, 2, 3)], indent=4, color=col,
                               doc=f"normal {vec(nrm)}"))
    face_text = "\n\n".join(faces)
    return HEADER + f'''(
    doc = """A unit cube centred on the origin whose six faces are separate Mesh prims of six
    colours, so that an unlit render shows which faces are in view: front (+z, towards
    the cameras) yellow, back (-z) cyan, trailing (-x) red, leading (+x) green, top (+y)
    white, bottom (-y) grey. Referenced by sphere_and_cubes.usda."""
    defaultPrim = "ColourCube"
    upAxis = "Y"
    metersPerUnit = 1
)

def Xform "ColourCube"
{{
{face_text}
}}
'''


def sphere_cubes_usda() -> str:
    cubes = []
    for name, (c, col) in SPHERE_CUBES.items():
        cubes.append(f'''        def Xform "{name}" (
            prepend references = @./colour_cube.usda@
            prepend apiSchemas = ["SpacetimeBodyAPI"]
        )
        {{
            double3 xformOp:translate = {vec(c)}
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }}''')
    cube_text = "\n\n".join(cubes)
    return HEADER + f'''(
    doc = """Fig. 2.1 (section 2.2.1): a sphere and four cubes at rest, the reference for Fig. 2.2
    (sphere_and_cubes_moving.usda sublayers this file and sets them moving).

    - /World/Bodies/Sphere: radius 1 at the origin, a beach ball of {GORES} gores
      (beach_ball.usda; vertical axis, the gore facing the camera is blue) so that its
      apparent rotation shows.
    - Four unit cubes at (+-2.5, +-2, 0) with six coloured faces (colour_cube.usda; the
      front, facing the cameras, yellow; the trailing -x face red).
    - /World/Camera: (0, 0, 10) looking down -z, 50 degree field of view.
    - /World/Telescope: (0, 0, 200), 3 degree field of view: the same bodies seen almost
      orthographically, where the Penrose-Terrell rotation is a rotation (used to measure it).
    Each body carries SpacetimeBodyAPI (here at rest; reference times are set by the
    moving scene). No light: unlit colours, so every face in view shows (a lit scene would
    leave the trailing faces of the moving bodies dark: light from the left cannot catch
    a face running away from it at 0.866c)."""
    upAxis = "Y"
    metersPerUnit = 1
    defaultPrim = "World"
    renderSettingsPrimPath = "/Render/Settings"
)

def Xform "World"
{{
    def Camera "Camera" (
        prepend apiSchemas = ["SpacetimeCameraAPI"]
    )
    {{
        double3 xformOp:translate = {vec(NEAR_CAMERA)}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        float focalLength = {f(round(0.5 * 20.955 / math.tan(math.radians(25)), 6))}
        float horizontalAperture = 20.955
        float verticalAperture = 11.787188
        token spacetime:lightSpeed = "finite"
    }}

    def Camera "Telescope" (
        prepend apiSchemas = ["SpacetimeCameraAPI"]
    )
    {{
        double3 xformOp:translate = {vec(FAR_CAMERA)}
        uniform token[] xformOpOrder = ["xformOp:translate"]
        float focalLength = {f(round(0.5 * 20.955 / math.tan(math.radians(1.5)), 6))}
        float horizontalAperture = 20.955
        float verticalAperture = 11.787188
        token spacetime:lightSpeed = "finite"
    }}

    def Xform "Bodies"
    {{
        def Xform "Sphere" (
            prepend references = @./beach_ball.usda@
            prepend apiSchemas = ["SpacetimeBodyAPI"]
        )
        {{
            double3 xformOp:translate = (0, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }}

{cube_text}
    }}
}}

def Scope "Render"
{{
    def RenderSettings "Settings"
    {{
        uniform int2 resolution = (640, 360)
        rel camera = </World/Camera>
        custom token spacetime:precision = "float32"
        custom color3f spacetime:background = (0.02, 0.02, 0.03)
    }}
}}
'''


def sphere_cubes_moving_usda() -> str:
    overs = []
    d_sphere = math.dist(NEAR_CAMERA, (0, 0, 0))
    for name, (c, _) in [("Sphere", ((0.0, 0.0, 0.0), None))] + list(SPHERE_CUBES.items()):
        t_ref = 10.0 - math.dist(NEAR_CAMERA, c)
        overs.append(f'''        over "{name}"
        {{
            # seen at its authored place from the camera at t = 10: 10 - |camera - centre|
            double4 spacetime:fourVelocity = (2, {f(2 * BETA_FAST)}, 0, 0)
            double spacetime:referenceTime = {f(round(t_ref, 9))}
        }}''')
    over_text = "\n\n".join(overs)
    return HEADER + f'''(
    doc = """Fig. 2.2 (section 2.2.1): the sphere and four cubes of sphere_and_cubes.usda moving
    left to right past the camera at 0.866c (sqrt(3)/2, gamma = 2), Lorentz coupled.

    Each body's referenceTime puts the centre where it is drawn at the moment its light
    reaches the camera at camera time 10 (frame 0): t_ref = 10 - |camera - centre|.
    Camera time = frame / 10 + 10 for /World/Camera; the telescope at (0, 0, 200) uses
    frame / 10 + 200, so its frame 0 sees the sphere's centre at the origin too; the
    cubes' light reaching it is 0.47 t.units younger than the near camera's, so the
    telescope sees them 0.41 units further right than drawn.

    Expected: the sphere's outline stays a circle (Penrose, Terrell, Boas); the gores and
    the cubes appear rotated about the vertical by arcsin(0.866) = 60 degrees, the cubes'
    trailing (-x) faces in view (measured by examples/thesis/sphere_and_cubes.py)."""
    subLayers = [
        @./sphere_and_cubes.usda@
    ]
    upAxis = "Y"
    metersPerUnit = 1
    defaultPrim = "World"
    startTimeCode = -100
    endTimeCode = 100
    timeCodesPerSecond = 24
)

over "World"
{{
    over "Camera"
    {{
        double spacetime:time.timeSamples = {{
            -4096: -399.6,
            4096: 419.6,
        }}
    }}

    over "Telescope"
    {{
        double spacetime:time.timeSamples = {{
            -4096: -209.6,
            4096: 609.6,
        }}
    }}

    over "Bodies"
    {{
{over_text}
    }}
}}
'''


FILES = {
    "stage.usda": stage_usda,
    "flange.usda": flange_usda,
    "flange_slow.usda": flange_slow_usda,
    "flange_0866c_coupled.usda": lambda: flange_fast_usda(False),
    "flange_0866c_decoupled.usda": lambda: flange_fast_usda(True),
    "aberration.usda": aberration_usda,
    "beach_ball.usda": beach_ball_usda,
    "colour_cube.usda": colour_cube_usda,
    "sphere_and_cubes.usda": sphere_cubes_usda,
    "sphere_and_cubes_moving.usda": sphere_cubes_moving_usda,
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    bad = 0
    for name, make in FILES.items():
        text = make()
        path = args.out / name
        if args.check:
            if not path.exists() or path.read_text() != text:
                print(f"differs: {path}")
                bad += 1
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
            print(f"wrote {path} ({len(text.splitlines())} lines)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
