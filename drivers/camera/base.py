"""What every camera driver shares on top of :class:`snrmon.drivers.device.Device`: the negotiated
format and drop counting from the camera's own counter."""

from __future__ import annotations

import logging

from snrmon.drivers.camera.counter import FrameCounterGaps
from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.device import Device

log = logging.getLogger(__name__)


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

    def _negotiated(self, fmt: CameraFormat) -> None:
        """Record and report the format the camera agreed to at start-up."""
        if fmt != self.format:
            log.info("camera %s negotiated %s", self.name, fmt)
        self.format = fmt
        self._gaps.reset()

    def _account(self, counter: int) -> None:
        """Count the frames missing before ``counter`` (camera or link drops)."""
        missing = self._gaps.update(counter)
        if missing:
            self._set(
                dropped=self.status().dropped + missing,
                last_error=f"{missing} frame(s) missing before counter {counter}",
            )
