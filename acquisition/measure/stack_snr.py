"""The vectorised Eq. (4) path for a stack of frames (replay): the same numbers as the per-frame
:class:`snrmon.acquisition.measure.peak_snr.PeakSnrMeter`, bit for bit, flags and running state
included.

The peak search, the background gather and the statistics run on all frames at once (the same
reductions as the per-frame path, which calls the same core with N = 1); only the
``rim_contaminated`` flag, whose recent-noise reference depends on the frames before, is decided
in a short scalar loop. Frames are processed in chunks so memory stays bounded on long stacks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.measure.peak_snr import (
    PeakSnr,
    PeakSnrMeter,
    background_of,
    flags_from_bits,
    measure_core,
    pixel_of,
    result_at,
    sequential_pass,
)


@dataclass(frozen=True)
class StackSnr:
    """Struct of arrays, one entry per frame, fields as in :class:`PeakSnr`; ``flag_bits`` bit i
    is ``FLAG_NAMES[i]``."""

    peak_x: np.ndarray
    peak_y: np.ndarray
    peak: np.ndarray
    bg_mean: np.ndarray
    bg_std: np.ndarray
    snr: np.ndarray
    flag_bits: np.ndarray
    background: str = "rim"  # the method of every frame: "rim" or "rect"

    def __len__(self) -> int:
        return len(self.snr)

    def __getitem__(self, i: int) -> PeakSnr:
        return result_at(self, i, self.background)  # type: ignore[arg-type]

    @property
    def bits(self) -> np.ndarray:
        return self.flag_bits

    def flags(self, i: int) -> frozenset[str]:
        return flags_from_bits(int(self.flag_bits[i]))

    def to_list(self) -> list[PeakSnr]:
        return [result_at(self, i, self.background) for i in range(len(self))]  # type: ignore[arg-type]


def measure_stack(
    stack: np.ndarray,
    at_xy: tuple[float, float],
    *,
    meter: PeakSnrMeter | None = None,
    chunk_frames: int = 4096,
    window: int = 100,
    **settings,
) -> StackSnr:
    """Eq. (4) on every frame of ``stack`` (N, H, W) at the fixed point ``at_xy``.

    Equals ``[meter.measure(frame, at_xy) for frame in stack]`` bit for bit. With ``meter`` its
    configuration and state (noise reference, running statistics) are used and advanced, so a
    long replay can be fed in pieces; without it a fresh ``PeakSnrMeter(window=window,
    **settings)`` is used (settings: the fields of ``PeakSnrConfig``).
    """
    if meter is None:
        meter = PeakSnrMeter(window=window, **settings)
    elif settings:
        raise ValueError("give either a meter or settings, not both")
    if stack.ndim != 3:
        raise ValueError(f"a stack must be 3-D (frames, rows, columns), got shape {stack.shape}")
    x, y = pixel_of(at_xy)
    parts = []
    for start in range(0, max(len(stack), 1), chunk_frames):
        core = measure_core(stack[start : start + chunk_frames], x, y, meter.config)
        sequential_pass(core, meter.config, reference=meter.reference, running=meter.running)
        parts.append(core)

    def joined(name: str) -> np.ndarray:
        return np.concatenate([getattr(p, name) for p in parts])

    return StackSnr(
        joined("peak_x"),
        joined("peak_y"),
        joined("peak"),
        joined("bg_mean"),
        joined("bg_std"),
        joined("snr"),
        joined("bits"),
        background_of(meter.config),
    )
