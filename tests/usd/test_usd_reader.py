"""The USD reader: stage → Scene (docs/spec.md §2 and §3).

Each test names the law it checks. Geometry is compared with hand-computed values
at 1e-9 (float64 arithmetic on exactly representable inputs; rotations by 90
degrees round to ~1e-16); authored float32 points are exact small integers.
"""
from __future__ import annotations

import json
import math
import os
import pickle
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom  # noqa: E402  (after warp_st: the schemas register first)

import warp_st
from warp_st import SceneError
from warp_st.core.conventions import LightSpeed, Precision
from warp_st.usd.reader import load_scene

TOL = 1e-9
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write(tmp_path, body: str, name: str = "scene.usda", header: str = "") -> str:
    path = tmp_path / name
    path.write_text("#usda 1.0\n" + (f"(\n{header}\n)\n" if header else "") + textwrap.dedent(body))
    return str(path)


def load(tmp_path, body: str, **kwargs):
    return load_scene(write(tmp_path, body, header=kwargs.pop("header", "")), **kwargs)


def by_path(scene):
    return {b.prim_path: b for b in scene.bodies}


def run_python(code: str) -> str:
    """Run ``code`` in a fresh interpreter (without this process's PXR_PLUGINPATH_NAME); last stdout line."""
    env = {k: v for k, v in os.environ.items() if k != "PXR_PLUGINPATH_NAME"}
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()[-1]


def assert_error(excinfo, *parts):
    """A SceneError is one line and names every part (file, prim, attribute)."""
    message = str(excinfo.value)
    assert "\n" not in message, message
    for part in parts:
        assert part in message, f"{part!r} not in {message!r}"


QUAD = """
    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
"""


# -- schema registration ------------------------------------------------------------------
def test_schemas_registered_after_import():
    """Law: `import warp_st` before pxr registers both codeless API schemas with the SPEC fallbacks."""
    code = textwrap.dedent(
        """
        import json, warp_st
        from pxr import Usd
        r = Usd.SchemaRegistry()
        body = r.FindAppliedAPIPrimDefinition("SpacetimeBodyAPI")
        cam = r.FindAppliedAPIPrimDefinition("SpacetimeCameraAPI")
        print(json.dumps({
            "body": sorted(body.GetPropertyNames()),
            "camera": sorted(cam.GetPropertyNames()),
            "fourVelocity": list(body.GetAttributeFallbackValue("spacetime:fourVelocity")),
            "lifetime": [str(x) for x in body.GetAttributeFallbackValue("spacetime:lifetime")],
            "referenceTime": body.GetAttributeFallbackValue("spacetime:referenceTime"),
            "decoupled": body.GetAttributeFallbackValue("spacetime:lorentzDecoupled"),
            "lightSpeed": cam.GetAttributeFallbackValue("spacetime:lightSpeed"),
            "allowed": list(cam.GetPropertyDefinition("spacetime:lightSpeed").GetMetadata("allowedTokens")),
            "time": cam.GetAttributeFallbackValue("spacetime:time"),
            "kinds": [str(Usd.SchemaRegistry.GetSchemaKind(r.GetTypeFromSchemaTypeName(n)))
                      for n in ("SpacetimeBodyAPI", "SpacetimeCameraAPI")],
        }))
        """
    )
    info = json.loads(run_python(code))
    assert info["body"] == ["spacetime:animationFrame", "spacetime:fourVelocity", "spacetime:lifetime",
                            "spacetime:lorentzDecoupled", "spacetime:referenceTime"]
    assert info["camera"] == ["spacetime:lightSpeed", "spacetime:time"]
    assert info["fourVelocity"] == [1, 0, 0, 0]
    assert info["lifetime"] == ["-inf", "inf"]
    assert info["referenceTime"] == 0 and info["decoupled"] is False
    assert info["lightSpeed"] == "finite" and info["allowed"] == ["finite", "infinite"]
    assert info["time"] is None  # no fallback: unauthored means t_c = time code
    assert all(k.endswith("SingleApplyAPI") for k in info["kinds"]), info["kinds"]


# -- bodies ------------------------------------------------------------------------------
PLAIN_BODY = """
def Xform "Car" (
    prepend apiSchemas = ["SpacetimeBodyAPI"]
)
{
    double3 xformOp:translate = (1, 2, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    custom double4 spacetime:fourVelocity = (2, 1, 0.5, 0)
    custom double2 spacetime:lifetime = (-4, 7)
    custom double spacetime:referenceTime = 3
    custom bool spacetime:lorentzDecoupled = true
    def Mesh "m"
    {
        %s
    }
}
""" % QUAD


def _body_summary(scene):
    return [
        dict(path=b.prim_path, origin=b.origin.tolist(), v=b.velocity.tolist(), tref=b.reference_time,
             life=list(b.lifetime), dec=b.decoupled, points=[s.points.tolist() for s in b.surfaces])
        for b in scene.bodies
    ]


