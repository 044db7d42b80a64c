"""``FrameCrops``: crops of recorded frames read straight from the memory-mapped file equal what
h5py reads, and anything it cannot map (compressed, unwritten) is read through h5py."""

from __future__ import annotations

import h5py
import numpy as np

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
