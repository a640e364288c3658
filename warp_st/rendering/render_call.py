"""The public one-frame call, ``warp_st.render``: a renderer per call, kept between calls.

A call makes a :class:`~warp_st.rendering.renderer.Renderer` (its option checks, the
windows look-up, the memory check and the database choice: ~0.4 ms after a warm frame),
unless the scene keeps the renderer of a recent call with the same frame and options
(``database_cache.SceneCache.renderer``; docs/design/database-cache.md). A kept renderer is
a copy without its scene (the cache is the scene's own: an entry referring to the scene
would keep it alive), given the scene again when it is taken.
"""
from __future__ import annotations

import dataclasses

from warp_st.core.scene import Scene
from warp_st.output.film import Image
from warp_st.rendering import database_cache
from warp_st.rendering.renderer import Renderer

__all__ = ["render_frame", "call_key", "detached", "attached"]


def render_frame(scene: Scene, *, frame=None, **options) -> Image:
    """Render a single frame (docs/spec.md §5 ``warp_st.render``).

    What the render builds stays cached on ``scene`` while the scene lives, so a second
    call with the same options and frames builds nothing; a call with the frame and
    options of a recent one takes that call's renderer again."""
    key = call_key(frame, options)
    cache = database_cache.for_scene(scene)
    kept = None if key is None else cache.renderer(key)
    if kept is not None:
        renderer = attached(kept, scene)
    else:
        renderer = Renderer(scene, frames=None if frame is None else [frame], **options)
        if key is not None:
            cache.keep_renderer(key, detached(renderer))
    return renderer.render(frame)


def call_key(frame, options: dict):
    """The renderer cache's key of a call; None (not kept) for the measuring options, which
    build databases of their own, or for an option that cannot be hashed."""
    if options.get("sweep_fraction") is not None or options.get("adjust_windows") is not None:
        return None
    key = (frame, tuple(sorted(options.items())))
    try:
        hash(key)
    except TypeError:
        return None
    return key


def detached(renderer: Renderer) -> Renderer:
    """A copy of ``renderer`` without its scene, to be kept in the scene's own cache."""
    copy = object.__new__(Renderer)
    copy.__dict__.update(renderer.__dict__, scene=None)
    return copy


def attached(kept: Renderer, scene: Scene) -> Renderer:
    """A renderer of ``scene`` (the one detached renderer ``kept`` was made for) sharing its
    database and frames, with stats of its own (nothing built)."""
    copy = object.__new__(Renderer)
    copy.__dict__.update(kept.__dict__, scene=scene, stats=dataclasses.replace(kept.stats, database_built=False))
    return copy
