"""Frame stacks from files, for ``snrmon measure`` and replay of other tools' recordings.

Sources (chosen by the file name's suffix):

* ``.npy``: an array (N, H, W) or one frame (H, W) -> (1, H, W); loaded memory-mapped.
* ``.tif``/``.tiff``: every plane of every page a frame (a page per frame, or pages of several
  planes), 16-bit kept (:mod:`snrmon.acquisition.replay.tiff`: an uncompressed contiguous stack
  is memory-mapped, any other read one page at a time, each page once; a file cut short is read
  to its last whole frame with a warning); colour pages keep their first channel.
* ``.png``: one frame (H, W); colour keeps the first channel.
* a raw binary file ``FILE`` with a JSON descriptor ``FILE.json`` beside it (``FILE.json`` may be
  given instead of ``FILE``)::

      {"shape": [N, H, W], "dtype": "uint16", "fps": 60, "byte_order": "little"}

  ``shape`` and ``dtype`` (a numpy name: uint8, uint16, int16, uint32, int32, float32, float64)
  are required; ``byte_order`` is "little" (default) or "big"; ``fps`` is informational. Frames
  are C-ordered, rows then columns, no header; the file size must match exactly.
* ``.ptw``: an Altair/ResearchIR radiometric recording (Cedip, FLIR): 16-bit frames as written,
  memory-mapped past each frame header (:mod:`snrmon.acquisition.replay.ptw`; rows, columns and
  frame count from its header, which is checked against the file).
* FLIR ``.seq``, ``.csq``, ``.fff`` and radiometric ``.jpg``: the raw 16-bit counts of every
  FFF frame, each frame's time and the camera's calibration (:mod:`snrmon.acquisition.replay.flir`).
* video (``.mp4 .avi .mkv .mov .mpg .mpeg .wmv .m4v``) through OpenCV: 8-bit frames (the camera's
  AGC'd output, not radiometric counts), first channel of each.

:func:`read_stack` is the one reader of every format: the frames and what the file says about
them (:class:`StackFile`: the camera, each frame's time, the camera's own radiometric
calibration); :func:`load_stack` is its frames.

Bad input is a ValueError (wrong shape, dtype, size, descriptor) or OSError (missing, unreadable)
with one message naming the file and the value.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import cv2
import numpy as np

from snrmon.acquisition.config import utf8_text
from snrmon.acquisition.replay.flir import FLIR_SUFFIXES, load_flir
from snrmon.acquisition.replay.ptw import load_ptw
from snrmon.acquisition.replay.tiff import iter_tiff, load_tiff

VIDEO_SUFFIXES = frozenset({".mp4", ".avi", ".mkv", ".mov", ".mpg", ".mpeg", ".wmv", ".m4v"})
RAW_DTYPES = frozenset({"uint8", "uint16", "int16", "uint32", "int32", "float32", "float64"})


def _as_stack(array: np.ndarray, path: Path) -> np.ndarray:
    if array.ndim == 2:
        array = array[None]
    if array.ndim != 3:
        raise ValueError(
            f"{path}: expected a stack (N,H,W) or a frame (H,W), got shape {array.shape}"
        )
    if 0 in array.shape:
        raise ValueError(f"{path}: empty stack, shape {array.shape}")
    if array.dtype.kind not in "uif":
        raise ValueError(f"{path}: pixels must be integers or floats, got dtype {array.dtype}")
    return array


def _grey(image: np.ndarray) -> np.ndarray:
    return image[..., 0] if image.ndim == 3 else image


def _raw_paths(path: Path) -> tuple[Path, Path]:
    if path.suffix == ".json":
        return path.with_suffix(""), path
    return path, path.with_name(path.name + ".json")


def _raw_descriptor(path: Path) -> tuple[Path, tuple[int, int, int], np.dtype]:
    data, desc_path = _raw_paths(path)
    try:
        desc = json.loads(utf8_text(desc_path, "descriptor"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{desc_path}: not valid JSON ({exc.msg})") from None
    if not isinstance(desc, dict):
        raise ValueError(f"{desc_path}: descriptor must be a JSON object")
    shape = desc.get("shape")
    if (
        not isinstance(shape, list)
        or len(shape) not in (2, 3)
        or not all(isinstance(v, int) and v > 0 for v in shape)
    ):
        raise ValueError(
            f"{desc_path}: shape must be [N, H, W] or [H, W] positive ints, got {shape}"
        )
    if len(shape) == 2:
        shape = [1, *shape]
    name = desc.get("dtype")
    if name not in RAW_DTYPES:
        raise ValueError(f"{desc_path}: dtype must be one of {sorted(RAW_DTYPES)}, got {name!r}")
    order = desc.get("byte_order", "little")
    if order not in ("little", "big"):
        raise ValueError(f"{desc_path}: byte_order must be 'little' or 'big', got {order!r}")
    dtype = np.dtype(name).newbyteorder("<" if order == "little" else ">")
    expected = int(np.prod(shape)) * dtype.itemsize
    size = data.stat().st_size
    if size != expected:
        what = "truncated" if size < expected else "too long"
        raise ValueError(
            f"{data}: raw file {what}: {size} bytes, but shape {shape} {name} needs {expected}"
        )
    return data, tuple(shape), dtype


def _is_raw(path: Path) -> bool:
    _, desc = _raw_paths(path)
    return desc.is_file() and path.suffix.lower() not in (
        {".npy", ".tif", ".tiff", ".png", ".ptw"} | FLIR_SUFFIXES
    )


def open_video(path: Path) -> cv2.VideoCapture:
    """The opened video file, or a ValueError naming it; every video the product reads is
    opened here.

    FFmpeg prints its own reason ("moov atom not found") on stderr while OpenCV probes the
    container, and a file that is not a video must be the one line below. OpenCV reads this
    level once, when FFmpeg first starts (cv2.utils.logging does not reach FFmpeg): quiet ("-8")
    unless the user set one. A video opened any other way first would start FFmpeg at its
    default level, and its reasons would double every later error line of the process."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise ValueError(f"{path}: OpenCV cannot open this video")
    return cap


