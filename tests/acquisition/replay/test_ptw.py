"""The Altair/ResearchIR ``.ptw`` reader on the two real Cedip Jade recordings, against an
independent reading of the same bytes (struct, frame by frame, from the documented offsets), and
its one-line errors on truncated, foreign and self-contradicting files."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from snrmon.acquisition.replay.ptw import load_ptw, read_ptw_header
from snrmon.acquisition.replay.stack_io import iter_stack, load_stack

DATA = Path(__file__).parents[2] / "data" / "pyradi"
# PROVENANCE.md: frames, rows, columns and the pixel range of each recording
FILES = {
    "PyradiSampleMWIR.ptw": (100, 64, 69, 6106, 6462),
    "PyradiSampleLWIR.ptw": (100, 68, 75, 5660, 5894),
}


def reference_read(path: Path) -> tuple[str, np.ndarray]:
    """Camera name and frames, read with struct only: main header size at byte 11, frame header
    size at 15, frame count at 27, camera name at 44-63, columns at 377, rows at 379; each frame's
    pixels after its frame header, row after row, little-endian 16-bit."""
    raw = path.read_bytes()
    (main,) = struct.unpack("<I", raw[11:15])
    (frame_header,) = struct.unpack("<I", raw[15:19])
    (count,) = struct.unpack("<I", raw[27:31])
    cols, rows = struct.unpack("<HH", raw[377:381])
    name = raw[44:64].split(b"\0")[0].decode("ascii")
    frames = []
    at = main
    for _ in range(count):
        at += frame_header
        pixels = struct.unpack(f"<{rows * cols}H", raw[at : at + 2 * rows * cols])
        frames.append(np.array(pixels, dtype=np.uint16).reshape(rows, cols))
        at += 2 * rows * cols
    assert at == len(raw)  # the file holds exactly the frames
    return name, np.stack(frames)


@pytest.mark.parametrize("name", sorted(FILES))
def test_real_recordings_come_out_as_written(name):
    path = DATA / name
    n, rows, cols, lo, hi = FILES[name]
    ref_name, ref = reference_read(path)
    stack = load_stack(path)
    frames, header = load_ptw(path)
    assert stack.shape == (n, rows, cols) and stack.dtype == np.uint16
    np.testing.assert_array_equal(stack, ref)  # every pixel of every frame
    np.testing.assert_array_equal(np.stack(list(iter_stack(path))), ref)
    assert (int(stack.min()), int(stack.max())) == (lo, hi)
    assert header.camera_name == ref_name == "Jade"
    assert (header.frames, header.rows, header.cols, header.bit_depth) == (n, rows, cols, 14)
    assert header.lens_name == "50 mm"
    assert header.frame_period_s == pytest.approx(0.01)  # 100 Hz
    assert not frames.flags.writeable  # a read-only map of the file, nothing copied


def _variant(tmp_path: Path, data: bytes, name: str = "x.ptw") -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def test_truncated_files_name_what_is_missing(tmp_path):
    raw = (DATA / "PyradiSampleMWIR.ptw").read_bytes()
    stride = 1016 + 2 * 64 * 69
    cut = _variant(tmp_path, raw[: 3476 + 37 * stride + 100])
    with pytest.raises(ValueError, match=r"x\.ptw: PTW file truncated: .* hold 37 whole frames"):
        load_stack(cut)
    head = _variant(tmp_path, raw[:2000], "head.ptw")
    with pytest.raises(ValueError, match=r"head\.ptw: truncated PTW file: 2000 bytes, the main"):
        load_stack(head)
    tiny = _variant(tmp_path, raw[:200], "tiny.ptw")
    with pytest.raises(ValueError, match=r"tiny\.ptw: truncated PTW main header \(200 bytes"):
        read_ptw_header(tiny)


def test_longer_foreign_and_contradicting_files_are_refused(tmp_path):
    raw = (DATA / "PyradiSampleLWIR.ptw").read_bytes()
    longer = _variant(tmp_path, raw + b"\0" * 10, "long.ptw")
    with pytest.raises(ValueError, match=r"long\.ptw: PTW file 10 bytes longer than its frames"):
        load_stack(longer)
    foreign = _variant(tmp_path, b"II*\0" + bytes(5000), "tiff.ptw")
    with pytest.raises(ValueError, match=r"tiff\.ptw: not a Cedip/Altair PTW file \(starts with"):
        load_stack(foreign)
    rows = bytearray(raw)
    rows[379:381] = struct.pack("<H", 70)
    with pytest.raises(ValueError, match=r"frame size 5100 words is not 70 rows x 75 columns"):
        load_stack(_variant(tmp_path, bytes(rows), "rows.ptw"))
    doubles = bytearray(raw)
    doubles[2105] = 1
    with pytest.raises(ValueError, match=r"frame buffer type 1 \(pixels as doubles\)"):
        load_stack(_variant(tmp_path, bytes(doubles), "doubles.ptw"))
    with pytest.raises(FileNotFoundError, match=r"nope\.ptw: no such file"):
        load_stack(tmp_path / "nope.ptw")


def test_measure_and_replay_read_a_ptw_stack(capsys):
    import json

    from snrmon.cli import main

    path = DATA / "PyradiSampleMWIR.ptw"
    _, ref = reference_read(path)
    assert main(["measure", str(path), "--at", "30,30", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n"] == 100
    for f in out["frames"]:
        assert f["peak"] == ref[f["index"], f["peak_y"], f["peak_x"]]
    assert main(["replay", str(path), "--at", "30,30", "--tracking", "off", "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == out
