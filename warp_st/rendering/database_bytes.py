"""What a rigid database holds, table by table: the count behind its bytes per triangle (issue 17).

``rigid_tables`` walks every array a rigid ``database_cache.Database`` keeps alive: the
host tables of its shapes (``spacetime.rigid.RigidShapes``), motion segments and top
level, the bottom levels' tables (``accel/blas.py``: wide nodes; the shapes' vertex
indices and points they read are the shapes' own, counted once), the uploaded arrays of
each precision (``device_rigid.RigidArrays``) and the recentred geometries it caches;
with deforming bodies also their tetrahedra (``device_mixed.MixedArrays``).
Each buffer is counted once, under the first name that reaches it: a device array made
over a host table without a copy costs nothing more. The scene's own bodies and surfaces
(what the reader made) are not the database's and are not counted.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import warp as wp

__all__ = ["Table", "rigid_tables", "extrusion_tables", "total_bytes"]


@dataclass(frozen=True)
class Table:
    """One counted buffer: where it lives and what it is, its rows and bytes."""

    name: str
    dtype: str
    rows: int
    nbytes: int


def total_bytes(tables: list[Table]) -> int:
    return int(sum(t.nbytes for t in tables))


class _Counter:
    def __init__(self):
        self.tables: list[Table] = []
        self.spans: list = []  # the memory counted so far: disjoint (start, end)

    def add(self, name: str, value) -> None:
        """Count ``value`` (an array, or a tuple / list / struct of them) under ``name``."""
        if isinstance(value, np.ndarray):
            self._buffer(name, value.__array_interface__["data"][0], str(value.dtype), len(value) if value.ndim else 1,
                         value.nbytes)
        elif isinstance(value, wp.array):
            size = int(value.size) * wp.types.type_size_in_bytes(value.dtype)
            self._buffer(name, value.ptr, wp.types.type_repr(value.dtype), int(value.shape[0]) if value.ndim else 1,
                         size)
        elif isinstance(value, (tuple, list)):
            for item in value:
                self.add(name, item)
        elif isinstance(value, dict):
            for key, item in value.items():
                self.add(f"{name}.{key}", item)
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            for f in dataclasses.fields(value):
                self.add(f"{name}.{f.name}", getattr(value, f.name))
        elif hasattr(value, "_cls") and hasattr(value._cls, "vars"):  # a wp.struct instance
            for field_name in value._cls.vars:
                self.add(f"{name}.{field_name}", getattr(value, field_name))

    def _buffer(self, name: str, ptr, dtype: str, rows: int, nbytes: int) -> None:
        """Count the bytes of [ptr, ptr + nbytes) no buffer counted before covers (a view of
        one, or an array over its memory, adds nothing)."""
        if nbytes == 0 or not ptr:
            return
        start, end = int(ptr), int(ptr) + int(nbytes)
        overlapping = [(a, b) for a, b in self.spans if a < end and start < b]  # the spans are disjoint
        nbytes -= sum(min(end, b) - max(start, a) for a, b in overlapping)
        self.spans = [sp for sp in self.spans if sp not in overlapping] + [
            (min([start] + [a for a, _ in overlapping]), max([end] + [b for _, b in overlapping]))]
        if nbytes <= 0:
            return
        for i, t in enumerate(self.tables):  # several buffers under one name (a tuple): one row
            if t.name == name and t.dtype == dtype:
                self.tables[i] = Table(name, dtype, t.rows + rows, t.nbytes + nbytes)
                return
        self.tables.append(Table(name, dtype, rows, nbytes))


def rigid_tables(db) -> list[Table]:
    """Every buffer of the rigid database ``db`` (see the module docstring), largest first."""
    c = _Counter()
    skip = {"materials", "bodies"}  # the scene's own
    for f in dataclasses.fields(db.shapes):
        if f.name not in skip:
            c.add(f"host shapes.{f.name}", getattr(db.shapes, f.name))
    c.add("host segments", db.segments)
    c.add("host top level", db.bvh)
    for name, value in vars(db.bottom).items():
        c.add(f"host bottom.{name}", value)
    if db.tets is not None:  # deforming bodies' tetrahedra (spacetime/mixed.py): the extrusion and its BVH
        c.add("host tets", db.tets[:2])
    return _uploads(c, db)


def extrusion_tables(db) -> list[Table]:
    """Every buffer of a prism or tet database ``db`` (its extrusion without the scene's
    materials and bodies, its BVH, uploads and geometries), largest first."""
    c = _Counter()
    for f in dataclasses.fields(db.mesh):
        if f.name not in ("materials", "bodies"):
            c.add(f"host mesh.{f.name}", getattr(db.mesh, f.name))
    c.add("host bvh", db.bvh)
    return _uploads(c, db)


def _uploads(c: _Counter, db) -> list[Table]:
    """``c`` with ``db``'s uploaded arrays per precision and its cached geometries, largest first."""
    for precision, static in db.static.items():
        for name, value in vars(static).items():
            if name != "bottom":
                c.add(f"{precision} {name}", vars(value) if name == "tet_static" else value)
    for key, geometry in db.geometry.items():
        c.add(f"{key[0]} frame geometry", geometry)
    return sorted(c.tables, key=lambda t: -t.nbytes)