def test_plain_custom_attributes_read_like_the_applied_schema(tmp_path):
    """Law (docs/spec.md §2): plain `custom` attributes + apiSchemas metadata read the same as the
    schema applied through the API -- and the same again in a process where the plugin
    never registered (pxr's schema registry built before `import warp_st`)."""
    path = write(tmp_path, PLAIN_BODY)
    plain = _body_summary(load_scene(path))

    stage = Usd.Stage.CreateInMemory()
    car = UsdGeom.Xform.Define(stage, "/Car")
    car.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    prim = car.GetPrim()
    prim.ApplyAPI("SpacetimeBodyAPI")
    assert prim.HasAPI("SpacetimeBodyAPI")
    prim.GetAttribute("spacetime:fourVelocity").Set(Gf.Vec4d(2, 1, 0.5, 0))
    prim.GetAttribute("spacetime:lifetime").Set(Gf.Vec2d(-4, 7))
    prim.GetAttribute("spacetime:referenceTime").Set(3.0)
    prim.GetAttribute("spacetime:lorentzDecoupled").Set(True)
    mesh = UsdGeom.Mesh.Define(stage, "/Car/m")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    applied = _body_summary(load_scene(stage))
    assert plain == applied
    assert plain[0]["v"] == [0.5, 0.25, 0.0] and plain[0]["origin"] == [1, 2, 3]

    code = textwrap.dedent(
        f"""
        import json
        from pxr import Usd
        Usd.SchemaRegistry()  # built now: the warp_st plugin can no longer join it
        import warp_st
        assert Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("SpacetimeBodyAPI") is None
        import sys
        sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r})
        from test_usd_reader import _body_summary
        print(json.dumps(_body_summary(warp_st.load({path!r}))))
        """
    )
    assert json.loads(run_python(code)) == plain


def test_body_fallbacks(tmp_path):
    """Law (docs/spec.md §2 table): an applied schema with nothing authored is at rest, unbounded, t_ref 0, coupled."""
    scene = load(tmp_path, f'def Mesh "m" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{ {QUAD} }}')
    (body,) = scene.bodies
    assert body.velocity.tolist() == [0, 0, 0] and body.reference_time == 0.0
    assert body.lifetime == (-math.inf, math.inf) and body.decoupled is False


def test_decoupled_body_may_be_superluminal(tmp_path):
    """Law (docs/spec.md §2): a Lorentz-decoupled body accepts any finite v, superluminal included."""
    scene = load(tmp_path, f'''
        def Mesh "m" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{
            {QUAD}
            custom double4 spacetime:fourVelocity = (1, 3, 0, 0)
            custom bool spacetime:lorentzDecoupled = 1
        }}''')
    assert scene.bodies[0].velocity.tolist() == [3, 0, 0] and scene.bodies[0].decoupled


def test_float_variants_accepted(tmp_path):
    """Law: float4 / float2 / float spelling of the body attributes reads like double."""
    scene = load(tmp_path, f'''
        def Mesh "m" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{
            {QUAD}
            custom float4 spacetime:fourVelocity = (2, 1, 0, 0)
            custom float2 spacetime:lifetime = (-1, 1)
            custom float spacetime:referenceTime = 0.5
        }}''')
    body = scene.bodies[0]
    assert body.velocity.tolist() == [0.5, 0, 0] and body.lifetime == (-1, 1) and body.reference_time == 0.5


def test_nearest_ancestor_owns_gprims(tmp_path):
    """Law (docs/spec.md §2): each gprim belongs to its nearest SpacetimeBodyAPI ancestor; a gprim
    with none is its own body at rest at its world origin; bodies come in traversal order."""
    scene = load(tmp_path, f'''
        def Xform "Outer" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{
            double3 xformOp:translate = (10, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
            custom double4 spacetime:fourVelocity = (1, 0.5, 0, 0)
            def Mesh "A" {{ {QUAD} }}
            def Xform "Inner" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{
                double3 xformOp:translate = (0, 5, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                custom double4 spacetime:fourVelocity = (1, 0, 0.25, 0)
                def Xform "deep" {{
                    def Mesh "B" {{ {QUAD} }}
                }}
            }}
            def Mesh "C" {{ {QUAD} }}
        }}
        def Cube "Free" {{
            double3 xformOp:translate = (0, 0, -3)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }}
        def Xform "Empty" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{ }}''')
    assert scene.body_paths() == ["/Outer", "/Outer/Inner", "/Free"]  # empty body dropped
    bodies = by_path(scene)
    assert [s.prim_path for s in bodies["/Outer"].surfaces] == ["/Outer/A", "/Outer/C"]
    assert [s.prim_path for s in bodies["/Outer/Inner"].surfaces] == ["/Outer/Inner/deep/B"]
    assert bodies["/Outer"].velocity.tolist() == [0.5, 0, 0]
    assert bodies["/Outer/Inner"].velocity.tolist() == [0, 0.25, 0]
    assert bodies["/Outer/Inner"].origin.tolist() == [10, 5, 0]
    free = bodies["/Free"]
    assert free.origin.tolist() == [0, 0, -3] and free.velocity.tolist() == [0, 0, 0]
    assert free.lifetime == (-math.inf, math.inf)


