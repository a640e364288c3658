"""MaterialX shading networks inlined in USD (the ``mtlx`` render context) -> :class:`Material`.

A Material with no universal ``outputs:surface`` but an ``outputs:mtlx:surface`` (found with
``UsdShade.Material.ComputeSurfaceSource("mtlx")``, through NodeGraph outputs) is read
here when that surface is one of the shading models of :data:`MODELS`:

- ``ND_standard_surface_surfaceshader`` (Autodesk Standard Surface 1.0.1, MaterialX 1.39's
  defaults; ``..._100`` is 1.0.0 with MaterialX 1.38's): diffuse = ``base`` x
  ``base_color``, emissive = ``emission`` x ``emission_color``, metallic = ``metalness``;
- ``ND_open_pbr_surface_surfaceshader`` (OpenPBR 1.1): diffuse = ``base_weight`` x
  ``base_color``, emissive = ``emission_luminance`` x ``emission_color`` (the nits taken
  as the renderer's linear radiance, 1 nit = 1.0, as MaterialX's own graph of the node
  feeds its ``uniform_edf``), metallic = ``base_metalness``.

The weights (``base``, ``emission``, ...) are constants; the colours and the metalness a
constant or an ``ND_image_color3`` / ``ND_image_float`` node (:class:`ImageReader`). Every
input is read through UsdShade's ``GetValueProducingAttributes`` (material and NodeGraph
interface inputs and outputs seen through); an unauthored one is the model's default.
The other inputs of the model (roughness, specular, coat, ...) are not honoured: one
warning per input authored with a value other than its default, or connected. An honoured
input driven by any other node, a surface of another kind: a warning, and the material
falls back to displayColor.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from pxr import Sdf, UsdShade

from warp_st.core.scene import Material, SceneError, Texture
from warp_st.usd import attributes as A
from warp_st.usd.attributes import Where
from warp_st.usd.diagnostics import Notes, same_value
from warp_st.usd.images import ImageError
from warp_st.usd.textures import TextureReader, one_st, rgba

__all__ = ["MaterialXReader", "ImageReader", "MODELS"]

_WHITE = (1.0, 1.0, 1.0)
_BLACK = (0.0, 0.0, 0.0)

#: Autodesk Standard Surface 1.0.0 (MaterialX 1.38's ND_standard_surface_surfaceshader):
#: input -> default (None: a geometric default, Nworld / Tworld, any authored value differs).
STANDARD_100 = {
    "base": 0.8, "base_color": _WHITE, "diffuse_roughness": 0.0, "metalness": 0.0,
    "specular": 1.0, "specular_color": _WHITE, "specular_roughness": 0.2, "specular_IOR": 1.5,
    "specular_anisotropy": 0.0, "specular_rotation": 0.0,
    "transmission": 0.0, "transmission_color": _WHITE, "transmission_depth": 0.0, "transmission_scatter": _BLACK,
    "transmission_scatter_anisotropy": 0.0, "transmission_dispersion": 0.0, "transmission_extra_roughness": 0.0,
    "subsurface": 0.0, "subsurface_color": _WHITE, "subsurface_radius": _WHITE, "subsurface_scale": 1.0,
    "subsurface_anisotropy": 0.0,
    "sheen": 0.0, "sheen_color": _WHITE, "sheen_roughness": 0.3,
    "coat": 0.0, "coat_color": _WHITE, "coat_roughness": 0.1, "coat_anisotropy": 0.0, "coat_rotation": 0.0,
    "coat_IOR": 1.5, "coat_normal": None, "coat_affect_color": 0.0, "coat_affect_roughness": 0.0,
    "thin_film_thickness": 0.0, "thin_film_IOR": 1.5,
    "emission": 0.0, "emission_color": _WHITE, "opacity": _WHITE, "thin_walled": False,
    "normal": None, "tangent": None,
}
#: Standard Surface 1.0.1 (MaterialX 1.39): the same but base 1 and base_color 0.8.
STANDARD = {**STANDARD_100, "base": 1.0, "base_color": (0.8, 0.8, 0.8)}
#: OpenPBR Surface 1.1 (MaterialX 1.39's ND_open_pbr_surface_surfaceshader).
OPEN_PBR = {
    "base_weight": 1.0, "base_color": (0.8, 0.8, 0.8), "base_diffuse_roughness": 0.0, "base_metalness": 0.0,
    "specular_weight": 1.0, "specular_color": _WHITE, "specular_roughness": 0.3, "specular_ior": 1.5,
    "specular_roughness_anisotropy": 0.0,
    "transmission_weight": 0.0, "transmission_color": _WHITE, "transmission_depth": 0.0,
    "transmission_scatter": _BLACK, "transmission_scatter_anisotropy": 0.0, "transmission_dispersion_scale": 0.0,
    "transmission_dispersion_abbe_number": 20.0,
    "subsurface_weight": 0.0, "subsurface_color": (0.8, 0.8, 0.8), "subsurface_radius": 1.0,
    "subsurface_radius_scale": (1.0, 0.5, 0.25), "subsurface_scatter_anisotropy": 0.0,
    "fuzz_weight": 0.0, "fuzz_color": _WHITE, "fuzz_roughness": 0.5,
    "coat_weight": 0.0, "coat_color": _WHITE, "coat_roughness": 0.0, "coat_roughness_anisotropy": 0.0,
    "coat_ior": 1.6, "coat_darkening": 1.0,
    "thin_film_weight": 0.0, "thin_film_thickness": 0.5, "thin_film_ior": 1.4,
    "emission_luminance": 0.0, "emission_color": _WHITE,
    "geometry_opacity": 1.0, "geometry_thin_walled": False, "geometry_normal": None, "geometry_coat_normal": None,
    "geometry_tangent": None, "geometry_coat_tangent": None,
}


class Model(NamedTuple):
    """A surface shader's inputs for diffuse = weight x colour, emissive = weight x colour
    and metallic, and its input defaults."""

    diffuse: tuple[str, str]
    emission: tuple[str, str]
    metallic: str
    defaults: dict


_STANDARD_MODEL = (("base", "base_color"), ("emission", "emission_color"), "metalness")
#: The surface shaders read, by info:id.
MODELS = {
    "ND_standard_surface_surfaceshader": Model(*_STANDARD_MODEL, STANDARD),
    "ND_standard_surface_surfaceshader_100": Model(*_STANDARD_MODEL, STANDARD_100),
    "ND_open_pbr_surface_surfaceshader": Model(("base_weight", "base_color"), ("emission_luminance", "emission_color"),
                                               "base_metalness", OPEN_PBR),
}

#: MaterialX image node inputs -> defaults (``default`` is the node's type's zero).
IMAGE_DEFAULTS = {"file": None, "layer": "", "default": None, "texcoord": None, "uaddressmode": "periodic",
                  "vaddressmode": "periodic", "filtertype": "linear", "framerange": "", "frameoffset": 0,
                  "frameendaction": "constant"}
#: MaterialX address modes -> the Texture's wrap modes ("constant": the node's default, the border).
_ADDRESS = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "black"}
#: MaterialX colour-space names (the file input's colorSpace) -> images.py's.
_SPACES = {"srgb_texture": "sRGB", "lin_rec709": "raw", "raw": "raw"}
_ADDRESS_INPUTS = ("uaddressmode", "vaddressmode")
_TILING = ("uvtiling", "uvoffset", "realworldimagesize", "realworldtilesize")
#: ND_tiledimage's inputs: the image's, without address modes (always periodic), with tiling.
TILED_DEFAULTS = {**{k: v for k, v in IMAGE_DEFAULTS.items() if k not in _ADDRESS_INPUTS},
                  **dict(zip(_TILING, ((1.0, 1.0), (0.0, 0.0), (1.0, 1.0), (1.0, 1.0))))}
#: Image nodes by the size of the value they feed (3: a colour, 1: a float).
_IMAGES = {3: ("ND_image_color3", "ND_tiledimage_color3"), 1: ("ND_image_float", "ND_tiledimage_float")}


class MaterialXReader:
    """``reader(material, shader) -> Material | None`` for a Material whose ``mtlx``
    surface is ``shader`` (None: warned, displayColor is used)."""

    def __init__(self, where: Where, notes: Notes, textures: TextureReader):
        self.where = where
        self.notes = notes
        self.images = ImageReader(where, notes, textures)

    def __call__(self, material, shader) -> Material | None:
        shader_id = str(shader.GetShaderId() or "")
        model = MODELS.get(shader_id)
        if model is None:
            self.notes.warn(material.GetPrim(), "outputs:mtlx:surface",
                            f"its shader {shader.GetPath()} is {shader_id or 'not identified'!r}, not one of "
                            f"{', '.join(MODELS)}, which are the MaterialX surfaces supported; displayColor is used",
                            "UnsupportedShader")
            return None
        if self._unevaluated(shader, model):
            return None
        diffuse, diffuse_tex = self._product(shader, model, *model.diffuse)
        emissive, emissive_tex = self._product(shader, model, *model.emission)
        metallic, metallic_tex = self._input(shader, model, model.metallic, 1)
        textures = [t for t in (diffuse_tex, emissive_tex, metallic_tex) if t is not None]
        one_st(self.notes, shader.GetPrim(), textures)
        self._other_inputs(shader, model)
        return Material(diffuse=tuple(diffuse), emissive=tuple(emissive),
                        metallic=float(np.clip(metallic[0], 0.0, 1.0)), diffuse_texture=diffuse_tex,
                        emissive_texture=emissive_tex, metallic_texture=metallic_tex,
                        prim_path=str(material.GetPath()))

    def _unevaluated(self, shader, model: Model) -> bool:
        """Whether an honoured input is driven by a node that is not evaluated (one warning
        for the first): the weights must be constants, the rest may be an image node."""
        weights = {model.diffuse[0], model.emission[0]}
        for name, size in ((model.diffuse[0], 1), (model.diffuse[1], 3), (model.emission[0], 1),
                           (model.emission[1], 3), (model.metallic, 1)):
            inp = shader.GetInput(name)
            producers = inp.GetValueProducingAttributes() if inp else []
            if not (producers and UsdShade.Output.IsOutput(producers[0])):
                continue
            node = UsdShade.Shader(producers[0].GetPrim())
            node_id = str(node.GetShaderId() or "") if node else ""
            if name not in weights and node_id in _IMAGES[size]:
                continue
            what = "a constant" if name in weights else f"an {' or '.join(_IMAGES[size])} node"
            self.notes.warn(shader.GetPrim(), inp.GetFullName(),
                            f"is connected to {producers[0].GetPrim().GetPath()} ({node_id or 'no shader id'}), "
                            f"which is not evaluated (it can be {what}); displayColor is used", "NotHonoured")
            return True
        return False

    def _product(self, shader, model: Model, weight_name: str, colour_name: str):
        """(weight x colour, the colour's Texture scaled by the weight, or None)."""
        weight, _ = self._input(shader, model, weight_name, 1)
        colour, texture = self._input(shader, model, colour_name, 3)
        w = weight[0]
        if texture is not None and w != 1.0:  # (at 1 the texels stay shared with other users)
            texels = texture.texels.copy()
            texels[..., :3] *= np.float32(w)
            border = tuple(float(b) * w for b in texture.border[:3]) + (float(texture.border[3]),)
            texture = dataclasses.replace(texture, texels=texels, border=border)
        return [w * c for c in colour], texture

    def _input(self, shader, model: Model, name: str, size: int):
        """(the input's value (size floats), its Texture or None); a connected input is an
        image node (``_unevaluated`` checked)."""
        default = model.defaults[name]
        fallback = (float(default),) if size == 1 else tuple(float(x) for x in default)
        inp = shader.GetInput(name)
        if not inp:
            return list(fallback), None
        producers = inp.GetValueProducingAttributes()
        if producers and UsdShade.Output.IsOutput(producers[0]):
            return self.images(UsdShade.Shader(producers[0].GetPrim()), producers[0], size)
        attr = producers[0] if producers else inp.GetAttr()
        return _constant(self.where, self.notes, attr, size, fallback, "the MaterialX default"), None

    def _other_inputs(self, shader, model: Model) -> None:
        """Warnings for the inputs that are authored, differ from the defaults, and are not honoured."""
        honoured = {*model.diffuse, *model.emission, model.metallic}
        for inp in shader.GetInputs():
            name = inp.GetBaseName()
            if name in honoured:
                continue
            why = ("not honoured (the surface is Lambert diffuse plus a metallic mirror)" if name in model.defaults
                   else f"not an input of {shader.GetShaderId()} warp_st knows")
            _unused(self.where, self.notes, shader, inp, model.defaults.get(name), why)


class ImageReader:
    """``reader(node, output, size) -> (values, Texture | None)`` for an ``ND_image_color3``
    (size 3) or ``ND_image_float`` (size 1) node, or their ``ND_tiledimage_*`` (periodic,
    st mapped by :meth:`_tiling`), as the Texture of a UsdUVTexture: its
    ``file`` through OpenImageIO (``TextureReader.image``, in the colour space of the
    file input's ``colorSpace``: ``srgb_texture`` sRGB, ``lin_rec709`` / ``raw`` raw, none
    ``auto``), ``uaddressmode`` / ``vaddressmode`` (``constant``: the ``default`` outside
    [0, 1)), the st of ``texcoord``: an ``ND_texcoord_vector2`` (index 0: the primvar
    ``st``), an ``ND_geompropvalue_vector2`` (``geomprop``, its ``default`` where the gprim
    lacks it), a constant, or unauthored the primvar ``st`` (MaterialX's UV0). A missing or
    unreadable file: a warning, and the node's ``default`` is the value."""

    def __init__(self, where: Where, notes: Notes, textures: TextureReader):
        self.where = where
        self.notes = notes
        self.textures = textures
        self._read: dict[tuple[str, str, int], tuple] = {}

    def __call__(self, node, output, size: int):
        key = (str(node.GetPath()), output.GetBaseName(), size)
        if key not in self._read:  # one Texture per node: materials sharing it share its texels
            self._read[key] = self._image(node, output, size)
        return self._read[key]

    def _image(self, node, output, size: int):
        prim = node.GetPrim()
        default = _constant(self.where, self.notes, _attr(node, "default"), size, (0.0,) * size, "the default")
        constant = (default, None)
        if output.GetBaseName() != "out":
            self.notes.warn(prim, output.GetFullName(), f"is not the output of {node.GetShaderId()} (out); its "
                            f"default {tuple(default)} is used", "NotHonoured")
            return constant
        file_attr = _attr(node, "file")
        asset = file_attr.Get(self.where.time) if file_attr else None
        path = asset.resolvedPath if isinstance(asset, Sdf.AssetPath) else ""
        shown = asset.path if isinstance(asset, Sdf.AssetPath) and asset.path else "no file"
        if not path:
            self.notes.warn(prim, "inputs:file", f"{shown!s} cannot be found; the image's default {tuple(default)} "
                            "is used", "MissingTexture")
            return constant
        try:
            image = self.textures.image(path, self._space(node, file_attr))
        except ImageError as exc:
            self.notes.warn(prim, "inputs:file", f"{shown} cannot be read ({exc}); the image's default "
                            f"{tuple(default)} is used", "MissingTexture")
            return constant
        tiled = "tiledimage" in str(node.GetShaderId())
        if tiled:
            wraps, transform, defaults = ("repeat", "repeat"), self._tiling(node), TILED_DEFAULTS
        else:
            def address(where, prim, name, default):
                return A.token(where, prim, name, tuple(_ADDRESS), default)
            wraps = tuple(_ADDRESS[self._checked(node, axis, "periodic", address)] for axis in _ADDRESS_INPUTS)
            transform, defaults = None, IMAGE_DEFAULTS
        primvar, st_fallback = self._texcoord(node)
        used = ("file", "default", "texcoord", "filtertype", *(_TILING if tiled else _ADDRESS_INPUTS))
        for inp in node.GetInputs():
            name = inp.GetBaseName()
            if name not in used:
                why = "not honoured" if name in defaults else f"not an input of {node.GetShaderId()} warp_st knows"
                _unused(self.where, self.notes, node, inp, defaults.get(name), why)
        border = (*default, 1.0) if size == 3 else (default[0],) * 3 + (1.0,)
        texture = Texture(file=path, texels=rgba(image.texels), wrap=wraps, border=border,
                          channel=-1 if size == 3 else 0, primvar=primvar, st_fallback=st_fallback,
                          st_transform=transform)
        return list(default), texture

    def _tiling(self, node) -> np.ndarray | None:
        """The 2 x 3 affine st map of an ND_tiledimage (MaterialX's graph of the node):
        st' = (st x uvtiling - uvoffset) / realworldimagesize x realworldtilesize; None for
        the identity."""
        v = {name: np.array(_constant(self.where, self.notes, _attr(node, name), 2, TILED_DEFAULTS[name],
                                      "the default"), dtype=np.float64)
             for name in _TILING}
        if not (v["realworldimagesize"] > 0).all():
            self.notes.warn(node.GetPrim(), "inputs:realworldimagesize", f"must be > 0, got "
                            f"{tuple(v['realworldimagesize'].tolist())}; (1, 1) is used", "BadValue")
            v["realworldimagesize"] = np.ones(2)
        ratio = v["realworldtilesize"] / v["realworldimagesize"]
        scale, offset = v["uvtiling"] * ratio, -v["uvoffset"] * ratio
        if (scale == 1.0).all() and (offset == 0.0).all():
            return None
        return np.array([[scale[0], 0.0, offset[0]], [0.0, scale[1], offset[1]]])

    def _space(self, node, file_attr) -> str:
        authored = file_attr.GetColorSpace() if file_attr.HasColorSpace() else ""
        if not authored:
            return "auto"
        if str(authored) in _SPACES:
            return _SPACES[str(authored)]
        self.notes.warn(node.GetPrim(), "inputs:file", f"its colorSpace {str(authored)!r} is not supported "
                        f"({', '.join(_SPACES)}); 'auto' is used", "NotHonoured")
        return "auto"

    def _texcoord(self, node) -> tuple[str, tuple[float, float]]:
        """(primvar, fallback st) of the node's texcoord; primvar "" is the constant fallback."""
        inp = node.GetInput("texcoord")
        producers = inp.GetValueProducingAttributes() if inp else []
        if not producers:
            return "st", (0.0, 0.0)
        if not UsdShade.Output.IsOutput(producers[0]):
            if not producers[0].HasAuthoredValue():
                return "st", (0.0, 0.0)
            st = _constant(self.where, self.notes, producers[0], 2, (0.0, 0.0), "(0, 0)")
            return "", (st[0], st[1])
        source = UsdShade.Shader(producers[0].GetPrim())
        source_id = str(source.GetShaderId() or "") if source else ""
        if source_id == "ND_texcoord_vector2":
            index = self._checked(source, "index", 0, A.integer)
            if index != 0:
                self.notes.warn(source.GetPrim(), "inputs:index", f"is {index}: only the first texture coordinates "
                                "(index 0, the primvar 'st') are read; 'st' is used", "NotHonoured")
            return "st", (0.0, 0.0)
        if source_id == "ND_geompropvalue_vector2":
            attr = _attr(source, "geomprop")
            name = attr.Get(self.where.time) if attr else None
            fallback = _constant(self.where, self.notes, _attr(source, "default"), 2, (0.0, 0.0), "(0, 0)")
            return str(name or "st"), (fallback[0], fallback[1])
        self.notes.warn(node.GetPrim(), "inputs:texcoord", f"is connected to {source.GetPath() if source else '?'} "
                        f"({source_id or 'no shader id'}), which is not evaluated (only ND_texcoord_vector2 and "
                        "ND_geompropvalue_vector2 are); the primvar 'st' is used", "NotHonoured")
        return "st", (0.0, 0.0)

    def _checked(self, node, name: str, default, read):
        """``read(where, prim, attribute, default)`` of the input's value-producing attribute
        (``attributes.token``, ``integer``), ``default`` without one; a bad value is a
        warning and the default."""
        attr = _attr(node, name)
        if attr is None:
            return default
        try:
            return read(self.where, attr.GetPrim(), attr.GetName(), default)
        except SceneError as exc:
            self.notes.value_error(exc, f"{default!r} is used")
            return default


def _attr(node, name: str):
    """The attribute giving the input's value (through interface inputs), None when it has
    none or another node drives it."""
    inp = node.GetInput(name)
    if not inp:
        return None
    producers = inp.GetValueProducingAttributes()
    if producers and UsdShade.Output.IsOutput(producers[0]):
        return None
    return producers[0] if producers else inp.GetAttr()


def _constant(where: Where, notes: Notes, attr, size: int, fallback, what: str) -> list[float]:
    """The attribute's value as ``size`` floats, ``fallback`` when it has none; a value of
    the wrong type is a warning and the fallback."""
    if attr is None:
        return [float(x) for x in fallback]
    prim, name = attr.GetPrim(), attr.GetName()
    try:
        if size == 1:
            return [A.real(where, prim, name, fallback[0])]
        return [float(x) for x in A.vector(where, prim, name, size, fallback)]
    except SceneError as exc:
        notes.value_error(exc, f"{what} {tuple(fallback)} is used")
        return [float(x) for x in fallback]


def _unused(where: Where, notes: Notes, node, inp, default, why: str) -> None:
    """One warning for an input that is not honoured, when connected or authored with a
    value other than ``default`` (None: any authored value)."""
    producers = inp.GetValueProducingAttributes()
    if producers and UsdShade.Output.IsOutput(producers[0]):
        notes.warn(node.GetPrim(), inp.GetFullName(), f"is connected to {producers[0].GetPrim().GetPath()}: "
                   f"{why}; ignored", "NotHonoured")
        return
    attr = producers[0] if producers else inp.GetAttr()
    if not attr.HasAuthoredValue():
        return
    value = attr.Get(where.time)
    if default is not None and _same(value, default):
        return
    notes.warn(node.GetPrim(), inp.GetFullName(), f"{why}; ignored", "NotHonoured")


def _same(value, default) -> bool:
    """An authored value equal to a default of :data:`STANDARD` and co (float32 values
    compared at float32)."""
    if isinstance(default, tuple):
        try:
            return np.array_equal(np.asarray(value, dtype=np.float32), np.asarray(default, dtype=np.float32))
        except (TypeError, ValueError):
            return False
    if isinstance(default, float) and not isinstance(value, bool):
        try:
            return np.float32(value) == np.float32(default)
        except (TypeError, ValueError):
            return False
    return same_value(value, default)
