"""The suites of bench_performance.py: each measures one trade of speed against error.

``Bench(options, log).<suite>()`` returns that suite's results as plain data (the report
and the JSON file are made from them); every number is measured here. Renderers are
built with their explicit measuring options (``sweep_fraction``, ``adjust_windows``),
never by patching the library.
"""
from __future__ import annotations

import dataclasses
import re
import time

import numpy as np

from benchlib.machine import summarize
from benchlib.scenes import cube_cloud_scene, fixed_tessellation, lamp, load_parade, sun
from warp_st.core.scene import SceneError
from warp_st.testing import SphereView, numerical_errors, sphere_errors, sphere_grid_scene, sphere_view_scene

SUITES = ("scaling", "sequence", "precision", "tessellation", "slices", "needs", "adaptive")


def build_renderer(scene, **kw):
    """A Renderer of the 4D extrusion (what these suites measure; the two-level path is
    bench_two_level.py's) and the seconds its constructor took."""
    from warp_st.rendering.renderer import Renderer

    t0 = time.perf_counter()
    r = Renderer(scene, **{"primitive": "prism", **kw})
    return r, time.perf_counter() - t0


def time_render(r, frame, runs: int, threads=None):
    """(image, kernel seconds summary, full frame seconds summary, mean BVH visits/ray);
    one warm-up render first."""
    r.render(frame, threads=threads)
    kern, full = [], []
    img = None
    for _ in range(max(1, runs)):
        img = r.render(frame, threads=threads)
        kern.append(r.stats.last_kernel_seconds)
        full.append(r.stats.last_frame_seconds)
    return img, summarize(kern), summarize(full), r.stats.last_mean_visits


def render_view(view: SphereView, runs: int = 1):
    """(Renderer, image, kernel seconds summary, constructor seconds) for ``view``."""
    r, ctor = build_renderer(sphere_view_scene(view), **view.render_options())
    img, kern, _full, _vis = time_render(r, view.t_c, runs)
    return r, img, kern, ctor


def window_cut(early: float, late: float):
    """An ``adjust_windows`` for ``Renderer``: drop the earliest ``early`` and the latest
    ``late`` fraction of the span of every moving body's visibility window (to measure
    how much of the bound an image needs; the renderer never does this)."""
    from warp_st.spacetime.visibility import intersection, span

    def cut(scene, windows):
        out = []
        for body, window in zip(scene.bodies, windows):
            if window is not None and body.speed > 0.0:
                lo, hi = span(window)
                window = intersection(window, (lo + early * (hi - lo), hi - late * (hi - lo)))
            out.append(window)
        return out

    return cut


def factor_label(fac) -> str:
    return "default rule" if fac is None else f"x{fac:g}"


def _t(x: float) -> str:
    """A time for a label: 1e6 rather than 1e+06."""
    return f"{x:.0e}".replace("e+0", "e").replace("e+", "e") if abs(x) >= 1e5 else f"{x:g}"


