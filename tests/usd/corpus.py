"""A corpus of small real-world-like USD stages, one per class of what pipelines bring:
no camera (Y-up and Z-up), missing arcs, MaterialX references, bad primvars and material
inputs, textures, other shaders, animation, lights we do not support, subdivision,
points and curves, the analytic gprims, skinning, camera and schema attributes, unknown
types, per-face materials.

Each :class:`Stage` says which warnings the reader must give: (prim, attribute, message)
triples, exactly; ``render`` prints each as ``warp-st: warning: FILE: PRIM: ATTRIBUTE:
MESSAGE`` and ``validate`` as ``WARNING FILE:PRIM.ATTRIBUTE: MESSAGE``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

HEADER = '#usda 1.0\n(\n    upAxis = "{up}"\n    metersPerUnit = 0.01\n    startTimeCode = 1\n    endTimeCode = 24\n)\n'

#: A unit quad in the XY plane (faces +Z), the base of many stages.
QUAD = """point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]"""

CAMERA = """def Camera "Cam"
{
    double3 xformOp:translate = (0, 0, 20)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""

NOT_COMPOSED = "cannot be opened: not composed"
ANIMATED = "USD animation is not rendered yet: every frame uses its value at time code 1"
LAMBERT = "not honoured (the surface is Lambert diffuse plus a metallic mirror); ignored"


@dataclass
class Stage:
    """``files`` (name -> text; ``main`` is rendered), the warnings expected, whether the
    default camera is used, and extra files that exist beside it (not USD)."""

    main: str
    files: dict[str, str]
    warnings: list[tuple[str | None, str | None, str]]
    default_camera: bool = True
    others: dict[str, str | bytes] = field(default_factory=dict)

    def write(self, folder: Path) -> Path:
        for name, text in {**self.files, **self.others}.items():
            if isinstance(text, bytes):
                (folder / name).write_bytes(text)
            else:
                (folder / name).write_text(text)
        return folder / self.main


def _stage(body: str, up: str = "Y") -> str:
    return HEADER.format(up=up) + body


def chess_piece() -> Stage:
    """An asset as shipped: a pawn of analytic gprims under a default prim, no camera."""
    return Stage("pawn.usda", {"pawn.usda": _stage('''
def Xform "Pawn" (kind = "component")
{
    def Cylinder "Base"
    {
        double radius = 1
        double height = 0.4
        token axis = "Y"
    }
    def Cone "Body"
    {
        double radius = 0.7
        double height = 2
        token axis = "Y"
        double3 xformOp:translate = (0, 1.2, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Sphere "Head"
    {
        double radius = 0.45
        double3 xformOp:translate = (0, 2.4, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
''')}, [])


def vehicle_z_up() -> Stage:
    """A Z-up asset (a cart: a box on capsule axles): the default camera looks along +Y."""
    return Stage("cart.usda", {"cart.usda": _stage('''
def Xform "Cart"
{
    def Cube "Body"
    {
        double size = 2
        float3 xformOp:scale = (2, 1, 0.5)
        double3 xformOp:translate = (0, 0, 1)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
    }
    def Capsule "Axle"
    {
        double radius = 0.3
        double height = 2.4
        token axis = "Y"
        double3 xformOp:translate = (0, 0, 0.3)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Plane "Ground"
    {
        double width = 8
        double length = 8
        token axis = "Z"
    }
}
''', up="Z")}, [])


def missing_arcs() -> Stage:
    """A shot layer whose reference, payload and sublayer are not there; the rest renders."""
    text = HEADER.format(up="Y").replace("    endTimeCode = 24\n", "    endTimeCode = 24\n    subLayers = [@./lighting.usda@]\n")
    return Stage("shot.usda", {"shot.usda": text + f'''
def Xform "Set" (prepend references = @./assets/set.usda@)
{{
    def Mesh "Floor"
    {{
        {QUAD}
    }}
}}
def Xform "Hero" (prepend payload = @./assets/hero.usdc@)
{{
}}
'''}, [(None, None, f"sublayer @lighting.usda@ of shot.usda {NOT_COMPOSED}"),
       ("/Set", None, f"reference @assets/set.usda@ (in shot.usda) {NOT_COMPOSED}"),
       ("/Hero", None, f"payload @assets/hero.usdc@ (in shot.usda) {NOT_COMPOSED}")])


def materialx_reference() -> Stage:
    """Materials referenced from a .mtlx file (usd-core cannot open it): displayColor shows."""
    mtlx = '<?xml version="1.0"?>\n<materialx version="1.38">\n</materialx>\n'
    return Stage("teapot.usda", {"teapot.usda": _stage(f'''
def Material "Glaze" (prepend references = @./looks.mtlx@</MaterialX/Materials/Glaze>)
{{
}}
def Mesh "Teapot" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    {QUAD}
    color3f[] primvars:displayColor = [(0.8, 0.3, 0.1)]
    rel material:binding = </Glaze>
}}
''')}, [("/Glaze", None, "reference @looks.mtlx@ (in teapot.usda) is MaterialX, which usd-core cannot open "
                         "(no MaterialX file-format plugin): not composed"),
        ("/Glaze", "outputs:surface", "has no surface shader; displayColor is used")],
        others={"looks.mtlx": mtlx})


def bad_primvars() -> Stage:
    """normals authored as one point3f, a displayColor that is not an array, normals of the
    wrong length, per-vertex colours; faceVarying normals are honoured (no warning)."""
    return Stage("primvars.usda", {"primvars.usda": _stage(f'''
def Mesh "OneNormal"
{{
    {QUAD}
    point3f normals = (0, 0, 1)
}}
def Mesh "FlatColour"
{{
    {QUAD}
    color3f primvars:displayColor = (1, 0, 0)
}}
def Mesh "ShortNormals"
{{
    {QUAD}
    normal3f[] normals = [(0, 0, 1)] (interpolation = "vertex")
}}
def Mesh "VertexColours"
{{
    {QUAD}
    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)] (interpolation = "vertex")
}}
def Mesh "CornerNormals"
{{
    {QUAD}
    normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (interpolation = "faceVarying")
}}
''')}, [("/OneNormal", "normals", "must be a 3-vector array (point3f[], color3f[], float3[] or double3[]), not "
                                  "point3f; the faces' own (flat) normals are used"),
        ("/FlatColour", "primvars:displayColor", "must be a 3-vector array (point3f[], color3f[], float3[] or "
                                                 "double3[]), not color3f; the default colour (0.18, 0.18, 0.18) is used"),
        ("/ShortNormals", "normals", "has 1 values but vertex interpolation needs 4; the faces' own (flat) normals "
                                     "are used"),
        ("/VertexColours", "primvars:displayColor", "vertex colours are not supported (one colour per surface); its "
                                                    "first colour is used")])


def _material(name: str, inputs: str, shader_id: str = "UsdPreviewSurface") -> str:
    return f'''
    def Material "{name}"
    {{
        token outputs:surface.connect = </Looks/{name}/Surface.outputs:surface>
        def Shader "Surface"
        {{
            uniform token info:id = "{shader_id}"
            {inputs}
            token outputs:surface
        }}
    }}'''


def _bound_quads(*materials: str) -> str:
    return "\n".join(f'''
def Mesh "{m}Quad" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    {QUAD}
    rel material:binding = </Looks/{m}>
}}''' for m in materials)


def bad_material_inputs() -> Stage:
    """Inputs of the wrong type fall back to the defaults; unhonoured inputs are named."""
    looks = _material("Clay", '''color3f inputs:diffuseColor = (0.5, 0.4, 0.3)
            float inputs:roughness = 0.3
            float inputs:opacity = 0.5
            float inputs:ior = 1.5''') + _material("Odd", '''float inputs:diffuseColor = 0.5
            color3f inputs:metallic = (1, 1, 1)''')
    return Stage("clay.usda", {"clay.usda": _stage(f'def Scope "Looks"\n{{{looks}\n}}\n' + _bound_quads("Clay", "Odd"))},
                 [("/Looks/Clay/Surface", "inputs:roughness", LAMBERT),
                  ("/Looks/Clay/Surface", "inputs:opacity", LAMBERT),
                  ("/Looks/Odd/Surface", "inputs:diffuseColor", "must be a 3-vector (double3 or float3), not float; "
                                                               "the UsdPreviewSurface default (0.18, 0.18, 0.18) is used"),
                  ("/Looks/Odd/Surface", "inputs:metallic", "must be a real number (double or float), not color3f; "
                                                           "the UsdPreviewSurface default (0.0,) is used")])


def _png(pixels) -> bytes:
    """An 8-bit PNG of ``pixels`` (H, W, 3) uint8, through OpenImageIO."""
    import tempfile

    import numpy as np
    import OpenImageIO as oiio

    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "image.png")
        out = oiio.ImageOutput.create(path)
        out.open(path, oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.UINT8))
        out.write_image(pixels)
        out.close()
        return Path(path).read_bytes()


