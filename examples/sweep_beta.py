"""Apparent length of a moving rod against beta: a parameter study with ``warp_st.sweep``.

Two flat rods of rest length L move along +x at speed beta in the plane z = -D in front of a
camera at rest at the origin (90 degree view, camera time 0, light speed finite). Each beta
is its own scene, placed so that the rods' centres are *seen* 30 degrees left (the rod
coming towards the camera) and 30 degrees right (going away). From the image alone, the
script measures where each rod's ends appear in the centre row (the first and last pixel of
its objectId, the edge taken at the pixel boundary, so within half a pixel) and compares
them with the closed form:

- an end at rest coordinate xi is at u = u_c + xi / gamma at camera time (contracted about
  the rod's centre u_c); the light that reaches the camera left it at x_e with
  u - x_e = beta * sqrt(x_e^2 + D^2) (the rod moved on while the light crossed the
  distance), so x_e = gamma^2 (u - beta sqrt(u^2 + D^2 / gamma^2)) and tan(angle) = x_e / D;
- a centre seen at tan = s lies at u_c = s + beta sqrt(s^2 + D^2).

For a short rod the apparent length is L / (gamma (1 - beta cos phi)), phi the angle
between the velocity and the line of sight: the approaching rod first looks longer than at
rest, then shorter; the receding one only shorter. The plot shows the measured apparent
lengths on the closed-form curves, and each edge's residual in pixels.

    python examples/sweep_beta.py [--betas 0.1,0.3,...] [--width 4096] [--workers N]
                                  [--out docs/images/sweep_rod_length.png]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
os.environ.setdefault("WARP_CACHE_PATH", str(ROOT / ".warp_cache"))

import warp_st  # noqa: E402

BETAS = (0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.99)
LENGTH = 2.0  # rest length L
HEIGHT = 0.4  # the rods' extent in y (they fill the one-row image)
DISTANCE = 10.0  # D
SEEN_AT = math.tan(math.radians(30.0))  # |tan| of the apparent centres
FOCAL = 10.4775  # with the 20.955 aperture: a 90 degree view
APERTURE = 20.955
RODS = {"approaching": -SEEN_AT, "receding": SEEN_AT}  # apparent centre, tan of the view angle


def gamma(beta: float) -> float:
    return 1.0 / math.sqrt(1.0 - beta * beta)


def centre_position(beta: float, seen_tan: float) -> float:
    """u_c: where the rod's centre is at camera time when it is seen at tan = seen_tan."""
    s = seen_tan * DISTANCE
    return s + beta * math.hypot(s, DISTANCE)


def seen_tan(beta: float, u: float) -> float:
    """tan of the direction in which the rod point at x = u (at camera time) is seen."""
    g2 = gamma(beta) ** 2
    x_e = g2 * (u - beta * math.sqrt(u * u + DISTANCE * DISTANCE / g2))
    return x_e / DISTANCE


def expected_edges(beta: float, seen: float) -> tuple[float, float]:
    """(left, right) end of a rod seen centred at tan = ``seen``, as tan of the view angle."""
    u_c = centre_position(beta, seen)
    half = 0.5 * LENGTH / gamma(beta)
    return seen_tan(beta, u_c - half), seen_tan(beta, u_c + half)


def make_scene(beta: float):
    """The stage of one beta: two Lorentz-coupled rods (flat quads) and the camera."""
    from pxr import Sdf, Usd

    rods = []
    for name, seen in RODS.items():
        u_c = centre_position(beta, seen)
        rods.append(f"""
    def Xform "{name.capitalize()}" (prepend apiSchemas = ["SpacetimeBodyAPI"])
    {{
        double3 xformOp:translate = ({u_c!r}, 0, {-DISTANCE!r})
        uniform token[] xformOpOrder = ["xformOp:translate"]
        double4 spacetime:fourVelocity = (1, {beta!r}, 0, 0)
        def Mesh "Rod"
        {{
            int[] faceVertexCounts = [4]
            int[] faceVertexIndices = [0, 1, 2, 3]
            point3f[] points = [({-LENGTH / 2}, {-HEIGHT / 2}, 0), ({LENGTH / 2}, {-HEIGHT / 2}, 0),
                                ({LENGTH / 2}, {HEIGHT / 2}, 0), ({-LENGTH / 2}, {HEIGHT / 2}, 0)]
        }}
    }}""")
    text = f"""#usda 1.0
(
    upAxis = "Y"
)
def Xform "World"
{{
    def Camera "Camera"
    {{
        float focalLength = {FOCAL}
        float horizontalAperture = {APERTURE}
    }}{"".join(rods)}
}}
"""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.ImportFromString(text)
    return Usd.Stage.Open(layer)


