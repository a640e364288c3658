"""What a render call hands the kernel besides the geometry, kept between calls.

``warp_st.render`` makes a new renderer per call, so per-call work the renderer would
keep must live where the database lives: on the scene's cached
:class:`~warp_st.rendering.database_cache.Database` (freed with it, and with its scene).

- ``structs``: the Shading and Camera structs of one frame and set of options (a few
  small arrays each, recentred on the camera event), kept per database in an LRU of
  MAX_STRUCTS entries. The key holds every value they are made from: the kernels'
  precision, the camera's full state (event, velocity, orientation, lens), the image
  size, light-speed mode, samples, shutter, background, bounce limit and Doppler
  options; the lights, dome and bodies are the database's scene's own (a scene is
  frozen: a changed one is another object with other databases).
- ``take_film`` / ``give_back``: the film (the kernel's output planes, ~48 bytes a
  pixel) of the last call, reused without zeroing: the kernel writes every pixel of
  every plane on each call (visits and covered pixels once per kernel thread), and only ``overflow`` is
  reset. A film is taken out of the database while a render uses it, so two renders
  at once never share one (the second allocates its own); at most one idle film per
  database is kept (the most recent shape). A float32 render's film has no planes of
  its own (``into_image``): the kernel writes the Image's planes
  (``film_planes.film_into``), its times as absolute time codes.
- ``directions``: the pixel centres' ray directions of a lens (``camera.camera_rays``),
  made the second time the lens is asked for and kept per database in an LRU of
  MAX_DIRECTIONS; the key (``lens_key``) holds the orientation, lens, image size,
  velocity and precision, not the camera's event, so every frame of a fixed camera reads
  one table. A cached Camera struct holds its table too (at most MAX_DIRECTIONS +
  MAX_STRUCTS tables per database).
- ``image_planes``: the returned Image's planes (~52 bytes a pixel), carved from one
  block of MAX_BLOCKS per database. A block is reused only when no plane of it is
  alive any more (its reference count says so: every plane is a view whose base is the
  block), so an Image never shares memory with a later one; reusing the pages of a
  dropped Image saves the ~2,500 page faults (~3 ms) a fresh 512 x 512 Image costs.
  An Image kept by the caller keeps its block; the others are freed with the database.

Idle memory: only the database that served a scene's last render keeps a film and
blocks (``keep_only``): per scene about 2 x 52 bytes a pixel of its last frame size, and
48 more for a float64 render's film (a float32 film holds no planes).
"""
from __future__ import annotations

import sys
import threading

import numpy as np
import warp as wp

from warp_st.core.scene import CameraState
from warp_st.kernels.render_kernel import PIXELS_PER_THREAD
from warp_st.rendering.database_cache import lru

__all__ = ["MAX_STRUCTS", "MAX_DIRECTIONS", "MAX_LENSES", "MAX_BLOCKS", "camera_key", "lens_key", "structs",
           "directions", "take_film", "give_back", "film_visits", "film_covered", "image_planes", "keep_only"]

#: Shading / Camera struct pairs kept per database (a sequence's frames alternate with a
#: warm frame in the benchmarks; a sweep of options a few).
MAX_STRUCTS = 4

#: Pixel direction tables kept per database (``directions``): a fixed lens's every frame
#: reads one; a second lets two cameras alternate.
MAX_DIRECTIONS = 2
#: Lenses seen once (no table yet) remembered per database.
MAX_LENSES = 16

#: Image blocks kept per database: the caller's latest Image holds one while the next
#: render fills the other.
MAX_BLOCKS = 2
#: (Image attribute, dtype, values per pixel) of the planes of a block, in its order.
_PLANES = (("rgba", np.float32, 4), ("event_time", np.float64, 1), ("source_time", np.float64, 1),
           ("depth", np.float32, 1), ("proper_time", np.float32, 1), ("doppler", np.float32, 1),
           ("object_id", np.uint32, 1), ("bounces", np.uint32, 1))

_lock = threading.Lock()


def camera_key(cam: CameraState) -> tuple:
    """Every value of ``cam`` the kernel's Camera and the recentring depend on."""
    return (cam.prim_path, float(cam.time), *np.asarray(cam.position, dtype=np.float64).tolist(),
            *np.asarray(cam.rotation, dtype=np.float64).reshape(-1).tolist(),
            *np.asarray(cam.velocity, dtype=np.float64).tolist(), float(cam.focal_length),
            float(cam.horizontal_aperture), float(cam.vertical_aperture), float(cam.horizontal_aperture_offset),
            float(cam.vertical_aperture_offset), str(cam.light_speed), bool(cam.decoupled))


def lens_key(precision: str, cam: CameraState, width: int, height: int) -> tuple:
    """Every value the pixel centres' directions (``camera.camera_rays``) depend on."""
    return (precision, int(width), int(height), *np.asarray(cam.rotation, dtype=np.float64).reshape(-1).tolist(),
            *np.asarray(cam.velocity, dtype=np.float64).tolist(), float(cam.focal_length),
            float(cam.horizontal_aperture), float(cam.horizontal_aperture_offset),
            float(cam.vertical_aperture_offset), bool(cam.decoupled))


