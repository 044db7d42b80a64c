"""The format a camera negotiated at start-up: size, pixel format and frame rate."""

from __future__ import annotations

from dataclasses import dataclass

#: Bits per pixel on the wire of the pixel formats snrmon understands (GenICam PFNC names;
#: ``Y16`` is the UVC name of the same 16-bit mono layout).
BITS_PER_PIXEL = {"Mono8": 8, "Mono12": 12, "Mono14": 14, "Mono16": 16, "Y16": 16}


@dataclass(frozen=True, slots=True)
class CameraFormat:
    """What the camera agreed to deliver.

    Attributes:
        width: pixels per row.
        height: rows.
        pixel_format: GenICam / UVC name (``"Mono16"``, ``"Y16"``).
        fps: frame rate the camera reports, ``None`` when it does not say (free-running).
    """

    width: int
    height: int
    pixel_format: str
    fps: float | None

    @property
    def bits_per_pixel(self) -> int:
        """Bits per pixel on the wire; unknown formats count as 16 bits (raw IR)."""
        return BITS_PER_PIXEL.get(self.pixel_format, 16)

    @property
    def bytes_per_frame(self) -> int:
        """Payload of one frame in bytes."""
        return self.width * self.height * self.bits_per_pixel // 8

    @property
    def bytes_per_s(self) -> float:
        """Payload rate in bytes per second (0 when the rate is unknown)."""
        return self.bytes_per_frame * (self.fps or 0.0)

    def __str__(self) -> str:
        rate = "free-running" if self.fps is None else f"{self.fps:g} fps"
        return f"{self.width}x{self.height} {self.pixel_format} {rate}"
