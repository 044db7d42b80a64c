"""Reading only the rows of a recorded frame a measurement touches (``replay --fast``).

Reading a 40x40 crop through h5py costs about 250 us of library overhead per frame, more than
the measurement itself, and a filtered frame read through h5py is decompressed whole.
:class:`FrameCrops` asks HDF5 once for every chunk's byte offset (``H5Dchunk_iter``), memory-maps
the file and hands out frames whose pixels are read as the measurement reads them:

- **raw frames, one chunk per frame** (``--compression none``): the frame is a read-only view
  into the memory map; only the pages under what is read leave the disk.
- **row strips** (chunks ``(1, S, W)``, how filtered frames are written:
  :func:`snrmon.acquisition.compression.frame_chunks`): the frame is a
  :class:`~snrmon.acquisition.engine.lazy_frame.LazyFrame` whose strips are decompressed the first
  time a read falls in them. A ``bitshuffle-lz4`` strip (the default filter) is decoded from the
  memory map by bitshuffle's own decoder, without HDF5 (:func:`bitshuffle_lz4_decoder`), so a
  process forked from this one can read it too; a strip of another filter (or a chunk HDF5
  did not report) is read through HDF5.

Frames of any other chunk shape (or an HDF5 without chunk iteration) are read whole through
h5py, as before: the numbers are the same either way.
"""

from __future__ import annotations

import mmap

import h5py
import numpy as np

from snrmon.acquisition.compression import bitshuffle_lz4_decoder
from snrmon.acquisition.engine.lazy_frame import LazyFrame, Region

BITSHUFFLE_FILTER = 32008  # the filter id HDF5 registers bitshuffle under
BITSHUFFLE_LZ4 = 2  # its fifth parameter: what follows the shuffle (2: LZ4)
VIEW, RAW_STRIPS, BITSHUFFLE_STRIPS, HDF5_STRIPS = "view", "raw", "bitshuffle-lz4", "hdf5"


def _filters(frames: h5py.Dataset) -> list[tuple[int, tuple[int, ...]]]:
    """(filter id, its parameters) of each filter of ``frames``, in pipeline order."""
    plist = frames.id.get_create_plist()
    found = (plist.get_filter(k) for k in range(plist.get_nfilters()))
    return [(int(c[0]), tuple(int(v) for v in c[2])) for c in found]