def iter_stack(path: str | Path) -> Iterator[np.ndarray]:
    """Frames (H, W) of a stack file one by one, without loading the whole file where the
    format allows (npy, raw, PTW and FLIR raw frames are memory-mapped, TIFF read page by page,
    video decoded)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in VIDEO_SUFFIXES:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file")
        cap = open_video(path)
        try:
            while True:
                ok, image = cap.read()
                if not ok:
                    return
                yield _grey(image)
        finally:
            cap.release()
    elif suffix in (".tif", ".tiff"):
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file")
        yield from iter_tiff(path)
    else:
        yield from load_stack(path)


class Radiometry(Protocol):
    """A camera's own calibration of its counts, as its file carries it."""

    def object_signal(self, raw: np.ndarray) -> np.ndarray:
        """The object's radiance in the camera's radiometric unit."""
        ...

    def temperature_c(self, raw: np.ndarray) -> np.ndarray:
        """The object's temperature [degC]."""
        ...

    def attrs(self) -> dict[str, float]:
        """The calibration's constants, named."""
        ...


@dataclass(frozen=True)
class StackFile:
    """A stack file's frames (N, H, W) and what the file says about them: ``attrs`` (the
    camera, lens, filter, ... units in the names), ``utc`` (each frame's time, datetime64[ns],
    NaT where unknown; None for a file that stores no times) and ``radiometry`` (None for
    counts with no calibration in the file)."""

    frames: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)
    utc: np.ndarray | None = None
    radiometry: Radiometry | None = None

    def camera_line(self) -> str:
        """``camera NAME (LENS, filter F)``, or "" for a file that names no camera."""
        if "camera" not in self.attrs:
            return ""
        optics = [self.attrs.get("lens") or "", self.attrs.get("filter") or ""]
        optics[1] = optics[1] and f"filter {optics[1]}"
        inner = ", ".join(o for o in optics if o)
        return f"camera {self.attrs['camera'] or '?'}" + (f" ({inner})" if inner else "")


def _ptw_file(path: Path) -> StackFile:
    frames, header = load_ptw(path)
    attrs = {
        "camera": header.camera_name,
        "lens": header.lens_name,
        "filter": header.filter_name,
        "integration_time_s": header.integration_time_s,
        "frame_period_s": header.frame_period_s,
    }
    return StackFile(_as_stack(frames, path), attrs)


def _flir_file(path: Path) -> StackFile:
    rec = load_flir(path)
    attrs: dict[str, Any] = {}
    if rec.camera is not None:
        attrs = {
            "camera": rec.camera.model,
            "serial_number": rec.camera.serial_number,
            "lens": rec.camera.lens,
            "frame_rate_hz": rec.camera.frame_rate_hz,
            "utc_offset_min": rec.camera.utc_offset_min,
        }
    return StackFile(_as_stack(rec.frames, path), attrs, rec.utc, rec.calibration)


def read_stack(path: str | Path) -> StackFile:
    """The frames of ``path`` and what the file says about them (module docstring)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if _is_raw(path):
        data, shape, dtype = _raw_descriptor(path)
        return StackFile(_as_stack(np.memmap(data, dtype=dtype, mode="r", shape=shape), data))
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    if suffix == ".npy":
        try:
            array = np.load(path, mmap_mode="r", allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise ValueError(f"{path}: not a readable .npy array ({exc})") from None
        return StackFile(_as_stack(array, path))
    if suffix in (".tif", ".tiff"):
        return StackFile(_as_stack(load_tiff(path), path))
    if suffix == ".ptw":
        return _ptw_file(path)
    if suffix in FLIR_SUFFIXES:
        return _flir_file(path)
    if suffix == ".png":
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if image is None:
            raise ValueError(f"{path}: OpenCV cannot read this PNG")
        return StackFile(_as_stack(_grey(image), path))
    if suffix in VIDEO_SUFFIXES:
        frames = list(iter_stack(path))
        if not frames:
            raise ValueError(f"{path}: the video holds no frames OpenCV can decode")
        return StackFile(_as_stack(np.stack(frames), path))
    raise ValueError(
        f"{path}: unknown stack format {suffix or '(no suffix)'!r}; expected .npy, .tif/.tiff, "
        f".ptw, FLIR .seq/.csq/.fff/.jpg, .png, a video, or a raw file with {path.name}.json "
        "beside it"
    )


def load_stack(path: str | Path) -> np.ndarray:
    """The frames of ``path`` as an array (N, H, W) (see the module docstring for formats)."""
    return read_stack(path).frames
