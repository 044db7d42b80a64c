"""The uncertainty budget of paper section 9 / Fig. 12 as a band around the corrected curves.

Relative (1-sigma-like) uncertainties, defaults from section 9: target outline 3 % (area and
radiometry), path radiance 5 % (of the measured background radiance), real MTF 5 %, target-size
blur 10 %; radiometry (blackbody calibration, spectral) 2 % and the transmission, the spreads of
the Monte-Carlo band (:mod:`snrmon.model.montecarlo`); without them the band would be blind to
both. The transmission's error is a relative error of the band's optical depth OD = -ln(tau)
(10 %: the band model against the real spectrum and the met readings' own errors), so by
Beer-Lambert it moves the signal by 10 % x OD: 2.1 % at 50 m, 5.6 % at 500 m, 14.5 % at 5 km in
the MWIR on a US Standard day; not a flat +-3 % at every range. Outline, radiometry and
transmission scale the signal directly. The path radiance term is propagated through the
contrast: the signal is tau (L_target - L_background), so a fraction u of the background radiance
moves the SNR by u L_bg / (L_t - L_bg) -- the amplification the paper describes ("a 2 % change
in flux ... the SNR error is 83 %"). MTF and target-size blur apply only where the target is
unresolved (they act through the PVF). Components combine as a root sum of squares ("rss",
independent) or linearly ("linear", the worst case the paper cascades for its biased modelling
errors). Where the sky temperature was not measured but assumed equal to the air's, the
path-radiance term is the radiance of ``sky_assumed_k`` (8 K) of sky temperature instead of 5 %.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np


@dataclass(frozen=True)
class UncertaintyBudget:
    """Relative uncertainties (fractions) of Fig. 12 and how to combine them."""

    target_outline: float = 0.03
    path_radiance: float = 0.05
    mtf: float = 0.05
    target_size_blur: float = 0.10
    radiometry: float = 0.02  # the target's Delta-T to ~0.5 K of ~25 K (montecarlo.py)
    optical_depth: float = 0.10  # relative, of the band's -ln(tau) (montecarlo.py)
    sky_assumed_k: float = 8.0  # the sky's error when assumed equal to the air (montecarlo.py)
    combine: str = "rss"

    RELATIVE: ClassVar[tuple[str, ...]] = (
        "target_outline",
        "path_radiance",
        "mtf",
        "target_size_blur",
        "radiometry",
        "optical_depth",
    )
    """The terms that are fractions (``sky_assumed_k`` is in kelvin)."""

    @classmethod
    def only(cls, **terms: float) -> UncertaintyBudget:
        """A budget with every term 0 but ``terms`` (one source of the band at a time)."""
        values: dict[str, Any] = {f.name: 0.0 for f in fields(cls) if f.name != "combine"}
        values.update(terms)
        return cls(**values)

    def __post_init__(self) -> None:
        for name in self.RELATIVE:
            v = getattr(self, name)
            if not (0.0 <= v < 10.0):
                raise ValueError(f"uncertainty {name} must be a fraction >= 0, got {v!r}")
        if self.combine not in ("rss", "linear"):
            raise ValueError(f"uncertainty combine must be 'rss' or 'linear', got {self.combine!r}")
        if not (0.0 <= self.sky_assumed_k < 100.0):
            raise ValueError(
                f"uncertainty sky_assumed_k must be >= 0 K, got {self.sky_assumed_k!r}"
            )

    def terms(
        self,
        background_over_contrast: np.ndarray,
        unresolved: np.ndarray,
        optical_depth=0.0,
        sky_fraction_per_k: float | None = None,
    ) -> dict[str, np.ndarray]:
        """Each relative term per range, given L_bg / (L_t - L_bg) (photon, in band,
        response-weighted), the unresolved mask, the band's optical depth -ln(tau) per range and,
        where the sky was assumed rather than measured, dL_sky/dT / L_sky [1/K]."""
        amp = np.abs(np.asarray(background_over_contrast, dtype=float))
        unres = np.asarray(unresolved, dtype=bool)
        od = np.broadcast_to(np.asarray(optical_depth, dtype=float), amp.shape)
        path = self.path_radiance
        if sky_fraction_per_k is not None:
            path = self.sky_assumed_k * float(sky_fraction_per_k)
        return {
            "target_outline": np.full(amp.shape, self.target_outline),
            "radiometry": np.full(amp.shape, self.radiometry),
            "transmission": self.optical_depth * od,
            "path_radiance": path * amp,
            "mtf": np.where(unres, self.mtf, 0.0),
            "target_size_blur": np.where(unres, self.target_size_blur, 0.0),
        }

    def relative(
        self,
        background_over_contrast: np.ndarray,
        unresolved: np.ndarray,
        optical_depth=0.0,
        sky_fraction_per_k: float | None = None,
    ) -> np.ndarray:
        """Relative SNR uncertainty per range: the :meth:`terms` combined."""
        terms = self.terms(background_over_contrast, unresolved, optical_depth, sky_fraction_per_k)
        stack = np.stack(list(terms.values()))
        if self.combine == "rss":
            return np.sqrt(np.sum(stack**2, axis=0))
        return np.sum(stack, axis=0)

    def band(self, snr: np.ndarray, relative: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) = snr (1 -/+ u), the lower bound clipped at 0."""
        snr = np.asarray(snr, dtype=float)
        return np.clip(snr * (1.0 - relative), 0.0, None), snr * (1.0 + relative)
