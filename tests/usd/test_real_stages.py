"""Real-world USD stages render as a pipeline renderer renders them (issue 16).

Laws:
- every stage of the corpus (``corpus.py``, one per class) renders: exit 0, an EXR, and
  with no camera authored something visible at the image centre through the default
  camera; ``render`` prints exactly the corpus's warning lines and ``validate`` lists
  exactly the same ones (one list), the default camera as information;
- the default camera frames the stage's bounds as usdrecord's free camera does (USD's
  own BBoxCache is the oracle for the bounds, a pinhole projection written here for the
  framing), for upAxis Y and Z and a flat floor;
- the analytic gprims' triangles have USD's own extents (``ComputeExtentFromPlugins``),
  are closed and lie on the shapes;
- faceVarying and uniform normals and hole faces are honoured; time-sampled geometry is
  read at the stage's start time code (USD's value there is the oracle);
- a stage with nothing to render exits 2 (one line, nothing written); ``--camera`` still
  picks an authored camera.
"""
from __future__ import annotations

import collections
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from pxr import Usd, UsdGeom

import warp_st
from corpus import CORPUS, HEADER, QUAD, Stage
from warp_st.commands.cli import main
from warp_st.core import tessellate

SIZE = ("--width", "48", "--height", "32")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def location(path, prim, attribute) -> str:
    where = str(path)
    if prim:
        where += f":{prim}" + (f".{attribute}" if attribute else "")
    elif attribute:
        where += f":{attribute}"
    return where


def render_line(path, prim, attribute, message) -> str:
    return "warp-st: warning: " + ": ".join(p for p in (str(path), prim, attribute, message) if p)


def load_quietly(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return warp_st.load(str(path))


# --- the corpus -----------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_corpus_stage_renders_with_exactly_its_warnings(tmp_path, capsys, name):
    stage: Stage = CORPUS[name]()
    path = stage.write(tmp_path)
    out = tmp_path / "out.exr"
    code, _, err = run(capsys, "render", path, "-o", out, *SIZE, "--quiet")
    assert code == 0, err
    expected = sorted(render_line(path, *w) for w in stage.warnings)
    assert sorted(err.splitlines()) == expected  # exactly these lines, each once
    image = warp_st.read_exr(out)
    assert image.metadata["metersPerUnit"] == "0.01" and image.metadata["timeCodesPerSecond"] == "24.0"
    if stage.default_camera:
        assert image.metadata["camera"] == "default"
        assert image.rgba[16, 24, 3] > 0.0, "nothing visible at the image centre"
    else:
        assert image.metadata["camera"] == "/Cam"

    code, vout, verr = run(capsys, "validate", path)
    assert code == 0 and verr == "", verr
    lines = vout.splitlines()
    listed = sorted(ln for ln in lines if ln.startswith("WARNING "))
    assert listed == sorted(f"WARNING {location(path, *w[:2])}: {w[2]}" for w in stage.warnings)
    animated = [ln for ln in lines if ln.startswith("INFO ") and (": animated: " in ln or ": deforming: " in ln)]
    assert len(animated) == (name == "animated")  # the turntable's Cloth (docs/spec.md §2.1, §2.2)
    # docs/spec.md §1.1: a stage without our schemas has the physical speed of light (USD's
    # fallback units, asserted above: 299792458 m/s / 0.01 m / 24 time codes per second)
    speed = [ln for ln in lines if ln.startswith(f"INFO {path}: light speed ")]
    uses_schema = "SpacetimeBodyAPI" in path.read_text()
    assert speed == ([] if uses_schema else [
        f"INFO {path}: light speed 1.24913524e+09 stage units per time code: the physical speed of light, "
        "299792458 m/s at metersPerUnit 0.01 and 24 time codes per second"])
    info = [ln for ln in lines if ln.startswith("INFO ") and ln not in animated and ln not in speed]
    if stage.default_camera:
        assert len(info) == 1 and info[0].startswith(f"INFO {path}: the stage has no camera (UsdGeom.Camera): it "
                                                     "renders through the default camera, at rest at (")
    else:
        assert info == []
    assert len(listed) + len(info) + len(animated) + len(speed) + 1 == len(lines)  # and the summary line


def test_nothing_to_render(tmp_path, capsys):
    """No camera and no geometry: render exits 2 with one line and writes nothing; validate
    warns (as a layer to reference, such a stage is fine)."""
    path = tmp_path / "lamps.usda"
    path.write_text(HEADER.format(up="Y") + 'def SphereLight "Lamp"\n{\n}\n')
    code, _, err = run(capsys, "render", path, "-o", tmp_path / "x.exr", *SIZE, "--quiet")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"warp-st: error: {path}: nothing to render"), err
    assert not list(tmp_path.glob("*.exr"))
    code, out, _ = run(capsys, "validate", path)
    assert code == 0 and [ln for ln in out.splitlines() if ln.startswith("WARNING")] == [
        f"WARNING {path}: the stage has no camera and no supported visible geometry: there is nothing to render "
        "(as a layer to reference it is fine)"]


