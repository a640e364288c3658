"""Flying through a starfield at 0.5, 0.9 and 0.99c: the stars crowd forward (the "starbow").

Writes a latlong starfield (an EXR of random white stars) as a UsdLux DomeLight and a
camera flying along its view direction (-Z) at each beta, renders each with Doppler
colour and the searchlight, and writes a strip of the frames (tone-mapped x / (1 + x)).
Aberration alone decides where the stars go: the lab's forward hemisphere, half of the
stars, appears within the half-angle acos(beta) of the flight direction (60, 25.8 and 8.1
degrees), printed with the range of the Doppler factor in view (``spacetime.doppler``).
With the Doppler colour the stars ahead shift out of the visible band (blue, then black)
and those behind to red: the ring between is the starbow.

    python examples/starbow.py [--betas 0.5 0.9 0.99] [--out DIR] [--width 240 --height 240]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

import warp_st

SKY_W, SKY_H = 1024, 512
FOCAL, APERTURE = 6.0, 20.955  # a 120-degree field of view


def starfield(count: int = 2500, seed: int = 7) -> np.ndarray:
    """(H, W, 3) float32: ``count`` white stars (2 x 2 texels) at uniform random directions."""
    rng = np.random.default_rng(seed)
    sky = np.zeros((SKY_H, SKY_W, 3), np.float32)
    z = rng.uniform(-1.0, 1.0, count)  # uniform on the sphere: uniform in sin(latitude)
    lon = rng.uniform(-np.pi, np.pi, count)
    rows = np.clip(((np.pi / 2 - np.arcsin(z)) / np.pi * SKY_H).astype(int), 0, SKY_H - 2)
    cols = np.clip(((np.pi - lon) / (2 * np.pi) * SKY_W).astype(int), 0, SKY_W - 2)
    brightness = rng.uniform(0.3, 1.0, count).astype(np.float32)
    for dr in (0, 1):
        for dc in (0, 1):
            sky[rows + dr, cols + dc] = brightness[:, None]
    return sky


def write_stage(folder: Path, beta: float) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    sky_path = folder / "starfield.exr"
    if not sky_path.exists():
        out = oiio.ImageOutput.create(str(sky_path))
        out.open(str(sky_path), oiio.ImageSpec(SKY_W, SKY_H, 3, oiio.FLOAT))
        out.write_image(starfield())
        out.close()
    gamma = 1.0 / math.sqrt(1.0 - beta * beta)
    path = folder / f"starbow_{beta:g}.usda"
    path.write_text(f'''#usda 1.0
(
    upAxis = "Y"
)
def Camera "Cam" (prepend apiSchemas = ["SpacetimeBodyAPI"])
{{
    float focalLength = {FOCAL}
    float horizontalAperture = {APERTURE}
    float verticalAperture = {APERTURE}
    double4 spacetime:fourVelocity = ({gamma!r}, 0, 0, {-gamma * beta!r})
}}
def DomeLight "Stars"
{{
    asset inputs:texture:file = @starfield.exr@
    token inputs:texture:format = "latlong"
}}
''')
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--betas", type=float, nargs="+", default=[0.5, 0.9, 0.99])
    parser.add_argument("--out", default="starbow", help="folder for the stages, the map and the strip")
    parser.add_argument("--width", type=int, default=240)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument("--samples", type=int, default=4)
    args = parser.parse_args(argv)
    out = Path(args.out)
    frames = []
    for beta in args.betas:
        scene = warp_st.load(str(write_stage(out, beta)))
        shown = warp_st.render(scene, frame=0, width=args.width, height=args.height, samples=args.samples,
                               doppler_color=True, searchlight=True)
        print(f"beta {beta:g}: the forward lab hemisphere appears within {math.degrees(math.acos(beta)):.1f} deg "
              f"of the flight direction; D in view from {np.nanmin(shown.doppler):.2f} to "
              f"{np.nanmax(shown.doppler):.2f}")
        rgb = shown.rgba[..., :3]
        frames.append(rgb / (1.0 + rgb))
        frames.append(np.ones((args.height, 4, 3)))
    strip = np.concatenate(frames[:-1], axis=1)
    png = oiio.ImageOutput.create(str(out / "starbow.png"))
    png.open(str(out / "starbow.png"), oiio.ImageSpec(strip.shape[1], strip.shape[0], 3, oiio.UINT8))
    png.write_image((np.clip(strip, 0.0, 1.0) ** (1 / 2.2) * 255.0 + 0.5).astype(np.uint8))
    png.close()
    print(f"wrote {out / 'starbow.png'} (beta {', '.join(f'{b:g}' for b in args.betas)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
