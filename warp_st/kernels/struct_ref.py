"""A Warp struct of arrays with a small twin of raw pointers, for passing it to functions.

Warp passes struct arguments by value: a call to an out-of-line function taking the
traversal's Geometry (some forty array descriptors, ~1.9 KB) copies all of it at each
call site, and the lit render kernel calls ``trace`` from several. ``referenced`` makes
the struct with a field ``ref``: a struct holding each array's data pointer (8 bytes
instead of an array descriptor; a 2-d array's row length beside it), every other field as it is, and a nested referenced
struct's own ``ref``. A function takes the ``ref`` and rebuilds the struct with
``expand`` (force-inlined: the compiler keeps only the pointers it reads), so a call
copies a few hundred bytes. ``seal`` fills ``ref`` on the host once every field is set;
the struct must outlive the launches that read it (it holds the arrays).
"""
from __future__ import annotations

import itertools
import linecache

import warp as wp

__all__ = ["referenced", "seal"]

_LONG = 2**31 - 1  # the rebuilt arrays' length: indices are the struct's own, unchecked
_count = itertools.count()


def referenced(cls, name: str | None = None):
    """``wp.struct(cls)`` with a field ``ref`` (its pointer twin), and ``.Ref`` (that
    twin's type) and ``.expand`` (a Warp function: the twin to the struct) on it."""
    fields = dict(cls.__annotations__)
    ref_fields = {}
    for field, kind in fields.items():
        if isinstance(kind, wp.array):
            if kind.ndim > 2:
                raise TypeError(f"{cls.__name__}.{field}: only 1-d and 2-d arrays can be referenced")
            ref_fields[field] = wp.uint64
            if kind.ndim == 2:
                ref_fields[f"{field}_cols"] = wp.int32
        elif hasattr(kind, "Ref"):
            ref_fields[field] = kind.Ref
        else:
            ref_fields[field] = kind
    label = name or cls.__name__
    Ref = wp.struct(type(f"{label}Ref", (), {"__annotations__": ref_fields, "__module__": cls.__module__,
                                             "__qualname__": f"{cls.__qualname__}Ref"}))
    Struct = wp.struct(type(label, (), {"__annotations__": {**fields, "ref": Ref}, "__module__": cls.__module__,
                                        "__qualname__": cls.__qualname__}))
    Struct.Ref = Ref
    Struct.expand = _make_expand(Struct, Ref, fields)
    return Struct


def _make_expand(Struct, Ref, fields):
    """Generated source (Warp compiles a function from its source): one line a field."""
    env = {"wp": wp, "Struct": Struct, "Ref": Ref, "__name__": __name__}
    lines = ["def expand(r: Ref) -> Struct:", "    g = Struct()"]
    for i, (field, kind) in enumerate(fields.items()):
        if isinstance(kind, wp.array):
            env[f"T{i}"] = kind.dtype
            shape = f"({_LONG},)" if kind.ndim == 1 else f"({_LONG}, r.{field}_cols)"
            lines.append(f"    g.{field} = wp.array(ptr=r.{field}, shape={shape}, dtype=T{i})")
        elif hasattr(kind, "Ref"):
            env[f"X{i}"] = kind.expand
            lines.append(f"    g.{field} = X{i}(r.{field})")
        else:
            lines.append(f"    g.{field} = r.{field}")
    lines += ["    g.ref = r", "    return g", ""]
    source = "\n".join(lines)
    filename = f"<warp_st struct_ref {Struct.key} {next(_count)}>"
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    exec(compile(source, filename, "exec"), env)
    return wp.func(env["expand"], inline=True)


def seal(instance) -> None:
    """Fill ``instance.ref`` from its fields (call after setting the last of them)."""
    ref = instance.ref
    for field, var in instance._cls.vars.items():
        if field == "ref":
            continue
        value = getattr(instance, field)
        if isinstance(var.type, wp.array):
            if value is not None and value.size and not value.is_contiguous:
                raise ValueError(f"{instance._cls.key}.{field}: a referenced array must be contiguous")
            setattr(ref, field, wp.uint64((value.ptr or 0) if value is not None else 0))
            if var.type.ndim == 2:
                setattr(ref, f"{field}_cols", value.shape[1] if value is not None else 0)
        elif hasattr(var.type, "Ref"):
            seal(value)
            setattr(ref, field, value.ref)
        else:
            setattr(ref, field, value)
    instance.ref = ref