def test_camera_option_picks_an_authored_camera(tmp_path, capsys):
    path = tmp_path / "two.usda"
    cameras = "".join(f'def Camera "{n}"\n{{\n    double3 xformOp:translate = (0, 0, {z})\n'
                      f'    uniform token[] xformOpOrder = ["xformOp:translate"]\n}}\n' for n, z in (("A", 9), ("B", 12)))
    path.write_text(HEADER.format(up="Y") + cameras + f'def Mesh "Card"\n{{\n    {QUAD}\n}}\n')
    for extra, want in (((), "/A"), (("--camera", "/B"), "/B")):
        out = tmp_path / f"{want[1:]}.exr"
        assert run(capsys, "render", path, "-o", out, *SIZE, "--quiet", *extra)[0] == 0
        assert warp_st.read_exr(out).metadata["camera"] == want
    nocam = tmp_path / "nocam.usda"
    nocam.write_text(HEADER.format(up="Y") + f'def Mesh "Card"\n{{\n    {QUAD}\n}}\n')
    code, _, err = run(capsys, "render", nocam, "-o", tmp_path / "n.exr", "--camera", "/A", "--quiet")
    assert code == 2 and "/A: no such camera (cameras: none)" in err


# --- the default camera ----------------------------------------------------------------------

#: usdrecord's free camera: a default GfCamera (50 mm, 15.2908 mm vertical aperture).
VERTICAL_FOV = 2.0 * math.atan(15.2908 / 2.0 / 50.0)


def usd_bounds(path):
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.BBoxCache(Usd.TimeCode(stage.GetStartTimeCode()), [UsdGeom.Tokens.default_,
                                                                        UsdGeom.Tokens.render])
    box = cache.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
    return np.array(box.GetMin()), np.array(box.GetMax())


def ndc(cam, points, width=640, height=360):
    """Pinhole projection (docs/spec.md §3): the vertical aperture conformed to the image."""
    local = (np.asarray(points) - cam.position) @ cam.rotation  # camera frame (columns: its axes)
    assert (local[:, 2] < 0).all(), "a corner behind the camera"
    x = cam.focal_length * local[:, 0] / -local[:, 2] / (0.5 * cam.horizontal_aperture)
    y = cam.focal_length * local[:, 1] / -local[:, 2] / (0.5 * cam.horizontal_aperture * height / width)
    return x, y


FLOOR = 'def Plane "Floor"\n{\n    double width = 6\n    double length = 3\n    token axis = "Y"\n}\n'
#: A box on a ground plane, 0.5 / 100 as high as wide (under the 1 % of a flat stage), and
#: a train 4 / 100 as high as long (over it).
GROUND = FLOOR.replace("6", "100").replace("3", "100") + 'def Cube "Box"\n{\n    double size = 0.5\n}\n'
TRAIN = 'def Cube "Train"\n{\n    float3 xformOp:scale = (50, 2, 1)\n    uniform token[] xformOpOrder = ["xformOp:scale"]\n}\n'


@pytest.mark.parametrize("name, view", [("chess_piece", (0, 0, -1)), ("vehicle_z_up", (0, 1, 0)),
                                        ("floor", (0, -1, 0)), ("ground", (0, -1, 0)), ("train", (0, 0, -1))])
