"""Altair / ResearchIR ``.ptw`` recordings (Cedip, later FLIR, radiometric cameras) as frame stacks.

The file is a main header, then for every frame a frame header followed by the frame's pixels,
16-bit little-endian words, row after row (the DL002U-D Altair reference guide's layout). The main
header gives what is needed to find every pixel; the offsets (bytes from the start of the file,
integers little-endian) read here:

==========  =====  ===========================================================================
offset      type   field
==========  =====  ===========================================================================
0-2         char   signature: ``CED`` (Cedip/Altair; the only layout read here)
5-9         char   format version (e.g. ``5.60``)
11-14       u32    main header size [bytes]
15-18       u32    frame header size [bytes]
19-22       u32    frame header + frame size [16-bit words]
23-26       u32    frame size [16-bit words] (= rows x columns)
27-30       u32    number of frames in the file
44-63       char   camera name (NUL-padded)
64-83       char   lens name
84-103      char   filter name
220-230     char   camera serial number
377-378     u16    pixels per line (columns)
379-380     u16    lines per field (rows)
381-382     u16    A/D converter bit depth
403-406     f32    acquisition period [s] (Cedip)
407-410     f32    integration time [s] (Cedip)
2105        u8     frame buffer type: 0 = 16-bit words (the only one read here), 1 = doubles
==========  =====  ===========================================================================

Frame ``i`` (zero-based) starts at ``main header + i x (frame header + 2 x rows x columns)``;
its pixels follow its frame header. The pixels are returned as written (raw digital levels): a
header "special scale" (temperature or radiance units) is reported, not applied.

Everything the header claims is checked against the file before a pixel is read: a file that is
not a PTW, a header that contradicts itself or a file shorter (or longer) than its frames is one
``ValueError`` naming the file, the field and the value.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SIGNATURE = b"CED"
_MIN_HEADER = 411  # the last field read from every header ends here (integration time)
_BUFFER_TYPE_AT = 2105


@dataclass(frozen=True, slots=True)
class PtwHeader:
    """What the main header says (units in the names)."""

    version: str
    main_header_bytes: int
    frame_header_bytes: int
    frames: int
    rows: int
    cols: int
    bit_depth: int
    camera_name: str
    lens_name: str
    filter_name: str
    serial_number: str
    frame_period_s: float
    integration_time_s: float
    special_scale: bool  # the header carries a unit scale (not applied: pixels stay raw)

    @property
    def frame_stride_bytes(self) -> int:
        """From the start of one frame header to the next."""
        return self.frame_header_bytes + 2 * self.rows * self.cols

    @property
    def file_bytes(self) -> int:
        """The size of a file holding exactly the header's frames."""
        return self.main_header_bytes + self.frames * self.frame_stride_bytes


def _text(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("latin-1").strip()


def _u32(raw: bytes, at: int) -> int:
    return int(struct.unpack_from("<I", raw, at)[0])


def _u16(raw: bytes, at: int) -> int:
    return int(struct.unpack_from("<H", raw, at)[0])


def _f32(raw: bytes, at: int) -> float:
    return float(struct.unpack_from("<f", raw, at)[0])


def read_ptw_header(path: str | Path) -> PtwHeader:
    """The main header of ``path``, checked against itself and the file's size."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(max(_MIN_HEADER, _BUFFER_TYPE_AT + 1))
    if head[:3] != SIGNATURE:
        raise ValueError(
            f"{path}: not a Cedip/Altair PTW file (starts with {head[:3]!r}, expected "
            f"{SIGNATURE!r})"
        )
    if len(head) < _MIN_HEADER:
        raise ValueError(f"{path}: truncated PTW main header ({size} bytes, needs {_MIN_HEADER})")
    main = _u32(head, 11)
    if main < _MIN_HEADER:
        raise ValueError(
            f"{path}: PTW main header size {main} bytes is too small (its fields need "
            f"{_MIN_HEADER})"
        )
    if main > size:
        raise ValueError(f"{path}: truncated PTW file: {size} bytes, the main header alone {main}")
    frame_header, stride_words, frame_words, frames = (_u32(head, at) for at in (15, 19, 23, 27))
    cols, rows, bits = _u16(head, 377), _u16(head, 379), _u16(head, 381)
    if rows == 0 or cols == 0:
        raise ValueError(f"{path}: PTW header gives a {cols} x {rows} (columns x rows) frame")
    if frame_words != rows * cols:
        raise ValueError(
            f"{path}: PTW header's frame size {frame_words} words is not {rows} rows x {cols} "
            f"columns = {rows * cols}"
        )
    if 2 * stride_words != frame_header + 2 * frame_words:
        raise ValueError(
            f"{path}: PTW header's frame + frame header size {stride_words} words is not the "
            f"{frame_header}-byte frame header + {frame_words} pixel words"
        )
    if not 1 <= bits <= 16:
        raise ValueError(f"{path}: PTW header gives a bit depth of {bits} (16-bit words hold 1-16)")
    if main > _BUFFER_TYPE_AT and head[_BUFFER_TYPE_AT] != 0:
        raise ValueError(
            f"{path}: PTW frame buffer type {head[_BUFFER_TYPE_AT]} (pixels as doubles) is not "
            f"read; only 16-bit words (type 0)"
        )
    if frames == 0:
        raise ValueError(f"{path}: the PTW header says the file holds no frames")
    header = PtwHeader(
        version=_text(head[5:10]),
        main_header_bytes=main,
        frame_header_bytes=frame_header,
        frames=frames,
        rows=rows,
        cols=cols,
        bit_depth=bits,
        camera_name=_text(head[44:64]),
        lens_name=_text(head[64:84]),
        filter_name=_text(head[84:104]),
        serial_number=_text(head[220:231]),
        frame_period_s=_f32(head, 403),
        integration_time_s=_f32(head, 407),
        special_scale=_u16(head, 277) != 0,
    )
    if size != header.file_bytes:
        whole = (size - main) // header.frame_stride_bytes
        what = (
            f"truncated: {size} bytes hold {whole} whole frames"
            if size < header.file_bytes
            else f"{size - header.file_bytes} bytes longer than its frames"
        )
        raise ValueError(
            f"{path}: PTW file {what}; the header's {frames} frames of {rows} x {cols} need "
            f"{header.file_bytes} bytes"
        )
    return header


def load_ptw(path: str | Path) -> tuple[np.ndarray, PtwHeader]:
    """The frames (N, rows, columns) uint16 as written, memory-mapped (read only), and the
    header. Each frame is a strided view past its frame header: nothing is copied."""
    header = read_ptw_header(path)
    raw = np.memmap(path, dtype=np.uint8, mode="r")
    frames = np.ndarray(
        shape=(header.frames, header.rows, header.cols),
        dtype=np.dtype("<u2"),
        buffer=raw,
        offset=header.main_header_bytes + header.frame_header_bytes,
        strides=(header.frame_stride_bytes, 2 * header.cols, 2),
    )
    return frames, header
