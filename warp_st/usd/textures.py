"""UsdUVTexture networks -> :class:`Texture`, and a gprim's st primvar per triangle corner.

A UsdPreviewSurface input connected to a ``UsdUVTexture`` output (followed with
UsdShade's own ``GetValueProducingAttributes``, so material interface inputs are seen
through) becomes a texture: its ``file`` read through OpenImageIO (``images.py``) in
its ``sourceColorSpace``, ``scale`` and ``bias`` applied to the texels, ``wrapS`` /
``wrapT`` (``useMetadata``: the file's wrap modes, else repeat) and the output channel.
Its ``st`` comes from a ``UsdPrimvarReader_float2`` (``varname``, ``fallback``), through
any ``UsdTransform2d`` nodes (applied to the st on the host); an unconnected ``st`` is a
constant. A missing or unreadable file is a warning and the texture's ``fallback`` is the
input's value. What is not honoured (other shaders in between) is a warning naming the
prim and the input.
"""
from __future__ import annotations

import numpy as np
from pxr import Sdf, UsdGeom, UsdShade

from warp_st.core.scene import WRAP_MODES, SceneError, Texture
from warp_st.usd import attributes as A
from warp_st.usd.attributes import Where
from warp_st.usd.diagnostics import Notes
from warp_st.usd.images import ImageError, read_image

__all__ = ["TextureReader", "corner_st", "one_st", "rgba"]

_CHANNELS = {"rgb": -1, "rgba": -1, "r": 0, "g": 1, "b": 2, "a": 3}
_WRAP_TOKENS = WRAP_MODES + ("useMetadata",)


