"""FLIR radiometric files as frame stacks: FFF frames, SEQ and CSQ recordings, radiometric JPEG.

Every one of them is built of FFF frames (the layout exiftool's FLIR module documents):

* an FFF frame starts with a 64-byte header: ``FFF\\0``, the creator (16 bytes), the format
  version (u32 at 0x14, 100-199: it tells the header's byte order, which is either), the offset
  of the record directory (u32 at 0x18) and its number of entries (u32 at 0x1c);
* each directory entry is 32 bytes: record type (u16), subtype (u16), version, index, the
  record's offset from the frame's start (u32 at 0x0c) and its length (u32 at 0x10);
* the raw data record (type 1) starts with a u16 that is 2 in the byte order of its own fields
  and pixels (which may differ from the header's), the width (u16 at 0x02) and height (u16 at
  0x04); the image follows at 0x20: 16-bit words, a PNG (whose 16-bit words FLIR writes
  byte-swapped, as exiftool notes) or a JPEG-LS stream (the CSQ frames; decoded by imagecodecs);
* the camera information record (type 0x20), in the byte order its first u16 (= 2) gives, holds
  the calibration (:class:`~snrmon.acquisition.calibrate.flir_planck.FlirCalibration`: floats at
  0x20-0x80 and 0x308-0x30c), the camera model (0xd4), serial number (0x104), lens (0x170) and
  the frame's time at 0x384: Unix seconds (u32), milliseconds (the low 16 bits of the next u32)
  and the time zone in minutes west of UTC (i16).

A SEQ or CSQ file is FFF frames one after the other (each frame's extent is the end of its
furthest record); an ``.fff`` is one frame; a radiometric JPEG carries one FFF frame split over
APP1 segments that start ``FLIR\\0`` (byte 6 the chunk's number, byte 7 the last number).

A recording cut short (a card pulled, a copy interrupted) is read to its last whole frame with a
warning naming the file, the frame it breaks at and the frames read; a file with no whole frame
is a ``ValueError`` naming the file and what is missing.
"""

from __future__ import annotations

import logging
import mmap
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snrmon.acquisition.calibrate.flir_planck import (
    AtmosphericTransmission,
    FlirCalibration,
    MeasurementConditions,
    PlanckConstants,
)

log = logging.getLogger(__name__)

MAGIC = b"FFF\0"
HEADER_BYTES = 0x40
ENTRY_BYTES = 0x20
RAW_DATA = 0x01
CAMERA_INFO = 0x20
PIXELS_AT = 0x20  # in the raw data record
_CAMERA_INFO_BYTES = 0x466  # the last field read (the frame rate at 0x464) ends here
SEQUENCE_SUFFIXES = frozenset({".seq", ".csq"})
JPEG_SUFFIXES = frozenset({".jpg", ".jpeg"})
FLIR_SUFFIXES = frozenset({".fff", *SEQUENCE_SUFFIXES, *JPEG_SUFFIXES})
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
JPEG_SIGNATURE = b"\xff\xd8\xff"


@dataclass(frozen=True, slots=True)
class FlirCamera:
    """What the camera information record names (times in UTC nanoseconds)."""

    model: str
    serial_number: str
    lens: str
    frame_rate_hz: int
    utc_offset_min: int  # local time minus UTC, as the camera was set


@dataclass(frozen=True, slots=True)
class _Frame:
    """One FFF frame's place in the file: where its pixels are and how they are coded."""

    start: int  # the frame's first byte in the file
    end: int  # one past its furthest record
    rows: int
    cols: int
    pixels_at: int  # the payload's first byte in the file
    pixels_bytes: int
    coding: str  # "<u2", ">u2", "png" or "jpegls"
    info_at: int | None  # the camera information record in the file, or None
    info_order: str


def _u32(buf, at: int, order: str) -> int:
    return int(struct.unpack_from(order + "I", buf, at)[0])


def _u16(buf, at: int, order: str) -> int:
    return int(struct.unpack_from(order + "H", buf, at)[0])


def _record_order(buf, at: int) -> str:
    """The byte order of a record whose first u16 is 2 (exiftool's byte-order indicator)."""
    return "<" if _u16(buf, at, "<") == 2 else ">"