def directions(db, key: tuple, make, planned: bool = False):
    """The pixel centres' direction table of lens ``key`` (``lens_key``) on database ``db``,
    made by ``make()`` the second time the lens is asked for (MAX_DIRECTIONS kept), None
    the first time: a lens seen once (a camera turning every frame) costs no table, and its
    frame's kernel computes the directions itself. ``planned``: the caller will ask for the
    lens again (another of its frames has it), so the table is made the first time (the
    sequence row, frames 0 and 10,000 of one lens at 512²: ~1 ms less a frame)."""
    with _lock:
        if key not in db.directions and not planned:
            if key not in db.lenses:
                db.lenses[key] = None
                while len(db.lenses) > MAX_LENSES:
                    db.lenses.popitem(last=False)
                return None
            db.lenses.pop(key)
    return lru(db.directions, key, make, MAX_DIRECTIONS)


def structs(db, key: tuple, make):
    """The (Shading, Camera) pair of ``key`` on database ``db`` (made by ``make()`` when missing)."""
    return lru(db.frame_structs, key, make, MAX_STRUCTS)


def take_film(db, k, n_pix: int, sample_slots: int, into_image: bool = False):
    """A film of ``n_pix`` pixels (``sample_slots`` Cryptomatte sample ids) for kernels ``k``:
    the database's idle one when it has this shape, else a new one. Its ``overflow`` is 0;
    every other plane holds whatever the last render wrote (the kernel overwrites it all).
    ``into_image``: a film without planes of its own, for ``film_planes.film_into``."""
    key = (id(k), n_pix, sample_slots, into_image)
    with _lock:
        film = db.films.pop(key, None)
    if film is None:
        film = k.Film()
        rows = 0 if into_image else n_pix
        film.rgba = wp.empty(rows, dtype=k.vec4, device="cpu")
        for name in ("depth", "event_time", "proper_time", "doppler", "source_time"):
            setattr(film, name, wp.empty(rows, dtype=k.scalar, device="cpu"))
        film.object_id = wp.empty(rows, dtype=wp.int32, device="cpu")
        film.bounces = wp.empty(rows, dtype=wp.int32, device="cpu")
        film.event_code = wp.empty(0, dtype=wp.float64, device="cpu")
        film.source_code = wp.empty(0, dtype=wp.float64, device="cpu")
        film.sample_id = wp.empty(sample_slots, dtype=wp.int32, device="cpu")
        film.visits = wp.empty(-(-n_pix // PIXELS_PER_THREAD), dtype=wp.int32, device="cpu")
        film.covered = wp.empty(-(-n_pix // PIXELS_PER_THREAD), dtype=wp.int32, device="cpu")
        film.overflow = wp.zeros(1, dtype=wp.int32, device="cpu")
    else:
        film.overflow.numpy()[0] = 0
    return key, film


def give_back(db, key, film) -> None:
    """Keep ``film`` as ``db``'s idle film (replacing any other)."""
    with _lock:
        db.films.clear()
        db.films[key] = film


def film_visits(film, n_pix: int) -> float:
    """Mean node visits per pixel of the last render into ``film`` (the kernel sums them per thread)."""
    return float(film.visits.numpy().sum(dtype=np.int64)) / n_pix if n_pix else 0.0


def film_covered(film) -> int:
    """Pixels of the last render into ``film`` whose object id is not 0 (the kernel counts
    them per thread): the Image's coverage without a pass over its id plane."""
    return int(film.covered.numpy().sum(dtype=np.int64))


def image_planes(db, height: int, width: int) -> dict:
    """Fresh-to-the-caller planes of an Image of ``height`` x ``width`` pixels (contents
    undefined): views of a block of ``db`` no live plane uses, else of a new block."""
    n = height * width
    sizes = [n * count * np.dtype(dtype).itemsize for _, dtype, count in _PLANES]
    total = sum(sizes)
    with _lock:  # the views are made before the lock is released: no other render sees the block free
        blocks = db.image_blocks
        # In the list and as getrefcount's argument only (2): no plane of it is alive.
        free = [i for i in range(len(blocks)) if sys.getrefcount(blocks[i]) == 2]
        block = next((blocks[i] for i in free if blocks[i].nbytes == total), None)
        if block is None:
            block = np.empty(total, dtype=np.uint8)
            in_use = [b for i, b in enumerate(blocks) if i not in free]  # free ones of other sizes are dropped
            blocks[:] = in_use[max(0, len(in_use) - (MAX_BLOCKS - 1)):] + [block]
        planes, start = {}, 0
        for (name, dtype, count), size in zip(_PLANES, sizes):
            shape = (height, width, count) if count > 1 else (height, width)
            planes[name] = block[start:start + size].view(dtype).reshape(shape)
            start += size
    return planes


def keep_only(databases, db) -> None:
    """Free the idle films and Image blocks of every database in ``databases`` but ``db``
    (a scene's, when ``db`` serves its render): a scene holds one frame's buffers."""
    with _lock:
        for other in databases:
            if other is not db:
                other.films.clear()
                other.image_blocks.clear()  # blocks of live Images stay with their Images
                other.launches.clear()  # they hold their last render's film