def textured() -> Stage:
    """A texture on diffuseColor through a PrimvarReader (rendered), a normal map (not
    honoured), a texture whose file is missing (its fallback), and a second mesh that
    lacks the st primvar (the reader's fallback st)."""
    looks = _material("Wood", '''color3f inputs:diffuseColor.connect = </Looks/Wood/Tex.outputs:rgb>
            color3f inputs:emissiveColor.connect = </Looks/Wood/Glow.outputs:rgb>
            normal3f inputs:normal.connect = </Looks/Wood/Bump.outputs:rgb>''')[:-6] + '''
        def Shader "Tex"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @wood.png@
            float2 inputs:st.connect = </Looks/Wood/St.outputs:result>
            float3 outputs:rgb
        }
        def Shader "Glow"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @glow.png@
            float2 inputs:st.connect = </Looks/Wood/St.outputs:result>
            float3 outputs:rgb
        }
        def Shader "Bump"
        {
            uniform token info:id = "UsdUVTexture"
            asset inputs:file = @wood_normal.png@
            float3 outputs:rgb
        }
        def Shader "St"
        {
            uniform token info:id = "UsdPrimvarReader_float2"
            string inputs:varname = "st"
            float2 outputs:result
        }
    }'''
    quads = f'''
def Mesh "WoodQuad" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    {QUAD}
    texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (interpolation = "vertex")
    rel material:binding = </Looks/Wood>
}}
def Mesh "BareQuad" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [(1, -1, 0), (3, -1, 0), (3, 1, 0), (1, 1, 0)]
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    rel material:binding = </Looks/Wood>
}}'''
    grain = [[(160 + 10 * ((x + y) % 3), 110, 60) for x in range(8)] for y in range(8)]
    return Stage("wood.usda", {"wood.usda": _stage(f'def Scope "Looks"\n{{{looks}\n}}\n' + quads)},
                 [("/Looks/Wood/Surface", "inputs:normal", "is connected to /Looks/Wood/Bump (UsdUVTexture): textures "
                                                          "(UsdUVTexture) are read on diffuseColor, emissiveColor and "
                                                          "metallic only; ignored"),
                  ("/Looks/Wood/Glow", "inputs:file", "glow.png cannot be found; the texture's fallback (0.0, 0.0, "
                                                      "0.0, 1.0) is used"),
                  ("/BareQuad", "primvars:st", "is not authored, but a texture reads it; the primvar reader's "
                                               "fallback (0.0, 0.0) is used")],
                 others={"wood.png": _png(grain)})


