"""The drone as the model sees it (paper section 3): two characteristic dimensions and an
apparent (radiometric) temperature per band, plus the RSS delta-T for reference, and optionally
its outline: the segmented pixels of a close, resolved stop (:class:`Outline`), which the
model's "outline" footprint spreads the small dimension's light over instead of the paper's
square (:mod:`snrmon.model.footprint`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from snrmon.model.constants import ZERO_C_K

SIZES = ("small", "large")


@dataclass(frozen=True)
class Outline:
    """The drone's segmented outline at a close stop (paper section 3: "outlining the target
    (segmentation)"): ``rows`` of "0"/"1" (row 0 at the top, 1 = inside), each pixel a square
    of ``pixel_m`` at the drone (the stop's range x the camera's IFOV). Its area is the small
    dimension's square when the small dimension was measured from it."""

    rows: tuple[str, ...]
    pixel_m: float

    def __post_init__(self) -> None:
        widths = {len(r) for r in self.rows}
        if not self.rows or len(widths) != 1 or set("".join(self.rows)) - {"0", "1"}:
            raise ValueError("an outline is rows of equal length made of 0 and 1")
        if "1" not in "".join(self.rows):
            raise ValueError("an outline needs at least one pixel inside (1)")
        if not (self.pixel_m > 0 and math.isfinite(self.pixel_m)):
            raise ValueError(f"an outline's pixel_m must be > 0 m, got {self.pixel_m!r}")

    @property
    def mask(self) -> np.ndarray:
        """(rows, columns) booleans, True inside."""
        return np.array([[c == "1" for c in r] for r in self.rows], bool)

    @property
    def area_m2(self) -> float:
        return float(self.mask.sum()) * self.pixel_m**2

    def offsets_m(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x of each column, y of each row, mask): the pixel centres in metres from the
        outline's area centroid (x right, y down), for :func:`snrmon.model.footprint.
        average_pvf_outline`."""
        m = self.mask
        rows, cols = np.nonzero(m)
        x = (np.arange(m.shape[1]) - cols.mean()) * self.pixel_m
        y = (np.arange(m.shape[0]) - rows.mean()) * self.pixel_m
        return x, y, m


@dataclass(frozen=True, eq=False)
class Target:
    """``small_m``: square root of the outlined target area; ``large_m``: square root of the box
    around the body without blades (section 3). ``temp_c`` and ``rss_delta_t_k`` map a band key
    ("mwir", "lwir") to the measured average temperature [C] and RSS delta-T [K]."""

    name: str
    small_m: float
    large_m: float
    temp_c: Mapping[str, float]
    rss_delta_t_k: Mapping[str, float] = field(default_factory=dict)
    description: str = ""
    outline: Outline | None = None  # the segmented outline of a close stop, if measured

    def size_m(self, size: str) -> float:
        if size not in SIZES:
            raise ValueError(f"target size must be 'small' or 'large', got {size!r}")
        return self.small_m if size == "small" else self.large_m

    def temp_k(self, band: str) -> float:
        """Apparent target temperature in the band ("mwir"/"lwir") [K]."""
        if band not in self.temp_c:
            known = ", ".join(sorted(self.temp_c)) or "none"
            raise ValueError(f"target {self.name!r} has no temperature for band {band!r} ({known})")
        return float(self.temp_c[band]) + ZERO_C_K

    def area_m2(self, size: str) -> float:
        return self.size_m(size) ** 2