def test_default_camera_frames_the_bounds(tmp_path, name, view):
    """At rest, at the rendered time code, looking at the bounds' centre along -Z (Y up),
    +Y (Z up) or down on flat bounds (under 1 % as high as wide); every corner of USD's
    bounds inside the image, the front face touching its edge (tolerance: float32
    extents); usdrecord's vertical field of view at the default 16:9 resolution."""
    if name in ("floor", "ground", "train"):
        path = tmp_path / f"{name}.usda"
        path.write_text(HEADER.format(up="Y") + {"floor": FLOOR, "ground": GROUND, "train": TRAIN}[name])
    else:
        path = CORPUS[name]().write(tmp_path)
    lo, hi = usd_bounds(path)
    scene = load_quietly(path)
    cam = scene.camera_state(None, 7.5)
    assert cam.prim_path == "default" and cam.time == 7.5 * scene.light_speed and not np.asarray(cam.velocity).any()
    np.testing.assert_allclose(-cam.rotation[:, 2], view, atol=1e-12)
    to_centre = 0.5 * (lo + hi) - cam.position
    np.testing.assert_allclose(to_centre / np.linalg.norm(to_centre), view, atol=1e-6)
    v_ap = cam.horizontal_aperture * 360 / 640
    assert math.isclose(2.0 * math.atan(0.5 * v_ap / cam.focal_length), VERTICAL_FOV, rel_tol=1e-12)
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)])
    x, y = ndc(cam, corners)
    reach = np.maximum(np.abs(x), np.abs(y))
    assert reach.max() <= 1.0 + 1e-6 and reach.max() >= 1.0 - 1e-6, reach


#: A triangle off its pivot, half-turning about Z between time codes 1 and 13 (glTF's
#: AnimatedTriangle): at time code 13 it lies on the far side of the pivot.
TURNING = '''def Xform "Spin"
{
    float xformOp:rotateZ.timeSamples = { 1: 0, 13: 180, 24: 330 }
    uniform token[] xformOpOrder = ["xformOp:rotateZ"]
    def Mesh "Tri"
    {
        point3f[] points = [(1, 0, 0), (3, 0, 0), (3, 2, 0)]
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
    }
}
'''


def test_default_camera_frames_an_animated_stage_at_every_time_code(tmp_path):
    """A stage whose only body turns about a pivot off it: the default camera (at rest, one
    for the whole range) holds USD's bounds at every time code of the range in the image
    (BBoxCache per time code is the oracle; tolerance: the float32 points). Framing only the
    pivot's path, as 0.7.0 did, leaves the triangle out of the image at time code 13."""
    path = tmp_path / "turning.usda"
    path.write_text(HEADER.format(up="Y") + TURNING)
    scene = load_quietly(path)
    stage = Usd.Stage.Open(str(path))
    for code in range(1, 25):
        cam = scene.camera_state(None, float(code))
        cache = UsdGeom.BBoxCache(Usd.TimeCode(code), [UsdGeom.Tokens.default_])
        box = cache.ComputeWorldBound(stage.GetPseudoRoot()).ComputeAlignedRange()
        lo, hi = np.array(box.GetMin()), np.array(box.GetMax())
        corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)])
        x, y = ndc(cam, corners)
        assert np.maximum(np.abs(x), np.abs(y)).max() <= 1.0 + 1e-6, code


# --- geometry --------------------------------------------------------------------------------


def edges_closed(points, triangles) -> bool:
    key = [tuple(np.round(p, 9)) for p in points]
    count = collections.Counter(frozenset((key[a], key[b])) for t in triangles for a, b in ((t[0], t[1]),
                                                                                            (t[1], t[2]), (t[2], t[0])))
    return set(count.values()) == {2}


def test_shapes_have_usd_extents_and_are_closed(tmp_path):
    """Each analytic gprim of the corpus (every axis, two radii where the schema has them):
    the triangles' bounds are USD's world bounds of the prim (tolerance: USD's float32
    extents); all but the plane are closed (every edge shared by two triangles)."""
    path = CORPUS["shapes"]().write(tmp_path)
    stage = Usd.Stage.Open(str(path))
    cache = UsdGeom.BBoxCache(Usd.TimeCode(1), [UsdGeom.Tokens.default_])
    scene = load_quietly(path)
    assert len(scene.bodies) == 18
    for body in scene.bodies:
        (surface,) = body.surfaces
        box = cache.ComputeWorldBound(stage.GetPrimAtPath(body.prim_path)).ComputeAlignedRange()
        np.testing.assert_allclose(surface.points.min(axis=0), box.GetMin(), atol=1e-6, err_msg=body.prim_path)
        np.testing.assert_allclose(surface.points.max(axis=0), box.GetMax(), atol=1e-6, err_msg=body.prim_path)
        if "Plane" not in body.prim_path:
            assert edges_closed(surface.points, surface.triangles), body.prim_path


