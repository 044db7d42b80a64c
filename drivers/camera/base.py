"""What every camera driver shares on top of :class:`snrmon.drivers.device.Device`: the negotiated
format, drop counting from the camera's own counter, and the measured frame rate."""

from __future__ import annotations

import logging
import time
from collections import deque

from snrmon.drivers.camera.counter import FrameCounterGaps
from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.device import Device

log = logging.getLogger(__name__)
STALLED_INTERVALS = 5  # frames missed in a row before the measured rate reads 0
STALLED_MIN_S = 1.0


class CameraDevice(Device[Frame]):
    """A :class:`Device` that delivers :class:`Frame` objects.

    Subclasses call :meth:`_negotiated` from ``_connect`` once the camera agreed a format, and
    :meth:`_account` for each frame's counter before publishing it. Gaps in the counter are added
    to ``status().dropped``.
    """

    def __init__(
        self, name: str, *, counter_modulus: int | None = None, zero_skipped: bool = False, **kw
    ) -> None:
        super().__init__(name, **kw)
        self.format: CameraFormat | None = None
        self._gaps = FrameCounterGaps(counter_modulus, zero_skipped=zero_skipped)
        self._arrivals: deque[int] = deque(maxlen=121)

    def _negotiated(self, fmt: CameraFormat) -> None:
        """Record and report the format the camera agreed to at start-up."""
        if fmt != self.format:
            log.info("camera %s negotiated %s", self.name, fmt)
        self.format = fmt
        self._gaps.reset()
        self._arrivals.clear()

    def _account(self, counter: int) -> None:
        """Count the frames missing before ``counter`` (camera or link drops)."""
        self._arrivals.append(time.monotonic_ns())
        missing = self._gaps.update(counter)
        if missing:
            self._set(
                dropped=self.status().dropped + missing,
                last_error=f"{missing} frame(s) missing before counter {counter}",
            )

    def measured_fps(self) -> float | None:
        """Frame rate over the last (up to) 120 frames received, ``None`` before two frames;
        0 once no frame has come for :data:`STALLED_INTERVALS` of their mean interval (and at
        least :data:`STALLED_MIN_S`): a camera that stopped is not shown at its old rate."""
        arrivals = list(self._arrivals)
        if len(arrivals) < 2 or arrivals[-1] == arrivals[0]:
            return None
        span_ns = arrivals[-1] - arrivals[0]
        silent_ns = time.monotonic_ns() - arrivals[-1]
        if silent_ns > max(STALLED_INTERVALS * span_ns / (len(arrivals) - 1), STALLED_MIN_S * 1e9):
            return 0.0
        return (len(arrivals) - 1) / (span_ns / 1e9)
