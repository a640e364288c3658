"""The database belongs to the scene: what renders build is cached on the Scene object.

``warp_st.render(scene, frame=k)`` makes a new :class:`~warp_st.rendering.renderer.Renderer`
each call; without this cache every call would re-tessellate, extrude, box and build the
BVH again. The renderer looks here first and builds only what is missing.

Keys. Everything a build depends on is either in the key or checked on reuse:

- the scene object itself (identity): :class:`~warp_st.core.scene.Scene` is a frozen
  dataclass, so a scene changed in Python (``dataclasses.replace``, a new ``load``) is a
  new object and never sees another scene's entries;
- the sphere tessellation chosen for the frames, resolution, lens, light-speed modes and
  bounce limit (``spacetime.adaptive.sphere_tessellation``): its {prim: segments} map;
- the primitive kind ("rigid" / "prism" / "tet") and the time-segment rule (fine /
  coarse) of the extrusion;
- the visible windows (which the frames, shutter, light-speed modes and bounce limit
  determine): a database is reused only when its windows cover every body's new window,
  so it holds all the geometry the new frames can see; a wider window adds only exact
  geometry, never changes what a ray meets;
- the kernels' precision (the uploaded arrays, one set per precision in an entry).

The visible windows themselves are cached too, keyed by the tessellation, the
light-speed modes, bounce limit, shutter and every camera event and velocity.

Lifetime: entries live as long as the Scene object (a ``weakref.WeakKeyDictionary``
keyed by it): dropping the last reference to a scene frees them. ``clear(scene)`` (or
``clear()`` for every scene) frees them earlier.

Rigid bodies (the default path): the shapes and their bottom levels (one 3D BVH per
distinct shape, ``accel/blas.py``) depend on the tessellation only and are cached apart from the top
level, which the windows decide; a database for other frames rebuilds only the top
level (O(bodies)). Deforming bodies' tetrahedra (``spacetime.mixed``) belong to the
database, as the top level does (they follow the windows and the cameras' slice view); the
shapes' key leaves that view out (``database_mixed.shapes_key``), so other cameras reuse them.

Memory: per scene at most MAX_DATABASES databases, MAX_TESSELLATIONS re-tessellated body
sets and rigid shape sets, and MAX_WINDOWS window lists (a few floats per body each),
least recently used dropped first. A database costs about what one render of it holds
(``budget``: an extrusion ~465 bytes per tetrahedron and ~84 per vertex on the host and
the device; a rigid database at most ~156 bytes per triangle and 24 per vertex, ~42 per
triangle when 16 bodies share a shape, independent of speeds, lifetimes and frames:
``database_bytes``) plus its last MAX_GEOMETRIES recentred geometries (an
extrusion's: float32 copies of every vertex, primitive event and node box; a rigid
one's: a few vectors per motion segment).
Render calls keep an idle film, up to two blocks of Image planes and a few struct pairs
on each database (``rendering.frame_inputs``; docs/design/render-call.md).

Renderers: ``warp_st.render`` keeps the renderer of each of the last MAX_RENDERERS
(frame, options) pairs of a scene, detached from the scene (``render_call.detached``: no
entry refers to its scene). A call with the same frame and options takes that renderer
again instead of making a new one (its option checks, windows look-up, memory check and
database choice: ~0.4 ms a call after a warm frame). A database dropped from the cache
takes its kept renderers with it (``add``).
docs/design/database-cache.md says the same for users.
"""
from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field

from warp_st.spacetime.visibility import intervals

__all__ = ["MAX_DATABASES", "MAX_TESSELLATIONS", "MAX_GEOMETRIES", "MAX_WINDOWS", "MAX_RENDERERS", "Database",
           "SceneCache", "for_scene", "clear", "builds", "covers", "lru"]

#: Databases kept per scene (a sequence renders each frame from one database; sweeps of
#: a few option sets alternate between a few).
MAX_DATABASES = 4
#: Re-tessellated copies of a scene kept (one per sphere tessellation in use).
MAX_TESSELLATIONS = 4
#: Recentred geometries kept per database and precision (one per camera event).
MAX_GEOMETRIES = 2
#: Visible windows kept per scene (one per set of camera events and options; small).
MAX_WINDOWS = 64
#: Detached renderers of warp_st.render calls kept per scene (one per frame and options).
MAX_RENDERERS = 4

_lock = threading.Lock()
_caches: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_builds = 0


