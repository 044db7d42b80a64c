"""The recorded frames' lossless filters: names, the default, and h5py's arguments for each.

Light on purpose (h5py and hdf5plugin only when a filter is built or measured): the command
line offers the choices and the session config checks them without loading HDF5. The filters
come from hdf5plugin (a base dependency: the default is one of its), which registers them with
HDF5 when imported; a reader needs it too (docs/session-format.md, "Compressed frames").
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

COMPRESSIONS = ("gzip", "lz4", "zstd", "bitshuffle-lz4")
# in snrmon.limits, beside the other values the command line's parser states without numpy
from snrmon.limits import COMPRESSION_CHOICES  # noqa: E402


def stored_compression(choice: str | None) -> str | None:
    """The recorder's ``compression`` of a user's choice: ``"none"`` is no filter (None), a
    filter name is itself; anything else is a ValueError naming the choices."""
    if choice is None or choice == "none":
        return None
    if choice not in COMPRESSIONS:
        raise ValueError(f"unknown compression {choice!r}; known: {', '.join(COMPRESSION_CHOICES)}")
    return choice


def frame_filter(compression: str | None) -> dict:
    """h5py keyword arguments of the frames' lossless filter (``None``: no filter)."""
    if compression is None:
        return {}
    if compression == "gzip":
        return {"compression": "gzip", "compression_opts": 1, "shuffle": True}
    if compression not in COMPRESSIONS:
        raise ValueError(f"unknown compression {compression!r}; known: {', '.join(COMPRESSIONS)}")
    import hdf5plugin  # a base dependency: the default filter is one of its

    return {
        "lz4": lambda: dict(hdf5plugin.LZ4()),
        "zstd": lambda: dict(hdf5plugin.Zstd(clevel=1)),
        # blocks of 64 Ki pixels, not the plugin's 4 Ki: 2.26x instead of 2.23x on the twin's
        # MWIR frames (2.22x, 2.15x LWIR) at the same CPU (snrmon bench --only compression)
        "bitshuffle-lz4": lambda: dict(hdf5plugin.Bitshuffle(nelems=65536, cname="lz4")),
    }[compression]()


STRIP_ROWS = 16
"""Rows of one chunk of filtered frames: a frame is stored as row strips, so a reader that needs
only the rows around the target (``replay --fast``: the track's window, Eq. 4's box and rims)
decompresses only the strips holding them (2.7 a frame of MWIR, 2.0 of LWIR on a hil day).
Measured against whole-frame chunks (``snrmon bench --only compression``, twin, bitshuffle-lz4):
bytes per frame +0.3 % MWIR and +2.0 % LWIR, writer CPU +0.3 ms and +0.15 ms a frame, reading
a 64 px square 0.4-0.5 ms instead of 1.5-2.0 ms (MWIR)."""
STRIP_PX = 8192
"""... and at least this many pixels: a frame narrower than 512 columns has taller strips (a
64 x 69 Cedip frame is one chunk), where a chunk's own cost would outweigh what it saves."""


def frame_chunks(shape: tuple[int, int], compression: str | None) -> tuple[int, int, int]:
    """The chunk shape of a camera's ``frames`` dataset of frames ``shape`` (rows, columns):
    one frame per chunk when raw (contiguous pixels a reader memory-maps), row strips of
    :data:`STRIP_ROWS` rows (:data:`STRIP_PX` pixels at least) through a filter."""
    h, w = int(shape[0]), int(shape[1])
    if compression is None:
        return (1, h, w)
    return (1, min(max(STRIP_ROWS, -(-STRIP_PX // max(w, 1))), h), w)


BitshuffleDecoder = Callable[[int, int, int, int, int], int]
"""``decode(in_address, out_address, n_elements, element_bytes, block_elements)``: bitshuffle's
own ``bshuf_decompress_lz4``: the bytes it read, negative on a corrupt block."""


def bitshuffle_lz4_decoder() -> BitshuffleDecoder | None:
    """bitshuffle's LZ4 block decoder, from the filter library hdf5plugin ships (the code HDF5
    runs on the same chunks), callable without HDF5: a process forked from one holding the
    file open decodes chunks it reads from a memory map. None where that library does not
    export it (another build): the reader then goes through HDF5."""
    import ctypes
    import os

    import hdf5plugin

    try:
        lib = ctypes.CDLL(os.path.join(hdf5plugin.PLUGIN_PATH, "libh5bshuf.so"))
        decode = lib.bshuf_decompress_lz4
    except (OSError, AttributeError):
        return None
    decode.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t]
    decode.argtypes += [ctypes.c_size_t]
    decode.restype = ctypes.c_int64
    return decode


def register_filters() -> None:
    """Make every filter a session's frames may carry readable by this process's HDF5 (h5py,
    xarray and h5netcdf alike): hdf5plugin registers them on import."""
    import hdf5plugin  # noqa: F401


def measured_ratio(frames: Sequence[np.ndarray], compression: str | None) -> float:
    """Raw bytes over stored bytes of ``frames`` with ``compression`` (``None``: 1), each frame
    one chunk as the recorder writes it, in an HDF5 file in memory: what a recording of such
    frames will take on disk (``snrmon doctor`` measures it on the cameras' own frames), chunked
    as the recorder chunks them (:func:`frame_chunks`)."""
    import h5py

    if compression is None or not frames:
        return 1.0
    raw = stored = 0
    with h5py.File("ratio.h5", "w", driver="core", backing_store=False) as f:
        for i, pixels in enumerate(frames):
            data = np.ascontiguousarray(pixels, np.uint16)
            ds = f.create_dataset(
                f"f{i}",
                data=data[None],
                chunks=frame_chunks(data.shape, compression),
                **frame_filter(compression),
            )
            raw += data.nbytes
            stored += ds.id.get_storage_size()
    return raw / max(1, stored)
