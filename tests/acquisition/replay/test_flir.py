"""FLIR radiometric files as stacks, against independent readings of the same real frames:
exiftool's dump of the frame's tags (its own lines, parsed here), flirpy's reader and its
raw-to-temperature code, and a byte-level decode of the FFF layout written here. The CSQ,
radiometric JPEG and byte-order variants are the real frames re-packed here by that layout
(JPEG-LS by imagecodecs' CharLS encoder)."""

from __future__ import annotations

import dataclasses
import logging
import math
import struct
from datetime import datetime
from pathlib import Path

import cv2
import numpy as np
import pytest

import snrmon
from snrmon.acquisition.replay.flir import load_flir

SEQ = "flirpy-test.seq"
FFF = "flirpy-frame_000000.fff"
FFF_LE = "flirpy-frame_000000_le.fff"


@pytest.fixture
def flir(flir_files) -> Path:
    return flir_files


# ----------------------------------------------------------------------------- references
def exiftool_tags(path: Path) -> dict[str, str]:
    """``Tag Name : value`` lines of an exiftool dump."""
    tags = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        name, sep, value = line.partition(":")
        if sep:
            tags[name.strip()] = value.strip()
    return tags


def _number(text: str) -> float:
    return float(text.split()[0])


@dataclasses.dataclass
class RefFrame:
    """One FFF frame decoded here: its records (type -> bytes) and the raw pixels."""

    records: dict[int, bytes]
    pixels: np.ndarray


def reference_frames(data: bytes) -> list[RefFrame]:
    """Consecutive FFF frames by the layout (exiftool's FLIR module): the header's byte order
    from its version (100-199), the directory's 32-byte entries, the raw record's own byte
    order from its first word (2), its width and height, the pixel words at 0x20."""
    frames, at = [], 0
    while at + 64 <= len(data) and data[at : at + 4] == b"FFF\0":
        order = "<" if 100 <= struct.unpack_from("<I", data, at + 0x14)[0] < 200 else ">"
        directory, count = struct.unpack_from(order + "II", data, at + 0x18)
        end = at + directory + 32 * count
        records = {}
        for i in range(count):
            kind, _, _, _, offset, length = struct.unpack_from(
                order + "HHIIII", data, at + directory + 32 * i
            )
            if kind:
                records[kind] = data[at + offset : at + offset + length]
                end = max(end, at + offset + length)
        raw = records[1]
        word = "<" if raw[0] == 2 else ">"
        width, height = struct.unpack_from(word + "HH", raw, 2)
        pixels = np.frombuffer(raw, word + "u2", width * height, 32).reshape(height, width)
        frames.append(RefFrame(records, pixels.astype(np.uint16)))
        at = end
    return frames


def fff_bytes(frame: RefFrame, *, header: str = "<", words: str = "<", payload=None) -> bytes:
    """The frame packed again as an FFF: header and directory in byte order ``header``, the
    raw record's fields and pixels in ``words`` (or ``payload`` in their place: a PNG or a
    JPEG-LS stream), the other records as they were."""
    width, height = frame.pixels.shape[1], frame.pixels.shape[0]
    raw_head = bytearray(32)
    struct.pack_into(words + "HHH", raw_head, 0, 2, width, height)
    if payload is None:
        payload = frame.pixels.astype(words + "u2").tobytes()
    records = {1: bytes(raw_head) + payload, **{k: v for k, v in frame.records.items() if k != 1}}
    directory = bytearray()
    body = bytearray()
    offset = 64 + 32 * len(records)
    for kind, rec in records.items():
        subtype = {"<": 2, ">": 1}[words] if kind == 1 else 1
        directory += struct.pack(
            header + "HHIIIIIII", kind, subtype, 100, 1, offset + len(body), len(rec), 0, 0, 0
        )
        body += rec
    head = struct.pack(header + "4s16sIIIIH", b"FFF\0", b"test", 100, 64, len(records), 2, 0)
    return head.ljust(64, b"\0") + bytes(directory) + bytes(body)


