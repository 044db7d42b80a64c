"""Reading a small square of a recorded frame without HDF5's per-read cost (``replay --fast``).

A session file stores each camera's frames uncompressed by default, one chunk per frame
(docs/session-format.md). Reading a 40x40 crop through h5py costs about 250 us of
library overhead per frame, more than the measurement itself; the bytes are a few rows of a
memory-mapped file. :class:`FrameCrops` asks HDF5 once for every chunk's byte offset
(``H5Dchunk_iter``) and then slices the frame out of a read-only memory map, so only the
pages under the crop are read. Where that does not apply (compressed frames, another chunk
shape, an HDF5 without chunk iteration, a frame whose chunk was never written) it reads
through h5py as before: the numbers are the same either way.
"""

from __future__ import annotations

import mmap

import h5py
import numpy as np


class FrameCrops:
    """Crops of the frames of one ``(N, H, W)`` dataset."""

    def __init__(self, frames: h5py.Dataset) -> None:
        self._frames = frames
        self._shape = tuple(frames.shape[1:])
        self._dtype = frames.dtype
        self._nbytes = int(np.prod(self._shape)) * self._dtype.itemsize
        self._offsets = self._chunk_offsets()
        self._map: mmap.mmap | None = None
        self._bytes: np.ndarray | None = None
        if self._offsets:
            # A plain mmap, and plain ndarrays over it (np.frombuffer): numpy.memmap wraps every
            # slice in a memmap object, which cost more than the measurement per frame.
            with open(frames.file.filename, "rb") as fh:
                self._map = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)

    @property
    def direct(self) -> bool:
        """True when crops come from the memory map rather than through h5py."""
        return self._map is not None

    @property
    def frames_mapped(self) -> int:
        """How many frames come from the memory map (the others through h5py)."""
        return len(self._offsets) if self._map is not None else 0

    def _chunk_offsets(self) -> dict[int, int]:
        ds = self._frames
        if ds.chunks != (1, *self._shape) or not hasattr(ds.id, "chunk_iter"):
            return {}
        if ds.id.get_create_plist().get_nfilters():  # compressed, shuffled, checksummed: no
            return {}
        offsets: dict[int, int] = {}

        def visit(info) -> None:
            if info.size == self._nbytes:
                offsets[int(info.chunk_offset[0])] = int(info.byte_offset)

        try:
            ds.id.chunk_iter(visit)
        except (RuntimeError, ValueError, OSError):  # an HDF5 built without it
            return {}
        return offsets

    def frame_view(self, i: int) -> np.ndarray | None:
        """Frame ``i`` as a read-only view into the memory map (nothing is read until its pixels
        are touched, and then only their pages), or None where that does not apply."""
        offset = self._offsets.get(i) if self._map is not None else None
        if offset is None or self._map is None:
            return None
        if self._bytes is None:  # one array over the whole map; a frame is a slice of it
            self._bytes = np.frombuffer(self._map, np.uint8)
        view = self._bytes[offset : offset + self._nbytes].view(self._dtype)
        return view.reshape(self._shape)

    def crop(self, i: int, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """Rows ``y0:y1`` and columns ``x0:x1`` of frame ``i`` (a view where direct)."""
        frame = self.frame_view(i)
        if frame is None:
            return self._frames[i, y0:y1, x0:x1]
        return frame[y0:y1, x0:x1]