# -- geometry -----------------------------------------------------------------------------
def test_polygons_are_fan_triangulated(tmp_path):
    """Law: an n-gon gives n - 2 triangles (quad 2, pentagon 3); faces with < 3 vertices are skipped;
    every triangle's corners are vertices of its own polygon."""
    scene = load(tmp_path, '''
        def Mesh "m" {
            point3f[] points = [(0,0,0), (1,0,0), (1,1,0), (0,1,0), (2,0,0), (3,0,0), (3,1,0), (2.5,2,0), (2,1,0)]
            int[] faceVertexCounts = [4, 2, 5]
            int[] faceVertexIndices = [0, 1, 2, 3,  0, 1,  4, 5, 6, 7, 8]
        }''')
    tris = scene.bodies[0].surfaces[0].triangles
    assert tris.shape == (5, 3) and tris.dtype == np.int64
    assert set(tris[:2].ravel()) == {0, 1, 2, 3} and set(tris[2:].ravel()) == {4, 5, 6, 7, 8}
    assert tris[:2].tolist() == [[0, 1, 2], [0, 2, 3]]


def test_left_handed_mesh_keeps_orientation(tmp_path):
    """Law: orientation = leftHanded reverses the winding so triangle normals follow the right-hand rule."""
    scene = load(tmp_path, f'def Mesh "m" {{ {QUAD}    uniform token orientation = "leftHanded"\n}}')
    assert scene.bodies[0].surfaces[0].triangles.tolist() == [[0, 2, 1], [0, 3, 2]]


def test_xform_hierarchy_is_applied(tmp_path):
    """Law: points get the full world transform. Parent ops [translate (1,2,3), rotateY 90, scale 2]
    act on a row vector as scale, then rotate, then translate: (1,0,0) -> (2,0,0) -> (0,0,-2) -> (1,2,1);
    the child's own translate (0,1,0) is applied first: (0,1,0) -> (0,2,0) -> (0,2,0) -> (1,4,3)."""
    scene = load(tmp_path, '''
        def Xform "P" {
            double3 xformOp:translate = (1, 2, 3)
            float xformOp:rotateY = 90
            float3 xformOp:scale = (2, 2, 2)
            uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY", "xformOp:scale"]
            def Mesh "m" {
                double3 xformOp:translate = (0, 1, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                point3f[] points = [(1, -1, 0), (0, 0, 0), (0, -1, 1)]
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
            }
            def Sphere "s" {
                double radius = 0.5
            }
        }''')
    mesh, sphere = (b.surfaces[0] for b in scene.bodies)
    np.testing.assert_allclose(mesh.points, [[1, 2, 1], [1, 4, 3], [3, 2, 3]], atol=TOL)
    assert mesh.points.dtype == np.float64
    # Free gprims are bodies at their own world origin.
    np.testing.assert_allclose(scene.bodies[0].origin, [1, 4, 3], atol=TOL)
    # Sphere radius 0.5 scaled by 2 about (1, 2, 3); normals stay unit and radial.
    r = sphere.points - [1, 2, 3]
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 1.0, atol=TOL)
    np.testing.assert_allclose(sphere.normals, r, atol=TOL)


def test_normals_use_inverse_transpose(tmp_path):
    """Law: under a non-uniform scale the sphere's normals are transformed by the inverse
    transpose and renormalised, so they stay perpendicular to the ellipsoid: n ∝ (x/a², y/b², z/c²)."""
    scene = load(tmp_path, '''
        def Sphere "s" {
            float3 xformOp:scale = (2, 1, 0.5)
            uniform token[] xformOpOrder = ["xformOp:scale"]
        }''')
    s = scene.bodies[0].surfaces[0]
    expected = s.points / np.array([4.0, 1.0, 0.25])
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(s.normals, expected, atol=1e-12)


def test_cube_size_and_invisible_skipped(tmp_path):
    """Law: a Cube of size s spans [-s/2, s/2]^3; an invisible prim hides its whole subtree."""
    scene = load(tmp_path, f'''
        def Cube "c" {{
            double size = 3
        }}
        def Xform "hidden" {{
            token visibility = "invisible"
            def Mesh "m" {{ {QUAD} }}
        }}
        def Mesh "guide" {{ {QUAD}    uniform token purpose = "guide"
        }}''')
    assert scene.body_paths() == ["/c"]
    pts = scene.bodies[0].surfaces[0].points
    np.testing.assert_allclose([pts.min(axis=0), pts.max(axis=0)], [[-1.5] * 3, [1.5] * 3])