# ----------------------------------------------------------------------------- counts
def test_seq_counts_are_the_byte_level_decode_and_flirpy(flir):
    from flirpy.io.seq import Seq

    stack = snrmon.load_stack(flir / SEQ)
    assert stack.sizes == {"frame": 7, "row": 512, "col": 640}
    assert stack.dtype == np.uint16
    ref = reference_frames((flir / SEQ).read_bytes())
    assert len(ref) == 7
    theirs = Seq(str(flir / SEQ))
    assert len(theirs) == 7
    for i in range(7):
        np.testing.assert_array_equal(stack.values[i], ref[i].pixels)
        np.testing.assert_array_equal(stack.values[i], theirs[i].get_image())
    # a real scene, not a constant: 2623-2739 counts in frame 0
    assert (int(stack[0].min()), int(stack[0].max())) == (2623, 2739)


@pytest.mark.parametrize(("name", "shape"), [(FFF, (512, 640)), (FFF_LE, (240, 320))])
def test_fff_counts_are_the_byte_level_decode_and_flirpy(flir, name, shape):
    from flirpy.io.fff import Fff

    stack = snrmon.load_stack(flir / name)
    assert stack.shape == (1, *shape)
    ref = reference_frames((flir / name).read_bytes())
    np.testing.assert_array_equal(stack.values[0], ref[0].pixels)
    np.testing.assert_array_equal(stack.values[0], Fff(str(flir / name)).get_image())


def test_the_fff_is_the_first_frame_of_the_seq(flir):
    np.testing.assert_array_equal(
        snrmon.load_stack(flir / FFF).values[0], snrmon.load_stack(flir / SEQ).values[0]
    )


@pytest.mark.parametrize("header", ["<", ">"])
@pytest.mark.parametrize("words", ["<", ">"])
def test_both_byte_orders_give_the_same_counts_and_calibration(flir, tmp_path, header, words):
    real = load_flir(flir / FFF)
    frame = reference_frames((flir / FFF).read_bytes())[0]
    path = tmp_path / "frame.fff"
    path.write_bytes(fff_bytes(frame, header=header, words=words))
    again = load_flir(path)
    assert again.frames.dtype == np.uint16
    np.testing.assert_array_equal(again.frames, real.frames)
    assert again.calibration == real.calibration
    np.testing.assert_array_equal(again.utc, real.utc)


# ----------------------------------------------------------------------------- calibration
def test_calibration_and_camera_are_the_exiftool_dump(flir):
    tags = exiftool_tags(flir / "flirpy-frame_000000.txt")
    for name in (FFF, SEQ):
        a = snrmon.load_stack(flir / name).attrs
        assert a["planck_r1"] == float(tags["Planck R1"])
        assert a["planck_r2"] == float(tags["Planck R2"])
        assert a["planck_b"] == float(tags["Planck B"])
        assert a["planck_f"] == float(tags["Planck F"])
        assert a["planck_o"] == float(tags["Planck O"])
        # exiftool prints these rounded: 2 decimals, 0.1 C, 0.1 %, 6 decimals
        assert a["emissivity"] == pytest.approx(float(tags["Emissivity"]), abs=0.005)
        assert a["object_distance_m"] == pytest.approx(_number(tags["Object Distance"]), abs=0.005)
        for key, tag in [
            ("reflected_temp_k", "Reflected Apparent Temperature"),
            ("atmospheric_temp_k", "Atmospheric Temperature"),
            ("ir_window_temp_k", "IR Window Temperature"),
        ]:
            assert a[key] - 273.15 == pytest.approx(_number(tags[tag]), abs=0.05)
        assert a["ir_window_transmission"] == pytest.approx(
            float(tags["IR Window Transmission"]), abs=0.005
        )
        assert 100 * a["relative_humidity"] == pytest.approx(
            _number(tags["Relative Humidity"]), abs=0.05
        )
        for key, tag in [
            ("atm_trans_alpha1", "Atmospheric Trans Alpha 1"),
            ("atm_trans_alpha2", "Atmospheric Trans Alpha 2"),
            ("atm_trans_beta1", "Atmospheric Trans Beta 1"),
            ("atm_trans_beta2", "Atmospheric Trans Beta 2"),
            ("atm_trans_x", "Atmospheric Trans X"),
        ]:
            assert a[key] == pytest.approx(float(tags[tag]), abs=5e-7)
        assert a["camera"] == tags["Camera Model"]
        assert a["serial_number"] == tags["Camera Serial Number"]
        assert a["frame_rate_hz"] == int(tags["Frame Rate"])
        assert a["units"] == "DN"