def _text(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("latin-1").strip()


class _TruncatedError(ValueError):
    """A frame whose bytes end before its records do."""


def _frame(buf, start: int, name: str, index: int) -> _Frame:
    """The frame whose header starts at ``start`` (``_TruncatedError`` if the file ends inside it,
    ``ValueError`` if it is not an FFF frame)."""
    size = len(buf)
    if size - start < HEADER_BYTES:
        raise _TruncatedError(f"{size - start} bytes of its {HEADER_BYTES}-byte header")
    if buf[start : start + 4] != MAGIC:
        raise ValueError(
            f"{name}: frame {index} at byte {start} is not an FFF frame (starts with "
            f"{bytes(buf[start : start + 4])!r}, expected {MAGIC!r})"
        )
    order = "<" if 100 <= _u32(buf, start + 0x14, "<") < 200 else ">"
    if not 100 <= _u32(buf, start + 0x14, order) < 200:
        raise ValueError(
            f"{name}: frame {index}: FFF format version {_u32(buf, start + 0x14, '<')} is "
            "neither 1xx little- nor big-endian"
        )
    directory, entries = _u32(buf, start + 0x18, order), _u32(buf, start + 0x1C, order)
    end = start + directory + entries * ENTRY_BYTES
    if end > size:
        raise _TruncatedError(f"its record directory ends at byte {end}")
    raw: tuple[int, int] | None = None
    info: tuple[int, int] | None = None
    for i in range(entries):
        entry = start + directory + i * ENTRY_BYTES
        kind = _u16(buf, entry, order)
        if kind == 0:
            continue
        at = start + _u32(buf, entry + 0x0C, order)
        length = _u32(buf, entry + 0x10, order)
        end = max(end, at + length)
        if kind == RAW_DATA and raw is None:
            raw = (at, length)  # its pixels' byte order is the record's own, not the subtype
        elif kind == CAMERA_INFO and info is None:
            info = (at, length)
    if end > size:
        raise _TruncatedError(f"its records end at byte {end}")
    if raw is None:
        raise ValueError(f"{name}: frame {index} (byte {start}) holds no raw data record")
    at, length = raw
    if length < PIXELS_AT:
        raise ValueError(f"{name}: frame {index}: raw data record of {length} bytes")
    pixel_order = _record_order(buf, at)
    cols, rows = _u16(buf, at + 2, pixel_order), _u16(buf, at + 4, pixel_order)
    if not rows or not cols:
        raise ValueError(f"{name}: frame {index}: raw data gives a {cols} x {rows} image")
    payload = bytes(buf[at + PIXELS_AT : at + PIXELS_AT + len(PNG_SIGNATURE)])
    if payload.startswith(PNG_SIGNATURE):
        coding = "png"
    elif payload.startswith(JPEG_SIGNATURE):
        coding = "jpegls"
    else:
        coding = pixel_order + "u2"
        if length - PIXELS_AT < 2 * rows * cols:
            raise ValueError(
                f"{name}: frame {index}: raw data of {length - PIXELS_AT} bytes cannot hold "
                f"{cols} x {rows} 16-bit pixels"
            )
    info_at, info_order = None, "<"
    if info is not None and info[1] >= _CAMERA_INFO_BYTES:
        info_at, info_order = info[0], _record_order(buf, info[0])
    return _Frame(
        start=start,
        end=end,
        rows=rows,
        cols=cols,
        pixels_at=at + PIXELS_AT,
        pixels_bytes=length - PIXELS_AT,
        coding=coding,
        info_at=info_at,
        info_order=info_order,
    )


def _frames(buf, name: str, sequence: bool) -> list[_Frame]:
    """Every whole frame of the file, in order (one for an FFF frame file)."""
    frames: list[_Frame] = []
    cursor = 0
    while cursor < len(buf) and (sequence or not frames):
        try:
            frames.append(_frame(buf, cursor, name, len(frames)))
        except _TruncatedError as exc:
            if not frames:
                raise ValueError(
                    f"{name}: truncated FFF frame 0 ({len(buf)} bytes; {exc}): no whole frame"
                ) from None
            log.warning(
                "%s: the file is cut short in frame %d (byte %d; %s): read its %d whole frames",
                name,
                len(frames),
                cursor,
                exc,
                len(frames),
            )
            break
        cursor = frames[-1].end
    return frames


def _flir_jpeg_fff(path: Path) -> bytes:
    """The FFF frame a radiometric JPEG carries in its ``FLIR\\0`` APP1 segments, in chunk
    order; a JPEG with none is a ValueError saying what it is instead."""
    data = path.read_bytes()
    if not data.startswith(b"\xff\xd8"):
        raise ValueError(f"{path}: not a JPEG (starts with {data[:2]!r})")
    chunks: dict[int, bytes] = {}
    dji = False
    at = 2
    while at + 4 <= len(data) and data[at] == 0xFF:
        marker = data[at + 1]
        if marker == 0xDA:  # start of scan: the metadata segments are all before it
            break
        length = int.from_bytes(data[at + 2 : at + 4], "big")
        body = data[at + 4 : at + 2 + length]
        if marker == 0xE1 and body.startswith(b"FLIR\0") and len(body) >= 8:
            chunks[body[6]] = body[8:]
        elif marker in (0xE1, 0xE3) and b"DJI" in body[:4096]:
            dji = True
        at += 2 + length
    if not chunks:
        if dji:
            raise ValueError(
                f"{path}: a DJI JPEG with no FLIR radiometric data; DJI's radiometric JPEGs "
                "(R-JPEG) are readable only with DJI's closed Thermal SDK: export TIFF with it"
            )
        raise ValueError(f"{path}: a JPEG with no FLIR radiometric data (no FLIR APP1 segments)")
    missing = sorted(set(range(max(chunks) + 1)) - set(chunks))
    if missing:
        raise ValueError(f"{path}: FLIR radiometric data misses APP1 chunks {missing}")
    return b"".join(chunks[i] for i in sorted(chunks))


def _decode(buf, frame: _Frame, name: str, index: int) -> np.ndarray:
    payload = buf[frame.pixels_at : frame.pixels_at + frame.pixels_bytes]
    if frame.coding == "png":
        import cv2

        image = cv2.imdecode(np.frombuffer(payload, np.uint8), cv2.IMREAD_UNCHANGED)
        if image is None or image.dtype != np.uint16:
            raise ValueError(f"{name}: frame {index}: the raw PNG is not a 16-bit image")
        return image.byteswap()  # FLIR writes the PNG's words little-endian first
    if frame.coding == "jpegls":
        try:
            import imagecodecs
        except ImportError:
            raise ValueError(
                f"{name}: frame {index} is JPEG-LS coded (a CSQ recording): decoding it needs "
                "imagecodecs (pip install snrmon[flir])"
            ) from None
        try:
            return np.asarray(imagecodecs.jpegls_decode(bytes(payload)))
        except imagecodecs.JpeglsError as exc:
            raise ValueError(
                f"{name}: frame {index}: not a readable JPEG-LS image ({exc})"
            ) from None
    return np.frombuffer(payload, np.dtype(frame.coding), count=frame.rows * frame.cols).reshape(
        frame.rows, frame.cols
    )


def _calibration(buf, at: int, order: str) -> FlirCalibration:
    def f32(offset: int) -> float:
        return float(struct.unpack_from(order + "f", buf, at + offset)[0])

    humidity = f32(0x3C)
    return FlirCalibration(
        PlanckConstants(
            r1=f32(0x58),
            r2=f32(0x30C),
            b=f32(0x5C),
            f=f32(0x60),
            o=float(struct.unpack_from(order + "i", buf, at + 0x308)[0]),
        ),
        MeasurementConditions(
            emissivity=f32(0x20),
            object_distance_m=f32(0x24),
            reflected_temp_k=f32(0x28),
            atmospheric_temp_k=f32(0x2C),
            ir_window_temp_k=f32(0x30),
            ir_window_transmission=f32(0x34),
            # a ratio; some files store it in percent (exiftool: above 2 it is a percentage)
            relative_humidity=humidity / 100.0 if humidity > 2 else humidity,
        ),
        AtmosphericTransmission(
            alpha1=f32(0x70),
            alpha2=f32(0x74),
            beta1=f32(0x78),
            beta2=f32(0x7C),
            x=f32(0x80),
        ),
    )


def _camera(buf, at: int, order: str) -> FlirCamera:
    return FlirCamera(
        model=_text(bytes(buf[at + 0xD4 : at + 0xF4])),
        serial_number=_text(bytes(buf[at + 0x104 : at + 0x114])),
        lens=_text(bytes(buf[at + 0x170 : at + 0x190])),
        frame_rate_hz=_u16(buf, at + 0x464, order),
        utc_offset_min=-int(struct.unpack_from(order + "h", buf, at + 0x38C)[0]),
    )


def _utc_ns(buf, frame: _Frame) -> int:
    """The frame's time (UTC ns), or the smallest int64 (NaT) where it has none."""
    if frame.info_at is None:
        return int(np.iinfo(np.int64).min)
    seconds = _u32(buf, frame.info_at + 0x384, frame.info_order)
    ms = _u32(buf, frame.info_at + 0x388, frame.info_order) & 0xFFFF
    return seconds * 1_000_000_000 + ms * 1_000_000 if seconds else int(np.iinfo(np.int64).min)


@dataclass(frozen=True, slots=True)
class FlirRecording:
    """A FLIR file's frames (N, rows, columns) uint16, each frame's UTC time (datetime64[ns],
    NaT where a frame has none), the calibration and camera of its first frame (None when the
    file carries no camera information record)."""

    frames: np.ndarray
    utc: np.ndarray
    calibration: FlirCalibration | None
    camera: FlirCamera | None


def _strided(buf, frames: list[_Frame]) -> np.ndarray | None:
    """The frames as one strided view of ``buf`` (nothing copied) when they are raw
    little-endian words of one size, equally spaced; else None."""
    first = frames[0]
    if first.coding != "<u2":  # big-endian words are copied into native ones instead
        return None
    stride = frames[1].pixels_at - first.pixels_at if len(frames) > 1 else 0
    for i, f in enumerate(frames):
        if (f.coding, f.rows, f.cols) != (first.coding, first.rows, first.cols):
            return None
        if f.pixels_at != first.pixels_at + i * stride:
            return None
    return np.ndarray(
        shape=(len(frames), first.rows, first.cols),
        dtype=np.dtype(first.coding),
        buffer=buf,
        offset=first.pixels_at,
        strides=(stride or 2 * first.rows * first.cols, 2 * first.cols, 2),
    )


def _decoded(buf, frames: list[_Frame], shape: tuple[int, int], name: str) -> np.ndarray:
    """Every frame decoded into one array, allocated once the first frame has shown that the
    records' size is true (a damaged record's size is never allocated)."""
    stack: np.ndarray | None = None
    for i, f in enumerate(frames):
        image = _decode(buf, f, name, i)
        if image.shape != shape:
            raise ValueError(f"{name}: frame {i} decodes to {image.shape}, its record says {shape}")
        if stack is None:
            stack = np.empty((len(frames), *shape), np.uint16)
        stack[i] = image
    assert stack is not None  # frames is never empty
    return stack


def load_flir(path: str | Path) -> FlirRecording:
    """The frames of a FLIR ``.fff``, ``.seq``, ``.csq`` or radiometric ``.jpg``: raw frames
    memory-mapped (read only) where they lie equally spaced in the file, decoded otherwise."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    suffix = path.suffix.lower()
    buf: bytes | memoryview
    if suffix in JPEG_SUFFIXES:
        buf = _flir_jpeg_fff(path)
    else:
        if path.stat().st_size == 0:
            raise ValueError(f"{path}: is empty (0 bytes)")
        with path.open("rb") as fh:
            buf = memoryview(mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ))
    frames = _frames(buf, str(path), sequence=suffix in SEQUENCE_SUFFIXES)
    shapes = sorted({(f.rows, f.cols) for f in frames})
    if len(shapes) != 1:
        raise ValueError(f"{path}: FFF frames differ in size: {shapes} (rows, columns)")
    stack = _strided(buf, frames)
    if stack is None:
        stack = _decoded(buf, frames, shapes[0], str(path))
    utc = np.array([_utc_ns(buf, f) for f in frames], np.int64).view("datetime64[ns]")
    first = frames[0]
    calibration = camera = None
    if first.info_at is not None:
        calibration = _calibration(buf, first.info_at, first.info_order)
        camera = _camera(buf, first.info_at, first.info_order)
    return FlirRecording(frames=stack, utc=utc, calibration=calibration, camera=camera)
