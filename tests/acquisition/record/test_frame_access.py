"""``FrameCrops``: crops of recorded frames read straight from the memory-mapped file equal what
h5py reads, and anything it cannot map (compressed, unwritten) is read through h5py."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from snrmon.acquisition.record.frame_access import FrameCrops
from snrmon.acquisition.record.reader import open_session
from tests.acquisition.session_factory import write_session


def test_crops_of_a_session_file_come_from_the_map_and_equal_h5py(tmp_path):
    rec = write_session(tmp_path / "s.h5", cameras=("mwir",), hover_s=2.0, transit_s=1.0)
    rng = np.random.default_rng(5)
    with open_session(rec.path) as f:
        frames = f.cameras["mwir"].frames
        crops = FrameCrops(frames)
        assert crops.direct  # the recorder's uncompressed one-chunk-per-frame layout
        n, h, w = frames.shape
        for _ in range(50):
            i = int(rng.integers(n))
            y0, x0 = int(rng.integers(h - 1)), int(rng.integers(w - 1))
            y1, x1 = int(rng.integers(y0 + 1, h + 1)), int(rng.integers(x0 + 1, w + 1))
            np.testing.assert_array_equal(crops.crop(i, y0, y1, x0, x1), frames[i, y0:y1, x0:x1])


def test_compressed_or_unwritten_frames_are_read_through_h5py(tmp_path):
    data = np.arange(3 * 6 * 8, dtype=np.uint16).reshape(3, 6, 8)
    with h5py.File(tmp_path / "x.h5", "w") as f:
        f.create_dataset("gz", data=data, chunks=(1, 6, 8), compression="gzip")
        plain = f.create_dataset("plain", (3, 6, 8), np.uint16, chunks=(1, 6, 8))
        plain[0], plain[2] = data[0], data[2]  # frame 1 never written: HDF5's fill value 0
    with h5py.File(tmp_path / "x.h5", "r") as f:
        gz, plain = FrameCrops(f["gz"]), FrameCrops(f["plain"])
        assert not gz.direct and plain.direct
        np.testing.assert_array_equal(gz.crop(1, 2, 5, 1, 4), data[1, 2:5, 1:4])
        np.testing.assert_array_equal(plain.crop(2, 2, 5, 1, 4), data[2, 2:5, 1:4])
        np.testing.assert_array_equal(plain.crop(1, 2, 5, 1, 4), 0)


def _frames(n: int, h: int, w: int, seed: int = 3) -> np.ndarray:
    """Sky-like 14-bit frames (noise on an offset), what the filters see from a camera."""
    rng = np.random.default_rng(seed)
    return (1000 + rng.normal(0, 20, (n, h, w))).astype(np.uint16)


def test_row_strips_are_read_where_a_read_falls_and_equal_h5py(tmp_path):
    """Filtered frames in row strips (the recorder's layout) and in whole-frame chunks (files
    written before it), bitshuffle-lz4 and zstd: every read of a frame handed out equals h5py's,
    also across the edge strip (40 rows in strips of 16) and after the memory map is made."""
    import hdf5plugin

    data = _frames(4, 40, 520)
    bitshuffle = dict(hdf5plugin.Bitshuffle(nelems=65536, cname="lz4"))
    layouts = {
        "strips": ((1, 16, 520), bitshuffle),
        "whole": ((1, 40, 520), bitshuffle),
        "zstd": ((1, 16, 520), dict(hdf5plugin.Zstd(clevel=1))),
    }
    with h5py.File(tmp_path / "x.h5", "w") as f:
        for name, (chunks, filters) in layouts.items():
            f.create_dataset(name, data=data, chunks=chunks, **filters)
    rng = np.random.default_rng(7)
    with h5py.File(tmp_path / "x.h5", "r") as f:
        for name in layouts:
            crops = FrameCrops(f[name])
            for mapped in (False, True):
                if mapped:  # the chunks' offsets from HDF5's index, read from the memory map
                    assert crops.frames_mapped == (0 if name == "zstd" else 4), name
                for _ in range(20):
                    i = int(rng.integers(4))
                    y0 = int(rng.integers(39))
                    y1, x0 = int(rng.integers(y0 + 1, 41)), int(rng.integers(519))
                    got = crops.crop(i, y0, y1, x0, x0 + 1)
                    np.testing.assert_array_equal(got, data[i, y0:y1, x0 : x0 + 1], name)


def test_a_strip_frame_reads_only_the_strips_it_is_read_in_and_not_after_the_next(tmp_path):
    import hdf5plugin

    data = _frames(2, 48, 512)
    with h5py.File(tmp_path / "x.h5", "w") as f:
        f.create_dataset("frames", data=data, chunks=(1, 16, 512), **hdf5plugin.Bitshuffle())
        f.create_dataset("gap", (2, 48, 512), np.uint16, chunks=(1, 16, 512), **hdf5plugin.LZ4())
        f["gap"][0] = data[0]  # frame 1 never written: HDF5's fill value 0
    with h5py.File(tmp_path / "x.h5", "r") as f:
        crops = FrameCrops(f["frames"])
        frame = crops.frame_view(1)
        assert frame is not None and frame.shape == (48, 512)
        np.testing.assert_array_equal(frame[20:22, 5:9], data[1, 20:22, 5:9])
        plain = frame.view(np.ndarray)  # the buffer as it stands: only strip 1 was read
        np.testing.assert_array_equal(plain[16:32], data[1, 16:32])
        assert not plain[:16].any() and not plain[32:].any()
        crops.frame_view(0)
        with pytest.raises(RuntimeError, match="frame 1 read after the next one"):
            frame[40:41, 0:1]
        gap = FrameCrops(f["gap"])
        np.testing.assert_array_equal(gap.crop(1, 10, 30, 0, 512), 0)
        np.testing.assert_array_equal(gap.crop(0, 10, 30, 0, 512), data[0, 10:30])
