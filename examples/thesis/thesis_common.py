"""Shared helpers for the thesis experiments: hit events, edges, fits, tables, the command line.

Everything here is plain NumPy in float64 and independent of the renderer's kernels:
pixel directions are docs/spec.md §3's pinhole (``warp_st.rendering.camera.ray_directions``,
the float64 twin of the kernel camera), and hit events are rebuilt from the AOVs alone
(a camera at rest: event = (t_c - Z, c + Z n) with n the pixel's direction).
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if importlib.util.find_spec("warp_st") is None:  # run from a checkout without `pip install -e .`
    sys.path.insert(0, str(ROOT))
SCENES = ROOT / "usd_scenes" / "thesis"
BETA_FAST = math.sqrt(3.0) / 2.0  # the thesis's "0.866c" (gamma = 2)

from warp_st.rendering.camera import pixel_directions, ray_directions  # noqa: E402


# --------------------------------------------------------------------------- pinhole


def pixel_of(cam, width: int, height: int, dirs) -> np.ndarray:
    """Continuous pixel coordinates (px, py) of rest-frame lab-axes directions (..., 3)."""
    d = np.asarray(dirs, np.float64) @ np.asarray(cam.rotation, np.float64)  # camera axes
    f = float(cam.focal_length)
    h_ap = float(cam.horizontal_aperture)
    v_ap = h_ap * height / width
    x = -f * d[..., 0] / d[..., 2] - float(cam.horizontal_aperture_offset)
    y = -f * d[..., 1] / d[..., 2] - float(cam.vertical_aperture_offset)
    px = (x / (0.5 * h_ap) + 1.0) * width / 2.0
    py = (1.0 - y / (0.5 * v_ap)) * height / 2.0
    return np.stack([px, py], axis=-1)


def hit_events(img, cam) -> tuple[np.ndarray, np.ndarray]:
    """(t, x): event time (H, W) and lab position (H, W, 3) of every pixel's first hit,
    rebuilt from the AOVs for a camera AT REST: x = c + Z n (Z = the lookback s; docs/spec.md §4,
    the distance in the camera's rest frame, which is the lab here). NaN on misses."""
    if np.any(np.asarray(cam.velocity)):
        raise ValueError("hit_events needs a camera at rest")
    n = pixel_directions(cam, img.width, img.height)
    z = img.depth.astype(np.float64)
    z = np.where(img.object_id > 0, z, np.nan)
    x = np.asarray(cam.position, np.float64) + z[..., None] * n
    return img.event_time.astype(np.float64), x


def body_id(img, prim_path: str) -> int:
    """objectId of the body whose prim path is ``prim_path`` (img.id_manifest)."""
    for k, p in img.id_manifest.items():
        if p == prim_path:
            return int(k)
    raise KeyError(f"{prim_path} is not in the image's id manifest {img.id_manifest}")


def ray_plane(cam, width, height, px, py, normal, offset) -> np.ndarray:
    """Lab points where the rays of a camera at rest through (px, py) meet n·x = offset."""
    d = ray_directions(cam, width, height, px, py)
    c = np.asarray(cam.position, np.float64)
    n = np.asarray(normal, np.float64)
    s = (offset - c @ n) / (d @ n)
    return c + s[..., None] * d


# --------------------------------------------------------------------------- edges


def row_edges(mask: np.ndarray, side: str, *, boundary: np.ndarray | None = None):
    """Per row, the outermost ``mask`` pixel on ``side`` ("left" / "right") whose
    neighbour beyond it is outside the mask: [(row, col, neighbour col)].

    ``boundary`` (optional, same shape) restricts to rows where that neighbour lies in
    it (e.g. the part of the image the edge must be seen against)."""
    out = []
    for j in range(mask.shape[0]):
        cols = np.flatnonzero(mask[j])
        if len(cols) == 0:
            continue
        i = cols[-1] if side == "right" else cols[0]
        nb = i + 1 if side == "right" else i - 1
        if not 0 <= nb < mask.shape[1] or mask[j, nb]:
            continue
        if boundary is not None and not boundary[j, nb]:
            continue
        out.append((j, int(i), int(nb)))
    return out


def plane_edge_x(img, cam, mask, side, *, plane_z, axis=0):
    """Edge of a surface lying in the plane z = ``plane_z``, seen by a camera at rest,
    located per row to half a pixel from the hit events.

    For each row: the outermost ``mask`` pixel's hit position (on the surface) and the
    point where the next pixel's ray meets the same plane (the surface would be there
    had it reached that far). The edge lies between them: returns rows of
    (row, lab y of the hit, edge coordinate = their midpoint, half their gap, event time
    of the edge pixel); ``axis`` picks the coordinate (0: x)."""
    t, x = hit_events(img, cam)
    rows = []
    for j, i, nb in row_edges(mask, side):
        inside = x[j, i]
        if not np.isfinite(inside).all() or abs(inside[2] - plane_z) > 1e-3:
            continue
        beyond = ray_plane(cam, img.width, img.height, nb + 0.5, j + 0.5, (0, 0, 1), plane_z)
        a, b = inside[axis], beyond[axis]
        rows.append((j, inside[1], 0.5 * (a + b), 0.5 * abs(b - a), t[j, i]))
    return np.array(rows, dtype=np.float64).reshape(-1, 5)


# --------------------------------------------------------------------------- outlines


def boundary_midpoints(mask: np.ndarray) -> np.ndarray:
    """Continuous pixel coordinates (N, 2) of the midpoints between each mask pixel and
    each of its 4-neighbours outside the mask: the outline, unbiased to half a pixel.
    The image border is not an outline."""
    h, w = mask.shape
    pad = np.pad(mask, 1, constant_values=True)
    pts = []
    for dj, di in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        nb = pad[1 + dj:1 + dj + h, 1 + di:1 + di + w]  # nb[j, i] = mask[j + dj, i + di]
        jj, ii = np.nonzero(mask & ~nb)
        pts.append(np.stack([ii + 0.5 + 0.5 * di, jj + 0.5 + 0.5 * dj], axis=1))
    return np.concatenate(pts).astype(np.float64)


def solid_angle_centroid(cam, width, height, mask) -> np.ndarray:
    """Unit mean direction of the pixels in ``mask``, each weighted by its solid angle
    (a pinhole pixel at angle theta off-axis subtends ∝ cos^3 theta)."""
    j, i = np.nonzero(mask)
    d = ray_directions(cam, width, height, i + 0.5, j + 0.5)
    axis = np.asarray(cam.rotation, np.float64) @ np.array([0.0, 0.0, -1.0])
    w = (d @ axis) ** 3
    m = (d * w[:, None]).sum(axis=0)
    return m / np.linalg.norm(m)


def angle_deg(a, b) -> float:
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    return math.degrees(math.atan2(np.linalg.norm(np.cross(a, b)), float(a @ b)))


# --------------------------------------------------------------------------- stages


def open_stage(path):
    """A Usd.Stage of ``path`` that the examples may edit in memory before
    ``warp_st.load(stage)`` (e.g. to hide a reticle or widen a lens); the file is not touched."""
    from pxr import Usd

    import warp_st  # noqa: F401  (registers the spacetime schemas before pxr is used)

    return Usd.Stage.Open(str(path))


# --------------------------------------------------------------------------- tables


@dataclass
class Row:
    """One measured quantity: measured beside the closed form and the thesis's number."""

    name: str
    measured: float
    expected: float
    tol: float
    unit: str = ""
    thesis: str = ""
    note: str = ""

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.measured) and abs(self.measured - self.expected) <= self.tol)