def rod_edges(image) -> list[tuple[float, float]]:
    """Per rod (objectId 1, 2): (left, right) edge in the centre row, as tan of the view angle.

    The edge is taken at the boundary between the last miss and the first hit pixel, so
    it is within half a pixel of the true edge.
    """
    row = image.object_id[image.height // 2]
    width = image.width
    edges = []
    for object_id in (1, 2):
        hits = np.flatnonzero(row == object_id)
        if hits.size == 0:
            edges.append((math.nan, math.nan))
            continue
        ndc = (2.0 * np.array([hits[0], hits[-1] + 1]) / width) - 1.0
        edges.append(tuple(float(x) for x in ndc * APERTURE / (2.0 * FOCAL)))
    return edges


def run(betas=BETAS, *, width: int = 4096, workers: int | None = 0) -> list[dict]:
    """Sweep ``betas``; one row per beta and rod: measured and expected edges (tan)."""
    result = warp_st.sweep(make_scene, betas, frame=0, measure=rod_edges, workers=workers,
                           width=width, height=1, max_depth=0)
    pixel = APERTURE / (FOCAL * width)  # one pixel, in tan of the view angle
    rows = []
    for beta, edges in zip(result.values, result.results):
        for (name, seen), measured in zip(RODS.items(), edges):
            expected = expected_edges(beta, seen)
            rows.append({"beta": beta, "rod": name, "measured": measured, "expected": expected,
                         "error_px": [(m - e) / pixel for m, e in zip(measured, expected)]})
    return rows


def _degrees(edges) -> float:
    return math.degrees(math.atan(edges[1]) - math.atan(edges[0]))


def plot(rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, res) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    fine = np.linspace(0.0, 0.995, 400)
    at_rest = _degrees(expected_edges(0.0, SEEN_AT))
    ax.axhline(at_rest, color="0.6", ls=":", lw=1, label="at rest")
    for (name, seen), colour in zip(RODS.items(), ("tab:blue", "tab:red")):
        ax.plot(fine, [_degrees(expected_edges(b, seen)) for b in fine], color=colour, lw=1.2,
                label=f"{name}, closed form")
        mine = [r for r in rows if r["rod"] == name]
        ax.plot([r["beta"] for r in mine], [_degrees(r["measured"]) for r in mine], "o", color=colour, ms=5,
                mfc="none", label=f"{name}, measured")
        for side, marker in ((0, "<"), (1, ">")):
            res.plot([r["beta"] for r in mine], [r["error_px"][side] for r in mine], marker, color=colour, ms=5,
                     label=f"{('left', 'right')[side]} end" if name == "receding" else None)
    ax.set_ylabel("apparent length (degrees)")
    ax.set_title(f"Rod of rest length {LENGTH:g} at distance {DISTANCE:g}, seen 30° left / right (c = 1)")
    ax.legend(fontsize=8)
    res.axhspan(-0.5, 0.5, color="0.9", label="± half a pixel")
    res.legend(fontsize=7, ncol=3, loc="lower left")
    res.set_ylim(-0.8, 0.8)
    res.set_ylabel("edge − closed form\n(pixels)")
    res.set_xlabel("β = v / c")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--betas", default=",".join(map(str, BETAS)), help="comma-separated speeds")
    parser.add_argument("--width", type=int, default=4096, help="pixels in the one image row")
    parser.add_argument("--workers", type=int, default=0, help="Dask worker processes (0: this process)")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images" / "sweep_rod_length.png")
    args = parser.parse_args(argv)
    betas = [float(b) for b in args.betas.split(",")]
    rows = run(betas, width=args.width, workers=args.workers)
    print(f"{'beta':>5} {'rod':>11} {'measured deg':>13} {'closed form deg':>16} {'edge errors (px)':>18}")
    for r in rows:
        errors = " ".join(f"{e:+.2f}" for e in r["error_px"])
        print(f"{r['beta']:5.2f} {r['rod']:>11} {_degrees(r['measured']):13.4f} {_degrees(r['expected']):16.4f} "
              f"{errors:>18}")
    plot(rows, args.out)
    worst = max(abs(e) for r in rows for e in r["error_px"])
    print(f"wrote {args.out}; worst edge error {worst:.2f} px (bound 0.5 px)")
    return 0 if worst <= 0.5 else 1


if __name__ == "__main__":
    sys.exit(main())
