"""The recorded frames' lossless filters: names, the default, and h5py's arguments for each.

Light on purpose (h5py and hdf5plugin only when a filter is built or measured): the command
line offers the choices and the session config checks them without loading HDF5. The filters
come from hdf5plugin (a base dependency: the default is one of its), which registers them with
HDF5 when imported; a reader needs it too (docs/session-format.md, "Compressed frames").
"""

from __future__ import annotations

from collections.abc import Sequence

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


def register_filters() -> None:
    """Make every filter a session's frames may carry readable by this process's HDF5 (h5py,
    xarray and h5netcdf alike): hdf5plugin registers them on import."""
    import hdf5plugin  # noqa: F401


def measured_ratio(frames: Sequence[np.ndarray], compression: str | None) -> float:
    """Raw bytes over stored bytes of ``frames`` with ``compression`` (``None``: 1), each frame
    one chunk as the recorder writes it, in an HDF5 file in memory: what a recording of such
    frames will take on disk (``snrmon doctor`` measures it on the cameras' own frames)."""
    import h5py

    if compression is None or not frames:
        return 1.0
    raw = stored = 0
    with h5py.File("ratio.h5", "w", driver="core", backing_store=False) as f:
        for i, pixels in enumerate(frames):
            data = np.ascontiguousarray(pixels, np.uint16)
            ds = f.create_dataset(
                f"f{i}", data=data, chunks=data.shape, **frame_filter(compression)
            )
            raw += data.nbytes
            stored += ds.id.get_storage_size()
    return raw / max(1, stored)