def test_instance_proxies_are_traversed(tmp_path):
    """Law: each instance of an instanceable prim contributes its own body (instance proxies)."""
    scene = load(tmp_path, '''
        class Xform "Proto" {
            def Cube "c" {
                double size = 1
            }
        }
        def Xform "I1" (instanceable = true
            references = </Proto>) { }
        def Xform "I2" (instanceable = true
            references = </Proto>) {
            double3 xformOp:translate = (5, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }''')
    assert scene.body_paths() == ["/I1/c", "/I2/c"]
    a, b = (body.surfaces[0].points for body in scene.bodies)
    np.testing.assert_allclose(b - a, np.tile([5, 0, 0], (8, 1)), atol=TOL)


INSTANCER = '''
def Xform "Crowd" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {
    custom double4 spacetime:fourVelocity = (1, 0.5, 0, 0)
    def PointInstancer "pi" {
        rel prototypes = [</Crowd/pi/Protos/ball>, </Crowd/pi/Protos/box>]
        int[] protoIndices = [0, 1, 0]
        point3f[] positions = [(0, 0, 0), (10, 0, 0), (20, 0, 0)]
        %s
        def Scope "Protos" {
            def Sphere "ball" {
                double radius = 1
            }
            def Xform "box" {
                double3 xformOp:translate = (0, 3, 0)
                uniform token[] xformOpOrder = ["xformOp:translate"]
                def Cube "c" {
                    double size = 2
                }
            }
        }
    }
}
'''


def test_point_instancer_instances_are_surfaces_of_the_owning_body(tmp_path):
    """Law: every visible instance of every prototype gprim is one surface of the body owning
    the instancer, placed by position * prototype transform; prototypes are not drawn on their own."""
    scene = load(tmp_path, INSTANCER % "")
    (body,) = scene.bodies
    assert body.prim_path == "/Crowd" and body.velocity.tolist() == [0.5, 0, 0]
    assert len(body.surfaces) == 3
    centres = [s.points.mean(axis=0) for s in body.surfaces]
    np.testing.assert_allclose(centres, [[0, 0, 0], [10, 3, 0], [20, 0, 0]], atol=1e-9)
    assert body.surfaces[1].prim_path == "/Crowd/pi/Protos/box/c[1]"


def test_point_instancer_mask(tmp_path):
    """Law: invisibleIds hide instances."""
    scene = load(tmp_path, INSTANCER % "int64[] invisibleIds = [2]\nint64[] ids = [0, 1, 2]")
    assert len(scene.bodies[0].surfaces) == 2


# -- materials ---------------------------------------------------------------------------
def test_materials_preview_surface_display_color_and_default(tmp_path):
    """Law (docs/spec.md §2): a bound UsdPreviewSurface gives diffuse/emissive/metallic (connected inputs
    resolve to the producing attribute); else displayColor is the diffuse; else the default."""
    scene = load(tmp_path, f'''
        def Material "Mat" {{
            color3f inputs:tint = (0.1, 0.2, 0.3)
            token outputs:surface.connect = </Mat/PS.outputs:surface>
            def Shader "PS" {{
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor.connect = </Mat.inputs:tint>
                color3f inputs:emissiveColor = (1, 0.5, 0)
                float inputs:metallic = 0.75
                token outputs:surface
            }}
        }}
        def Mesh "bound" (prepend apiSchemas = ["MaterialBindingAPI"]) {{
            {QUAD}
            rel material:binding = </Mat>
            color3f[] primvars:displayColor = [(0, 1, 0)]
        }}
        def Mesh "painted" {{ {QUAD}    color3f[] primvars:displayColor = [(0, 1, 0), (1, 1, 1)]
        }}
        def Mesh "plain" {{ {QUAD} }}''')
    mats = {b.prim_path: b.surfaces[0].material for b in scene.bodies}
    np.testing.assert_allclose(mats["/bound"].diffuse, [0.1, 0.2, 0.3], rtol=1e-6)
    assert mats["/bound"].emissive == (1, 0.5, 0) and mats["/bound"].metallic == 0.75
    assert mats["/painted"] == warp_st.core.scene.Material(diffuse=(0.0, 1.0, 0.0))
    assert mats["/plain"] == warp_st.core.scene.Material()


# -- camera --------------------------------------------------------------------------------
CAMERA = '''
def Camera "Cam" (prepend apiSchemas = ["SpacetimeCameraAPI"]) {
    double3 xformOp:translate = (1, 2, 3)
    float xformOp:rotateY = 90
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateY"]
    float focalLength = 35
    float horizontalAperture = 36
    float verticalAperture = 24
    float horizontalApertureOffset = 1
    float verticalApertureOffset = -2
    double spacetime:time.timeSamples = { 0: 100, 10: 120 }
    token spacetime:lightSpeed = "infinite"
}
def Camera "Plain" { }
'''


