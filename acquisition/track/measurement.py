"""The track's measuring side: Eq. (4) of the followed object
(:class:`snrmon.acquisition.measure.target_snr.TargetMeter`) and the rim-contamination reference
it is measured against.

The reference (``reference_noise``): ``"recent"`` (default) keeps the same recent-noise median
as :class:`snrmon.acquisition.measure.peak_snr.PeakSnrMeter`, fed with the tracker's output
frames; a number fixes it (DN); None skips the contamination test.
"""

from __future__ import annotations

import math

import numpy as np

from snrmon.acquisition.measure.blob import Blob
from snrmon.acquisition.measure.contamination import NoiseReference
from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig, flags_to_bits, remember
from snrmon.acquisition.measure.running_stats import RunningSnr
from snrmon.acquisition.measure.target_snr import TargetMeter
from snrmon.acquisition.track.config import WING_PX, TrackerConfig


class TrackMeasurement:
    """Measures the followed object with Eq. (4) and keeps what that needs from frame to frame:
    the contamination reference (module docstring) and the PSF wings the meter has seen.
    ``memory``: the noise reference and running statistics the track feeds
    (:func:`snrmon.acquisition.measure.peak_snr.remember`), a measurer's own; None: a reference
    of the track's own and no running statistics."""

    def __init__(
        self,
        measurement: PeakSnrConfig,
        config: TrackerConfig,
        reference_noise: float | str | None,
        memory: tuple[NoiseReference, RunningSnr] | None,
    ) -> None:
        self.meter = TargetMeter(
            measurement, gate_px=config.gate_px, guard_px=config.guard_px, wing_px=WING_PX
        )
        if not (reference_noise is None or reference_noise == "recent") and (
            isinstance(reference_noise, str) or not math.isfinite(reference_noise)
        ):
            raise ValueError(
                f"reference_noise must be 'recent', a number (DN) or None, got {reference_noise!r}"
            )
        self._fixed_reference = reference_noise
        self._running: RunningSnr | None
        if memory is None:
            m = measurement
            self._reference = NoiseReference(m.reference_frames, m.reference_min_frames)
            self._running = None
        else:
            self._reference, self._running = memory

    @property
    def reference_noise(self) -> float | None:
        """The contamination reference (DN) the next frame is measured against."""
        if self._fixed_reference == "recent":
            return self._reference.value
        return self._fixed_reference  # type: ignore[return-value]

    def measure(self, pixels: np.ndarray, at, size: int, ref: float | None) -> PeakSnr:
        """Eq. (4) in the ``size`` window centred ``at``."""
        return self.meter.measure(pixels, at, size, ref)

    def measure_object(self, pixels: np.ndarray, blob: Blob, at, ref: float | None):
        """(Eq. (4) of the object ``blob``, where, the window's size)."""
        return self.meter.measure_object(pixels, blob, at, ref)

    def remember(self, m: PeakSnr) -> None:
        """The frame's output feeds the reference (and the running statistics)."""
        remember(flags_to_bits(m.flags), m.bg_std, m.snr, self._reference, self._running)

    def clear(self) -> None:
        """A new click: nothing of the last track's frames counts."""
        self._reference.clear()
        self.meter.wings.clear()

    def reference_snapshot(self) -> dict:
        return self._reference.snapshot()

    def wings_snapshot(self) -> dict:
        return self.meter.wings.snapshot()

    def restore(self, reference: dict, wings: dict) -> None:
        """Restore :meth:`reference_snapshot` and :meth:`wings_snapshot`."""
        self._reference.restore(reference)
        self.meter.wings.restore(wings)
