"""Figs. 2.1-2.2 (thesis §2.2.1, §2.3.4): a sphere and four cubes passing the camera at
0.866c; the sphere's outline stays a circle and the bodies appear rotated by arcsin(beta).

Renders ``sphere_and_cubes.usda`` (at rest) and ``sphere_and_cubes_moving.usda`` (0.866c
along +x, Lorentz coupled) at frame 0, and measures from the images:

- the sphere's outline on the sky: the midpoints between each sphere pixel and its
  outside 4-neighbours, as directions, fitted by a cone (a circle on the unit sphere);
  residuals in pixels, and the fitted centre and angular radius against the closed form
  (the rest-frame cone seen from the camera event, mapped to the lab by aberration,
  which takes circles to circles). The same sphere Lorentz-decoupled (an in-memory
  edit) is shown for contrast: it is not a circle.
- the Terrell rotation, from /World/Telescope at 200 units (the cubes 0.3 degrees wide,
  seen almost orthographically): for every cube pixel the hit event (x = c + Z n,
  t = eventTime) is carried back along the cube's worldline and un-contracted into the
  cube's rest frame, which says which face it is on and where. Along each pixel row the
  rest-frame coordinate across the front face (+z) and across the trailing face (-x) is
  linear in the column; extrapolating both to the faces' edges gives their apparent
  widths to a fraction of a pixel, and the apparent rotation phi = atan(trailing /
  front) (a cube turned by phi shows its faces in the ratio sin phi : cos phi). Expected:
  arcsin(beta) = 60 deg (Penrose-Terrell, distant observer), and exactly the same ratio
  from the cube's vertical edges each seen at its retarded time
  (``lorentz.retarded_time``), which includes the 0.7 degree perspective of the
  off-axis cubes.

    python examples/thesis/sphere_and_cubes.py [--quick] [--out DIR]
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import thesis_common as T  # noqa: E402
from pxr import Sdf  # noqa: E402  (after warp_st: it registers the spacetime schemas)

import warp_st  # noqa: E402
from warp_st.core import lorentz  # noqa: E402
from warp_st.rendering.camera import ray_directions  # noqa: E402
from warp_st.rendering.renderer import Renderer  # noqa: E402
from warp_st.testing import fit_cone  # noqa: E402

REST = T.SCENES / "sphere_and_cubes.usda"
MOVING = T.SCENES / "sphere_and_cubes_moving.usda"
V = np.array([T.BETA_FAST, 0.0, 0.0])
CUBES = {
    "CubeUpperLeft": (-2.5, 2.0, 0.0),
    "CubeUpperRight": (2.5, 2.0, 0.0),
    "CubeLowerLeft": (-2.5, -2.0, 0.0),
    "CubeLowerRight": (2.5, -2.0, 0.0),
}
NEAR = np.array([0.0, 0.0, 10.0])


def t_ref_of(centre) -> float:
    """The moving file's referenceTime: 10 - |near camera - centre|."""
    return 10.0 - float(np.linalg.norm(NEAR - np.asarray(centre, float)))


def render(stage_or_path, camera, width, height):
    scene = warp_st.load(stage_or_path)
    img = Renderer(scene, frames=[0], camera=camera, width=width, height=height).render(0)
    return img, scene.camera_state(camera, 0)


def expected_circle(cam, v, t_ref, centre=np.zeros(3), radius=1.0, n=720):
    """(axis, angular radius) of the sphere's outline on the sky of a camera at rest:
    the cone seen in the sphere's rest frame from the camera event, aberrated to the lab."""
    sep = np.array([cam.time - t_ref, *(np.asarray(cam.position) - centre)])
    d_b = (lorentz.boost(v) @ sep)[1:] if np.any(v) else sep[1:]
    axis_b = -d_b / np.linalg.norm(d_b)
    rho_b = math.asin(radius / np.linalg.norm(d_b))
    e1 = np.cross(axis_b, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis_b, e1)
    phi = np.linspace(0, 2 * np.pi, n, endpoint=False)[:, None]
    ring = math.cos(rho_b) * axis_b + math.sin(rho_b) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    lab = lorentz.aberrate(ring, v) if np.any(v) else ring
    axis, rho, _ = fit_cone(lab)
    return axis, rho


def circle_rows(img, cam, label, v, t_ref, pix):
    sid = T.body_id(img, "/World/Bodies/Sphere")
    mask = img.object_id == sid
    b = T.boundary_midpoints(mask)
    d = ray_directions(cam, img.width, img.height, b[:, 0], b[:, 1])
    axis, rho, resid = fit_cone(d)
    rms, worst = float(np.sqrt(np.mean(resid ** 2)) / pix), float(np.abs(resid).max() / pix)
    rows = [T.Row(f"{label}: outline residual rms", rms, 0.0, 0.5, "px", "a circle",
                  f"{len(b)} outline points, worst {worst:.2f} px, fitted radius {math.degrees(rho):.4f} deg")]
    if v is not None:
        e_axis, e_rho = expected_circle(cam, v, t_ref)
        sag = 2 * (1 - math.cos(math.pi / 64))  # the 64-longitude polyhedron lies within R(1 - sag) .. R
        rows.append(T.Row(f"{label}: circle centre vs closed form", T.angle_deg(axis, e_axis) / math.degrees(pix),
                          0.0, 0.5, "px", ""))
        rows.append(T.Row(f"{label}: circle radius vs closed form", (rho - e_rho) / pix, 0.0,
                          0.5 + sag * e_rho / pix, "px", "",
                          f"closed form {math.degrees(e_rho):.4f} deg; at rest it would be "
                          f"{math.degrees(math.asin(1 / 10)):.4f} deg"))
    return rows, resid