class Bench:
    def __init__(self, args, log):
        self.args = args
        self.log = log
        self.quick = args.quick
        self.runs = args.runs

    # ------------------------------------------------------------------ scaling
    def scaling(self):
        a = self.args
        w, h = a.width, a.height
        if self.quick:
            grids, cubes, segments = [1, 3], [8, 27], [8, 16]
        else:
            grids, cubes, segments = [1, 2, 3, 6, 11, 20], [3, 27, 125, 343, 1000], [8, 16, 32, 64, 80, 128, 256]
        rows = []
        for n in grids:
            scene = sphere_grid_scene(24, n)
            rows.append(self._scale_row("sphere grid", f"{n}x{n} spheres, 24 seg.", scene, w, h))
        for seg in segments:  # the same image, finer and finer tessellation
            scene = sphere_grid_scene(seg, 3)
            rows.append(self._scale_row("tessellated 3x3 grid", f"{seg} seg.", scene, w, h))
        for n in cubes:
            scene = cube_cloud_scene(n)
            rows.append(self._scale_row("moving cubes", f"{n} cubes", scene, w, h))
        return {"width": w, "height": h, "rows": rows}

    def _scale_row(self, family, label, scene, w, h):
        r, ctor = build_renderer(scene, frames=[0.0], width=w, height=h)
        _img, kern, full, visits = time_render(r, 0.0, self.runs)
        st = r.stats
        row = {"family": family, "label": label, "bodies": len(scene.bodies), "tetrahedra": st.tetrahedra,
               "bvh_nodes": st.bvh_nodes, "extrude_s": st.extrude_seconds, "bvh_s": st.bvh_seconds,
               "upload_s": st.upload_seconds, "constructor_s": ctor, "kernel_s": kern, "frame_s": full,
               "visits": visits}
        self.log(f"  [scaling] {label}: {st.tetrahedra:,} tets, BVH {st.bvh_seconds:.3f} s, "
                 f"render {1e3 * kern['median']:.1f} ms")
        return row

    # ------------------------------------------------------------------ sequence
    def sequence(self):
        import warp_st

        scene = load_parade()
        n = 3 if self.quick else 8
        step = 4.0
        frames = [i * step for i in range(n)]
        w, h = (96, 54) if self.quick else (320, 180)
        # warm: kernels loaded once, so neither side pays the compile
        warp_st.render(scene, frame=frames[0], width=w, height=h)
        t0 = time.perf_counter()
        from warp_st.rendering.renderer import Renderer

        r = Renderer(scene, frames=frames, width=w, height=h, primitive="prism")
        build = time.perf_counter() - t0
        per = []
        for f in frames:
            t1 = time.perf_counter()
            r.render(f)
            per.append(time.perf_counter() - t1)
        reuse_total = time.perf_counter() - t0
        shared_tets = r.stats.tetrahedra
        rebuild, single_tets = [], []
        for f in frames:
            t1 = time.perf_counter()
            rr = Renderer(scene, frames=[f], width=w, height=h, primitive="prism")
            rr.render(f)
            rebuild.append(time.perf_counter() - t1)
            single_tets.append(rr.stats.tetrahedra)
        res = {
            "scene": "relativistic_parade.usda", "frames": frames, "width": w, "height": h,
            "reuse_build_s": build, "reuse_render_s": summarize(per), "reuse_total_s": reuse_total,
            "reuse_per_frame_s": reuse_total / n, "rebuild_s": summarize(rebuild),
            "rebuild_total_s": sum(rebuild), "rebuild_per_frame_s": sum(rebuild) / n,
            "shared_tetrahedra": shared_tets, "single_tetrahedra": summarize(single_tets),
        }
        self.log(f"  [sequence] {n} frames: reuse {res['reuse_per_frame_s']:.3f} s/frame, "
                 f"rebuild {res['rebuild_per_frame_s']:.3f} s/frame")
        return res

    # ------------------------------------------------------------------ precision
    def precision(self):
        w, h = (64, 48) if self.quick else (160, 120)
        diag = np.array([1.0, 0.5, -1.0]) / np.linalg.norm([1.0, 0.5, -1.0])
        cases = [
            ("rest, t=0", dict()),
            ("0.9c coupled, t=0", dict(velocity=tuple(0.9 * diag))),
            ("0.9c coupled, t=1e6, x+1e4", dict(velocity=tuple(0.9 * diag), shift_t=1.0e6, shift_x=(1.0e4, 1.0e4, 1.0e4))),
        ]
        segments = 64 if self.quick else 128
        rows = []
        for prec in ("float32", "float64"):
            for label, kw in cases:
                view = SphereView(name=label, width=w, height=h, segments=segments, precision=prec, **kw)
                r, img, kern, _ = render_view(view, self.runs)
                err = sphere_errors(img, view, segments=segments)
                err.update(numerical_errors(img, view, segments))
                rows.append({"precision": prec, "case": label, "segments": segments, "kernel_s": kern,
                             "tetrahedra": r.stats.tetrahedra, "visits": r.stats.last_mean_visits, **err})
                self.log(f"  [precision] {prec} {label}: {1e3 * kern['median']:.1f} ms, {r.stats.tetrahedra:,} tets, "
                         f"Z err vs mesh {err['z_poly']:.2e}, t {err['t_poly']:.2e}; vs sphere {err['z_abs']:.2e}")
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ tessellation
    def tessellation(self):
        w, h = (96, 72) if self.quick else (320, 240)
        segs = [16, 32, 64] if self.quick else [16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512]
        series = [("rest", dict())]
        if not self.quick:
            series.append(("0.9c coupled", dict(velocity=(0.9, 0.0, 0.0))))
        rows = []
        for name, kw in series:
            for n in segs + [None]:
                view = SphereView(name=name, width=w, height=h, segments=n, **kw)
                r, img, kern, ctor = render_view(view, self.runs)
                chosen = n if n is not None else r.sphere_segments.get("/Sphere")
                err = sphere_errors(img, view, segments=chosen)
                rows.append({"series": name, "segments": chosen, "adaptive": n is None, "kernel_s": kern,
                             "constructor_s": ctor, "tetrahedra": r.stats.tetrahedra,
                             "bvh_s": r.stats.bvh_seconds, **err})
                self.log(f"  [tessellation] {name} {'adaptive ' if n is None else ''}{chosen} seg: "
                         f"silhouette {err['silhouette_px']:.3f} px, depth {err['depth_px']:.3f} px, "
                         f"{1e3 * kern['median']:.1f} ms")
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ slices
    def slices(self):
        w, h = (96, 54) if self.quick else (320, 180)
        n = 4 if self.quick else 5
        frames = [0.0, 20.0] if self.quick else [float(f) for f in range(0, 101, 10)]
        mid = frames[len(frames) // 2]
        series = [
            (f"{n}x{n} sphere grid (16 seg.), frames {frames[0]:g}–{frames[-1]:g}, frame {mid:g} rendered",
             sphere_grid_scene(16, n), frames, mid,
             [0.5, 1.0, 4.0] if self.quick else [0.25, 0.5, 1.0, 2.0, 4.0, 8.0]),
        ]
        one = SphereView(width=w, height=h, segments=32 if self.quick else 64, velocity=(0.9, 0.0, 0.0))
        series.append((f"one sphere at 0.9c ({one.segments} seg.), single frame", sphere_view_scene(one), [one.t_c],
                       one.t_c, [0.125, 1.0] if self.quick else [1 / 32, 1 / 16, 0.125, 0.25, 0.5, 1.0]))
        rows = []
        for label, scene, fr, render_at, factors in series:
            for fac in [*factors, None]:  # None: the default rule (extrude.segment_sweep)
                r, ctor = build_renderer(scene, frames=fr, width=w, height=h, sweep_fraction=fac)
                _img, kern, _full, visits = time_render(r, render_at, self.runs)
                box = _box_stats(r.mesh)
                rows.append({"series": label, "factor": fac, "tetrahedra": r.stats.tetrahedra,
                             "extrude_s": r.stats.extrude_seconds, "bvh_s": r.stats.bvh_seconds, "constructor_s": ctor,
                             "kernel_s": kern, "visits": visits, **box})
                self.log(f"  [slices] {label.split(',')[0]} {factor_label(fac)}: {r.stats.tetrahedra:,} tets, "
                         f"box/size {box['box_over_size']:.2f}, {visits:.1f} visits/ray, {1e3 * kern['median']:.1f} ms")
        return {"width": w, "height": h, "rows": rows}

    # ------------------------------------------------------------------ needs
    def needs(self):
        w, h = (96, 54) if self.quick else (320, 180)
        n = 4 if self.quick else 10
        res = {"width": w, "height": h}
        # (a) lights: shadow rays only when the scene has lights
        rows = []
        for label, lights in (("no light", ()), ("1 distant light", (sun(),)), ("distant + sphere light", (sun(), lamp()))):
            scene = sphere_grid_scene(24, n, lights=lights)
            r, ctor = build_renderer(scene, frames=[0.0], width=w, height=h)
            _img, kern, _full, visits = time_render(r, 0.0, self.runs)
            row = {"case": label, "lights": len(lights), "tetrahedra": r.stats.tetrahedra, "constructor_s": ctor,
                   "kernel_s": kern, "visits": visits}
            if lights:  # the same database traced without its lights: isolates the shadow rays
                r.scene = dataclasses.replace(scene, lights=())
                _img, kern0, _f, _v = time_render(r, 0.0, self.runs)
                row["kernel_s_same_db_unlit"] = kern0
            rows.append(row)
            self.log(f"  [needs] {label}: {r.stats.tetrahedra:,} tets, {1e3 * kern['median']:.1f} ms")
        res["lights"] = rows
        # (b) mirrors: reflection rays only where a surface is metallic
        rows = []
        for label, mirror in (("no mirror", False), ("one mirror sphere", True)):
            scene = sphere_grid_scene(24, n, mirror_centre=mirror)
            images = {}
            for depth in ((0, 4) if self.quick else (0, 1, 4)):
                try:
                    r, ctor = build_renderer(scene, frames=[0.0], width=w, height=h, max_depth=depth)
                except SceneError as exc:  # the memory guard: report the size it refused
                    count = re.search(r"\(([\d,]+) tetrahedra", str(exc))
                    rows.append({"case": label, "max_depth": depth, "refused": str(exc),
                                 "tetrahedra": int(count.group(1).replace(",", "")) if count else None})
                    self.log(f"  [needs] {label}, max depth {depth}: refused ({rows[-1]['tetrahedra']} tets)")
                    continue
                img, kern, _full, visits = time_render(r, 0.0, self.runs)
                images[depth] = img
                rows.append({"case": label, "max_depth": depth, "tetrahedra": r.stats.tetrahedra,
                             "kernel_s": kern, "visits": visits,
                             "bounced_pixels": int((img.bounces > 0).sum())})
                if depth > 0 and 0 in images:
                    rows[-1]["identical_to_depth0"] = bool(np.array_equal(images[0].rgba, img.rgba))
                self.log(f"  [needs] {label}, max depth {depth}: {r.stats.tetrahedra:,} tets, {visits:.2f} visits/ray, "
                         f"{1e3 * kern['median']:.1f} ms")
        res["mirrors"] = rows
        # (c) clipping: tetrahedra against the length of the sequence (the reader's fixed
        # sphere tessellation, so only the windows change)
        clip_segments = 16 if self.quick else None
        scene = fixed_tessellation(load_parade(), clip_segments)
        parade_camera = scene.camera_state  # the stage holds its camera time after frame 48: use t_c = frame

        def camera_at(path, frame):
            return dataclasses.replace(parade_camera(path, 0.0), time=float(frame))

        scene = dataclasses.replace(scene, camera_state=camera_at)
        res["clipping_sphere_segments"] = clip_segments or 64
        unlit = dataclasses.replace(scene, lights=())
        spans = [100.0] if self.quick else [10.0, 100.0, 1000.0]
        cases = [("lit", scene, [0.0])] + [("lit", scene, list(np.linspace(0.0, t, 11))) for t in spans]
        if not self.quick:
            cases += [("lit", scene, [1000.0]), ("lit", scene, [1.0e6])]
        cases += [("unlit", unlit, [0.0])]
        if not self.quick:
            cases += [("unlit", unlit, list(np.linspace(0.0, 1000.0, 11)))]
        cases += [("unlit", unlit, [1.0e6])]
        rows = []
        for lights, sc, frames in cases:
            frames = [float(f) for f in frames]
            label = f"frame {_t(frames[0])}" if len(frames) == 1 else f"{_t(frames[0])}–{_t(frames[-1])} ({len(frames)} frames)"
            row = {"span": label, "lights": lights, "frames": len(frames)}
            fine = True
            try:
                r, ctor = build_renderer(sc, frames=frames, width=16, height=9)
            except SceneError as exc:  # the memory guard refused: report the count it computed
                count = re.search(r"\(([\d,]+) tetrahedra", str(exc))
                row.update(tetrahedra=int(count.group(1).replace(",", "")) if count else None, refused=str(exc),
                           constructor_s=None, per_body={})
            else:
                fine = r.fine_segments
                row.update(tetrahedra=r.stats.tetrahedra, constructor_s=ctor, per_body=_tets_per_body(r),
                           time_segments="per triangle" if fine else "per body (memory)")
            if len(frames) > 1:  # the same windows filled in between (one interval per body)
                from warp_st.rendering.budget import count_database
                from warp_st.rendering.renderer import DEFAULT_MAX_DEPTH
                from warp_st.spacetime.visibility import span, visibility_windows

                cams = [sc.camera_state(sc.default_camera, f) for f in frames]
                wins = visibility_windows(sc, cams, infinite=False, max_depth=DEFAULT_MAX_DEPTH)
                row["span_tetrahedra"] = count_database(sc, [span(w) for w in wins], fine=fine)[0]
            rows.append(row)
            self.log(f"  [needs] parade {lights} {label}: {row['tetrahedra']:,} tets"
                     + (" (refused)" if "refused" in row else ""))
        res["clipping"] = rows
        res["parade_bodies"] = [b.prim_path for b in scene.bodies]
        # (d) slack: how much of the lit windows frame 0's image needs. Every moving
        # body's window is cut from one end; the pixels that change show where the
        # bound is already tight.
        ref, _ctor = build_renderer(scene, frames=[0.0], width=w, height=h)
        ref_img = ref.render(0.0)
        rows = []
        for early, late in ((0.25, 0.0), (0.35, 0.0), (0.5, 0.0), (0.0, 0.1), (0.0, 0.25)):
            r, _ctor = build_renderer(scene, frames=[0.0], width=w, height=h,
                                      adjust_windows=window_cut(early, late))
            img = r.render(0.0)
            changed = (np.abs(img.rgba - ref_img.rgba).max(axis=-1) > 1e-3) | (img.object_id != ref_img.object_id)
            rows.append({"earliest": early, "latest": late, "tetrahedra": r.stats.tetrahedra,
                         "changed_pixels": int(changed.sum())})
            self.log(f"  [needs] lit parade frame 0, windows cut {early:.0%} early / {late:.0%} late: "
                     f"{r.stats.tetrahedra:,} tets, {int(changed.sum())} pixels changed")
        res["slack"] = {"tetrahedra": ref.stats.tetrahedra, "rows": rows}
        return res

    # ------------------------------------------------------------------ adaptive
    def adaptive(self):
        scene = load_parade()
        fixed = fixed_tessellation(scene)
        sizes = [(96, 54)] if self.quick else [(160, 90), (640, 360), (1280, 720)]
        ref_segments = 96 if self.quick else 128
        reference = fixed_tessellation(scene, ref_segments)
        rows = []
        for w, h in sizes:
            row = {"width": w, "height": h}
            ref_img = None
            if w * h <= 640 * 360:
                rr, _ = build_renderer(reference, frames=[0.0], width=w, height=h)
                ref_img = rr.render(0.0)
            for label, sc in (("adaptive", scene), ("fixed 64", fixed)):
                r, ctor = build_renderer(sc, frames=[0.0], width=w, height=h)
                img, kern, _full, _vis = time_render(r, 0.0, self.runs)
                row[label] = {"segments": dict(r.sphere_segments) if label == "adaptive" else 64,
                              "tetrahedra": r.stats.tetrahedra, "constructor_s": ctor, "kernel_s": kern}
                if ref_img is not None:
                    row[label]["vs_reference"] = _image_difference(img, ref_img, r)
            rows.append(row)
            self.log(f"  [adaptive] {w}x{h}: segments {row['adaptive']['segments']}, "
                     f"{row['adaptive']['tetrahedra']:,} vs {row['fixed 64']['tetrahedra']:,} tets")
        return {"reference_segments": ref_segments, "rows": rows}


def _box_stats(mesh, sample: int = 200_000) -> dict:
    """Mean spatial extent (largest xyz side) and time extent of the primitives' 4D boxes
    (prisms or tetrahedra, as the BVH holds them), relative to their triangle's size
    (1 = a box as small as the triangle)."""
    n = mesh.prim_count
    if n == 0:
        return {"box_over_size": float("nan"), "box_dt": float("nan")}
    idx = np.random.default_rng(0).choice(n, size=min(n, sample), replace=False)
    lo, hi = mesh.prim_boxes()
    ext = hi[idx] - lo[idx]
    prim_tri = mesh.prism_tri if mesh.primitive == "prism" else mesh.tet_tri
    size = np.maximum(mesh.tri_size[prim_tri[idx]], 1e-12)
    return {"box_over_size": float((ext[:, 1:].max(axis=1) / size).mean()), "box_dt": float(ext[:, 0].mean())}


def _tets_per_body(r) -> dict:
    tri_body = r.mesh.tri_body[r.mesh.tet_tri]  # every mesh keeps its tetrahedra
    counts = np.bincount(tri_body, minlength=len(r.scene.bodies))
    return {b.prim_path: int(c) for b, c in zip(r.scene.bodies, counts)}


def _image_difference(img, ref, r) -> dict:
    """Against a finer reference render: pixels whose object differs, and the largest depth
    difference on pixels both hit with the same object, in pixel footprints (|dZ| / (Z x
    pixel angle at the image centre))."""
    cam = r.scene.camera_state(r.camera_path, r.frames[0])
    alpha = float(cam.horizontal_aperture) / r.width / float(cam.focal_length)
    same = (img.object_id == ref.object_id) & (img.object_id > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        dz = np.abs(img.depth.astype(np.float64) - ref.depth.astype(np.float64))
        px = dz / (ref.depth.astype(np.float64) * alpha)
    return {"object_differs": int((img.object_id != ref.object_id).sum()),
            "depth_px_p99": float(np.percentile(px[same], 99)) if same.any() else 0.0,
            "depth_px_max": float(px[same].max()) if same.any() else 0.0}