def test_frame_times_are_the_files_own(flir):
    tags = exiftool_tags(flir / "flirpy-frame_000000.txt")
    local = datetime.strptime(tags["Date/Time Original"], "%Y:%m:%d %H:%M:%S.%f%z")
    utc_ns = round(local.timestamp() * 1e3) * 1_000_000
    seq = snrmon.load_stack(flir / SEQ)
    times = seq["time"].values.astype(np.int64)
    assert times[0] == utc_ns  # 2018-11-05 12:14:43.084 +01:00
    assert seq.attrs["utc_offset_min"] == local.utcoffset().total_seconds() / 60 == 60
    assert np.all(np.diff(times) > 0)
    # the recording's frames as the camera stamped them: 2.198 s from the first to the last
    assert (times[-1] - times[0]) / 1e9 == pytest.approx(2.198, abs=1e-9)
    assert snrmon.load_stack(flir / FFF)["time"].values.astype(np.int64)[0] == utc_ns


def _flirpy_meta(attrs: dict) -> dict:
    """flirpy's meta keys (exiftool's tag names, degC temperatures) from our attributes."""
    return {
        "Planck R1": attrs["planck_r1"],
        "Planck R2": attrs["planck_r2"],
        "Planck B": attrs["planck_b"],
        "Planck F": attrs["planck_f"],
        "Planck O": attrs["planck_o"],
        "Emissivity": attrs["emissivity"],
        "Object Distance": attrs["object_distance_m"],
        "Reflected Apparent Temperature": attrs["reflected_temp_k"] - 273.15,
        "Atmospheric Temperature": attrs["atmospheric_temp_k"] - 273.15,
        "IR Window Temperature": attrs["ir_window_temp_k"] - 273.15,
        "IR Window Transmission": attrs["ir_window_transmission"],
        "Relative Humidity": attrs["relative_humidity"],
        "Atmospheric Trans Alpha 1": attrs["atm_trans_alpha1"],
        "Atmospheric Trans Alpha 2": attrs["atm_trans_alpha2"],
        "Atmospheric Trans Beta 1": attrs["atm_trans_beta1"],
        "Atmospheric Trans Beta 2": attrs["atm_trans_beta2"],
        "Atmospheric Trans X": attrs["atm_trans_x"],
    }


@pytest.mark.parametrize("name", [FFF, FFF_LE])
def test_temperature_is_flirpys_reading_of_the_same_frame(flir, name):
    from flirpy.io.fff import Fff
    from flirpy.util.raw import raw2temp

    temp = snrmon.load_stack(flir / name, units="temperature_c")
    assert temp.attrs["units"] == "degC" and temp.dtype == np.float64
    counts = snrmon.load_stack(flir / name).values[0]
    # flirpy's raw-to-temperature code (Thermimage's) on the same constants: the same relation
    ours = temp.values[0]
    np.testing.assert_allclose(ours, raw2temp(counts, _flirpy_meta(temp.attrs)), atol=1e-9)
    # flirpy's whole reading (its own reader of the constants): within 2 mK; flirpy takes
    # 273.14 for 0 degC in the temperatures it reads, 0.01 K off exiftool's 273.15
    theirs = Fff(str(flir / name))
    assert theirs.meta["Reflected Apparent Temperature"] == pytest.approx(
        temp.attrs["reflected_temp_k"] - 273.14, abs=1e-9
    )
    assert np.abs(ours - theirs.get_radiometric_image()).max() < 2e-3
    assert np.isfinite(ours).all()


