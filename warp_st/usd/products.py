"""UsdRender products and vars → :class:`warp_st.core.scene.RenderProduct` (docs/usd_render_products.md).

The chosen RenderSettings prim's ``products`` name UsdRender.Product prims (productName,
possibly time-sampled; camera and resolution overriding the settings'); each product's
``orderedVars`` name UsdRender.Var prims, resolved here to docs/spec.md §4 channels:

- the source: ``sourceName`` (default: the var's prim name) through :data:`SOURCES`;
  ``sourceType`` raw or intrinsic, or lpe for the beauty (``C.*``); primvar has no source;
- the storage: ``dataType`` through :data:`DATA_TYPES` (HALF, FLOAT or UINT, 1, 3 or 4
  components), which must fit the source;
- the names: ``driver:parameters:aov:name`` (default: the var's prim name, as the
  UsdRender schema says) for one component, ``<name>.R/.G/.B(/.A)`` for several, except
  the beauty layer (colour named color, rgba, Ci or C; alpha named a or alpha), whose
  channels are the plain R, G, B, A a compositor reads as its rgba layer;
- a Cryptomatte source (``CryptoObject``, ``CryptoMaterial``): its float32 rank groups
  ``<name>00.R .. <name>02.A`` (docs/spec.md §4.4).

Anything else is a SceneError naming the file, the prim and the attribute.
"""
from __future__ import annotations

from pxr import UsdGeom, UsdRender

from warp_st.core.scene import RenderProduct, RenderVar
from warp_st.output import cryptomatte
from warp_st.output.film import CHANNEL_NAMES, channel_spec
from warp_st.usd.attributes import DEFAULT_TIME, Where

__all__ = ["SOURCES", "DATA_TYPES", "read_products"]

_BEAUTY = ("R", "G", "B", "A")

#: sourceName -> the docs/spec.md §4 channels it holds: pipeline names, then every SPEC name.
SOURCES: dict[str, tuple[str, ...]] = {
    **dict.fromkeys(("color", "rgba", "Ci", "C", "LdrColor", "HdrColor"), _BEAUTY),
    **dict.fromkeys(("a", "alpha"), ("A",)),
    **dict.fromkeys(("depth", "z"), ("Z",)),
    **dict.fromkeys(("primId", "id"), ("objectId",)),
    **{name: (name,) for name in CHANNEL_NAMES},
}

#: dataType -> (EXR pixel type, components).
DATA_TYPES: dict[str, tuple[str, int]] = {
    "half": ("HALF", 1), "float": ("FLOAT", 1), "int": ("UINT", 1), "uint": ("UINT", 1),
    "color3h": ("HALF", 3), "half3": ("HALF", 3), "color3f": ("FLOAT", 3), "float3": ("FLOAT", 3),
    "color4h": ("HALF", 4), "half4": ("HALF", 4), "color4f": ("FLOAT", 4), "float4": ("FLOAT", 4),
}

#: LPEs that select the whole beauty (all light reaching the camera).
_BEAUTY_LPES = ("C.*", "C.*[LO]")
#: Names of the beauty layer: written as the plain R, G, B, A channels.
_BEAUTY_COLOR_NAMES = ("color", "rgba", "Ci", "C")
_BEAUTY_ALPHA_NAMES = ("a", "alpha")
AOV_NAME = "driver:parameters:aov:name"


def _string(where: Where, prim, name: str) -> str | None:
    """A uniform token / string value, None when it has none."""
    attr = prim.GetAttribute(name)
    value = attr.Get(DEFAULT_TIME) if attr else None
    if value is None:
        return None
    if not isinstance(value, str):
        # (the schema's declared type can hide the authored one: report the value's)
        raise where.error(prim, name, f"must be a token or string, got {type(value).__name__} {value!r}")
    return value


def _targets(where: Where, stage, prim, rel_name: str, schema, what: str) -> list:
    prims = []
    for path in prim.GetRelationship(rel_name).GetForwardedTargets():
        target = stage.GetPrimAtPath(path)
        if not target or not target.IsA(schema):
            raise where.error(prim, rel_name, f"{path} is not a {what} prim")
        prims.append(target)
    return prims


def _source(where: Where, var, source_name: str, source_type: str) -> tuple[str, ...]:
    if source_type == "lpe":
        if source_name not in _BEAUTY_LPES:
            raise where.error(var, "sourceName", f"light path expression {source_name!r} is not supported: "
                              f"warp_st computes the whole beauty only ({' or '.join(_BEAUTY_LPES)})")
        return _BEAUTY
    if source_type == "primvar":
        raise where.error(var, "sourceType", "warp_st writes no primvar outputs; use sourceType raw with a "
                          f"sourceName of {', '.join((*SOURCES, *cryptomatte.LAYERS))}")
    if source_name not in SOURCES:
        raise where.error(var, "sourceName", f"unknown source {source_name!r}; known: "
                          f"{', '.join((*SOURCES, *cryptomatte.LAYERS))}")
    return SOURCES[source_name]


