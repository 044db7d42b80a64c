"""The drone as the model sees it (paper section 3): two characteristic dimensions and an
apparent (radiometric) temperature per band, plus the RSS delta-T for reference."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from snrmon.model.constants import ZERO_C_K

SIZES = ("small", "large")


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