def test_radiance_is_the_object_signal_the_temperature_inverts(flir):
    rad = snrmon.load_stack(flir / SEQ, units="radiance")
    temp = snrmon.load_stack(flir / SEQ, units="temperature_c")
    a = rad.attrs
    assert a["units"] == "DN (object signal)"
    t_k = a["planck_b"] / np.log(
        a["planck_r1"] / (a["planck_r2"] * (rad.values + a["planck_o"])) + a["planck_f"]
    )
    np.testing.assert_allclose(t_k - 273.15, temp.values, atol=1e-9)
    # frame 0: 9.56-12.58 degC (the Duo Pro R's scene at 0.94 emissivity, 50 m)
    assert float(temp[0].min()) == pytest.approx(9.557, abs=1e-3)
    assert float(temp[0].max()) == pytest.approx(12.582, abs=1e-3)


def test_object_signal_is_the_counts_for_a_blackbody_seen_through_nothing(flir):
    cal = load_flir(flir / FFF).calibration
    assert cal is not None
    seen_bare = dataclasses.replace(cal.conditions, emissivity=1.0, object_distance_m=0.0)
    clear = dataclasses.replace(cal, conditions=seen_bare)
    counts = np.array([2623.0, 2700.0, 2739.0])
    np.testing.assert_allclose(clear.object_signal(counts), counts, rtol=1e-12)
    # a blackbody's counts at 300 K read back 300 K
    assert clear.temperature_k(np.array([clear.blackbody_counts(300.0)]))[0] == pytest.approx(
        300.0, abs=1e-9
    )
    # the path's transmission at 50 m, 20 degC, 30 %: FLIR's two-band model by hand
    h2o = 0.3 * math.exp(1.5587 + 0.06939 * 20 - 0.00027816 * 400 + 0.00000068455 * 8000)
    tau = 1.9 * math.exp(-5 * (0.006569 + -0.002276 * math.sqrt(h2o))) + (1 - 1.9) * math.exp(
        -5 * (0.012620 + -0.006670 * math.sqrt(h2o))
    )
    assert cal.path_transmission() == pytest.approx(tau, abs=1e-6)
    assert cal.path_transmission() == pytest.approx(0.9753, abs=5e-5)  # docs/measurement.md


def test_counts_only_where_the_file_has_no_calibration(tmp_path):
    np.save(tmp_path / "s.npy", np.zeros((2, 4, 4), np.uint16))
    with pytest.raises(ValueError, match=r"s\.npy: units='temperature_c' needs the camera's"):
        snrmon.load_stack(tmp_path / "s.npy", units="temperature_c")
    with pytest.raises(ValueError, match=r"units must be one of counts, radiance, temperature_c"):
        snrmon.load_stack(tmp_path / "s.npy", units="kelvin")


# ----------------------------------------------------------------------------- other kinds
def _jpeg_with_segments(segments: list[bytes]) -> bytes:
    ok, jpeg = cv2.imencode(".jpg", np.full((24, 32), 128, np.uint8))
    assert ok
    data = jpeg.tobytes()
    app = b"".join(b"\xff\xe1" + (len(s) + 2).to_bytes(2, "big") + s for s in segments)
    return data[:2] + app + data[2:]


def test_radiometric_jpeg_is_the_fff_in_its_app1_segments(flir, tmp_path):
    fff = (flir / FFF_LE).read_bytes()
    size = 60000
    chunks = [fff[i : i + size] for i in range(0, len(fff), size)]
    last = len(chunks) - 1
    segments = [b"FLIR\0\x01" + bytes([i, last]) + c for i, c in enumerate(chunks)]
    path = tmp_path / "IR_0001.jpg"
    path.write_bytes(_jpeg_with_segments(segments[::-1]))  # chunk order, not file order
    jpeg, real = snrmon.load_stack(path), snrmon.load_stack(flir / FFF_LE)
    np.testing.assert_array_equal(jpeg.values, real.values)
    assert {k: v for k, v in jpeg.attrs.items() if k != "source"} == {
        k: v for k, v in real.attrs.items() if k != "source"
    }
    np.testing.assert_array_equal(jpeg["time"].values, real["time"].values)


