"""A textured globe passing the camera at 0.9c: its meridians turned by Terrell rotation.

Writes a USD stage (a UV-sphere mesh with faceVarying st, a UsdUVTexture of a globe map
whose red channel is the longitude), renders it at rest and moving at beta along +x
across the view, and prints the longitude seen at the image centre beside the closed
form. The ray through the image centre passes through the sphere's centre event, so in
the sphere's rest frame it leaves the surface point whose outward normal is the photon's
rest-frame direction, the aberrated (-beta, 0, 1/gamma): longitude -asin(beta), the
trailing side turned towards the camera (-64.2 degrees at 0.9c; 0 at rest).

    python examples/terrell_globe.py [--beta 0.9] [--out DIR] [--width 321 --height 241]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

import warp_st

TEX_W, TEX_H = 256, 128
N_LON, N_LAT = 96, 48
DISTANCE = 6.0


def globe_texture() -> np.ndarray:
    """(H, W, 3) uint8: red = longitude column (0..255 from -180 to +180 degrees), green =
    latitude, blue = a graticule every 30 degrees; the prime meridian is bright (green and
    blue full, red still the column)."""
    j, i = np.mgrid[0:TEX_H, 0:TEX_W]
    lon = (i + 0.5) / TEX_W * 360.0 - 180.0
    lat = 90.0 - (j + 0.5) / TEX_H * 180.0
    grid = (np.abs((lon + 15.0) % 30.0 - 15.0) < 1.5) | (np.abs((lat + 15.0) % 30.0 - 15.0) < 1.5)
    rgb = np.stack([i, (255 * (lat + 90.0) / 180.0).astype(int), np.where(grid, 255, 40)], axis=-1)
    prime = np.abs(lon) < 2.0
    rgb[prime, 1:] = 255
    return rgb.astype(np.uint8)


def uv_sphere(radius: float = 1.0):
    """Points (outward: lon 0 faces +z, +y up), quads by (lat, lon), faceVarying st per corner."""
    lats = np.linspace(-90.0, 90.0, N_LAT + 1)
    lons = np.linspace(-180.0, 180.0, N_LON + 1)
    la, lo = np.radians(lats)[:, None], np.radians(lons)[None, :]
    pts = radius * np.stack([np.cos(la) * np.sin(lo), np.sin(la) * np.ones_like(lo), np.cos(la) * np.cos(lo)], -1)
    index = np.arange((N_LAT + 1) * (N_LON + 1)).reshape(N_LAT + 1, N_LON + 1)
    faces, st = [], []
    for a in range(N_LAT):
        for b in range(N_LON):
            corners = [(a, b), (a, b + 1), (a + 1, b + 1), (a + 1, b)]
            faces.append([index[c] for c in corners])
            st.extend((c[1] / N_LON, c[0] / N_LAT) for c in corners)
    return pts.reshape(-1, 3), np.array(faces), np.array(st)


def _array(values, fmt) -> str:
    return "[" + ", ".join(fmt(v) for v in values) + "]"


def write_stage(folder: Path, beta: float) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    out = oiio.ImageOutput.create(str(folder / "globe.png"))
    tex = globe_texture()
    out.open(str(folder / "globe.png"), oiio.ImageSpec(TEX_W, TEX_H, 3, oiio.UINT8))
    out.write_image(tex)
    out.close()
    pts, faces, st = uv_sphere()
    gamma = 1.0 / math.sqrt(1.0 - beta * beta)
    xyz = lambda p: f"({p[0]:.9g}, {p[1]:.9g}, {p[2]:.9g})"  # noqa: E731
    text = f'''#usda 1.0
(
    upAxis = "Y"
    startTimeCode = 0
    endTimeCode = 0
)
def Camera "Cam"
{{
    float focalLength = 30
}}
def Material "Globe"
{{
    token outputs:surface.connect = </Globe/Surface.outputs:surface>
    def Shader "Surface"
    {{
        uniform token info:id = "UsdPreviewSurface"
        color3f inputs:diffuseColor.connect = </Globe/Map.outputs:rgb>
        token outputs:surface
    }}
    def Shader "Map"
    {{
        uniform token info:id = "UsdUVTexture"
        asset inputs:file = @globe.png@
        token inputs:sourceColorSpace = "raw"
        token inputs:wrapS = "repeat"
        token inputs:wrapT = "clamp"
        float2 inputs:st.connect = </Globe/Reader.outputs:result>
        float3 outputs:rgb
    }}
    def Shader "Reader"
    {{
        uniform token info:id = "UsdPrimvarReader_float2"
        string inputs:varname = "st"
        float2 outputs:result
    }}
}}
def Xform "Flyby" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    double3 xformOp:translate = (0, 0, {-DISTANCE})
    uniform token[] xformOpOrder = ["xformOp:translate"]
    double4 spacetime:fourVelocity = ({gamma!r}, {gamma * beta!r}, 0, 0)
    double spacetime:referenceTime = {-DISTANCE}
    def Mesh "Earth" (prepend apiSchemas = ["MaterialBindingAPI"])
    {{
        point3f[] points = {_array(pts, xyz)}
        normal3f[] normals = {_array(pts, xyz)} (interpolation = "vertex")
        int[] faceVertexCounts = {_array([4] * len(faces), str)}
        int[] faceVertexIndices = {_array(faces.reshape(-1), str)}
        texCoord2f[] primvars:st = {_array(st, lambda u: f"({u[0]:.9g}, {u[1]:.9g})")} (interpolation = "faceVarying")
        rel material:binding = </Globe>
    }}
}}
'''
    path = folder / f"globe_{beta:g}.usda"
    path.write_text(text)
    return path


def centre_longitude(img) -> float:
    """Longitude (degrees) of the texel seen at the image's centre pixel (odd sizes)."""
    h, w = img.rgba.shape[:2]
    column = int(round(float(img.rgba[h // 2, w // 2, 0]) * 255.0))
    return (column + 0.5) / TEX_W * 360.0 - 180.0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beta", type=float, default=0.9)
    parser.add_argument("--out", default="terrell_globe", help="folder for the stages, EXRs and PNG")
    parser.add_argument("--width", type=int, default=321)
    parser.add_argument("--height", type=int, default=241)
    args = parser.parse_args(argv)
    out = Path(args.out)
    frames = []
    for beta in (0.0, args.beta):
        scene = warp_st.load(str(write_stage(out, beta)))
        img = warp_st.render(scene, frame=0, width=args.width, height=args.height)
        img.write_exr(str(out / f"globe_{beta:g}.exr"))
        frames.append(img.rgba[..., :3])
        closed = -math.degrees(math.asin(beta))
        print(f"beta {beta:g}: longitude at the image centre {centre_longitude(img):+.1f} deg "
              f"(closed form -asin(beta) = {closed:+.1f} deg; texel width {360.0 / TEX_W:.1f} deg)")
    both = np.concatenate([frames[0], np.ones((args.height, 4, 3)), frames[1]], axis=1)
    png = oiio.ImageOutput.create(str(out / "terrell_globe.png"))
    png.open(str(out / "terrell_globe.png"), oiio.ImageSpec(both.shape[1], both.shape[0], 3, oiio.UINT8))
    png.write_image((np.clip(both, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8))
    png.close()
    print(f"wrote {out / 'terrell_globe.png'} (at rest | at beta {args.beta:g})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
