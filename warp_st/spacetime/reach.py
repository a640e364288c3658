"""Which chunks of each animated body's motion the frames can reach (issue 18).

An animated body is cut into pieces of uniform motion (``spacetime.animation``); cutting
and holding pieces the frames never see is what made a single frame of a long animation
cost as much as the whole. Here each chunk of its probes (``animation.motion_chunks``)
stands in as a ball at rest for the chunk's lab times: the box of the pivot's probe
positions (linear interpolation between probes stays inside it), grown by the body's
extent about its pivot (R times the largest singular value of the probes' linear parts;
the contraction only shrinks it) and by how far the pieces may stray from the probes
(their tolerance). Before the first probe and after the last, the body is held: a ball
moving with the held velocity. Every body point the pieces hold at a chunk's times is
inside its ball, so the visibility windows of those stand-ins (``visibility_windows``:
the frames' past lightcones, mirror paths and shadow rays, with the other bodies of the
scene as they are) hold every time at which any frame can see the body, or its shadow,
or its reflection: a chunk whose stand-in has no window is not cut, nor one later than
the frames' past lightcones (every event on a path of light to a camera is in its past
lightcone; the shadow windows of a large body such as a floor reach past it, their ball
holding the camera). ``shadow_reach`` tightens the shadows' lower bound where it holds.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from warp_st.core.deform import surface_hull_points
from warp_st.core.scene import Body, Scene, Surface
from warp_st.spacetime.animation import body_radius, motion_chunks
from warp_st.spacetime.shadow_reach import analytic_ball, earliest_shadow_times, static_shadow_scene
from warp_st.spacetime.visibility import intersection, union, visibility_windows

__all__ = ["motion_reach", "body_extent"]

_OCTAHEDRON = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])


def body_extent(body: Body) -> float:
    """A bound on the distance of any point of ``body``'s surfaces from its static pivot,
    at the start time code: the points (every sample of a deforming surface) and the
    analytic spheres and quadrics the triangles approximate (traced exactly, or
    re-tessellated finer, they reach past the points)."""
    pivot = body.motion.static_pivot
    out = 0.0
    for s in body.surfaces:
        pts = surface_hull_points(s)
        if len(pts):
            out = max(out, float(np.linalg.norm(pts - pivot, axis=1).max()))
        ball = analytic_ball(s)
        if ball is not None:
            out = max(out, float(np.linalg.norm(ball[0] - pivot)) + ball[1])
    return out


def _stand_in(body: Body, centre, radius: float, velocity, t_ref: float, lifetime) -> Body:
    """A body whose visibility ball is (centre at t_ref, radius) moving with ``velocity``,
    over ``lifetime``: six points at +-radius along the axes, flagged a sphere so that
    ``visibility.body_pieces`` keeps it one ball; a mirror if any of ``body``'s surfaces is."""
    radius = radius * (1.0 + 1e-12) + 1e-12  # past the rounding of the ball around the points
    points = np.asarray(centre, dtype=np.float64) + radius * np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]
    material = next((s.material for s in body.surfaces if s.material.metallic > 0.0), body.surfaces[0].material)
    place = np.eye(4)
    place[3, :3] = centre
    surface = Surface(prim_path=body.prim_path, points=points, triangles=_OCTAHEDRON, material=material,
                      sphere=(radius, place))
    lo, hi = max(lifetime[0], body.lifetime[0]), min(lifetime[1], body.lifetime[1])
    return Body(prim_path=body.prim_path, surfaces=(surface,), origin=np.asarray(centre, dtype=np.float64),
                velocity=np.asarray(velocity, dtype=np.float64), reference_time=float(t_ref),
                lifetime=(float(lo), float(hi)), decoupled=True)


def _stand_ins(body: Body, margin: np.ndarray) -> tuple[list[Body], np.ndarray, int]:
    """The chunks' stand-ins of animated ``body`` in chunk order, then its two held ends;
    their balls (centre, radius), (chunks + 2, 4); and the number of chunks."""
    m = body.motion
    extent = body_extent(body)
    scale = np.linalg.norm(m.linear, ord=2, axis=(1, 2))
    bounds = motion_chunks(body, body_radius(body))
    balls = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        pts = m.pivot[a:b + 1]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        radius = (0.5 * float(np.linalg.norm(hi - lo)) + extent * float(scale[a:b + 1].max())
                  + float(margin[a:b + 1].max()))
        balls.append((0.5 * (lo + hi), radius, np.zeros(3), 0.0, (m.times[a], m.times[b])))
    for k, life in ((0, (-np.inf, m.times[0])), (-1, (m.times[-1], np.inf))):
        balls.append((m.pivot[k], extent * float(scale[k]) + float(margin[k]), m.hold_velocity, m.times[k], life))
    out = [_stand_in(body, *ball) for ball in balls]
    return out, np.array([[*b.origin, b.surfaces[0].sphere[0]] for b in out]), len(bounds) - 1


