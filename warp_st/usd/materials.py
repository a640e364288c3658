"""Bound UsdPreviewSurface materials → :class:`Material`, with ``displayColor`` as the fallback.

Bindings are resolved by USD (``UsdShade.MaterialBindingAPI.ComputeBoundMaterial``):
direct and collection-based bindings, inherited down the hierarchy, binding strength.
The purpose is ``full`` (a final-frame renderer), then ``preview`` when a prim has no
full or all-purpose binding. GeomSubsets of the ``materialBind`` family bind their
faces' own materials (:meth:`MaterialReader.subsets`).

Honoured: a UsdPreviewSurface on the material's universal ``outputs:surface``, its
``diffuseColor``, ``emissiveColor`` and ``metallic`` (the weight of a perfect mirror,
docs/spec.md §2), each a constant or a ``UsdUVTexture`` (``warp_st.usd.textures``).
Everything else a bound material says is a warning naming the prim and the attribute
(``warp_st.usd.diagnostics``): other shaders and render contexts, inputs
driven by other shaders, the other UsdPreviewSurface inputs when they differ from the
shader's defaults, per-vertex display colours. A value of the wrong type is a warning
too, and the default is used. A material without a universal surface but with a MaterialX
one (``outputs:mtlx:surface``: Standard Surface, OpenPBR) is read by ``warp_st.usd.materialx``,
MaterialX's ``ND_UsdPreviewSurface_surfaceshader`` there as a UsdPreviewSurface.
"""
from __future__ import annotations

import dataclasses
import threading

import numpy as np
from pxr import Sdr, UsdGeom, UsdShade

from warp_st.core.scene import Material, SceneError, Texture
from warp_st.usd import attributes as A
from warp_st.usd.attributes import Where
from warp_st.usd.diagnostics import Notes, same_value
from warp_st.usd.materialx import MaterialXReader
from warp_st.usd.textures import TextureReader, one_st

__all__ = ["MaterialReader", "preview_defaults"]

#: The render context of inline MaterialX networks (``warp_st.usd.materialx``), read
#: when a material has no universal surface.
MTLX = "mtlx"
#: MaterialX's own UsdPreviewSurface node (the inputs and defaults of UsdPreviewSurface).
MTLX_PREVIEW = "ND_UsdPreviewSurface_surfaceshader"

#: UsdPreviewSurface inputs the renderer uses.
HONOURED_INPUTS = ("diffuseColor", "emissiveColor", "metallic")


_defaults: dict | None = None
_defaults_lock = threading.Lock()


def preview_defaults() -> dict:
    """UsdPreviewSurface's input defaults, from USD's shader registry (read once).

    Serialised: two of USD's validation worker threads entering the registry's first
    discovery together deadlocked (its lock against the GIL); ``validate_stage`` also
    reads it in the main thread before the validators run."""
    global _defaults
    with _defaults_lock:
        if _defaults is None:
            node = Sdr.Registry().GetShaderNodeByIdentifier("UsdPreviewSurface")
            _defaults = {} if not node else {name: node.GetShaderInput(name).GetDefaultValue()
                                             for name in node.GetShaderInputNames()}
    return _defaults