class TextureReader:
    """``reader(texture_output, size) -> Texture | values`` (the fallback's ``size``
    values when the texture cannot be used); warnings go to ``notes``."""

    def __init__(self, where: Where, notes: Notes):
        self.where = where
        self.notes = notes
        self._images: dict[tuple[str, str], object] = {}
        self._textures: dict[tuple[str, str], Texture | np.ndarray] = {}

    def __call__(self, output, size: int):
        key = (str(output.GetPrim().GetPath()), output.GetBaseName())
        if key not in self._textures:
            self._textures[key] = self._read(output)
        found = self._textures[key]
        if isinstance(found, Texture):
            return found
        channel = _CHANNELS.get(output.GetBaseName(), -1)
        values = found[:3] if channel < 0 else np.repeat(found[channel], 3)
        return [float(x) for x in (values if size == 3 else values[:1])]

    # -- one UsdUVTexture ------------------------------------------------------------
    def _read(self, output):
        tex = UsdShade.Shader(output.GetPrim())
        prim = tex.GetPrim()
        fallback = self._vector(tex, "fallback", 4, (0.0, 0.0, 0.0, 1.0))
        name = output.GetBaseName()
        if name not in _CHANNELS:
            self.notes.warn(prim, output.GetFullName(), "is not an output of UsdUVTexture (rgb, r, g, b, a); the "
                            "texture's fallback is used", "NotHonoured")
            return fallback
        asset = self._value(tex, "file", None)
        path = asset.resolvedPath if isinstance(asset, Sdf.AssetPath) else ""
        if not path:
            what = asset.path if isinstance(asset, Sdf.AssetPath) and asset.path else "no file"
            self.notes.warn(prim, "inputs:file", f"{what!s} cannot be found; the texture's fallback "
                            f"{_shown(fallback)} is used", "MissingTexture")
            return fallback
        space = self._token(tex, "sourceColorSpace", ("raw", "sRGB", "auto"), "auto")
        try:
            image = self.image(path, space)
        except ImageError as exc:
            self.notes.warn(prim, "inputs:file", f"{asset.path} cannot be read ({exc}); the texture's fallback "
                            f"{_shown(fallback)} is used", "MissingTexture")
            return fallback
        wraps = []
        for axis, attr in enumerate(("wrapS", "wrapT")):
            mode = self._token(tex, attr, _WRAP_TOKENS, "useMetadata")
            if mode == "useMetadata":
                mode = image.wraps[axis] if image.wraps else "repeat"
            wraps.append(mode)
        scale = self._vector(tex, "scale", 4, (1.0, 1.0, 1.0, 1.0))
        bias = self._vector(tex, "bias", 4, (0.0, 0.0, 0.0, 0.0))
        texels = rgba(image.texels) * scale.astype(np.float32) + bias.astype(np.float32)
        primvar, st_fallback, transform = self._st(tex)
        return Texture(file=path, texels=texels.astype(np.float32), wrap=(wraps[0], wraps[1]),
                       border=tuple(float(b) for b in bias), channel=_CHANNELS[name], primvar=primvar,
                       st_fallback=st_fallback, st_transform=transform)

    def image(self, path: str, space: str):
        """The decoded image at ``path`` in colour space ``space`` (read once; raises ImageError)."""
        key = (path, space)
        if key not in self._images:
            self._images[key] = read_image(path, space)
        return self._images[key]

    def _st(self, shader, name: str = "st", depth: int = 0):
        """(primvar name, fallback st, 2 x 3 affine or None) of the shader's st input:
        through UsdTransform2d nodes (scale, then rotation in degrees counter-clockwise,
        then translation; composed) to a UsdPrimvarReader_float2; primvar "" = a constant."""
        inp = shader.GetInput(name)
        producers = inp.GetValueProducingAttributes() if inp else []
        if not (producers and UsdShade.Output.IsOutput(producers[0])):
            st = self._vector(shader, name, 2, (0.0, 0.0))
            if inp and inp.HasConnectedSource() is False and inp.GetAttr().HasAuthoredConnections():
                self.notes.warn(shader.GetPrim(), f"inputs:{name}", f"is connected to "
                                f"{inp.GetAttr().GetConnections()[0]}, which does not exist; the constant st "
                                f"{tuple(st.tolist())} is used", "BadValue")
            return "", (float(st[0]), float(st[1])), None
        source = UsdShade.Shader(producers[0].GetPrim())
        source_id = str(source.GetShaderId() or "")
        if source_id == "UsdTransform2d" and depth < 8:
            primvar, fallback, inner = self._st(source, "in", depth + 1)
            outer = self._transform2d(source)
            return primvar, fallback, outer if inner is None else _compose(outer, inner)
        if source_id != "UsdPrimvarReader_float2":
            self.notes.warn(shader.GetPrim(), f"inputs:{name}", f"is connected to {source.GetPath()} "
                            f"({source_id or 'no shader id'}), which is not evaluated (only UsdPrimvarReader_float2 "
                            "and UsdTransform2d are); the primvar 'st' is used", "NotHonoured")
            return "st", (0.0, 0.0), None
        varname = self._value(source, "varname", "st")
        fallback = self._vector(source, "fallback", 2, (0.0, 0.0))
        return str(varname or "st"), (float(fallback[0]), float(fallback[1])), None

    def _transform2d(self, node) -> np.ndarray:
        scale = self._vector(node, "scale", 2, (1.0, 1.0))
        translation = self._vector(node, "translation", 2, (0.0, 0.0))
        attr = self._attr(node, "rotation")
        angle = 0.0
        if attr is not None:
            try:
                angle = A.real(self.where, attr.GetPrim(), attr.GetName(), 0.0)
            except SceneError as exc:
                self.notes.value_error(exc, "no rotation is used")
        c, s_ = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        linear = np.array([[c, -s_], [s_, c]]) @ np.diag(scale)
        return np.column_stack([linear, translation])

    # -- inputs, through connections to interface inputs -------------------------------
    def _attr(self, shader, name: str):
        inp = shader.GetInput(name)
        if not inp:
            return None
        producers = inp.GetValueProducingAttributes()
        if producers and UsdShade.Output.IsOutput(producers[0]):
            self.notes.warn(shader.GetPrim(), inp.GetFullName(), f"is connected to {producers[0].GetPrim().GetPath()}: "
                            "shader networks are not evaluated; its default is used", "NotHonoured")
            return None
        return producers[0] if producers else inp.GetAttr()

    def _value(self, shader, name: str, default):
        attr = self._attr(shader, name)
        value = attr.Get(self.where.time) if attr else None
        return default if value is None else value

    def _vector(self, shader, name: str, size: int, default) -> np.ndarray:
        attr = self._attr(shader, name)
        if attr is None:
            return np.array(default, dtype=np.float64)
        try:
            return A.vector(self.where, attr.GetPrim(), attr.GetName(), size, default)
        except SceneError as exc:
            self.notes.value_error(exc, f"the default {tuple(default)} is used")
            return np.array(default, dtype=np.float64)

    def _token(self, shader, name: str, allowed, default: str) -> str:
        attr = self._attr(shader, name)
        if attr is None:
            return default
        try:
            return A.token(self.where, attr.GetPrim(), attr.GetName(), allowed, default)
        except SceneError as exc:
            self.notes.value_error(exc, f"{default!r} is used")
            return default