@pytest.mark.parametrize("bottom, top, height", [(1.0, 1.0, 2.0), (0.7, 0.0, 2.0), (0.5, 0.25, 3.0)])
def test_cylinders_and_cones_lie_on_their_surfaces(bottom, top, height):
    """Side vertices (normals off the axis) at the radius linear in z, cap vertices (normals
    along the axis) on their end's disk; closed; every normal of unit length; every
    triangle facing outward."""
    points, triangles, normals = tessellate.cylinder(bottom, top, height, "Z")
    r, z = np.hypot(points[:, 0], points[:, 1]), points[:, 2]
    side = np.abs(normals[:, 2]) < 1.0 - 1e-12
    np.testing.assert_allclose(r[side], bottom + (top - bottom) * (z[side] + 0.5 * height) / height, atol=1e-12)
    np.testing.assert_allclose(z[~side], 0.5 * height * normals[~side, 2], atol=1e-12)
    assert (r[~side] <= np.where(normals[~side, 2] > 0, top, bottom) + 1e-12).all()
    assert edges_closed(points, triangles)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    face = np.cross(points[triangles[:, 1]] - points[triangles[:, 0]], points[triangles[:, 2]] - points[triangles[:, 0]])
    assert (np.einsum("ij,ij->i", face, points[triangles].mean(axis=1)) > 0).all()  # convex about the origin


def test_capsule_lies_at_its_radius_from_the_spine():
    """Every vertex at the radius from the spine segment, its normal pointing away from the
    segment's nearest point; closed."""
    points, triangles, normals = tessellate.capsule(0.5, 0.5, 1.0, "X")
    nearest = np.zeros_like(points)
    nearest[:, 0] = np.clip(points[:, 0], -0.5, 0.5)
    np.testing.assert_allclose(np.linalg.norm(points - nearest, axis=1), 0.5, atol=1e-12)
    np.testing.assert_allclose(normals, (points - nearest) / 0.5, atol=1e-12)
    assert edges_closed(points, triangles)


def mesh_stage(tmp_path, normals: str, extra: str = "", name: str = "mesh") -> Path:
    path = tmp_path / f"{name}.usda"
    path.write_text(HEADER.format(up="Y") + f'''def Mesh "Two"
{{
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)]
    int[] faceVertexCounts = [4, 4]
    int[] faceVertexIndices = [0, 1, 2, 3, 1, 4, 5, 2]
    {normals}
    {extra}
}}
''')
    return path


def test_face_varying_and_uniform_normals_are_honoured(tmp_path):
    """One vertex per face corner, each with its authored normal (USD's flattened primvar
    is the oracle, indexed or not); uniform normals give each face's corners its normal."""
    corner = [(0, 0, 1), (0, 0.6, 0.8), (0, 0.8, 0.6), (0, 1, 0), (0.6, 0, 0.8), (0.8, 0, 0.6), (1, 0, 0), (0, 0, 1)]
    text = ", ".join(map(str, corner))
    for i, primvar in enumerate((f"normal3f[] primvars:normals = [{text}] (interpolation = \"faceVarying\")",
                                 f"normal3f[] primvars:normals = [{text}] (interpolation = \"faceVarying\")\n"
                                 "    int[] primvars:normals:indices = [7, 6, 5, 4, 3, 2, 1, 0]")):
        path = mesh_stage(tmp_path, primvar, name=f"corners{i}")
        stage = Usd.Stage.Open(str(path))
        flat = np.array(UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/Two")).GetPrimvar("normals").ComputeFlattened(),
                        dtype=np.float64)
        surface = load_quietly(path).bodies[0].surfaces[0]
        indices = [0, 1, 2, 3, 1, 4, 5, 2]
        np.testing.assert_allclose(surface.points, np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),
                                                             (2, 0, 0), (2, 1, 0)])[indices])
        np.testing.assert_allclose(surface.normals, flat / np.linalg.norm(flat, axis=1, keepdims=True), atol=1e-7)
    path = mesh_stage(tmp_path, 'normal3f[] normals = [(0, 0, 1), (1, 0, 0)] (interpolation = "uniform")',
                      name="uniform")
    surface = load_quietly(path).bodies[0].surfaces[0]
    face_of_corner = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    np.testing.assert_allclose(surface.normals, np.array([(0, 0, 1), (1, 0, 0)])[face_of_corner])
    assert len(surface.triangles) == 4


