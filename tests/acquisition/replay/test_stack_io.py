"""Loading frame stacks: npy, multi-page TIFF, PNG, raw + JSON descriptor, video; bad input."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import tifffile

from snrmon.acquisition.replay.stack_io import iter_stack, load_stack


@pytest.fixture
def stack():
    return np.random.default_rng(1).integers(0, 65535, (4, 9, 11)).astype(np.uint16)


def test_npy_stack_and_single_frame(tmp_path, stack):
    np.save(tmp_path / "s.npy", stack)
    np.save(tmp_path / "f.npy", stack[0])
    np.testing.assert_array_equal(load_stack(tmp_path / "s.npy"), stack)
    assert load_stack(tmp_path / "f.npy").shape == (1, 9, 11)
    assert [f.shape for f in iter_stack(tmp_path / "s.npy")] == [(9, 11)] * 4


def test_npy_wrong_shape_and_missing_file(tmp_path):
    np.save(tmp_path / "bad.npy", np.zeros((2, 3, 4, 5)))
    with pytest.raises(ValueError, match=r"bad.npy: expected .*got shape \(2, 3, 4, 5\)"):
        load_stack(tmp_path / "bad.npy")
    with pytest.raises(OSError, match=r"nope\.npy: no such file"):
        load_stack(tmp_path / "nope.npy")
    (tmp_path / "junk.npy").write_bytes(b"not numpy")
    with pytest.raises(ValueError, match=r"junk\.npy: not a readable \.npy"):
        load_stack(tmp_path / "junk.npy")


def test_multipage_tiff_keeps_16_bits(tmp_path, stack, monkeypatch):
    # OpenCV writes LZW, which tifffile decodes only with imagecodecs: the OpenCV fallback
    # (tifffile made to answer as it does where imagecodecs is not installed).
    def no_codec(self, *args, **kwargs):
        raise ValueError(f"<COMPRESSION.LZW: 5> requires the 'imagecodecs' package ({self})")

    monkeypatch.setattr(tifffile.TiffPage, "asarray", no_codec)
    path = str(tmp_path / "s.tif")
    assert cv2.imwritemulti(path, list(stack))
    loaded = load_stack(path)
    assert loaded.dtype == np.uint16
    np.testing.assert_array_equal(loaded, stack)
    np.testing.assert_array_equal(np.stack(list(iter_stack(path))), stack)


def test_uncompressed_tiff_is_memory_mapped(tmp_path, stack):
    path = tmp_path / "s.tif"
    tifffile.imwrite(path, np.concatenate([stack, stack[::-1]]), photometric="minisblack")
    loaded = load_stack(path)
    assert isinstance(loaded, np.memmap) and loaded.shape == (8, 9, 11)
    np.testing.assert_array_equal(loaded[4:], stack[::-1])
    frames = list(iter_stack(path))
    assert len(frames) == 8 and all(isinstance(f, np.memmap) for f in frames)
    np.testing.assert_array_equal(frames[3], stack[3])


def test_compressed_tiff_is_read_page_by_page_once_each(tmp_path, stack, monkeypatch):
    path = tmp_path / "z.tif"
    tifffile.imwrite(path, stack, compression="zlib", photometric="minisblack")
    reads = []
    real = tifffile.TiffPage.asarray
    monkeypatch.setattr(
        tifffile.TiffPage, "asarray", lambda self, *a, **k: reads.append(self.index) or real(self)
    )
    np.testing.assert_array_equal(np.stack(list(iter_stack(path))), stack)
    assert reads == [0, 1, 2, 3]  # each page decoded once, in order (not from page 0 each time)
    np.testing.assert_array_equal(load_stack(path), stack)


def test_a_cut_tiff_without_metadata_reads_to_its_break(tmp_path, stack, caplog):
    # No ImageJ or tifffile metadata declares the count: the break is the page chain's last link
    # pointing past the end, or a page whose data the file does not hold whole.
    pages = np.concatenate([stack, stack[::-1]])
    one_ifd_per_page = tmp_path / "pages.tif"
    with tifffile.TiffWriter(one_ifd_per_page) as w:
        for frame in pages:
            w.write(frame, photometric="minisblack", metadata=None, contiguous=False)
    contiguous = tmp_path / "contiguous.tif"
    tifffile.imwrite(contiguous, pages, photometric="minisblack", metadata=None)
    for whole, frames, why in [
        (one_ifd_per_page, 3, "page 3: ValueError: failed to read 198 bytes, got"),
        (contiguous, 1, "its page chain breaks after page 0"),
    ]:
        cut = tmp_path / f"cut-{whole.name}"
        data = whole.read_bytes()
        cut.write_bytes(data[: len(data) // 2])
        caplog.clear()
        np.testing.assert_array_equal(load_stack(cut), pages[:frames])
        said = [r.getMessage() for r in caplog.records if r.name.startswith("snrmon")]
        assert len(said) == 1, said
        assert said[0].startswith(f"{cut}: the file is cut short in frame {frames} ({why}")
        assert said[0].endswith(f"read its {frames} whole frame" + "s" * (frames > 1)), said


def test_tiff_bad_input(tmp_path, stack):
    (tmp_path / "junk.tif").write_bytes(b"not a tiff at all")
    with pytest.raises(ValueError, match=r"junk\.tif: not a readable TIFF"):
        load_stack(tmp_path / "junk.tif")
    with tifffile.TiffWriter(tmp_path / "mixed.tif") as w:
        w.write(stack[0])
        w.write(np.zeros((5, 5), np.uint16))
    with pytest.raises(ValueError, match=r"mixed\.tif: TIFF pages differ in size"):
        load_stack(tmp_path / "mixed.tif")
    with pytest.raises(FileNotFoundError, match=r"nope\.tif: no such file"):
        next(iter_stack(tmp_path / "nope.tif"))


@pytest.mark.parametrize("order", ["little", "big"])
def test_raw_with_json_descriptor(tmp_path, stack, order):
    raw = tmp_path / "rec.bin"
    raw.write_bytes(stack.astype("<u2" if order == "little" else ">u2").tobytes())
    desc = {"shape": [4, 9, 11], "dtype": "uint16", "fps": 60, "byte_order": order}
    (tmp_path / "rec.bin.json").write_text(json.dumps(desc))
    np.testing.assert_array_equal(load_stack(raw), stack)
    np.testing.assert_array_equal(load_stack(tmp_path / "rec.bin.json"), stack)


def test_raw_truncated_or_bad_descriptor(tmp_path, stack):
    raw = tmp_path / "rec.bin"
    raw.write_bytes(stack.tobytes()[:-2])
    (tmp_path / "rec.bin.json").write_text(json.dumps({"shape": [4, 9, 11], "dtype": "uint16"}))
    with pytest.raises(ValueError, match=r"rec.bin: raw file truncated: 790 bytes"):
        load_stack(raw)
    (tmp_path / "rec.bin.json").write_text(json.dumps({"shape": [4, 9, 11], "dtype": "int8"}))
    with pytest.raises(ValueError, match=r"dtype must be one of .* got 'int8'"):
        load_stack(raw)
    (tmp_path / "rec.bin.json").write_text("{shape")
    with pytest.raises(ValueError, match=r"rec\.bin\.json: not valid JSON"):
        load_stack(raw)


def test_unknown_format(tmp_path):
    (tmp_path / "x.dat").write_bytes(b"1234")
    with pytest.raises(ValueError, match=r"x.dat: unknown stack format '.dat'"):
        load_stack(tmp_path / "x.dat")


def test_real_video_gives_8_bit_grey_frames(shared_data):
    path = shared_data / "ir_small_targets" / "videos" / "IR_DRONE_151.mp4"
    frames = load_stack(path)
    assert frames.shape == (301, 256, 320) and frames.dtype == np.uint8
    first = next(iter_stack(path))
    np.testing.assert_array_equal(first, frames[0])
