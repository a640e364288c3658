"""``warp-st inspect A.exr --diff B.exr``: per-channel difference metrics against a tolerance.

Values compared: every channel as :meth:`warp_st.output.film.Image.channel` gives it (event
and source times absolute, float64), in float64. A pixel where both files hold NaN,
or both the same infinity, is equal (the background of the AOVs); NaN or inf against
anything else is a mismatch, which makes max-abs and rms infinite.

Metrics (per channel): ``max-abs`` = max |a - b|; ``rms`` = sqrt(mean (a - b)^2) over
all pixels (equal non-finite pairs count 0); ``fraction`` = the fraction of pixels
that differ (|a - b| > --threshold, or a mismatch).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

METRICS = ("max-abs", "rms", "fraction")


@dataclass(frozen=True)
class ChannelDiff:
    """The difference of one channel between two images of the same size."""

    name: str
    max_abs: float
    rms: float
    differing: int
    pixels: int

    @property
    def fraction(self) -> float:
        return self.differing / self.pixels if self.pixels else 0.0

    def metric(self, metric: str) -> float:
        return {"max-abs": self.max_abs, "rms": self.rms, "fraction": self.fraction}[metric]


def channel_diff(name: str, a, b, threshold: float = 0.0) -> ChannelDiff:
    """Metrics of ``a`` against ``b`` (same shape), see the module docstring."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    finite = np.isfinite(a) & np.isfinite(b)
    same_special = (np.isnan(a) & np.isnan(b)) | (np.isinf(a) & np.isinf(b) & (a == b))
    mismatch = ~(finite | same_special)
    d = np.zeros(a.shape)
    d[finite] = np.abs(a[finite] - b[finite])
    if mismatch.any():
        max_abs = rms = math.inf
    else:
        max_abs = float(d.max()) if d.size else 0.0
        rms = float(np.sqrt(np.mean(d * d))) if d.size else 0.0
    differing = int(np.count_nonzero(mismatch | (d > threshold)))
    return ChannelDiff(name, max_abs, rms, differing, int(a.size))


@dataclass
class Comparison:
    """What ``--diff`` found: per-channel metrics and what keeps the files from matching."""

    diffs: list[ChannelDiff]
    only_a: list[str]
    only_b: list[str]
    size_a: tuple[int, int]
    size_b: tuple[int, int]

    @property
    def same_size(self) -> bool:
        return self.size_a == self.size_b


def compare(image_a, image_b, channels=None, threshold: float = 0.0) -> Comparison:
    """Compare the channels of two images (``channels``: those only, else all of both)."""
    names_a, names_b = list(image_a.channel_names), list(image_b.channel_names)
    if channels is None:
        wanted = names_a + [n for n in names_b if n not in names_a]
    else:
        wanted = list(channels)
    only_a = [n for n in wanted if n in names_a and n not in names_b]
    only_b = [n for n in wanted if n in names_b and n not in names_a]
    size_a, size_b = (image_a.width, image_a.height), (image_b.width, image_b.height)
    diffs = []
    if size_a == size_b:
        diffs = [channel_diff(n, image_a.channel(n), image_b.channel(n), threshold)
                 for n in wanted if n in names_a and n in names_b]
    return Comparison(diffs, only_a, only_b, size_a, size_b)


def _num(x: float) -> str:
    return f"{x:.6g}"


def report(comparison: Comparison, name_a: str, name_b: str, metric: str, tolerance: float) -> tuple[list[str], bool]:
    """(lines to print, within tolerance)."""
    c = comparison
    lines = []
    ok = True
    if not c.same_size:
        lines.append(f"sizes differ: {name_a} is {c.size_a[0]} x {c.size_a[1]}, {name_b} is "
                     f"{c.size_b[0]} x {c.size_b[1]}: no pixels compared")
        ok = False
    for names, where, other in ((c.only_a, name_a, name_b), (c.only_b, name_b, name_a)):
        if names:
            lines.append(f"only in {where} (not in {other}): {', '.join(names)}")
            ok = False
    if c.diffs:
        lines.append(f"  {'channel':<22} {'max-abs':>12} {'rms':>12} {'differing':>10} {'fraction':>10}  "
                     f"{metric} <= {tolerance:g}")
    over = []
    for d in c.diffs:
        value = d.metric(metric)
        passed = value <= tolerance
        if not passed:
            over.append(d.name)
        lines.append(f"  {d.name:<22} {_num(d.max_abs):>12} {_num(d.rms):>12} {d.differing:>10} "
                     f"{d.fraction:>10.4g}  {'ok' if passed else 'OVER'}")
    if over:
        lines.append(f"{metric} over the tolerance {tolerance:g} on {len(over)} channel(s): {', '.join(over)}")
        ok = False
    elif c.diffs and ok:
        lines.append(f"{metric} within the tolerance {tolerance:g} on all {len(c.diffs)} channel(s)")
    return lines, ok