class MaterialReader:
    """``reader(gprim) -> Material``; the warnings go to ``notes``."""

    def __init__(self, where: Where, notes: Notes):
        self.where = where
        self.notes = notes
        self._by_material: dict[str, Material | None] = {}
        self._texture = TextureReader(where, notes)
        self._materialx = MaterialXReader(where, notes, self._texture)

    def __call__(self, prim) -> Material:
        found = self._bound(prim)
        return found if found is not None else self._display_color(prim)

    def subsets(self, prim) -> list[tuple[np.ndarray, Material]]:
        """(face indices, material) of each ``materialBind`` GeomSubset of ``prim`` that
        binds a UsdPreviewSurface material (the faces of the others keep the gprim's)."""
        out = []
        for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
            found = self._bound(subset.GetPrim(), keep_unusable=False)
            if found is None:
                continue
            try:
                faces = A.int_array(self.where, subset.GetPrim(), "indices")
            except SceneError as exc:
                self.notes.value_error(exc, "the subset's faces keep the mesh's material")
                continue
            if faces is not None and len(faces):
                out.append((faces, found))
        return out

    def _bound(self, prim, keep_unusable: bool = True) -> Material | None:
        """The material bound to ``prim`` (purpose full, else preview), None without one.
        A bound material whose shading cannot be used gives the prim's displayColor under
        the material's name (its CryptoMaterial), unless ``keep_unusable`` is False."""
        binding = UsdShade.MaterialBindingAPI(prim)
        material, _ = binding.ComputeBoundMaterial(UsdShade.Tokens.full)
        if not material:
            material, _ = binding.ComputeBoundMaterial(UsdShade.Tokens.preview)
        if not material:
            return None
        key = str(material.GetPath())
        if key not in self._by_material:
            self._by_material[key] = self._preview_surface(material)
        if self._by_material[key] is None and keep_unusable:  # displayColor, still its CryptoMaterial
            return dataclasses.replace(self._display_color(prim), prim_path=key)
        return self._by_material[key]

    def _preview_surface(self, material) -> Material | None:
        source = material.ComputeSurfaceSource()
        shader = source[0] if isinstance(source, tuple) else source
        instead = "displayColor is used"
        expected = "UsdPreviewSurface"  # on the universal output
        if not shader:
            mtlx = material.ComputeSurfaceSource(MTLX)[0]  # no universal surface here: the mtlx one only
            if mtlx and mtlx.GetShaderId() == MTLX_PREVIEW:
                shader, expected = mtlx, MTLX_PREVIEW  # MaterialX's UsdPreviewSurface: the same inputs
            elif mtlx:
                return self._materialx(material, mtlx)
        if not shader:
            others = [o.GetFullName() for o in material.GetSurfaceOutputs() if o.GetFullName() != "outputs:surface"]
            if others:
                self.notes.warn(material.GetPrim(), others[0], "only a UsdPreviewSurface on outputs:surface or a "
                                f"MaterialX surface on outputs:mtlx:surface is supported (not this render context's "
                                f"shading); {instead}", "UnsupportedShader")
            else:
                self.notes.warn(material.GetPrim(), "outputs:surface", f"has no surface shader; {instead}",
                                "UnsupportedShader")
            return None
        shader_id = shader.GetShaderId()
        if shader_id != expected:
            self.notes.warn(material.GetPrim(), "outputs:surface",
                            f"its shader {shader.GetPath()} is {str(shader_id or 'not identified')!r}, not "
                            f"UsdPreviewSurface, which is the only one supported; {instead}", "UnsupportedShader")
            return None
        defaults = Material()
        diffuse, diffuse_tex = self._input(shader, "diffuseColor", 3, defaults.diffuse)
        emissive, emissive_tex = self._input(shader, "emissiveColor", 3, defaults.emissive)
        metallic, metallic_tex = self._input(shader, "metallic", 1, (defaults.metallic,))
        textures = [t for t in (diffuse_tex, emissive_tex, metallic_tex) if t is not None]
        one_st(self.notes, shader.GetPrim(), textures)
        material_out = Material(
            diffuse=tuple(diffuse), emissive=tuple(emissive), metallic=float(np.clip(metallic[0], 0.0, 1.0)),
            diffuse_texture=diffuse_tex, emissive_texture=emissive_tex, metallic_texture=metallic_tex,
            prim_path=str(material.GetPath()),
        )
        self._other_inputs(shader)
        return material_out

    def _input(self, shader, name: str, size: int, fallback):
        """(the input's value, its Texture or None), following connections to the
        value-producing attribute.

        A connection to a UsdUVTexture output is a texture (``warp_st.usd.textures``;
        its fallback when the file cannot be used). A connection to another shader's
        output cannot be evaluated here: a warning, and the input's own authored value,
        else the UsdPreviewSurface default. A value of the wrong type: a warning, and
        the default."""
        inp = shader.GetInput(name)
        if not inp:
            return [float(x) for x in fallback], None
        attr = inp.GetAttr()
        producers = inp.GetValueProducingAttributes()
        if producers and UsdShade.Output.IsOutput(producers[0]):
            source = UsdShade.Shader(producers[0].GetPrim())
            if source and source.GetShaderId() == "UsdUVTexture":
                found = self._texture(producers[0], size)
                if isinstance(found, Texture):
                    return [float(x) for x in fallback], found
                return found, None
            self._connected(shader, inp, producers[0], "its own value, else the default, is used")
        elif producers:
            attr = producers[0]
        prim, attr_name = attr.GetPrim(), attr.GetName()
        try:
            if size == 1:
                return [A.real(self.where, prim, attr_name, fallback[0])], None
            return [float(x) for x in A.vector(self.where, prim, attr_name, size, fallback)], None
        except SceneError as exc:
            self.notes.value_error(exc, f"the UsdPreviewSurface default {tuple(fallback)} is used")
            return [float(x) for x in fallback], None

    def _connected(self, shader, inp, output, instead: str) -> None:
        source = UsdShade.Shader(output.GetPrim())
        source_id = str(source.GetShaderId() or "") if source else ""
        what = ("textures (UsdUVTexture) are read on diffuseColor, emissiveColor and metallic only"
                if source_id == "UsdUVTexture" else "shader networks are not evaluated")
        self.notes.warn(shader.GetPrim(), inp.GetFullName(), f"is connected to {output.GetPrim().GetPath()} "
                        f"({source_id or 'no shader id'}): {what}; {instead}", "NotHonoured")

    def _other_inputs(self, shader) -> None:
        """Warnings for authored UsdPreviewSurface inputs the renderer does not use."""
        defaults = preview_defaults()
        for inp in shader.GetInputs():
            name = inp.GetBaseName()
            if name in HONOURED_INPUTS:
                continue
            producers = inp.GetValueProducingAttributes()
            if producers and UsdShade.Output.IsOutput(producers[0]):
                self._connected(shader, inp, producers[0], "ignored")
                continue
            attr = producers[0] if producers else inp.GetAttr()
            if not attr.HasAuthoredValue():
                continue
            value = attr.Get(self.where.time)
            if name in defaults and same_value(value, defaults[name]):
                continue  # the default: the same picture as not authoring it
            why = ("not honoured (the surface is Lambert diffuse plus a metallic mirror)" if name in defaults
                   else "not a UsdPreviewSurface input")
            self.notes.warn(shader.GetPrim(), inp.GetFullName(), f"{why}; ignored", "NotHonoured")

    def _display_color(self, prim) -> Material:
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance("displayColor")
        if not (primvar and primvar.HasValue()):
            return Material()
        attr = primvar.GetAttr()
        try:
            colors = A.vec3_array(self.where, attr.GetPrim(), attr.GetName())
        except SceneError as exc:
            self.notes.value_error(exc, f"the default colour {Material().diffuse} is used")
            return Material()
        if colors is None or not len(colors):
            return Material()
        first = 0
        if primvar.IsIndexed():
            indices = primvar.GetIndices(self.where.time)
            first = int(indices[0]) if len(indices) and 0 <= indices[0] < len(colors) else 0
        distinct = len(np.unique(colors, axis=0)) > 1
        interpolation = primvar.GetInterpolation()
        if distinct and interpolation != UsdGeom.Tokens.constant:
            self.notes.warn(attr.GetPrim(), attr.GetName(), f"{interpolation} colours are not supported (one colour "
                            "per surface); its first colour is used", "NotHonoured")
        return Material(diffuse=tuple(float(c) for c in colors[first]))