def test_png_coded_raw_data_reads_the_same_counts(flir, tmp_path):
    # FLIR's PNG-coded raw images hold their 16-bit words byte-swapped (exiftool's FLIR notes)
    frame = reference_frames((flir / FFF_LE).read_bytes())[0]
    ok, png = cv2.imencode(".png", frame.pixels.byteswap())
    assert ok
    path = tmp_path / "png.fff"
    path.write_bytes(fff_bytes(frame, payload=png.tobytes()))
    np.testing.assert_array_equal(load_flir(path).frames[0], frame.pixels)


def test_csq_jpeg_ls_frames_read_as_the_seq(flir, tmp_path):
    imagecodecs = pytest.importorskip("imagecodecs", reason="the flir extra decodes CSQ")
    frames = reference_frames((flir / SEQ).read_bytes())
    payloads = [imagecodecs.jpegls_encode(f.pixels) for f in frames]
    assert all(p[:3] == b"\xff\xd8\xff" for p in payloads)
    path = tmp_path / "rec.csq"
    path.write_bytes(
        b"".join(fff_bytes(f, payload=p) for f, p in zip(frames, payloads, strict=True))
    )
    csq, seq = snrmon.load_stack(path), snrmon.load_stack(flir / SEQ)
    assert csq.sizes == {"frame": 7, "row": 512, "col": 640}
    np.testing.assert_array_equal(csq.values, seq.values)
    np.testing.assert_array_equal(csq["time"].values, seq["time"].values)
    assert csq.attrs["planck_r1"] == seq.attrs["planck_r1"]


def test_a_jpeg_without_flir_data_is_refused_saying_what_it_is(tmp_path):
    plain = tmp_path / "photo.jpg"
    plain.write_bytes(_jpeg_with_segments([b"Exif\0\0II*\0" + b"\0" * 32]))
    with pytest.raises(ValueError, match=r"photo\.jpg: a JPEG with no FLIR radiometric data"):
        snrmon.load_stack(plain)
    dji = tmp_path / "DJI_0001_R.JPG"
    dji.write_bytes(_jpeg_with_segments([b"Exif\0\0II*\0" + b"\0" * 16 + b"DJI\0FC6520\0"]))
    with pytest.raises(ValueError, match=r"DJI_0001_R\.JPG: a DJI JPEG .*DJI's closed Thermal SDK"):
        snrmon.load_stack(dji)


# ----------------------------------------------------------------------------- damage
def test_a_recording_cut_in_half_reads_to_its_last_whole_frame_and_says_so(flir, tmp_path, caplog):
    data = (flir / SEQ).read_bytes()
    cut = tmp_path / "cut.seq"
    cut.write_bytes(data[: len(data) // 2])
    with caplog.at_level(logging.WARNING):
        stack = snrmon.load_stack(cut)
    assert stack.sizes["frame"] == 3
    np.testing.assert_array_equal(stack.values, snrmon.load_stack(flir / SEQ).values[:3])
    (record,) = [r for r in caplog.records if r.levelno == logging.WARNING]
    message = record.getMessage()
    assert str(cut) in message and "cut short in frame 3" in message
    assert "read its 3 whole frames" in message


def test_a_frame_cut_in_half_is_refused_naming_the_file_and_the_frame(flir, tmp_path):
    data = (flir / FFF).read_bytes()
    cut = tmp_path / "cut.fff"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.fff: truncated FFF frame 0 \(329282 bytes"):
        snrmon.load_stack(cut)
    junk = tmp_path / "junk.seq"
    junk.write_bytes(data[:64] + b"\0" * 100)
    with pytest.raises(ValueError, match=r"junk\.seq: truncated FFF frame 0"):
        snrmon.load_stack(junk)