def test_hole_faces_are_not_drawn(tmp_path):
    path = mesh_stage(tmp_path, "", "int[] holeIndices = [1]")
    surface = load_quietly(path).bodies[0].surfaces[0]
    assert sorted(map(sorted, surface.triangles.tolist())) == [[0, 1, 2], [0, 2, 3]]


@pytest.mark.parametrize("start", [1, 12])
def test_time_sampled_geometry_is_read_at_the_start_time_code(tmp_path, start):
    """The deforming, turning cloth of the corpus: its triangles are USD's points at the
    start time code through USD's transform there (held and interpolated samples alike)."""
    path = CORPUS["animated"]().write(tmp_path)
    path.write_text(path.read_text().replace("startTimeCode = 1", f"startTimeCode = {start}"))
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/Turntable/Cloth")
    time = Usd.TimeCode(start)
    matrix = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim))
    local = np.array(prim.GetAttribute("points").Get(time), dtype=np.float64)
    want = local @ matrix[:3, :3] + matrix[3, :3]
    bodies = {b.prim_path: b for b in load_quietly(path).bodies}
    np.testing.assert_allclose(bodies["/Turntable/Cloth"].surfaces[0].points, want, atol=1e-6)
    assert start == 1 or not np.allclose(want, local)  # at 12 the samples matter: turned and moved up
    assert math.isclose(bodies["/Pulse"].surfaces[0].sphere[0], stage.GetPrimAtPath("/Pulse").GetAttribute(
        "radius").Get(time))


def test_default_camera_header_and_inspect(tmp_path, capsys):
    """``inspect`` shows that the default camera was used, and the stage's units."""
    path = CORPUS["chess_piece"]().write(tmp_path)
    out = tmp_path / "pawn.exr"
    assert run(capsys, "render", path, "-o", out, *SIZE, "--quiet")[0] == 0
    code, text, _ = run(capsys, "inspect", out)
    assert code == 0
    for line in ("  spacetime:camera: default", "  spacetime:metersPerUnit: 0.01", "  spacetime:timeCodesPerSecond: 24.0"):
        assert line in text.splitlines()


LISTING = """
import sys, warnings
import warp_st
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    warp_st.load(sys.argv[1])
print("|".join(str(w.message).split(": ", 1)[1] for w in caught))
"""


def test_time_samples_under_zero_time_codes_per_second(tmp_path):
    """timeCodesPerSecond = 0 over a sublayer with time samples (a conformance stage): USD
    cannot list the samples there (it loops), so the warning names them without counting;
    the stage loads (in a child process, ended after 120 s if it does not)."""
    import subprocess
    import sys

    (tmp_path / "anim.usda").write_text('#usda 1.0\ndef Xform "X"\n{\n    double3 xformOp:translate.timeSamples = '
                                        '{ 0: (0, 0, 0), 10: (1, 0, 0) }\n    uniform token[] xformOpOrder = '
                                        '["xformOp:translate"]\n    def Cube "C"\n    {\n    }\n}\n')
    path = tmp_path / "zero.usda"
    path.write_text('#usda 1.0\n(\n    timeCodesPerSecond = 0\n    subLayers = [@./anim.usda@]\n)\n')
    proc = subprocess.run([sys.executable, "-c", LISTING, str(path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == ("timeCodesPerSecond: is 0, not positive: the light speed takes USD's fallback, "
                                   "24|/X: xformOp:translate: has time samples; USD animation is not rendered yet: "
                                   "every frame uses its value at time code 0")


def test_default_camera_survives_pickling(tmp_path):
    """Farm workers get the scene pickled: the default camera evaluates the same there."""
    import pickle

    scene = load_quietly(CORPUS["vehicle_z_up"]().write(tmp_path))
    here, there = scene.camera_state(None, 3.0), pickle.loads(pickle.dumps(scene.camera_state))(None, 3.0)
    for name in ("position", "rotation", "focal_length", "horizontal_aperture", "time"):
        np.testing.assert_array_equal(getattr(there, name), getattr(here, name))