def other_shaders() -> Stage:
    """A MaterialX network (outputs:mtlx:surface, read since issue 16's MaterialX item) with
    an input it does not honour, another render context's surface only, and a universal
    surface of another shader."""
    looks = '''
    def Material "Metal"
    {
        token outputs:mtlx:surface.connect = </Looks/Metal/Std.outputs:out>
        def Shader "Std"
        {
            uniform token info:id = "ND_standard_surface_surfaceshader"
            float inputs:metalness = 1
            float inputs:specular_roughness = 0.05
            token outputs:out
        }
    }
    def Material "Ri"
    {
        token outputs:ri:surface.connect = </Looks/Ri/Disney.outputs:out>
        def Shader "Disney"
        {
            uniform token info:id = "PxrDisneyBsdf"
            token outputs:out
        }
    }''' + _material("Pxr", "", shader_id="PxrSurface")
    return Stage("shaders.usda", {"shaders.usda": _stage(f'def Scope "Looks"\n{{{looks}\n}}\n'
                                                         + _bound_quads("Metal", "Ri", "Pxr"))},
                 [("/Looks/Metal/Std", "inputs:specular_roughness", LAMBERT),
                  ("/Looks/Ri", "outputs:ri:surface", "only a UsdPreviewSurface on outputs:surface or a MaterialX "
                                                      "surface on outputs:mtlx:surface is supported (not this render "
                                                      "context's shading); displayColor is used"),
                  ("/Looks/Pxr", "outputs:surface", "its shader /Looks/Pxr/Surface is 'PxrSurface', not "
                                                    "UsdPreviewSurface, which is the only one supported; displayColor "
                                                    "is used")])