def _pixel_type(where: Where, var, data_type: str, source_name: str, sources: tuple[str, ...]) -> tuple[str, int]:
    """(pixel type, components) of ``data_type`` if it can hold ``sources``."""
    spec_type = channel_spec(sources[0]).pixel_type
    if sources == _BEAUTY:
        fits = {"color3h", "half3", "color3f", "float3", "color4h", "half4", "color4f", "float4"}
    elif spec_type == "UINT":
        fits = {"int", "uint"}
    else:
        fits = {"half", "float"}
    if data_type not in fits:
        raise where.error(var, "dataType", f"{data_type!r} cannot hold source {source_name!r} "
                          f"({spec_type} x {len(sources)}); use one of {', '.join(sorted(fits))}")
    return DATA_TYPES[data_type]


def _cryptomatte_var(where: Where, var, source_name: str) -> RenderVar:
    """A Cryptomatte layer (docs/spec.md §4.4): its float32 RGBA rank groups, named
    ``<aov name>00.R ..`` (the aov name, else the prim name, is the layer's typename)."""
    authored = var.GetAttribute("dataType")
    data_type = (_string(where, var, "dataType") if authored and authored.HasAuthoredValue() else None) or "color4f"
    if data_type not in ("color4f", "float4"):
        raise where.error(var, "dataType", f"{data_type!r} cannot hold source {source_name!r} (Cryptomatte "
                          "layers are float32 RGBA); use color4f or float4")
    aov_name = _string(where, var, AOV_NAME)
    if aov_name is not None and not aov_name.strip():
        raise where.error(var, AOV_NAME, "is empty: name the EXR channel")
    name = aov_name or var.GetName()
    sources = cryptomatte.rank_channels(source_name)
    return RenderVar(str(var.GetPath()), source_name, data_type,
                     tuple((name + s[len(source_name):], s) for s in sources))


def read_var(where: Where, var) -> RenderVar:
    """One UsdRender.Var resolved to channels (see the module docstring)."""
    prim_name = var.GetName()
    source_name = _string(where, var, "sourceName") or prim_name
    source_type = _string(where, var, "sourceType") or "raw"
    if source_type not in ("raw", "intrinsic", "lpe", "primvar"):
        raise where.error(var, "sourceType", f"must be raw, primvar, lpe or intrinsic; got {source_type!r}")
    if source_name in cryptomatte.LAYERS and source_type in ("raw", "intrinsic"):
        return _cryptomatte_var(where, var, source_name)
    sources = _source(where, var, source_name, source_type)
    data_type = _string(where, var, "dataType") or "color3f"
    pixel_type, components = _pixel_type(where, var, data_type, source_name, sources)
    aov_name = _string(where, var, AOV_NAME)
    if aov_name is not None and not aov_name.strip():
        raise where.error(var, AOV_NAME, "is empty: name the EXR channel")
    name = aov_name or prim_name
    sources = sources[:components]
    if components == 1:
        names = ("A",) if sources == ("A",) and name in _BEAUTY_ALPHA_NAMES else (name,)
    elif name in _BEAUTY_COLOR_NAMES:
        names = sources
    else:
        names = tuple(f"{name}.{c}" for c in sources)
    return RenderVar(str(var.GetPath()), source_name, data_type, tuple(zip(names, sources)),
                     half=pixel_type == "HALF")


def _product_name(where: Where, product) -> tuple[str, tuple[tuple[float, str], ...]]:
    """(default, time samples) of productName; every value a non-empty .exr name."""
    attr = product.GetAttribute("productName")
    times = attr.GetTimeSamples() if attr else []
    samples = tuple((float(t), attr.Get(t)) for t in times)
    default = _string(where, product, "productName") or ""
    for time, value in samples or ((None, default),):
        at = "" if time is None else f" at time {time:g}"
        if not isinstance(value, str) or not value.strip():
            raise where.error(product, "productName", f"is empty{at}: name the file the product writes")
        if not value.lower().endswith(".exr"):
            raise where.error(product, "productName", f"{value!r}{at} must end in .exr (warp_st writes OpenEXR)")
    return default, samples


def read_products(where: Where, stage, settings, resolution) -> tuple[RenderProduct, ...]:
    """The products of the RenderSettings prim ``settings``, in ``products`` order.

    ``resolution(prim)``: the reader's validated int2 ``resolution`` of a prim, or None.
    """
    products = []
    for product in _targets(where, stage, settings, "products", UsdRender.Product, "UsdRender.Product"):
        product_type = _string(where, product, "productType") or "raster"
        if product_type != "raster":
            raise where.error(product, "productType", f"{product_type!r} is not supported (raster only)")
        name, samples = _product_name(where, product)
        cameras = _targets(where, stage, product, "camera", UsdGeom.Camera, "UsdGeom.Camera")
        var_prims = _targets(where, stage, product, "orderedVars", UsdRender.Var, "UsdRender.Var")
        if not var_prims:
            raise where.error(product, "orderedVars", "names no RenderVar: list the channels to write")
        vars_ = tuple(read_var(where, var) for var in var_prims)
        seen: dict[str, str] = {}
        for var, var_prim in zip(vars_, var_prims):
            for channel, _ in var.channels:
                if channel in seen:
                    raise where.error(var_prim, AOV_NAME, f"EXR channel {channel!r} is also written by "
                                      f"{seen[channel]}; give the vars distinct names")
                seen[channel] = var.prim_path
        products.append(RenderProduct(
            prim_path=str(product.GetPath()), name=name, vars=vars_, name_samples=samples,
            camera=str(cameras[0].GetPath()) if cameras else None, resolution=resolution(product)))
    return tuple(products)
