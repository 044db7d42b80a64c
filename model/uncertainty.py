"""The uncertainty budget of paper section 9 / Fig. 12 as a band around the corrected curves.

Relative (1-sigma-like) uncertainties, defaults from section 9: target outline 3 % (area and
radiometry), path radiance 5 % (of the measured background radiance), real MTF 5 %, target-size blur
10 %; radiometry (blackbody calibration, spectral) 2 % and transmission (actual vs modelled) 3 %,
the spreads of the Monte-Carlo band (:mod:`snrmon.model.montecarlo`); without them the band would be
blind to both. Outline, radiometry and transmission scale the signal directly. The path radiance
term is propagated through the contrast: the signal is tau (L_target - L_background), so a fraction
u of the background radiance moves the SNR by u L_bg / (L_t - L_bg) -- the amplification the paper
describes ("a 2 % change in flux ... the SNR error is 83 %"). MTF and target-size blur apply only
where the target is unresolved (they act through the PVF). Components combine as a root sum of
squares ("rss", independent) or linearly ("linear", the worst case the paper cascades for its biased
modelling errors).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UncertaintyBudget:
    """Relative uncertainties (fractions) of Fig. 12 and how to combine them."""

    target_outline: float = 0.03
    path_radiance: float = 0.05
    mtf: float = 0.05
    target_size_blur: float = 0.10
    radiometry: float = 0.02  # the target's Delta-T to ~0.5 K of ~25 K (montecarlo.py)
    transmission: float = 0.03  # the transmission's weighting spectrum and fit (montecarlo.py)
    combine: str = "rss"

    def __post_init__(self) -> None:
        for name in (
            "target_outline",
            "path_radiance",
            "mtf",
            "target_size_blur",
            "radiometry",
            "transmission",
        ):
            v = getattr(self, name)
            if not (0.0 <= v < 10.0):
                raise ValueError(f"uncertainty {name} must be a fraction >= 0, got {v!r}")
        if self.combine not in ("rss", "linear"):
            raise ValueError(f"uncertainty combine must be 'rss' or 'linear', got {self.combine!r}")

    def relative(self, background_over_contrast: np.ndarray, unresolved: np.ndarray) -> np.ndarray:
        """Relative SNR uncertainty per range, given L_bg / (L_t - L_bg) (photon, in band,
        response-weighted) and the unresolved mask."""
        amp = np.abs(np.asarray(background_over_contrast, dtype=float))
        unres = np.asarray(unresolved, dtype=bool)
        terms = [
            np.full(amp.shape, self.target_outline),
            np.full(amp.shape, self.radiometry),
            np.full(amp.shape, self.transmission),
            self.path_radiance * amp,
            np.where(unres, self.mtf, 0.0),
            np.where(unres, self.target_size_blur, 0.0),
        ]
        stack = np.stack(terms)
        if self.combine == "rss":
            return np.sqrt(np.sum(stack**2, axis=0))
        return np.sum(stack, axis=0)

    def band(self, snr: np.ndarray, relative: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) = snr (1 -/+ u), the lower bound clipped at 0."""
        snr = np.asarray(snr, dtype=float)
        return np.clip(snr * (1.0 - relative), 0.0, None), snr * (1.0 + relative)