def print_table(title: str, rows: list[Row], command: str) -> None:
    print(f"## {title}")
    print(f"$ {command}")
    print("| quantity | measured | expected (closed form) | tolerance | thesis | ok |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        u = f" {r.unit}" if r.unit else ""
        print(f"| {r.name} | {r.measured:.5g}{u} | {r.expected:.5g}{u} | ±{r.tol:.2g} | {r.thesis} | "
              f"{'yes' if r.ok else 'NO'} |")
    notes = [r for r in rows if r.note]
    for r in notes:
        print(f"- {r.name}: {r.note}")


def summary(rows: list[Row]) -> int:
    bad = [r.name for r in rows if not r.ok]
    print(f"{len(rows) - len(bad)}/{len(rows)} within tolerance" + (f"; outside: {', '.join(bad)}" if bad else ""))
    return 1 if bad else 0


# --------------------------------------------------------------------------- command line


def experiment_main(argv, run, doc: str, title: str, script: str, *, quick: str,
                    out: str = "write the rendered EXRs here") -> int:
    """The command line of one experiment: ``--quick`` (help text ``quick``) and ``--out DIR``
    (help text ``out``) go to ``run(quick, out)``, whose rows are printed as the table
    ``title`` with the command that made it; exit status 1 when a row is out of tolerance."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=quick)
    parser.add_argument("--out", type=Path, default=None, help=out)
    args = parser.parse_args(argv)
    rows = run(args.quick, args.out)
    print_table(title, rows, f"python {script}" + (" --quick" if args.quick else ""))
    return summary(rows)