def animated() -> Stage:
    """A turntable (time-sampled rotation on a parent Xform: honoured since issue 18, not
    warned), a deforming mesh on it whose points are time-sampled (honoured since issue 18:
    an info line, not a warning), a pulsing sphere radius, a body's
    time-sampled spacetime attribute beside its default, and instancer velocities."""
    return Stage("anim.usda", {"anim.usda": _stage('''
def Xform "Turntable"
{
    float xformOp:rotateY.timeSamples = { 1: 0, 24: 360 }
    uniform token[] xformOpOrder = ["xformOp:rotateY"]
    def Mesh "Cloth"
    {
        point3f[] points.timeSamples = {
            1: [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
            12: [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],
        }
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
    }
}
def Sphere "Pulse"
{
    double radius = 0.5
    double radius.timeSamples = { 1: 0.5, 24: 1 }
}
def Xform "Probe" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{
    custom double spacetime:referenceTime = 0
    custom double spacetime:referenceTime.timeSamples = { 1: 0, 2: 1 }
    def Cube "Box"
    {
        double size = 0.5
    }
}
def PointInstancer "Swarm"
{
    point3f[] positions = [(-1, 1.2, 0), (1, 1.2, 0)]
    vector3f[] velocities = [(1, 0, 0), (1, 0, 0)]
    int[] protoIndices = [0, 0]
    rel prototypes = </Swarm/Dot>
    def Cube "Dot"
    {
        double size = 0.2
    }
}
''')},
        [("/Pulse", "radius", f"has 2 time samples (1 to 24); {ANIMATED}"),
         ("/Probe", "spacetime:referenceTime", "has 2 time samples (1 to 2); USD animation is not rendered yet: "
                                               "every frame uses its default value"),
         ("/Swarm", "velocities", "motion from velocities is not rendered; ignored")])


def lights() -> Stage:
    """Lights as assets author them: a dome (the sky: tests/rendering/test_sky.py), a cylinder
    light (ignored), a rect light, a sphere light with a radius (honoured), shaping and a
    filter (warned), a distant light with an angle (honoured)."""
    return Stage("lit.usda", {"lit.usda": _stage(f'''{CAMERA}
def Mesh "Floor"
{{
    {QUAD}
}}
def DomeLight "Sky"
{{
}}
def RectLight "Softbox"
{{
}}
def CylinderLight "Tube"
{{
}}
def SphereLight "Bulb" (prepend apiSchemas = ["ShapingAPI"])
{{
    float inputs:intensity = 10
    float inputs:radius = 2
    float inputs:shaping:cone:angle = 30
    rel light:filters = </Gobo>
    double3 xformOp:translate = (0, 0, 5)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
def DistantLight "Sun"
{{
    float inputs:angle = 5
}}
def Xform "Gobo"
{{
}}
''')}, [("/Tube", None, "CylinderLight is not supported (only SphereLight, DistantLight, RectLight and DiskLight "
                        "are); ignored"),
        ("/Bulb", "inputs:shaping:cone:angle", "light shaping is not supported; ignored"),
        ("/Bulb", "light:filters", "light filters are not supported; ignored")],
        default_camera=False)


def subdivision() -> Stage:
    """Three subdivision surfaces (schemes authored): one warning for the stage."""
    meshes = "\n".join(f'''
def Mesh "Sub{i}"
{{
    {QUAD.replace(", 0)", f", {i})")}
    uniform token subdivisionScheme = "{scheme}"
}}''' for i, scheme in enumerate(("catmullClark", "loop", "bilinear")))
    return Stage("subdiv.usda", {"subdiv.usda": _stage(meshes + '''
def Mesh "Poly"
{
    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    uniform token subdivisionScheme = "none"
}
''')}, [("/Sub0", "subdivisionScheme", "subdivision surfaces are not refined (and 2 more meshes): they render their "
                                       "control cage (the authored polygons)")])


def points_and_curves() -> Stage:
    """Hair, a point cloud and a NURBS patch beside a mesh: skipped with a warning each."""
    return Stage("groom.usda", {"groom.usda": _stage(f'''
def Mesh "Scalp"
{{
    {QUAD}
}}
def BasisCurves "Hair"
{{
    int[] curveVertexCounts = [2]
    point3f[] points = [(0, 0, 0), (0, 1, 0)]
}}
def Points "Dust"
{{
    point3f[] points = [(0, 0, 1)]
}}
def NurbsPatch "Sheet"
{{
}}
''')}, [("/Hair", None, "BasisCurves gprims are not rendered; skipped"),
        ("/Dust", None, "Points gprims are not rendered; skipped"),
        ("/Sheet", None, "NurbsPatch gprims are not rendered; skipped")])