def cube_rotation(img, cam, name, centre):
    """Measured and closed-form apparent rotation (deg) of one cube, from its face widths."""
    o = np.asarray(centre, float)
    t_ref = t_ref_of(o)
    fid = T.body_id(img, f"/World/Bodies/{name}")
    t, x = T.hit_events(img, cam)
    mask = img.object_id == fid
    r = np.full(x.shape, np.nan)
    r[mask] = lorentz.uncontract(x[mask] - o - V * (t[mask] - t_ref)[:, None], V)
    tol = 2e-3
    front = mask & (np.abs(r[..., 2] - 0.5) < tol)
    trail = mask & (np.abs(r[..., 0] + 0.5) < tol)
    meas, exp, bound = [], [], []
    for j in range(img.height):
        fi, ti = np.flatnonzero(front[j]), np.flatnonzero(trail[j])
        if len(fi) < 3 or len(ti) < 3 or (mask[j] & ~front[j] & ~trail[j]).any():
            continue
        cf = np.polyfit(r[j, fi, 0], fi + 0.5, 1)  # column across the front face
        ct = np.polyfit(r[j, ti, 2], ti + 0.5, 1)  # column across the trailing face
        wf = abs(np.polyval(cf, 0.5) - np.polyval(cf, -0.5))
        wt = abs(np.polyval(ct, 0.5) - np.polyval(ct, -0.5))
        meas.append(math.degrees(math.atan2(wt, wf)))
        # closed form: the three vertical edges at this row's height, each seen at its retarded time
        y = float(np.nanmean(r[j, fi, 1]))
        edges = np.array([[-0.5, y, 0.5], [0.5, y, 0.5], [-0.5, y, -0.5]]) + o  # authored (rest) points
        p_ref = lorentz.worldline_point(edges, o, V, t_ref, t_ref)
        tr = lorentz.retarded_time(p_ref, V, t_ref, cam.time, cam.position)
        seen = p_ref + V * (tr - t_ref)[:, None]
        px = T.pixel_of(cam, img.width, img.height, seen - cam.position)[:, 0]
        ewf, ewt = abs(px[1] - px[0]), abs(px[0] - px[2])
        exp.append(math.degrees(math.atan2(ewt, ewf)))
        # half a pixel on each of the four edges, the worst way round
        bound.append(math.degrees(math.atan2(ewt + 1.0, ewf - 1.0) - math.atan2(ewt, ewf)))
    if not meas:
        raise RuntimeError(f"{name}: no pixel row shows both its front and trailing faces")
    return float(np.mean(meas)), float(np.mean(exp)), float(np.mean(bound)), len(meas)


def run(quick: bool = False, out: Path | None = None) -> list[T.Row]:
    near_size = (320, 180) if quick else (640, 360)
    tel_size = (320, 180) if quick else (640, 360)
    rows = []
    # --- the sphere's outline
    img_rest, cam = render(REST, "/World/Camera", *near_size)
    pix = float(cam.horizontal_aperture) / near_size[0] / float(cam.focal_length)  # rad per pixel at the centre
    r, _ = circle_rows(img_rest, cam, "sphere at rest", np.zeros(3), 0.0, pix)
    rows += r
    img_mov, cam = render(MOVING, "/World/Camera", *near_size)
    r, _ = circle_rows(img_mov, cam, "sphere at 0.866c", V, t_ref_of((0, 0, 0)), pix)
    rows += r
    stage = T.open_stage(MOVING)
    stage.GetPrimAtPath("/World/Bodies/Sphere").CreateAttribute(
        "spacetime:lorentzDecoupled", Sdf.ValueTypeNames.Bool).Set(True)  # in memory only
    img_dec, cam = render(stage, "/World/Camera", *near_size)
    r, _ = circle_rows(img_dec, cam, "sphere at 0.866c decoupled", None, 0.0, pix)
    r[0].expected, r[0].tol, r[0].thesis = r[0].measured, np.inf, "(contrast: not a circle)"
    rows += r
    # --- Terrell rotation of the cubes
    img_tel, cam = render(MOVING, "/World/Telescope", *tel_size)
    for name, centre in CUBES.items():
        m, e, b, n = cube_rotation(img_tel, cam, name, centre)
        rows.append(T.Row(f"{name}: apparent rotation (telescope)", m, e, b, "deg",
                          f"arcsin 0.866 = {math.degrees(math.asin(T.BETA_FAST)):.1f}",
                          f"{n} rows; the closed form includes the off-axis perspective"))
    if out is not None:
        for img, stem in ((img_rest, "rest"), (img_mov, "moving"), (img_dec, "moving_decoupled_sphere"),
                          (img_tel, "moving_telescope")):
            img.write_exr(str(Path(out) / f"thesis_sphere_and_cubes_{stem}.exr"))
    return rows


def main(argv=None) -> int:
    return T.experiment_main(argv, run, __doc__,
                             "Figs. 2.1-2.2: sphere and cubes at 0.866c: circular outline and Terrell rotation",
                             "examples/thesis/sphere_and_cubes.py", quick="320 x 180")


if __name__ == "__main__":
    raise SystemExit(main())