def motion_reach(scene: Scene, margins: dict, *, cameras, infinite_modes=(False,), max_depth: int = 0,
                 shutter: float = 0.0) -> dict:
    """{body index: (chunks,) bool, the chunks of its motion some frame can reach} for the
    animated bodies in ``margins`` ({index: (probes,), how far its pieces may stray from
    each probe}), for the frames' camera states ``cameras`` under each light-speed mode of
    ``infinite_modes`` (True: infinite), ``max_depth`` mirror bounces and ``shutter`` (as
    ``visibility_windows`` takes them).

    Where ``shadow_reach``'s bound holds (finite light speed), a chunk is reached when its
    stand-in is seen directly or through mirrors (the windows without lights) or that
    bound lets it cast a shadow; elsewhere when the windows with lights reach it. Either
    way no later than the frames' past lightcones."""
    bodies, owners, balls, chunk_balls, counts = [], [], [], [], {}
    for i, body in enumerate(scene.bodies):
        if i not in margins:
            bodies.append(body)
            owners.append(None)
            continue
        stand_ins, own, counts[i] = _stand_ins(body, margins[i])
        bodies.extend(stand_ins)
        balls.append(own)
        chunk_balls.append(own[:counts[i]])
        owners.extend([(i, q) for q in range(counts[i])] + [None, None])
    stand_in_scene = dataclasses.replace(scene, bodies=tuple(bodies))
    cameras = list(cameras)
    ends = cameras + [c.advanced(shutter) for c in cameras if shutter > 0.0]
    chunk_balls = np.concatenate(chunk_balls)
    # Every event on a path of light that ends at a camera event (t_c, c) (a hit, a
    # mirror's, a shadow ray's occluder) is in its past lightcone, t <= t_c - |x - c| (at an
    # infinite light speed, t <= t_c): a chunk's ball at rest no later than the latest
    # t_c - |m - c| + rho of any frame.
    times = np.array([c.time for c in ends])
    gaps = np.linalg.norm(np.array([np.asarray(c.position, dtype=np.float64) for c in ends])[None]
                          - chunk_balls[:, None, :3], axis=2)
    latest = {False: (times[None] - gaps).max(axis=1) + chunk_balls[:, 3], True: np.full(len(chunk_balls), times.max())}
    shadows = None
    if scene.lights and all(not np.any(scene.bodies[i].motion.hold_velocity) for i in margins):
        shadows = static_shadow_scene(scene, set(margins), np.concatenate(balls), max_depth)
    out = {i: np.zeros(n, dtype=bool) for i, n in counts.items()}
    chunks = [(k, o) for k, o in enumerate(owners) if o is not None]
    for infinite in sorted(set(infinite_modes)):
        if shadows is not None and not infinite:
            # seen directly or through mirrors (the windows without lights), or casting a
            # shadow within shadow_reach's bound (standing alone: visibility's shadow
            # widening per frame costs seconds for a hundred frames, and is looser here)
            windows = visibility_windows(dataclasses.replace(stand_in_scene, lights=()), cameras, infinite=False,
                                         max_depth=max_depth, shutter=shutter)
            earliest = earliest_shadow_times(shadows, scene.lights, chunk_balls, ends)
            for (k, _o), first, last in zip(chunks, earliest, latest[False]):
                if np.isfinite(first):
                    windows[k] = union(windows[k], intersection((first, last), bodies[k].lifetime))
        else:
            windows = visibility_windows(stand_in_scene, cameras, infinite=infinite, max_depth=max_depth,
                                         shutter=shutter)
        for (k, (i, q)), last in zip(chunks, latest[infinite]):
            if windows[k] is not None and windows[k][0][0] <= last:
                out[i][q] = True
    return out