def _compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """The 2 x 3 affine ``outer`` after ``inner``."""
    return np.column_stack([outer[:, :2] @ inner[:, :2], outer[:, :2] @ inner[:, 2] + outer[:, 2]])


def _shown(values) -> tuple:
    """Values as authored (float32 inputs shown to their 7 significant digits)."""
    return tuple(float(f"{float(x):.7g}") for x in values)


def rgba(texels: np.ndarray) -> np.ndarray:
    """(H, W, C) -> (H, W, 4): grey to rgb, alpha 1 where the file has none."""
    h, w, c = texels.shape
    out = np.ones((h, w, 4), dtype=np.float32)
    if c == 1 or c == 2:
        out[..., :3] = texels[..., :1]
        if c == 2:
            out[..., 3] = texels[..., 1]
    else:
        out[..., :min(c, 4)] = texels[..., :4]
    return out


def one_st(notes: Notes, prim, textures: list[Texture]) -> None:
    """A warning when the textures of one surface shader ``prim`` read different st
    (primvars or UsdTransform2d chains): one st per surface is supported, the first's."""
    if len({t.primvar for t in textures}) > 1:
        notes.warn(prim, "inputs", "its textures read different st primvars "
                   f"({', '.join(sorted({repr(t.primvar) for t in textures}))}); one st per surface is "
                   f"supported: {textures[0].primvar!r} is used for all", "NotHonoured")
    elif len({None if t.st_transform is None else t.st_transform.tobytes() for t in textures}) > 1:
        notes.warn(prim, "inputs", "its textures transform st differently (UsdTransform2d); "
                   "one st per surface is supported: the first texture's is used for all", "NotHonoured")


def corner_st(where: Where, notes: Notes, prim, texture: Texture, n_tri: int, topology) -> np.ndarray:
    """st at every triangle corner, (n_tri, 3, 2) (see ``_corner_st``), through the
    texture's UsdTransform2d chain (affine: applying it at the corners is applying it at
    every hit)."""
    st = _corner_st(where, notes, prim, texture, n_tri, topology)
    if texture.st_transform is None:
        return st
    m = np.asarray(texture.st_transform, dtype=np.float64)
    return st @ m[:, :2].T + m[:, 2]


def _corner_st(where: Where, notes: Notes, prim, texture: Texture, n_tri: int, topology) -> np.ndarray:
    """st at every triangle corner, (n_tri, 3, 2), for the gprim ``prim``.

    topology: (corners, faces, face_vertex_indices, point count, face count) of a Mesh's
    triangles (face-corner ids (T, 3), face of each triangle (T,)), or None for the
    other gprims (which have no st: the reader's fallback everywhere). The primvar
    is flattened by USD (``ComputeFlattened``: indices applied) and placed by its
    interpolation: vertex / varying per point, faceVarying per face corner, uniform per
    face, constant. A primvar that cannot be used is a warning and the fallback is used."""
    constant = np.broadcast_to(np.array(texture.st_fallback, dtype=np.float64), (n_tri, 3, 2))
    if topology is None or not texture.primvar:
        return constant
    corners, faces, indices, n_points, n_faces = topology
    primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(texture.primvar)
    instead = f"the primvar reader's fallback {texture.st_fallback} is used"
    if not (primvar and primvar.HasValue()):
        notes.warn(prim, f"primvars:{texture.primvar}", f"is not authored, but a texture reads it; {instead}",
                   "MissingPrimvar")
        return constant
    values = primvar.ComputeFlattened(where.time)
    name = primvar.GetAttr().GetName()
    try:
        st = np.asarray(values, dtype=np.float64).reshape(-1, 2)
    except (TypeError, ValueError):
        st = None
    if st is None or not np.isfinite(st).all():
        notes.warn(prim, name, f"is not a finite float2 array ({primvar.GetTypeName()}); {instead}", "BadValue")
        return constant
    interp = primvar.GetInterpolation()
    if interp in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(st) == n_points:
        return st[indices[corners]]
    if interp == UsdGeom.Tokens.faceVarying and len(st) == len(indices):
        return st[corners]
    if interp == UsdGeom.Tokens.uniform and len(st) == n_faces:
        return np.repeat(st[faces][:, None, :], 3, axis=1)
    if interp == UsdGeom.Tokens.constant and len(st) == 1:
        return np.broadcast_to(st[0], (n_tri, 3, 2))
    notes.warn(prim, name, f"has {len(st)} values, which do not fit its {interp} interpolation; {instead}",
               "BadValue")
    return constant
