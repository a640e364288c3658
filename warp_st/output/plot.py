"""Pictures of images: one channel in false colour, the beauty, a contact sheet.

They serve ``warp-st inspect``'s PNGs and Jupyter (``Image._repr_png_``, ``Image.show``:
:class:`ChannelView`), so scripted studies need no plotting code of their own.

Colour: each AOV in a colour map with a colour bar titled with its units
(``warp_st.output.film.channel_spec(name).units``); the Doppler factor on a logarithmic
red-blue scale centred on 1 (red: received redder than emitted); objectId in a
qualitative map; NaN / inf pixels (the background of most AOVs) in grey. Event and
source times are drawn relative to the header's ``spacetime:timeOrigin`` (the camera
time), i.e. minus the lookback, in a single image; a contact sheet shares one absolute
scale across its frames. PNGs are written atomically.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

BEAUTY = "RGB"
BACKGROUND_GREY = "0.5"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def srgb(image) -> np.ndarray:
    """The beauty as sRGB in [0, 1], (H, W, 3): linear values clipped to [0, 1], NaN as 0."""
    linear = np.clip(np.nan_to_num(image.rgba[..., :3].astype(np.float64)), 0.0, 1.0)
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)


def spec_of(name: str):
    """The docs/spec.md §4 registry entry of ``name``; None for an extra (renamed RenderVar) channel."""
    from warp_st.output.channels import channel_spec

    try:
        return channel_spec(name)
    except KeyError:
        return None


def units(name: str) -> str:
    spec = spec_of(name)
    return spec.units if spec is not None and spec.units else "value as stored"


def plane(image, name: str, *, relative: bool) -> np.ndarray:
    """Channel ``name`` as float64; event / source times minus timeOrigin when ``relative``."""
    data = np.asarray(image.channel(name), dtype=np.float64)
    spec = spec_of(name)
    if relative and spec is not None and spec.relative_time:
        data = data - image.time_origin
    return data


def shown(name: str, data: np.ndarray) -> np.ndarray:
    """``data`` as drawn: NaN where there is no value (objectId 0, the background, too)."""
    if name == "objectId":
        return np.where(data == 0, np.nan, data)
    return data


@dataclass
class Colouring:
    """How a channel is coloured: a colour map and a norm over the given planes."""

    cmap: object
    norm: object
    label: str


def colouring(name: str, planes, label: str) -> Colouring:
    """One shared colour scale for ``planes`` (finite values only; grey for the rest)."""
    import matplotlib.colors as mcolors

    plt = _pyplot()
    finite = np.concatenate([p[np.isfinite(p)] for p in planes]) if planes else np.zeros(0)
    if name == "spacetime.doppler":
        positive = finite[finite > 0]
        span = float(np.max(np.abs(np.log(positive)))) if positive.size else 0.0
        span = max(span, 1e-6)
        cmap = plt.get_cmap("RdBu").with_extremes(bad=BACKGROUND_GREY)
        label = f"{label}\nlog scale; red: redshift (< 1), blue: blueshift (> 1)"
        return Colouring(cmap, mcolors.LogNorm(math.exp(-span), math.exp(span)), label)
    lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    if name == "objectId":  # one colour per id: tab20 without its greys, repeating after 18 ids
        ids = int(hi) if finite.size else 1
        palette = [plt.get_cmap("tab20")(k) for k in range(20) if k not in (14, 15)]
        colours = [palette[k % len(palette)] for k in range(ids)]
        cmap = mcolors.ListedColormap(colours).with_extremes(bad=BACKGROUND_GREY)
        return Colouring(cmap, mcolors.BoundaryNorm(np.arange(0.5, ids + 1.0), ids), label)
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    cmap = plt.get_cmap("viridis").with_extremes(bad=BACKGROUND_GREY)
    return Colouring(cmap, mcolors.Normalize(lo, hi), label)


_LOG_TICKS = (0.1, 0.2, 0.25, 1 / 3, 0.5, 2 / 3, 0.8, 1.0, 1.25, 1.5, 2.0, 3.0, 4.0, 5.0, 10.0)


def _colour_bar(fig, picture, ax, colours: Colouring):
    """A colour bar labelled with the units; plain-number ticks on the Doppler's log scale,
    integer ticks for objectId."""
    import matplotlib.colors as mcolors
    import matplotlib.ticker as mticker

    bar = fig.colorbar(picture, ax=ax, fraction=0.05, pad=0.02)
    bar.set_label(colours.label)
    if isinstance(colours.norm, mcolors.BoundaryNorm):
        bar.ax.yaxis.set_major_locator(mticker.MaxNLocator(integer=True, nbins=20))
    if isinstance(colours.norm, mcolors.LogNorm):
        lo, hi = colours.norm.vmin, colours.norm.vmax
        ticks = [t for t in _LOG_TICKS if lo <= t <= hi] or [1.0]
        bar.set_ticks(ticks)
        bar.ax.yaxis.set_major_formatter(mticker.FuncFormatter(lambda v, _: f"{v:.3g}"))
        bar.ax.yaxis.set_minor_formatter(mticker.NullFormatter())
    return bar


def _save(fig, png_path: Path) -> None:
    from warp_st.output.exr import atomic_output

    with atomic_output(png_path) as fh:
        fig.savefig(fh, format="png")


def _frame_text(image) -> str:
    frame = image.frame
    text = f"frame {frame:g}" if math.isfinite(frame) else "frame ?"
    return f"{text}, t_c = {image.camera_time:g}"


def write_beauty_png(image, png_path: Path) -> None:
    """The beauty as an 8-bit sRGB PNG, one pixel per pixel (no axes, no colour bar)."""
    plt = _pyplot()
    from warp_st.output.exr import atomic_output

    with atomic_output(png_path) as fh:
        plt.imsave(fh, srgb(image), format="png")


def channel_figure(image, title: str, name: str):
    """The figure of channel ``name``: false colour, colour bar with the units, title, pixel axes."""
    plt = _pyplot()
    spec = spec_of(name)
    data = plane(image, name, relative=True)
    label = units(name)
    if spec is not None and spec.relative_time:
        if image.time_origin == image.camera_time:
            label = f"{label}\nt - t_c (t_c = {image.camera_time!r}): minus the lookback"
        else:
            label = f"{label}\nt - spacetime:timeOrigin ({image.time_origin!r})"
    data = shown(name, data)
    colours = colouring(name, [data], label)
    dpi = 100
    image_w = max(5.0, min(10.0, 1.6 * image.width / dpi))  # inches for the picture itself
    fig, ax = plt.subplots(figsize=(image_w + 2.2, image_w * image.height / max(image.width, 1) + 1.2), dpi=dpi,
                           layout="constrained")
    picture = ax.imshow(np.ma.masked_invalid(data), cmap=colours.cmap, norm=colours.norm, interpolation="nearest")
    _colour_bar(fig, picture, ax, colours)
    ax.set_title(f"{title}: {name}  ({_frame_text(image)})")
    ax.set_xlabel("x (pixels); grey: no value (NaN / inf: background)")
    ax.set_ylabel("y (pixels)")
    return fig


def write_channel_png(image, exr_path: Path, name: str, png_path: Path) -> None:
    """:func:`channel_figure` as a PNG, written atomically."""
    fig = channel_figure(image, exr_path.name, name)
    try:
        _save(fig, png_path)
    finally:
        _pyplot().close(fig)


def grid_shape(count: int, columns: int | None = None) -> tuple[int, int]:
    """(rows, columns) of a contact sheet: ``columns`` (default ceil(sqrt(count))) wide."""
    cols = max(1, min(count, columns or math.ceil(math.sqrt(count))))
    return math.ceil(count / cols), cols


def contact_sheet_figure(images, names, channel: str, columns: int | None = None):
    """A grid of thumbnails of ``channel`` (BEAUTY: the sRGB beauty), one per image in
    row-major order, each titled with its name, frame and camera time; AOVs share one
    colour scale (absolute values) and one colour bar."""
    plt = _pyplot()
    rows, cols = grid_shape(len(images), columns)
    aspect = images[0].height / max(images[0].width, 1)
    cell_w = 3.2
    fig, axes = plt.subplots(rows, cols, figsize=(cols * cell_w + (1.2 if channel != BEAUTY else 0.2),
                                                  rows * (cell_w * aspect + 0.6)), dpi=100, squeeze=False,
                             layout="constrained")
    colours = None
    if channel != BEAUTY:
        planes = [shown(channel, plane(img, channel, relative=False)) for img in images]
        label = units(channel)
        if spec_of(channel) is not None and spec_of(channel).relative_time:
            label += "\nabsolute lab time t"
        colours = colouring(channel, planes, label)
    picture = None
    for k, ax in enumerate(axes.flat):
        ax.set_xticks([])
        ax.set_yticks([])
        if k >= len(images):
            ax.set_axis_off()
            continue
        if colours is None:
            ax.imshow(srgb(images[k]), interpolation="nearest")
        else:
            picture = ax.imshow(np.ma.masked_invalid(planes[k]), cmap=colours.cmap, norm=colours.norm,
                                interpolation="nearest")
        ax.set_title(f"{names[k]}\n{_frame_text(images[k])}", fontsize=8)
    fig.suptitle(f"{channel}: {len(images)} frames" + ("" if colours is None else " (one shared colour scale)"))
    if picture is not None:
        _colour_bar(fig, picture, axes.ravel().tolist(), colours)
    return fig, (rows, cols)


def write_contact_sheet(images, names, channel: str, png_path: Path, columns: int | None = None) -> tuple[int, int]:
    """:func:`contact_sheet_figure` as a PNG, written atomically; returns (rows, columns)."""
    fig, shape = contact_sheet_figure(images, names, channel, columns)
    try:
        _save(fig, png_path)
    finally:
        _pyplot().close(fig)
    return shape


def beauty_png(image) -> bytes:
    """The beauty as 8-bit sRGB PNG bytes, one pixel per pixel (Jupyter's ``_repr_png_``)."""
    buffer = io.BytesIO()
    _pyplot().imsave(buffer, srgb(image), format="png")
    return buffer.getvalue()


class ChannelView:
    """What ``Image.show(name)`` returns: Jupyter draws it as :func:`channel_figure` (false
    colour, a colour bar with the units); ``name`` None shows the beauty."""

    def __init__(self, image, name: str | None = None, title: str = "Image"):
        if name is not None:
            image.channel(name)  # an unknown name fails here, not inside Jupyter's display
        self.image, self.name, self.title = image, name, title

    def figure(self):
        """The matplotlib figure (the caller closes it); None for the beauty."""
        return None if self.name is None else channel_figure(self.image, self.title, self.name)

    def _repr_png_(self) -> bytes:
        if self.name is None:
            return beauty_png(self.image)
        fig = self.figure()
        try:
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png")
            return buffer.getvalue()
        finally:
            _pyplot().close(fig)
