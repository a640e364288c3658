"""The report of bench_performance.py: markdown sections per suite, the summary table, plots."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from benchlib.suites import factor_label
from warp_st.spacetime.extrude import MIN_SWEEP_FRACTION, SWEEP_FRACTION, TRIANGLE_SWEEP


def _ms(s):
    return f"{1e3 * s['median']:.1f}"


def _ms_range(s):
    return f"{1e3 * s['median']:.1f} ({1e3 * s['min']:.1f}–{1e3 * s['max']:.1f})"


def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def report_sections(results, images_rel):
    """Markdown sections, one per suite that ran."""
    L = []
    if "scaling" in results:
        s = results["scaling"]
        L += [f"## Scaling: time against tetrahedra ({s['width']}x{s['height']})", "",
              "Extrusion, 4D SAH BVH build and render time (kernel, median of the runs) against the database size. "
              "Sphere grid: n x n UV spheres of 24 segments covering the same part of the image, mixed velocities up "
              "to 0.9c, unlit (more, smaller bodies: the image itself changes). Tessellated 3x3 grid: the same 3 x 3 "
              "spheres at 8 to 256 segments (the same image, more triangles). Moving cubes: N cubes up to 0.95c in random directions, one distant light (shadow "
              "rays, and windows widened for them).", ""]
        L += _table(["scene", "tetrahedra", "BVH nodes", "extrude s", "BVH build s", "render ms", "visits/ray"],
                    [[f"{r['family']}: {r['label']}", f"{r['tetrahedra']:,}", f"{r['bvh_nodes']:,}",
                      f"{r['extrude_s']:.3f}", f"{r['bvh_s']:.3f}", _ms_range(r["kernel_s"]), f"{r['visits']:.1f}"]
                     for r in s["rows"]])
        L += ["", f"![scaling]({images_rel}/perf_scaling.png)", ""]
    if "sequence" in results:
        s = results["sequence"]
        n = len(s["frames"])
        L += [f"## Sequences: one database for many frames ({s['width']}x{s['height']}, {s['scene']}, "
              f"{n} frames {s['frames'][0]:g}–{s['frames'][-1]:g})", ""]
        L += _table(["", "seconds per frame", "total s", "tetrahedra"],
                    [["one database (`Renderer(scene, frames=...)`, `render(f)`)", f"{s['reuse_per_frame_s']:.3f}",
                      f"{s['reuse_total_s']:.2f}", f"{s['shared_tetrahedra']:,} (shared)"],
                     ["  of which: build once", f"{s['reuse_build_s'] / n:.3f}", f"{s['reuse_build_s']:.2f}", ""],
                     ["  of which: render", f"{s['reuse_render_s']['median']:.3f} (median)",
                      f"{sum(s['reuse_render_s']['runs']):.2f}", ""],
                     ["rebuild per frame (`warp_st.render(scene, frame=f)`)", f"{s['rebuild_per_frame_s']:.3f}",
                      f"{s['rebuild_total_s']:.2f}", f"{int(s['single_tetrahedra']['median']):,} (median per frame)"]])
        L += [""]
    if "precision" in results:
        s = results["precision"]
        L += [f"## Precision: float32 against float64 kernels ({s['width']}x{s['height']}, analytic sphere)", "",
              "Numerical error: the rendered Z and eventTime against the exact float64 first hit of the same "
              "tessellated sphere (`warp_st.testing.polyhedron_hit`: a ray/triangle test in the body frame, "
              "where the extruded world-tube is exactly the rest mesh), largest over the pixels. Tessellation error: against the "
              "closed-form sphere (`warp_st.core.lorentz.sphere_hit`), over pixels where the inner ball R - g is hit too. "
              f"{s['rows'][0]['segments']} segments. The t = 10^6 case shifts every time by 10^6 and every position "
              "by 10^4 (coordinates are recentred on the camera event in float64 before rounding). Z and eventTime "
              "are stored as float32 either way (docs/spec.md §4): about 2.4e-7 at Z ~ 5 is the storage floor.", ""]
        L += _table(["precision", "case", "tetrahedra", "visits/ray", "render ms", "Z err (numerical)",
                     "eventTime err (numerical)", "Z err vs sphere (tessellation)"],
                    [[r["precision"], r["case"], f"{r['tetrahedra']:,}", f"{r['visits']:.1f}", _ms_range(r["kernel_s"]),
                      f"{r['z_poly']:.1e}", f"{r['t_poly']:.1e}", f"{r['z_abs']:.1e}"] for r in s["rows"]])
        L += [""]
    if "tessellation" in results:
        s = results["tessellation"]
        L += [f"## Sphere tessellation: segments against error ({s['width']}x{s['height']})", "",
              "A unit sphere seen at distance 6 (19° across in a 48° field of view). Silhouette: the largest "
              "distance from a pixel whose hit/miss differs from the exact sphere's to the exact outline (pixels). "
              "Depth: the largest distance of a rendered hit event from the exact sphere (in the body frame), in pixel "
              "footprints Z x pixel angle. "
              "\"adaptive\" is the renderer's choice for this view (target: 0.5 px).", ""]
        L += _table(["series", "segments", "tetrahedra", "silhouette px", "depth px", "render ms", "build s"],
                    [[r["series"], f"{r['segments']}{' (adaptive)' if r['adaptive'] else ''}", f"{r['tetrahedra']:,}",
                      f"{r['silhouette_px']:.3f}", f"{r['depth_px']:.3f}", _ms_range(r["kernel_s"]),
                      f"{r['constructor_s']:.3f}"] for r in s["rows"]])
        L += ["", f"![speed against error]({images_rel}/perf_error.png)", ""]
    if "slices" in results:
        s = results["slices"]
        L += [f"## Time-segment length of extrusions ({s['width']}x{s['height']})", "",
              "Factor f cuts segments in which a body sweeps f x its size; \"default rule\" is what the renderer "
              f"does (`extrude.segment_sweep`: {SWEEP_FRACTION:g} x its size, shortened for finely tessellated "
              f"bodies to {TRIANGLE_SWEEP:g} x the median triangle size, but not below {MIN_SWEEP_FRACTION:g} x its "
              "size). box/size: mean largest spatial side of a primitive's 4D box over its triangle's size; box "
              "Δt: mean time extent.", ""]
        L += _table(["scene", "factor", "tetrahedra", "box/size", "box Δt", "extrude s", "BVH s", "render ms",
                     "visits/ray"],
                    [[r["series"], factor_label(r["factor"]), f"{r['tetrahedra']:,}", f"{r['box_over_size']:.2f}",
                      f"{r['box_dt']:.2f}", f"{r['extrude_s']:.3f}", f"{r['bvh_s']:.3f}", _ms_range(r["kernel_s"]),
                      f"{r['visits']:.1f}"] for r in s["rows"]])
        L += [""]
    if "needs" in results:
        s = results["needs"]
        L += [f"## Model only what a scene needs ({s['width']}x{s['height']})", "",
              "Lights: the shading loop runs once per light, so an unlit scene traces no shadow rays; with lights "
              "the windows also widen for shadow rays. \"same database, unlit\" renders the lit scene's database "
              "with its lights removed, isolating the shadow rays' cost.", ""]
        L += _table(["scene", "tetrahedra", "render ms", "same database, unlit ms", "visits/ray (primary)"],
                    [[r["case"], f"{r['tetrahedra']:,}", _ms_range(r["kernel_s"]),
                      _ms_range(r["kernel_s_same_db_unlit"]) if "kernel_s_same_db_unlit" in r else "–",
                      f"{r['visits']:.1f}"] for r in s["lights"]])
        L += ["", "Mirrors: reflection rays are traced only from metallic surfaces (visits/ray counts every BVH node "
              "visited along the camera path, reflections included).", ""]
        L += _table(["scene", "max depth", "tetrahedra", "render ms", "visits/ray", "pixels with a reflection",
                     "image = depth 0"],
                    [[r["case"], r["max_depth"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      _ms_range(r["kernel_s"]), f"{r['visits']:.2f}", r["bounced_pixels"],
                      {True: "yes", False: "no"}.get(r.get("identical_to_depth0"), "")] if "refused" not in r else
                     [r["case"], r["max_depth"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      "refused by the memory guard", "–", "–", ""] for r in s["mirrors"]])
        L += ["", "Clipping: the shipped parade scene's bodies (unbounded lifetimes, bodies at 0.9c, two lights; "
              f"spheres at a fixed {s['clipping_sphere_segments']} segments so only the windows change) with camera "
              "time = frame number; the database covers only what the requested frames' past lightcones (and, lit, "
              "what shadow rays from any hit event can reach) can see. \"unlit\": the same bodies with the lights "
              "removed. Per-body columns: tetrahedra (the floor and posts are at rest: one segment each). "
              "\"one interval\": what the same windows would extrude with the gaps between groups of frames "
              "filled in (one interval per body, as before 0.2.0), with the same time-segment rule; \"segments\": "
              "per triangle (extrude.segment_sweep) or per body (the coarser rule the renderer falls back to when the "
              "finer one would exceed the memory limit).", ""]
        bodies = s["parade_bodies"]
        shown = [b for b in bodies if "Posts" not in b]
        L += _table(["frames", "lights", "tetrahedra", "one interval", "segments", "build s"]
                    + [b.rsplit("/", 2)[-2] + "/" + b.rsplit("/", 1)[-1] for b in shown],
                    [[r["span"], r["lights"], f"{r['tetrahedra']:,}" if r["tetrahedra"] else "?",
                      f"{r['span_tetrahedra']:,}" if "span_tetrahedra" in r else "", r.get("time_segments", "–"),
                      f"{r['constructor_s']:.2f}" if r["constructor_s"] is not None else "refused by the memory guard"]
                     + [f"{r['per_body'].get(b, 0):,}" if r["per_body"] else "–" for b in shown]
                     for r in s["clipping"]])
        if "slack" in s:
            L += ["", f"Slack of the lit bound: frame 0 of the lit parade (same bodies, {s['width']}x{s['height']}, "
                  f"{s['slack']['tetrahedra']:,} tetrahedra) rendered again with every moving body's window cut "
                  "from one end by a fraction of its span (`Renderer(adjust_windows=window_cut(...))`, "
                  "benchlib/suites.py); pixels whose colour changes by more than 1e-3 or whose objectId changes. Where none change, that part of the bound was more "
                  "than the image needs.", ""]
            L += _table(["window cut", "tetrahedra", "pixels changed"],
                        [[(f"earliest {r['earliest']:.0%}" if r["earliest"] else f"latest {r['latest']:.0%}"),
                          f"{r['tetrahedra']:,}", r["changed_pixels"]] for r in s["slack"]["rows"]])
        L += [""]
    if "adaptive" in results:
        s = results["adaptive"]
        L += ["## Adaptive sphere tessellation on the parade scene", "",
              f"Adaptive (the default) against the reader's fixed 64 segments; \"vs ref\": against a "
              f"{s['reference_segments']}-segment render of the same frame: pixels whose objectId differs (the "
              "outlines move by under half a pixel, so pixels on them flip), and the 99th percentile / max |ΔZ| on "
              "pixels showing the same object, in pixel footprints Z x pixel angle (the max sits on grazing pixels "
              "next to an outline, where a sub-pixel shift of the surface moves Z a lot).", ""]
        rows = []
        for r in s["rows"]:
            for label in ("adaptive", "fixed 64"):
                x = r[label]
                seg = x["segments"] if isinstance(x["segments"], int) else ", ".join(
                    f"{k.rsplit('/', 2)[-2]}: {v}" for k, v in x["segments"].items())
                ref = x.get("vs_reference")
                rows.append([f"{r['width']}x{r['height']}", label, seg, f"{x['tetrahedra']:,}",
                             f"{x['constructor_s']:.2f}", _ms_range(x["kernel_s"]),
                             f"{ref['object_differs']} / {ref['depth_px_p99']:.2f} / {ref['depth_px_max']:.2f}"
                             if ref else "–"])
        L += _table(["resolution", "tessellation", "sphere segments", "tetrahedra", "build s", "render ms",
                     "vs ref: id px / depth p99 / max"], rows)
        L += [""]
    return L


def summary_rows(results):
    """The one table printed on stdout: the headline number of each suite."""
    rows = []
    if "scaling" in results:
        for fam in ("sphere grid", "tessellated 3x3 grid", "moving cubes"):
            rs = [r for r in results["scaling"]["rows"] if r["family"] == fam]
            if rs:
                a, b = rs[0], rs[-1]
                text = (f"BVH {a['bvh_s']:.3f} → {b['bvh_s']:.3f} s; render {_ms(a['kernel_s'])} → "
                        f"{_ms(b['kernel_s'])} ms")
                if fam == "tessellated 3x3 grid":
                    # Render-time growth at a fixed image, to the row nearest 10^6 tets (the
                    # other families change the image itself as they grow).
                    m = min(rs, key=lambda r: abs(np.log10(max(r["tetrahedra"], 1)) - 6.0))
                    growth = m["kernel_s"]["median"] / a["kernel_s"]["median"]
                    text += f"; {growth:.2f}x at {m['tetrahedra']:,} tets"
                rows.append([f"scaling ({fam})", f"{a['tetrahedra']:,} → {b['tetrahedra']:,} tets", text])
    if "sequence" in results:
        s = results["sequence"]
        rows.append(["sequence reuse", f"{len(s['frames'])} parade frames",
                     f"{s['reuse_per_frame_s']:.3f} s/frame (one database) vs {s['rebuild_per_frame_s']:.3f} "
                     f"s/frame (rebuilt)"])
    if "precision" in results:
        for prec in ("float32", "float64"):
            rs = [r for r in results["precision"]["rows"] if r["precision"] == prec]
            if rs:
                rows.append([f"precision {prec}", "analytic sphere, t = 0 and 1e6",
                             f"render {', '.join(_ms(r['kernel_s']) for r in rs)} ms; numerical Z err ≤ "
                             f"{max(r['z_poly'] for r in rs):.1e}, eventTime err ≤ {max(r['t_poly'] for r in rs):.1e}"])
    if "tessellation" in results:
        for r in results["tessellation"]["rows"]:
            if r["adaptive"]:
                rows.append([f"tessellation ({r['series']})", f"adaptive: {r['segments']} segments",
                             f"silhouette {r['silhouette_px']:.2f} px, depth {r['depth_px']:.2f} px, "
                             f"{_ms(r['kernel_s'])} ms"])
    if "slices" in results:
        for series in dict.fromkeys(r["series"] for r in results["slices"]["rows"]):
            rs = [r for r in results["slices"]["rows"] if r["series"] == series]
            best = min(rs, key=lambda r: r["kernel_s"]["median"])
            default = next(r for r in rs if r["factor"] is None)
            fixed = [r["factor"] for r in rs if r["factor"] is not None]
            rows.append([f"time segments: {series.split(',')[0]}", f"factors {fixed[0]:g}–{fixed[-1]:g} and the default rule",
                         f"fastest render at {factor_label(best['factor'])} ({_ms(best['kernel_s'])} ms, {best['tetrahedra']:,} "
                         f"tets); default rule {_ms(default['kernel_s'])} ms, {default['tetrahedra']:,} tets"])
    if "needs" in results:
        s = results["needs"]
        lit = [r for r in s["lights"] if "kernel_s_same_db_unlit" in r]
        if lit:
            r = lit[0]
            rows.append(["needs: lights", r["case"],
                         f"{_ms(r['kernel_s'])} ms lit vs {_ms(r['kernel_s_same_db_unlit'])} ms same database unlit"])
        nm = [r for r in s["mirrors"] if r["case"] == "no mirror" and "refused" not in r]
        if nm:
            rows.append(["needs: mirrors", "no mirror, max depth 0 / 4",
                         f"{nm[0]['visits']:.2f} / {nm[-1]['visits']:.2f} visits/ray, "
                         f"{_ms(nm[0]['kernel_s'])} / {_ms(nm[-1]['kernel_s'])} ms"])
        for lights in ("lit", "unlit"):
            cl = [r for r in s["clipping"] if r["lights"] == lights]
            if cl:
                rows.append([f"needs: clipping ({lights})", "parade bodies, " + " / ".join(r["span"] for r in cl),
                             " / ".join(f"{r['tetrahedra']:,}" + (" (refused)" if "refused" in r else "")
                                        for r in cl) + " tets"])
        if "slack" in s:
            rows.append(["needs: slack of the lit bound", "parade frame 0, moving bodies' windows cut "
                         + " / ".join(f"{r['earliest']:.0%} early" if r["earliest"] else f"{r['latest']:.0%} late"
                                      for r in s["slack"]["rows"]),
                         " / ".join(str(r["changed_pixels"]) for r in s["slack"]["rows"]) + " pixels changed"])
    if "adaptive" in results:
        for r in results["adaptive"]["rows"]:
            a, f = r["adaptive"], r["fixed 64"]
            rows.append([f"adaptive parade {r['width']}x{r['height']}",
                         ", ".join(str(v) for v in a["segments"].values()) + " segments",
                         f"{a['tetrahedra']:,} vs {f['tetrahedra']:,} tets (fixed 64); render {_ms(a['kernel_s'])} vs "
                         f"{_ms(f['kernel_s'])} ms"])
    return rows


def make_plots(results, images: Path, log) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    written = []
    images.mkdir(parents=True, exist_ok=True)
    if "scaling" in results:
        s = results["scaling"]
        fig, ax = plt.subplots(figsize=(7, 4.8))
        for fam, marker, ls in (("sphere grid", "o", "-"), ("tessellated 3x3 grid", "^", ":"), ("moving cubes", "s", "--")):
            rs = sorted((r for r in s["rows"] if r["family"] == fam), key=lambda r: r["tetrahedra"])
            if not rs:
                continue
            x = [r["tetrahedra"] for r in rs]
            ax.loglog(x, [r["bvh_s"] for r in rs], marker=marker, ls=ls, color="C0", label=f"{fam}: BVH build")
            ax.loglog(x, [r["extrude_s"] for r in rs], marker=marker, ls=ls, color="C1", label=f"{fam}: extrusion")
            ax.loglog(x, [r["kernel_s"]["median"] for r in rs], marker=marker, ls=ls, color="C2",
                      label=f"{fam}: render (kernel)")
        ax.set_xlabel("tetrahedra")
        ax.set_ylabel("seconds")
        ax.set_title(f"warp_st scaling, {s['width']}x{s['height']} render")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        p = images / "perf_scaling.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    panels = [k for k in ("precision", "tessellation", "slices") if k in results]
    if panels:
        fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.4), squeeze=False)
        for ax, key in zip(axes[0], panels):
            s = results[key]
            if key == "precision":
                for prec, marker in (("float32", "o"), ("float64", "s")):
                    rs = [r for r in s["rows"] if r["precision"] == prec]
                    for r in rs:
                        ax.scatter(max(r["z_poly"], 1e-12), 1e3 * r["kernel_s"]["median"], marker=marker,
                                   label=f"{prec}: {r['case']}")
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlabel("numerical Z error (vs exact hit of the same mesh)")
                ax.set_ylabel("render ms")
                ax.set_title("float32 vs float64 (analytic sphere)")
                ax.legend(fontsize=6)
            elif key == "tessellation":
                for series in dict.fromkeys(r["series"] for r in s["rows"]):
                    rs = sorted((r for r in s["rows"] if r["series"] == series and not r["adaptive"]),
                                key=lambda r: r["segments"])
                    ax.loglog([max(r["silhouette_px"], 1e-3) for r in rs], [1e3 * r["kernel_s"]["median"] for r in rs],
                              "o-", label=f"{series}: silhouette")
                    ax.loglog([max(r["depth_px"], 1e-3) for r in rs], [1e3 * r["kernel_s"]["median"] for r in rs],
                              "^:", label=f"{series}: depth")
                    for r in rs:
                        ax.annotate(str(r["segments"]), (max(r["silhouette_px"], 1e-3), 1e3 * r["kernel_s"]["median"]),
                                    fontsize=6)
                    ad = [r for r in s["rows"] if r["series"] == series and r["adaptive"]]
                    for r in ad:
                        ax.scatter([max(r["silhouette_px"], 1e-3)], [1e3 * r["kernel_s"]["median"]], marker="*", s=120,
                                   zorder=5, label=f"{series}: adaptive ({r['segments']})")
                ax.axvline(0.5, color="grey", lw=0.8, ls="--")
                ax.set_xlabel("measured error (pixels; 0 drawn at 1e-3); dashed: 0.5 px")
                ax.set_ylabel("render ms")
                ax.set_title(f"sphere segments ({s['width']}x{s['height']})")
                ax.legend(fontsize=6)
            else:
                for k, series in enumerate(dict.fromkeys(r["series"] for r in s["rows"])):
                    rs = [r for r in s["rows"] if r["series"] == series and r["factor"] is not None]
                    x = [r["factor"] for r in rs]
                    short = series.split(",")[0].split(" (")[0]
                    ax.loglog(x, [1e3 * r["kernel_s"]["median"] for r in rs], "o-", color=f"C{k}",
                              label=f"{short}: render ms")
                    ax.loglog(x, [r["tetrahedra"] / 1e3 for r in rs], "s:", color=f"C{k}",
                              label=f"{short}: k tetrahedra")
                    default = next((r for r in s["rows"] if r["series"] == series and r["factor"] is None), None)
                    if default is not None:  # the default rule, drawn at no factor: a horizontal mark
                        ax.axhline(1e3 * default["kernel_s"]["median"], color=f"C{k}", lw=0.8, ls="-.",
                                   label=f"{short}: default rule, render ms")
                ax.set_xlabel("sweep per time segment (x body size)")
                ax.set_ylabel("render ms / thousand tetrahedra")
                ax.set_title("time-segment length")
                ax.legend(fontsize=6)
            ax.grid(True, which="both", alpha=0.3)
            for a in fig.axes:
                a.xaxis.set_minor_formatter(NullFormatter())
                a.yaxis.set_minor_formatter(NullFormatter())
        fig.tight_layout()
        p = images / "perf_error.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    for p in written:
        log(f"wrote {p}")
    return written


def markdown(results, seconds, machine, options, images_rel: str) -> tuple[str, list[str]]:
    """(the whole report, the summary table's lines) of one run; ``options``: the parsed
    command line (quick, runs)."""
    m = machine
    command = "python examples/benchmarks/bench_performance.py" + (" --quick" if options.quick else "")
    header = [
        "# Performance: speed against error",
        "",
        f"Generated by `{command}` (its suites are examples/benchmarks/benchlib/). Every number below is "
        "measured by it; rerun it to reproduce them.",
        "",
        f"Machine: {m['cpu']}, {m['cpu_count']} logical cores ({m['usable_cores']} usable), warp {m['warp']}, "
        f"numpy {m['numpy']}, Python {m['python']}, {m['platform']}; {m['date']}. 1-min load average "
        f"{m['loadavg'][0]:.2f} at start, {m['loadavg_end'][0]:.2f} at end (a load above the core count means "
        f"other processes shared the cores: timings are then noisy). Renders use every core; times are medians "
        f"of {options.runs} run(s) (min–max in brackets); kernels were compiled before timing.",
        "",
        "## Summary",
        "",
    ]
    table = _table(["suite", "case", "result"], summary_rows(results))
    lines = header + table + [""] + report_sections(results, images_rel)
    lines += ["## Notes", "",
              "- render ms = `Renderer.stats.last_kernel_seconds` (the megakernel over all row tiles: primary rays, "
              "shadow rays, reflections, every AOV); build = the `Renderer` constructor (visibility windows, "
              "adaptive tessellation, extrusion, BVH, upload).",
              "- How the adaptive sphere tessellation works, and why its half-pixel bound holds: "
              "examples/benchmarks/README.md.",
              "- Suite wall times: " + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()) + ".", ""]
    return "\n".join(lines), table