class ChunkIndex:
    """Where each frame's chunks are in the file, from HDF5's chunk index (``H5Dchunk_iter``,
    walked once: about 2 us a chunk), and the file's memory map to read them from: per frame
    and strip, the chunk's byte offset (-1: not reported), stored size and filter mask.
    ``whole_frames``: only chunks of a whole raw frame count (one chunk per frame)."""

    def __init__(self, frames: h5py.Dataset, strip: int, *, whole_frames: bool) -> None:
        n, h, w = (int(v) for v in frames.shape)
        offset = self.offset = np.full((n, -(-h // strip)), -1, np.int64)
        size, mask = self.size, self.mask = np.zeros_like(offset), np.zeros_like(offset)
        self.bytes: np.ndarray | None = None  # the file's bytes (None: not mapped)
        self.mapped = 0  # frames every chunk of which is in the index
        if not hasattr(frames.id, "chunk_iter"):
            return
        raw_size = strip * w * frames.dtype.itemsize

        def visit(info) -> None:
            i, s = info.chunk_offset[0], info.chunk_offset[1] // strip
            if i < n and (not whole_frames or info.size == raw_size):
                offset[i, s], size[i, s], mask[i, s] = info.byte_offset, info.size, info.filter_mask

        try:
            frames.id.chunk_iter(visit)
        except (RuntimeError, ValueError, OSError):  # an HDF5 built without it
            return
        # A plain mmap, and plain ndarrays over it (np.frombuffer): numpy.memmap wraps every
        # slice in a memmap object, which cost more than the measurement per frame.
        with open(frames.file.filename, "rb") as fh:
            self.bytes = np.frombuffer(mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ), np.uint8)
        self.mapped = int(np.count_nonzero((offset >= 0).all(axis=1)))

    def stored(self, i: int, s: int) -> np.ndarray | None:
        """The stored bytes of frame ``i``'s strip ``s`` from the memory map (None: not
        there)."""
        offset = int(self.offset[i, s])
        if offset < 0 or self.bytes is None:
            return None
        return self.bytes[offset : offset + int(self.size[i, s])]


class Hdf5Strips:
    """Row strips of one frame dataset read through HDF5 (its selections made once)."""

    def __init__(self, frames: h5py.Dataset, strip: int) -> None:
        self._frames = frames
        self._strip = strip
        self._file_space: h5py.h5s.SpaceID | None = None
        self._memory_space: dict[tuple[int, ...], h5py.h5s.SpaceID] = {}

    def read(self, i: int, s: int, out: np.ndarray) -> None:
        """Strip ``s`` of frame ``i`` into ``out`` (its rows)."""
        space = self._file_space
        if space is None:
            space = self._file_space = self._frames.id.get_space()
        space.select_hyperslab((i, s * self._strip, 0), (1, *out.shape))
        memory = self._memory_space.get(out.shape)
        if memory is None:
            memory = self._memory_space[out.shape] = h5py.h5s.create_simple(out.shape)
        self._frames.id.read(memory, space, out)


class FrameCrops:
    """The frames of one ``(N, H, W)`` dataset as ``replay --fast`` reads them (above).

    A frame handed out (:meth:`frame_view`) is valid until the next one: row strips are read
    into one buffer per dataset (a new zeroed frame each time cost more than its reads). Where
    the chunks are is a :class:`ChunkIndex`; strips it does not hold are read by
    :class:`Hdf5Strips`."""

    def __init__(self, frames: h5py.Dataset) -> None:
        self._frames = frames
        _, h, w = frames.shape
        self._shape = (int(h), int(w))
        self._dtype = frames.dtype
        chunks = frames.chunks
        strip = int(chunks[1]) if chunks and chunks[0] == 1 and chunks[2] == w else 0
        self._strip = strip
        self._kind = self._kind_of(frames, strip)
        self._decode = bitshuffle_lz4_decoder() if self._kind == BITSHUFFLE_STRIPS else None
        if self._kind == BITSHUFFLE_STRIPS and self._decode is None:
            self._kind = HDF5_STRIPS
        # filled when the frames are to be read without HDF5 (raw frames: now; strips: when
        # frames_mapped is first asked)
        self._chunks: ChunkIndex | None = None
        self._through_hdf5 = Hdf5Strips(frames, strip)
        self._buffer: np.ndarray | None = None  # the strips' frame (one at a time)
        self._current: _FrameStrips | None = None
        if self._kind == VIEW:
            self._chunks = ChunkIndex(frames, strip, whole_frames=True)

    def _kind_of(self, frames: h5py.Dataset, strip: int) -> str | None:
        if not strip:
            return None  # another chunk shape: whole frames through h5py
        filters = _filters(frames)
        if not filters:
            return VIEW if strip == self._shape[0] else RAW_STRIPS
        if len(filters) == 1 and filters[0][0] == BITSHUFFLE_FILTER:
            values = filters[0][1]
            if len(values) > 4 and values[4] == BITSHUFFLE_LZ4 and self._dtype.itemsize == 2:
                return BITSHUFFLE_STRIPS
        return HDF5_STRIPS

    @property
    def direct(self) -> bool:
        """True when frames come from the memory map rather than through h5py."""
        return self._chunks is not None and self._chunks.bytes is not None

    @property
    def frames_mapped(self) -> int:
        """How many frames are read from the memory map alone, without HDF5 (every chunk of
        theirs in HDF5's index; the others are read through h5py). Row strips are mapped on
        this first call: HDF5's chunk index is walked once (about 2 us a chunk), which a read
        through HDF5 does not need (it looks each chunk up)."""
        if self._kind in (RAW_STRIPS, BITSHUFFLE_STRIPS) and self._chunks is None:
            self._chunks = ChunkIndex(self._frames, self._strip, whole_frames=False)
        return self._chunks.mapped if self.direct and self._chunks is not None else 0

    def frame_view(self, i: int) -> np.ndarray | None:
        """Frame ``i`` whose pixels are read when touched: a read-only view into the memory map
        (raw frames), a :class:`LazyFrame` that decompresses the strips a read falls in (row
        strips), or None where neither applies (read it whole through h5py)."""
        if self._kind is None:
            return None
        if self._kind == VIEW:
            stored = self._chunks.stored(i, 0) if self._chunks is not None else None
            if stored is None:
                return None
            nbytes = self._shape[0] * self._shape[1] * self._dtype.itemsize
            return stored[:nbytes].view(self._dtype).reshape(self._shape)
        if self._buffer is None:
            self._buffer = np.zeros(self._shape, self._dtype)
        strips = self._current = _FrameStrips(self, i, self._buffer)
        return LazyFrame.of(self._buffer, strips)

    def crop(self, i: int, y0: int, y1: int, x0: int, x1: int) -> np.ndarray:
        """Rows ``y0:y1`` and columns ``x0:x1`` of frame ``i`` (a copy)."""
        frame = self.frame_view(i)
        if frame is None:
            return self._frames[i, y0:y1, x0:x1]
        return np.array(frame[y0:y1, x0:x1])

    @property
    def strip_rows(self) -> int:
        """Rows of one strip (the chunks' rows; 0: not chunked by rows)."""
        return self._strip

    def read_strip(self, strips: _FrameStrips, s: int, out: np.ndarray) -> None:
        """Strip ``s`` of the frame of ``strips`` into ``out`` (its rows of the buffer)."""
        if strips is not self._current:
            raise RuntimeError(f"{self._frames.name}: frame {strips.i} read after the next one")
        i = strips.i
        chunk = self._chunks.stored(i, s) if self._chunks is not None else None
        if chunk is not None:  # from the memory map
            assert self._chunks is not None
            self._decode_chunk(chunk, int(self._chunks.mask[i, s]), out, i, s)
            return
        if self._kind == BITSHUFFLE_STRIPS:  # HDF5 finds the chunk, bitshuffle decodes it
            try:
                mask, data = self._frames.id.read_direct_chunk((i, s * self._strip, 0))
            except (KeyError, OSError, RuntimeError, ValueError):
                pass  # not written (HDF5's fill value) or not found: read as HDF5 reads it
            else:
                self._decode_chunk(np.frombuffer(data, np.uint8), int(mask), out, i, s)
                return
        self._through_hdf5.read(i, s, out)

    def _decode_chunk(self, chunk: np.ndarray, mask: int, out: np.ndarray, i: int, s: int):
        """One stored chunk (its bytes) into ``out``: copied when unfiltered (the raw layout, or
        an optional filter HDF5 skipped: bit 0 of ``mask``), else bitshuffle's LZ4 decoder (a
        12-byte header: the raw size, big-endian uint64, and the block size in bytes, uint32)."""
        stored = self._strip * self._shape[1]  # an edge strip's chunk holds whole rows too
        if self._kind == RAW_STRIPS or mask & 1:
            out[...] = chunk[: out.nbytes].view(self._dtype).reshape(out.shape)
            return
        assert self._decode is not None
        block = int.from_bytes(chunk[8:12].tobytes(), "big") // self._dtype.itemsize
        target = out if out.size == stored else np.empty(stored, self._dtype)
        itemsize = self._dtype.itemsize
        done = self._decode(chunk.ctypes.data + 12, target.ctypes.data, stored, itemsize, block)
        if done != chunk.size - 12:
            rows = f"{s * self._strip}:{s * self._strip + out.shape[0]}"
            raise OSError(
                f"{self._frames.file.filename}: {self._frames.name} frame {i} rows {rows}: "
                "corrupt bitshuffle-lz4 chunk"
            )
        if target is not out:
            out[...] = target[: out.size].reshape(out.shape)


class _FrameStrips:
    """A :class:`LazyFrame`'s owner: reads frame ``i``'s strips into its buffer once each."""

    __slots__ = ("buffer", "crops", "height", "i", "read", "rows")

    def __init__(self, crops: FrameCrops, i: int, buffer: np.ndarray) -> None:
        self.crops, self.i, self.buffer = crops, int(i), buffer
        self.rows, self.height = crops.strip_rows, buffer.shape[0]
        self.read = bytearray(-(-self.height // self.rows))

    def ensure(self, region: Region | None) -> None:
        """Read the strips holding rows ``region[0]:region[1]`` (None: every row)."""
        rows, h = self.rows, self.height
        y0, y1 = (0, h) if region is None else (max(region[0], 0), min(region[1], h))
        read = self.read
        for s in range(y0 // rows, -(-y1 // rows)):
            if not read[s]:
                self.crops.read_strip(self, s, self.buffer[s * rows : min((s + 1) * rows, h)])
                read[s] = 1
