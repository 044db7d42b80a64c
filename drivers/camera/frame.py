"""The frame that every camera source delivers."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, slots=True)
class Frame:
    """One raw camera frame.

    Attributes:
        pixels: 2-D ``uint16`` array (rows, columns) of raw digital numbers (DN). Sources hand
            out the array they received without copying; consumers must not modify it.
        camera: name of the camera that produced it (``"mwir"``, ``"lwir"``, ...).
        counter: the camera's own frame counter; a gap means the camera or link dropped frames.
        t_host_ns: ``time.monotonic_ns()`` when the host received the frame (the common clock of
            every device thread).
        t_device_ns: the camera's own timestamp in nanoseconds where it gives one, else ``None``.
        meta: anything else the source reports (format, exposure), never needed by the pipeline.
    """

    pixels: np.ndarray
    camera: str
    counter: int
    t_host_ns: int
    t_device_ns: int | None = None
    meta: dict = field(default_factory=dict, compare=False)

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the pixel array."""
        return self.pixels.shape  # type: ignore[return-value]
