"""The thesis's aberration experiment under a real sky (issue 19): the observers of
``usd_scenes/thesis/aberration.usda`` inside a latlong DomeLight whose texels encode their
own lab direction.

Each texel's red channel is its longitude and green its latitude (the latlong mapping of
``warp_st.kernels.sky``), so every sky pixel of a render says which lab direction its light
came from. For each observer (at rest; moving towards the star, and to the left, at
0.866c, relativistic and classical) the sky pixels' decoded lab directions are compared
with the camera's own pixel directions carried to the lab by the aberration formulas
(``warp_st.rendering.camera.ray_directions``: the Lorentz boost, or Galilean addition for
a decoupled camera): the median and largest angle between them, in degrees, beside the
half-texel size (the resolution of the encoding). The star itself is aberrated by the same
boost; its apparent edges are ``examples/thesis/aberration.py``'s measurement.

    python examples/aberration_sky.py [--out DIR] [--width 160 --height 160]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

import warp_st
from warp_st.rendering.camera import pixel_directions

ROOT = Path(__file__).resolve().parents[1]
STAGE = ROOT / "usd_scenes" / "thesis" / "aberration.usda"
SKY_W, SKY_H = 2048, 1024
OBSERVERS = ("Rest", "Towards_0866_Relativistic", "Left_0866_Relativistic", "Left_0866_Classical")


def direction_sky() -> np.ndarray:
    """(H, W, 3) float32: each texel's longitude and latitude as red and green, in [0, 1]."""
    u = (np.arange(SKY_W) + 0.5) / SKY_W
    v = (np.arange(SKY_H) + 0.5) / SKY_H
    lon = np.pi - 2.0 * np.pi * u  # kernels/sky.py: u = (pi - lon) / 2 pi
    lat = 0.5 * np.pi - np.pi * v  # v = (pi/2 - lat) / pi
    sky = np.zeros((SKY_H, SKY_W, 3), np.float32)
    sky[..., 0] = ((lon + np.pi) / (2.0 * np.pi))[None, :]
    sky[..., 1] = ((lat + 0.5 * np.pi) / np.pi)[:, None]
    sky[..., 2] = 0.5
    return sky


def decode(rgb: np.ndarray) -> np.ndarray:
    """Unit lab directions from sky colours (the inverse of ``direction_sky``)."""
    lon = rgb[..., 0].astype(np.float64) * 2.0 * np.pi - np.pi
    lat = rgb[..., 1].astype(np.float64) * np.pi - 0.5 * np.pi
    return np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)], axis=-1)


def write_stage(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    sky = folder / "direction_sky.exr"
    out = oiio.ImageOutput.create(str(sky))
    out.open(str(sky), oiio.ImageSpec(SKY_W, SKY_H, 3, oiio.FLOAT))
    out.write_image(direction_sky())
    out.close()
    path = folder / "aberration_sky.usda"
    path.write_text(f'''#usda 1.0
(
    subLayers = [@{STAGE}@]
)
def DomeLight "Sky"
{{
    asset inputs:texture:file = @{sky.name}@
    token inputs:texture:format = "latlong"
}}
''')
    return path


def measure(scene, camera: str, width: int, height: int):
    """(median, max angle in degrees, sky pixels, image) for one observer."""
    img = warp_st.render(scene, frame=0, camera=camera, width=width, height=height)
    cam = scene.camera_state(camera, 0.0)
    expected = pixel_directions(cam, width, height, frame="lab")
    sky = img.object_id == 0
    got = decode(img.rgba[..., :3][sky])
    cos = np.clip(np.sum(got * expected[sky], axis=-1), -1.0, 1.0)
    angle = np.degrees(np.arccos(cos))
    return float(np.median(angle)), float(angle.max()), int(sky.sum()), img


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("aberration_sky_out"))
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=160)
    args = p.parse_args(argv)
    scene = warp_st.load(str(write_stage(args.out)))
    half_texel = 0.5 * 360.0 / SKY_W * math.sqrt(2.0)  # the encoding's resolution (diagonal)
    print(f"half a texel's diagonal: {half_texel:.3f} deg")
    print("| observer | sky pixels | angle to the aberrated pixel direction, median / max (deg) |")
    print("|---|---|---|")
    results = {}
    for name in OBSERVERS:
        med, mx, n, img = measure(scene, f"/World/Observers/{name}/Camera", args.width, args.height)
        img.write_exr(args.out / f"{name}.exr")
        results[name] = (med, mx, n)
        print(f"| {name} | {n} | {med:.3f} / {mx:.3f} |")
    return 0 if all(mx < 2.0 * half_texel for _m, mx, _n in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