def shapes() -> Stage:
    """Every analytic gprim on every axis, with two radii where the schema has them."""
    body, x = [], -9.0
    for kind, extra in (("Cylinder", ""), ("Cone", ""), ("Capsule", ""), ("Plane", "double length = 1"),
                        ("Cylinder_1", "double radiusTop = 0.25"), ("Capsule_1", "double radiusBottom = 0.25")):
        for axis in "XYZ":
            body.append(f'''
def {kind} "{kind}{axis}"
{{
    token axis = "{axis}"
    {extra}
    double3 xformOp:translate = ({x}, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}''')
            x += 1.0
    return Stage("shapes.usda", {"shapes.usda": _stage("\n".join(body))}, [])


def skinned() -> Stage:
    """A mesh bound to a skeleton without joint indices (UsdSkel does not skin it): rendered
    as authored, with one warning."""
    return Stage("skel.usda", {"skel.usda": _stage(f'''
def SkelRoot "Character"
{{
    def Skeleton "Rig"
    {{
        uniform token[] joints = ["root"]
    }}
    def Mesh "Skin" (prepend apiSchemas = ["SkelBindingAPI"])
    {{
        {QUAD}
        rel skel:skeleton = </Character/Rig>
    }}
}}
''')}, [("/Character/Skin", "primvars:skel:jointIndices", "the mesh is bound to a skeleton but has no joint indices: "
                                                    "UsdSkel does not skin it; rendered as authored")])


def camera_and_settings() -> Stage:
    """A camera with depth of field and exposure, settings with a pixel aspect ratio; the
    clipping range (no clipping in a ray tracer) is not warned of."""
    return Stage("dof.usda", {"dof.usda": _stage(f'''
def Camera "Cam"
{{
    double3 xformOp:translate = (0, 0, 20)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    float fStop = 2.8
    float focusDistance = 20
    float exposure = 1
    float2 clippingRange = (0.1, 100)
}}
def Mesh "Card"
{{
    {QUAD}
}}
def RenderSettings "Settings"
{{
    rel camera = </Cam>
    uniform float pixelAspectRatio = 2
}}
''')}, [("/Cam", "fStop", "depth of field is not rendered; ignored"),
        ("/Cam", "exposure", "camera exposure is not applied; ignored"),
        ("/Settings", "pixelAspectRatio", "is not honoured by the renderer; ignored")], default_camera=False)


def unknown_types_and_subsets() -> Stage:
    """A prim of a type no loaded schema knows, and per-face (GeomSubset) material bindings
    (honoured: tests/usd/test_materials.py)."""
    looks = _material("Red", "color3f inputs:diffuseColor = (1, 0, 0)") + _material(
        "Blue", "color3f inputs:diffuseColor = (0, 0, 1)")
    return Stage("subsets.usda", {"subsets.usda": _stage(f'''def Scope "Looks"
{{{looks}
}}
def PxrMeshLight "Glow"
{{
}}
def Mesh "Dice" (prepend apiSchemas = ["MaterialBindingAPI"])
{{
    point3f[] points = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0), (3, -1, 0), (3, 1, 0)]
    int[] faceVertexCounts = [4, 4]
    int[] faceVertexIndices = [0, 1, 2, 3, 1, 4, 5, 2]
    rel material:binding = </Looks/Red>
    def GeomSubset "Right" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        uniform token elementType = "face"
        uniform token familyName = "materialBind"
        int[] indices = [1]
        rel material:binding = </Looks/Blue>
    }}
}}
''')}, [("/Glow", None, "its type 'PxrMeshLight' is not known to USD here (no schema is loaded for it); not rendered")])


#: Every class of the corpus, by name.
CORPUS = {f.__name__: f for f in (chess_piece, vehicle_z_up, missing_arcs, materialx_reference, bad_primvars,
                                  bad_material_inputs, textured, other_shaders, animated, lights, subdivision,
                                  points_and_curves, shapes, skinned, camera_and_settings, unknown_types_and_subsets)}
