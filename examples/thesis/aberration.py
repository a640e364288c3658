"""Figs. 4.10-4.13 (thesis §4.4.3-4.4.4): classical and relativistic aberration, measured.

Renders the observers of ``usd_scenes/thesis/aberration.usda`` (at rest; moving towards,
away from, left and right of the star at 0.5c and 0.866c; classical = Lorentz-decoupled
camera, Galilean addition, and relativistic = Lorentz boost) and measures, in each
camera's rest frame, from the rendered image alone:

- the apparent direction of the red marker on the middle of the star's near face (the
  solid-angle-weighted mean direction of its pixels): the direction perpendicular to a
  sideways motion. The thesis's shifts are exactly its shifts: classical arctan(beta)
  (26.565 deg at 0.5c, "5.00 grid marks"), relativistic arcsin(beta) (30.0 deg, "5.77
  grid marks" = 10 tan 30);
- the star's left and right edges on the middle rows: the outermost star pixel, refined
  to a fraction of a pixel by extrapolating the light's lookback (t_c - eventTime, the
  distance to the face) along the row to the distance of the edge.

Expected values are the thesis's equations for a source at angle alpha from the
velocity: relativistic cos a' = (cos a + b) / (1 + b cos a) (Eq. 2.3), classical
tan t' = sin t / (cos t + b) (Eq. 2.1). The reticles are hidden for the measurement and
the lens widened where an expected direction is outside the 90 degree view (the
edits are made on an in-memory copy of the stage; the file is not changed).

    python examples/thesis/aberration.py [--quick] [--out DIR]
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import thesis_common as T  # noqa: E402

import warp_st  # noqa: E402
from warp_st.rendering.camera import ray_directions  # noqa: E402
from warp_st.rendering.renderer import Renderer  # noqa: E402

SCENE = T.SCENES / "aberration.usda"
HALF = 0.5e5  # half the star's side
NEAR = 1.0e5  # distance of its near face
EDGE_DEG = math.degrees(math.atan(HALF / NEAR))  # 26.565
DIRECTIONS = {"Towards": (0, 0, -1), "Away": (0, 0, 1), "Left": (-1, 0, 0), "Right": (1, 0, 0)}
SPEEDS = {"0500": 0.5, "0866": T.BETA_FAST}


def apparent(n_lab, beta, vhat, classical: bool) -> np.ndarray:
    """Thesis Eq. 2.3 (relativistic) or Eq. 2.1 (classical): the direction in which a
    source seen along the lab direction ``n_lab`` appears to an observer moving along
    ``vhat`` at ``beta``; it stays in the plane of vhat and n_lab."""
    n = np.asarray(n_lab, float) / np.linalg.norm(n_lab)
    vhat = np.asarray(vhat, float)
    ca = float(n @ vhat)
    sa = math.sqrt(max(0.0, 1.0 - ca * ca))
    if classical:
        a2 = math.atan2(sa, ca + beta)
    else:
        a2 = math.acos((ca + beta) / (1.0 + beta * ca))
    e = n - ca * vhat
    e = e / np.linalg.norm(e) if np.linalg.norm(e) > 1e-12 else np.array([1.0, 0.0, 0.0])
    return math.cos(a2) * vhat + math.sin(a2) * e


def view_angle(d) -> float:
    """Signed angle (deg) of a direction from the view axis -z, positive towards +x."""
    return math.degrees(math.atan2(d[0], -d[2]))


def expected(beta, vhat, classical):
    """(marker angle, left edge angle, right edge angle) in degrees, or at rest."""
    out = []
    for n in ((0, 0, -1), (-HALF, 0, -NEAR), (HALF, 0, -NEAR)):
        d = np.asarray(n, float) / np.linalg.norm(n)
        if beta > 0:
            d = apparent(d, beta, vhat, classical)
        out.append(view_angle(d))
    return out


def edge_angle(img, cam, mask, j, side):
    """Signed view angle (deg) of the star's edge on row j, refined along the row by the
    lookback s = t_c - eventTime, which on the near face grows as sqrt(x^2 + NEAR^2)
    towards the edge's known distance sqrt(HALF^2 + NEAR^2). Returns (angle, half-pixel
    width in degrees there)."""
    cols = np.flatnonzero(mask[j])
    i = int(cols[-1] if side == "right" else cols[0])
    step = -1 if side == "right" else 1
    idx = [i + k * step for k in range(4)]
    s = cam.time - img.event_time[j, idx].astype(np.float64)
    s_edge = math.hypot(HALF, NEAR)
    px = np.array(idx, float) + 0.5
    c = np.polyfit(s, px, 2)  # column as a function of the lookback
    p_edge = float(np.polyval(c, s_edge))
    boundary = i + (1.0 if side == "right" else 0.0)
    if not abs(p_edge - boundary) <= 1.0:  # a failed extrapolation: keep the pixel boundary
        p_edge = boundary
    d = ray_directions(cam, img.width, img.height, p_edge, j + 0.5)
    d2 = ray_directions(cam, img.width, img.height, p_edge + 0.5, j + 0.5)
    return view_angle(d), abs(view_angle(d2) - view_angle(d))


def measure(name, beta, vhat, classical, size, out=None):
    exp_marker, exp_left, exp_right = expected(beta, vhat, classical)
    need = max(abs(exp_left), abs(exp_right), abs(exp_marker))
    half_fov = max(45.0, math.degrees(math.atan(math.tan(math.radians(need)) / 0.85)))
    stage = T.open_stage(SCENE)
    from pxr import UsdGeom

    for prim in stage.Traverse():
        if prim.GetName() == "Reticle":
            UsdGeom.Imageable(prim).MakeInvisible()
    path = f"/World/Observers/{name}/Camera"
    cam_prim = UsdGeom.Camera(stage.GetPrimAtPath(path))
    if half_fov > 45.0:
        cam_prim.GetFocalLengthAttr().Set(float(0.5 * 20.955 / math.tan(math.radians(half_fov))))
    scene = warp_st.load(stage)
    img = Renderer(scene, frames=[0], camera=path, width=size, height=size).render(0)
    if out is not None:
        img.write_exr(str(Path(out) / f"thesis_aberration_{name}.exr"))
    cam = scene.camera_state(path, 0)
    star = T.body_id(img, "/World/Star")
    marker = T.body_id(img, "/World/StarCentre")
    m = T.solid_angle_centroid(cam, size, size, img.object_id == marker)
    cube = (img.object_id == star) | (img.object_id == marker)
    lefts, rights, hl, hr = [], [], [], []
    for j in (size // 2 - 1, size // 2):
        a, h = edge_angle(img, cam, cube, j, "left")
        lefts.append(a)
        hl.append(h)
        a, h = edge_angle(img, cam, cube, j, "right")
        rights.append(a)
        hr.append(h)
    # a pixel at the marker (for its tolerance): the angular size of half a pixel there
    pm = T.pixel_of(cam, size, size, m)
    hm = abs(view_angle(ray_directions(cam, size, size, pm[0] + 0.5, pm[1])) - view_angle(m))
    return dict(marker=(view_angle(m), exp_marker, hm), left=(np.mean(lefts), exp_left, max(hl)),
                right=(np.mean(rights), exp_right, max(hr)), hfov=2 * half_fov, img=img)


def observers(quick: bool):
    yield "Rest", 0.0, np.zeros(3), False
    for d, vhat in DIRECTIONS.items():
        for sname, beta in SPEEDS.items():
            if quick and (d, sname) not in (("Left", "0500"), ("Left", "0866"), ("Away", "0866"), ("Towards", "0500")):
                continue
            for model in ("Classical", "Relativistic"):
                yield f"{d}_{sname}_{model}", beta, np.asarray(vhat, float), model == "Classical"


def run(quick: bool = False, out: Path | None = None) -> list[T.Row]:
    size = 240 if quick else 480
    rows = []
    for name, beta, vhat, classical in observers(quick):
        r = measure(name, beta, vhat, classical, size, out)
        lens = f" ({r['hfov']:.0f} deg lens)" if r["hfov"] > 90.5 else ""
        # half a pixel of quantisation, shared by the two middle rows, and 0.01 deg of slack
        # for the refinement along the row
        edges = [("left edge", r["left"]), ("right edge", r["right"])]
        if name.startswith(("Left", "Right")) or name == "Rest":
            edges.insert(0, ("marker (face centre)", r["marker"]))
        for what, (meas, exp, half) in edges:
            thesis = ""
            if name == "Rest" and what != "marker (face centre)":
                thesis = "±26.565 (10 x 10 on the grid)"
            if name == "Left_0500_Classical" and what.startswith("marker"):
                thesis = "26.565 (\"5.00 grid marks\")"
            if name == "Left_0500_Relativistic" and what.startswith("marker"):
                thesis = "30.0 (\"5.77 grid marks\")"
            if name in ("Left_0500_Classical", "Left_0500_Relativistic") and what == "right edge":
                thesis = "the thesis reads 5.00 / 5.77 marks here"
            if name == "Away_0866_Relativistic" and what == "right edge":
                thesis = "153.4 -> 93.6 from v (Eq. 2.1's value)"
            note = ""
            if what.startswith("marker") and beta > 0:
                note = f"shift {abs(meas):.3f} deg = {10 * math.tan(math.radians(abs(meas))):.3f} grid marks"
            if what == "right edge" and name.startswith("Left_0500"):
                note = (f"moved {5 - 10 * math.tan(math.radians(meas)):.3f} grid marks from +5 "
                        f"(expected {5 - 10 * math.tan(math.radians(exp)):.3f})")
            if name.startswith("Away_0866") and what == "right edge":
                note = f"{180 - abs(meas):.2f} deg from the velocity (from {180 - EDGE_DEG:.2f})"
            rows.append(T.Row(f"{name}{lens}: {what}", meas, exp, half + 0.01, "deg", thesis, note))
    return rows


def main(argv=None) -> int:
    return T.experiment_main(argv, run, __doc__,
                             "Figs. 4.10-4.13: aberration of a distant cube (angles from the view axis, + = right)",
                             "examples/thesis/aberration.py", quick="240 x 240 and the thesis's views only")


if __name__ == "__main__":
    raise SystemExit(main())