def test_camera_state_transform_lens_and_time_samples(tmp_path):
    """Law (docs/spec.md §3): position = world translation; rotation = lab_from_camera with columns the
    camera axes (rotateY 90: +X -> -Z, +Z -> +X, so the camera looks down -X); spacetime:time
    is evaluated (linearly interpolated) at the time code."""
    scene = load(tmp_path, CAMERA)
    assert scene.cameras == ("/Cam", "/Plain") and scene.default_camera == "/Cam"
    state = scene.camera_state(None, 5)
    assert state.prim_path == "/Cam" and state.time == 110.0
    np.testing.assert_allclose(state.position, [1, 2, 3], atol=TOL)
    np.testing.assert_allclose(state.rotation, [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=TOL)
    assert (state.focal_length, state.horizontal_aperture, state.vertical_aperture) == (35, 36, 24)
    assert (state.horizontal_aperture_offset, state.vertical_aperture_offset) == (1, -2)
    assert state.light_speed is LightSpeed.INFINITE
    assert scene.camera_state("/Cam", 10).time == 120.0


def test_camera_time_falls_back_to_time_code(tmp_path):
    """Law (docs/spec.md §3): without spacetime:time, t_c = the time code; lightSpeed falls back to finite."""
    scene = load(tmp_path, CAMERA)
    state = scene.camera_state("/Plain", 42.5)
    assert state.time == 42.5 and state.light_speed is LightSpeed.FINITE
    np.testing.assert_allclose(state.rotation, np.eye(3), atol=TOL)


def test_camera_rotation_is_orthonormalised(tmp_path):
    """Law: scale on the camera does not leak into lab_from_camera (R^T R = I, det R = 1)."""
    scene = load(tmp_path, '''
        def Camera "C" {
            float xformOp:rotateX = 30
            float3 xformOp:scale = (2, 3, 0.5)
            uniform token[] xformOpOrder = ["xformOp:rotateX", "xformOp:scale"]
        }''')
    r = scene.camera_state(None, 0).rotation
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert abs(np.linalg.det(r) - 1) < 1e-12
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    np.testing.assert_allclose(r[:, 2], [0, -s, c], atol=1e-7)  # float rotateX: ~1e-8


def test_moving_camera_position(tmp_path):
    """Law (docs/spec.md §3): a camera with SpacetimeBodyAPI is at o + v (t_c - t_ref) at camera time t_c."""
    scene = load(tmp_path, '''
        def Camera "C" (prepend apiSchemas = ["SpacetimeBodyAPI", "SpacetimeCameraAPI"]) {
            double3 xformOp:translate = (1, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
            custom double4 spacetime:fourVelocity = (2, 1, 0, 0)
            custom double spacetime:referenceTime = 4
            custom bool spacetime:lorentzDecoupled = true
            custom double spacetime:time.timeSamples = { 0: 10, 1: 14 }
        }''')
    assert scene.bodies == ()  # a camera is never a body
    state = scene.camera_state(None, 1)
    assert state.time == 14.0 and state.decoupled is True
    np.testing.assert_allclose(state.velocity, [0.5, 0, 0])
    np.testing.assert_allclose(state.position, [1 + 0.5 * (14 - 4), 0, 0], atol=TOL)


def test_camera_state_survives_pickling(tmp_path):
    """Law: camera_state is picklable (file scenes reopen the file, in-memory ones their text)."""
    scene = load(tmp_path, CAMERA)
    again = pickle.loads(pickle.dumps(scene.camera_state))
    assert again(None, 5).time == 110.0
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Camera.Define(stage, "/C").AddTranslateOp().Set(Gf.Vec3d(0, 0, 7))
    mem = pickle.loads(pickle.dumps(load_scene(stage).camera_state))
    np.testing.assert_allclose(mem("/C", 3).position, [0, 0, 7])


def test_camera_errors(tmp_path):
    """Law: an unknown camera, a stage with neither a camera nor geometry for the default
    camera to frame, and a bad lightSpeed token are SceneErrors."""
    scene = load(tmp_path, CAMERA)
    with pytest.raises(SceneError) as e:
        scene.camera_state("/Nope", 0)
    assert_error(e, "scene.usda", "/Nope")
    with pytest.raises(SceneError) as e:
        load(tmp_path, 'def SphereLight "L" {\n}').camera_state(None, 0)
    assert_error(e, "scene.usda", "nothing to render")
    bad = load(tmp_path, 'def Camera "C" {\n token spacetime:lightSpeed = "warp"\n}')
    with pytest.raises(SceneError) as e:
        bad.camera_state(None, 0)
    assert_error(e, "scene.usda", "/C", "spacetime:lightSpeed")


# -- lights and settings ---------------------------------------------------------------------
def test_lights(tmp_path):
    """Law (docs/spec.md §3): L = intensity * color * 2^exposure; a SphereLight at its world position
    with the schema's radius 0.5 shines as a point of I / pi = L r^2; a DistantLight with the schema's
    angle 0.53 degrees gives E / pi = L sin^2(angle / 2); its direction is its local +Z in world
    (rotateX -90 turns +Z into +Y); invisible skipped."""
    scene = load(tmp_path, '''
        def SphereLight "Bulb" {
            double3 xformOp:translate = (1, 2, 3)
            uniform token[] xformOpOrder = ["xformOp:translate"]
            float inputs:intensity = 4
            color3f inputs:color = (1, 0.5, 0.25)
            float inputs:exposure = 1
        }
        def DistantLight "Sun" {
            float inputs:intensity = 3
            float xformOp:rotateX = -90
            uniform token[] xformOpOrder = ["xformOp:rotateX"]
        }
        def SphereLight "Off" {
            token visibility = "invisible"
        }''')
    bulb, sun = scene.lights
    assert bulb.kind == "sphere" and bulb.position == (1, 2, 3) and bulb.radiance == (2, 1, 0.5)
    assert bulb.radius == 0.5
    half_angle = math.radians(float(np.float32(0.53))) / 2  # the schema's float fallback
    # rel 1e-12: pi sin^2 / pi in float64
    np.testing.assert_allclose(sun.radiance, [3 * math.sin(half_angle) ** 2] * 3, rtol=1e-12)
    assert sun.kind == "distant"
    np.testing.assert_allclose(sun.direction, [0, 1, 0], atol=1e-7)


SETTINGS = '''
def Scope "Render" {
    def RenderSettings "Draft" { }
    def RenderSettings "Final" {
        uniform int2 resolution = (640, 360)
        rel camera = </Cam>
        custom int spacetime:maxDepth = 3
        custom int spacetime:samples = 4
        custom double spacetime:shutter = 0.5
        custom token spacetime:precision = "float64"
        custom color3f spacetime:background = (0.1, 0.2, 0.3)
    }
}
def Camera "Other" { }
def Camera "Cam" { }
'''


def test_render_settings(tmp_path):
    """Law (docs/spec.md §3): the stage's renderSettingsPrimPath picks the settings prim; its values and
    camera land in RenderSettings, and the settings' camera is the default camera."""
    scene = load(tmp_path, SETTINGS, header='    renderSettingsPrimPath = "/Render/Final"')
    s = scene.settings
    assert s.prim_path == "/Render/Final" and s.resolution == (640, 360) and s.camera == "/Cam"
    assert (s.max_depth, s.samples, s.shutter, s.precision) == (3, 4, 0.5, Precision.FLOAT64)
    np.testing.assert_allclose(s.background, [0.1, 0.2, 0.3], rtol=1e-6)
    assert scene.default_camera == "/Cam"
    # Without the metadata the first settings prim wins; unauthored values stay None.
    first = load(tmp_path, SETTINGS)
    assert first.settings.prim_path == "/Render/Draft" and first.settings.resolution is None
    assert first.default_camera == "/Other"


@pytest.mark.parametrize(
    "line, attribute",
    [
        ("custom int spacetime:samples = 0", "spacetime:samples"),
        ("custom int spacetime:maxDepth = -1", "spacetime:maxDepth"),
        ("custom float spacetime:samples = 2", "spacetime:samples"),
        ('custom token spacetime:precision = "float16"', "spacetime:precision"),
        ("uniform int2 resolution = (0, 10)", "resolution"),
        ("rel camera = </Nowhere>", "camera"),
    ],
)
def test_bad_render_settings(tmp_path, line, attribute):
    """Law: invalid render settings raise SceneError naming file, prim and attribute."""
    with pytest.raises(SceneError) as e:
        load(tmp_path, f'def RenderSettings "RS" {{\n{line}\n}}')
    assert_error(e, "scene.usda", "/RS", attribute)


def test_stage_metadata(tmp_path):
    """Law: up axis and authored time code range are reported; no range -> None."""
    scene = load(tmp_path, f'def Mesh "m" {{ {QUAD} }}',
                 header='    upAxis = "Z"\n    startTimeCode = 0\n    endTimeCode = 48')
    assert scene.up_axis == "Z" and scene.frame_range == (0.0, 48.0)
    assert load(tmp_path, f'def Mesh "m" {{ {QUAD} }}').frame_range is None


# -- references ------------------------------------------------------------------------------
def test_references_compose_and_no_references_skips_them(tmp_path):
    """Law: references compose by default; no_references=True reads only the file's own layers;
    an unresolvable reference is left out with a warning naming the layer and the asset
    (what composed is read), and not even tried when references are skipped."""
    write(tmp_path, f'def Mesh "m" {{ {QUAD} }}', name="asset.usda")
    main = write(tmp_path, f'''
        def "A" (references = @./asset.usda@</m>) {{
        }}
        def Mesh "local" {{ {QUAD} }}''', name="main.usda")
    assert load_scene(main).body_paths() == ["/A", "/local"]
    assert load_scene(main, no_references=True).body_paths() == ["/local"]
    broken = write(tmp_path, f'def "A" (references = @./missing.usda@</m>) {{\n}}\ndef Mesh "local" {{ {QUAD} }}',
                   name="broken.usda")
    with pytest.warns(UserWarning) as caught:
        scene = load_scene(broken)
    assert scene.body_paths() == ["/local"]
    assert [str(w.message) for w in caught] == [
        f"{broken}: /A: reference @missing.usda@ (in broken.usda) cannot be opened: not composed"]
    assert [d.code for d in load_scene(broken, no_references=True).diagnostics] == ["LightSpeed", "DefaultCamera"]


# -- bad input ---------------------------------------------------------------------------------
def test_missing_file(tmp_path):
    """Law: a missing file is a one-line SceneError naming it."""
    with pytest.raises(SceneError) as e:
        load_scene(tmp_path / "nope.usda")
    assert_error(e, "nope.usda", "no such file")
    assert isinstance(e.value, ValueError)


def test_syntax_error(tmp_path):
    """Law: a file USD cannot parse is a one-line SceneError naming the file (and the line)."""
    with pytest.raises(SceneError) as e:
        load(tmp_path, 'def Xform "a" {\n  double x = \n}\n')
    assert_error(e, "scene.usda", "cannot open")


BODY_ERRORS = [
    ("custom double4 spacetime:fourVelocity = (1, 1, 0, 0)", "spacetime:fourVelocity", "speed"),
    ("custom double4 spacetime:fourVelocity = (1, 0.6, 0.8, 0)", "spacetime:fourVelocity", ">= 1"),
    ("custom double4 spacetime:fourVelocity = (0, 0.1, 0, 0)", "spacetime:fourVelocity", "> 0"),
    ("custom double4 spacetime:fourVelocity = (-1, 0.1, 0, 0)", "spacetime:fourVelocity", "> 0"),
    ("custom double4 spacetime:fourVelocity = (1, nan, 0, 0)", "spacetime:fourVelocity", "finite"),
    ("custom double4 spacetime:fourVelocity = (1, inf, 0, 0)", "spacetime:fourVelocity", "finite"),
    ("custom double2 spacetime:lifetime = (3, 3)", "spacetime:lifetime", "tBegin"),
    ("custom double2 spacetime:lifetime = (5, -5)", "spacetime:lifetime", "tBegin"),
    ("custom double2 spacetime:lifetime = (nan, 5)", "spacetime:lifetime", "NaN"),
    ("custom double spacetime:referenceTime = inf", "spacetime:referenceTime", "finite"),
    ("custom double spacetime:referenceTime = nan", "spacetime:referenceTime", "finite"),
    ('custom string spacetime:referenceTime = "0"', "spacetime:referenceTime", "real number"),
    ("custom double3 spacetime:fourVelocity = (1, 0, 0)", "spacetime:fourVelocity", "4-vector"),
    ("custom double4[] spacetime:fourVelocity = [(1, 0, 0, 0)]", "spacetime:fourVelocity", "4-vector"),
    ("custom int spacetime:lorentzDecoupled = 1", "spacetime:lorentzDecoupled", "bool"),
    ("custom double spacetime:referenceTime.timeSamples = { 0: 1 }", "spacetime:referenceTime", "time-sampled"),
]


@pytest.mark.parametrize("line, attribute, problem", BODY_ERRORS)
def test_bad_body_attributes(tmp_path, line, attribute, problem):
    """Law (docs/spec.md §2): invalid body attributes (|v| >= 1 coupled, t <= 0, empty lifetime, NaN/inf,
    wrong type or shape) raise one-line SceneErrors naming file, prim and attribute."""
    with pytest.raises(SceneError) as e:
        load(tmp_path, f'''
            def Xform "World" {{
                def Mesh "Ship" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {{
                    {QUAD}
                    {line}
                }}
            }}''')
    assert_error(e, "scene.usda", "/World/Ship", attribute, problem)


@pytest.mark.parametrize(
    "mesh, attribute",
    [
        ("point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\nint[] faceVertexCounts = [3]\n"
         "int[] faceVertexIndices = [0, 1, 3]", "faceVertexIndices"),
        ("point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\nint[] faceVertexCounts = [3]\n"
         "int[] faceVertexIndices = [0, -1, 2]", "faceVertexIndices"),
        ("point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\nint[] faceVertexCounts = [4]\n"
         "int[] faceVertexIndices = [0, 1, 2]", "faceVertexCounts"),
        ("point3f[] points = [(0,0,0), (1,0,0), (0,nan,0)]\nint[] faceVertexCounts = [3]\n"
         "int[] faceVertexIndices = [0, 1, 2]", "points"),
        ("int[] points = [0, 1, 2]\nint[] faceVertexCounts = [3]\n"
         "int[] faceVertexIndices = [0, 1, 2]", "points"),
    ],
)
def test_bad_mesh(tmp_path, mesh, attribute):
    """Law: a mesh whose points or topology cannot be used (indices out of range, counts not
    summing to the index count, non-finite or mistyped points) is a real-world USD problem:
    one warning naming file, prim and attribute, that mesh is not rendered and the rest of the
    stage is (docs/spec.md §7)."""
    with pytest.warns(UserWarning) as caught:
        scene = load(tmp_path, f'def Mesh "Hull" {{\n{mesh}\n}}\ndef Mesh "Good" {{\n{QUAD}\n}}')
    lines = [str(w.message) for w in caught if "/Hull" in str(w.message)]
    assert len(lines) == 1 and "\n" not in lines[0], lines
    assert "scene.usda" in lines[0] and f"/Hull: {attribute}:" in lines[0] and "the mesh is not rendered" in lines[0]
    assert [b.prim_path for b in scene.bodies] == ["/Good"]


def test_error_names_the_authoring_layer(tmp_path):
    """Law: a bad value authored in a referenced file is reported against the root file and names
    the layer that holds it, so the user knows what to edit."""
    write(tmp_path, '''
        def Mesh "m" (prepend apiSchemas = ["SpacetimeBodyAPI"]) {
            custom double4 spacetime:fourVelocity = (1, 2, 0, 0)
        }''', name="asset.usda")
    main = write(tmp_path, 'def "A" (references = @./asset.usda@</m>) {\n}', name="main.usda")
    with pytest.raises(SceneError) as e:
        load_scene(main)
    assert_error(e, "main.usda", "/A", "spacetime:fourVelocity", "asset.usda")


# -- the shipped scene -------------------------------------------------------------------------
def test_shipped_parade_scene():
    """Law: the shipped demo loads: a camera, two rows of three bodies at 0.9c (coupled, decoupled)."""
    scene = load_scene(os.path.join(REPO, "usd_scenes", "relativistic_parade.usda"))
    moving = [b for b in scene.bodies if b.speed > 0]
    assert len(moving) == 6
    assert all(abs(b.speed - 0.9) < 1e-12 for b in moving)
    assert sum(b.decoupled for b in moving) == 3
    assert scene.settings.resolution == (640, 360) and scene.default_camera is not None
    state = scene.camera_state(None, scene.frame_range[0])
    np.testing.assert_allclose(state.rotation, np.eye(3), atol=TOL)


def test_a_value_of_another_type_than_declared_is_an_error_naming_it():
    """Regression (found by the byte-corruption fuzzer): a damaged .usdc held a point3f[]
    whose value was a float[] of 4 (and a float3 whose value was a double), which crashed
    the reader (exit 1). Law: a value whose type is not one the declared type allows is a
    SceneError naming the file, prim and attribute. A damaged crate cannot be authored
    through the USD API, so the attribute's ``Get`` is stood in for; everything else is
    the real prim's."""
    from pxr import Vt

    from warp_st.core.scene import SceneError
    from warp_st.usd.attributes import Where, vec3_array

    stage = Usd.Stage.CreateInMemory()
    mesh = UsdGeom.Mesh.Define(stage, "/Floor")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0)])

    class Damaged:
        def __init__(self, wrapped, value):
            self._wrapped, self._value = wrapped, value

        def __getattr__(self, name):
            return getattr(self._wrapped, name)

        def Get(self, *args):
            return self._value

    class Prim:
        def __init__(self, prim, value):
            self._prim, self._value = prim, value

        def __getattr__(self, name):
            return getattr(self._prim, name)

        def GetAttribute(self, name):
            return Damaged(self._prim.GetAttribute(name), self._value)

    where = Where("damaged.usdc")
    assert vec3_array(where, Prim(mesh.GetPrim(), Vt.Vec3fArray([(0, 0, 0)])), "points").shape == (1, 3)
    with pytest.raises(SceneError) as err:
        vec3_array(where, Prim(mesh.GetPrim(), Vt.FloatArray(4)), "points")
    message = str(err.value)
    assert "damaged.usdc" in message and "/Floor" in message and "points" in message and "float[]" in message
    assert "\n" not in message


def test_an_attribute_authored_as_a_relationship_is_an_error_naming_it(tmp_path):
    """Regression (found by the byte-corruption fuzzer, seed 4242): a damaged .usdc held a
    relationship spec under a light's ``inputs:intensity``, and reading its authored type
    crashed the reader (exit 1: a RelationshipSpec has no typeName). Law: an attribute
    whose strongest opinion is a relationship is a SceneError naming the file, prim and
    attribute, on one line. The same spec authored in .usda text stands in for the
    damaged crate."""
    import warp_st
    from warp_st.core.scene import SceneError

    path = tmp_path / "relationship.usda"
    path.write_text('#usda 1.0\ndef Camera "Cam"\n{\n}\ndef Cube "Box"\n{\n}\n'
                    'def DistantLight "Sun"\n{\n    rel inputs:intensity = </Box>\n}\n')
    with pytest.raises(SceneError) as err:
        warp_st.load(str(path))
    message = str(err.value)
    assert "relationship.usda" in message and "/Sun" in message and "inputs:intensity" in message
    assert "not a relationship" in message and "\n" not in message