@dataclass(eq=False)
class Database:
    """One built database over ``windows`` of a tessellated scene: the extrusion
    (``mesh``) and its BVH, or the rigid bodies' motion ``segments`` and the top level
    (``bvh``) over the ``shapes`` and their ``bottom`` levels (shared by every database
    of the tessellation: ``SceneCache.shapes``).

    ``nbytes``: its memory estimate without a frame's pixels (``rendering.budget``);
    ``stats``: how long its build took (``renderer._BuildStats``); ``static`` its uploaded
    arrays per precision, ``geometry`` its recentred geometries per (precision, camera
    event); ``frame_structs``, ``films``, ``image_blocks`` and ``launches`` what render calls reuse
    (``frame_inputs``, ``launches``)."""

    tessellation: tuple
    primitive: str
    fine: bool
    windows: list
    bvh: object
    nbytes: int
    stats: object
    mesh: object = None
    segments: object = None
    shapes: object = None
    bottom: object = None
    tets: object = None  # rigid with deforming bodies: (extrusion, its BVH, triangle offset), spacetime/mixed.py
    static: dict = field(default_factory=dict)
    geometry: OrderedDict = field(default_factory=OrderedDict)
    frame_structs: OrderedDict = field(default_factory=OrderedDict)  # rendering/frame_inputs.py
    directions: OrderedDict = field(default_factory=OrderedDict)  # pixel direction tables (frame_inputs.py)
    lenses: OrderedDict = field(default_factory=OrderedDict)  # lenses seen once, no table yet (frame_inputs.py)
    films: dict = field(default_factory=dict)  # its idle film (rendering/frame_inputs.py)
    image_blocks: list = field(default_factory=list)  # the memory of its Images (rendering/frame_inputs.py)
    launches: dict = field(default_factory=dict)  # each thread's recorded pixel launch (rendering/launches.py)

    def geometry_for(self, precision: str, origin: tuple, make):
        """The geometry recentred on ``origin`` (made by ``make()`` when missing)."""
        return lru(self.geometry, (precision, origin), make, MAX_GEOMETRIES)


class SceneCache:
    """The entries of one scene (see the module docstring)."""

    def __init__(self):
        self.tessellations: OrderedDict = OrderedDict()
        self._windows: OrderedDict = OrderedDict()
        self._shapes: OrderedDict = OrderedDict()
        self._renderers: OrderedDict = OrderedDict()
        self.databases: list[Database] = []

    def renderer(self, key):
        """The detached renderer kept for ``key`` (a call's frame and options), or None; its
        database is one of this scene's (``add`` drops the renderers of a dropped one)."""
        with _lock:
            renderer = self._renderers.get(key)
            if renderer is None:
                return None
            self._renderers.move_to_end(key)
        self.use(renderer.database)
        return renderer

    def keep_renderer(self, key, renderer) -> None:
        """Keep detached ``renderer`` for ``key`` (least recently used dropped past MAX_RENDERERS)."""
        with _lock:
            self._renderers[key] = renderer
            self._renderers.move_to_end(key)
            while len(self._renderers) > MAX_RENDERERS:
                self._renderers.popitem(last=False)

    def windows(self, key, make):
        """The visible windows of the cameras and options in ``key`` (made by ``make()``
        when missing): the body balls and shadow bounds cost more than a look-up."""
        return lru(self._windows, key, make, MAX_WINDOWS)

    def tessellated(self, key, make):
        """The scene's bodies re-tessellated as ``key`` says (made by ``make()`` when
        missing). Bodies, not a Scene: no entry may refer to the scene it is cached on,
        or the scene would never be freed."""
        return lru(self.tessellations, key, make, MAX_TESSELLATIONS)

    def shapes(self, tessellation, make):
        """The rigid shapes and bottom levels of a tessellation (made by ``make()`` when
        missing): built once per scene and tessellation, whatever the frames."""
        return lru(self._shapes, tessellation, make, MAX_TESSELLATIONS)

    def candidates(self, tessellation, primitive, windows) -> list[Database]:
        """Databases of this tessellation and primitive whose windows cover ``windows``,
        most recently used first, fine time segments before coarse."""
        found = [d for d in reversed(self.databases)
                 if d.tessellation == tessellation and d.primitive == primitive and covers(d.windows, windows)]
        return sorted(found, key=lambda d: not d.fine)

    def use(self, db: Database) -> None:
        """Mark ``db`` most recently used."""
        self.databases.remove(db)
        self.databases.append(db)

    def add(self, db: Database) -> None:
        global _builds
        with _lock:
            _builds += 1
        self.databases.append(db)
        while len(self.databases) > MAX_DATABASES:
            gone = self.databases.pop(0)
            with _lock:  # a kept renderer must not keep a dropped database alive
                for key in [k for k, r in self._renderers.items() if r.database is gone]:
                    del self._renderers[key]


def lru(entries: OrderedDict, key, make, limit: int):
    """``entries[key]``, made by ``make()`` when missing; least recently used dropped past
    ``limit``. The look-up and the insertion hold the lock, ``make()`` does not (it may
    build a database's shapes): two threads missing at once both make, the last is kept."""
    with _lock:
        if key in entries:
            entries.move_to_end(key)
            return entries[key]
    value = make()
    with _lock:
        entries[key] = value
        while len(entries) > limit:
            entries.popitem(last=False)
    return value


def for_scene(scene) -> SceneCache:
    """The cache of ``scene`` (created empty on first use)."""
    with _lock:
        cache = _caches.get(scene)
        if cache is None:
            cache = _caches[scene] = SceneCache()
        return cache


def clear(scene=None) -> None:
    """Free the entries of ``scene`` (None: of every scene)."""
    with _lock:
        if scene is None:
            _caches.clear()
        else:
            _caches.pop(scene, None)


def builds() -> int:
    """Databases built (added to a cache) in this process so far: tests count builds by it."""
    return _builds


def covers(cached, wanted) -> bool:
    """True when every body's ``wanted`` window lies inside its ``cached`` window (both
    per-body lists of windows, see ``visibility.intervals``)."""
    if len(cached) != len(wanted):
        return False
    for have, need in zip(cached, wanted):
        have = intervals(have)
        for lo, hi in intervals(need):
            if not any(a <= lo and hi <= b for a, b in have):
                return False
    return True
