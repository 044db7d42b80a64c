"""The importers and the session reader fed damaged versions of real files: truncated, bit-flipped
and with two pieces swapped (seeded). Never a traceback, never a hang: each one either reads (a
damaged comment line is still a good log) or is refused as bad input, which the command line
shows as one line and exit 2.

The files: the real NMEA logs and the real AirData export (its first 1,500 rows) of tests/data;
frames of the real thermal clips as a multi-page TIFF and as a raw file with its descriptor; a
real clip (mp4); the real .ptw recordings when the stack reader knows the format; the real FLIR
.seq and .fff, and that .fff in a radiometric JPEG's APP1 chunks; a session file written by the
recorder. There is no real .tlog in tests/data: the tlog here is one that
pymavlink writes for a simulated flight.
"""

from __future__ import annotations

import gzip
import json
import shutil
import signal
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from snrmon.cli import BAD_INPUT, main

SEED = 25
MUTATIONS = ("truncated", "bit_flipped", "reordered")
"""Each made ``CASES_PER_MUTATION`` times per file, and the file cut to nothing (refused)."""
CASES_PER_MUTATION = 2
TIMEOUT_S = 30  # a reader that does not come back is a hang, not a slow machine


def mutate(data: bytes, how: str, rng: np.random.Generator) -> bytes:
    """``data`` truncated at a random byte, with 8 random bits flipped, or with two pieces of a
    sixteenth of it swapped."""
    n = len(data)
    if how == "truncated":
        return data[: int(rng.integers(0, n))]
    if how == "bit_flipped":
        out = bytearray(data)
        for i in rng.integers(0, n, 8):
            out[int(i)] ^= 1 << int(rng.integers(0, 8))
        return bytes(out)
    k = max(1, n // 16)
    a, b = sorted(int(x) * k for x in rng.choice(n // k, 2, replace=False))
    return data[:a] + data[b : b + k] + data[a + k : b] + data[a : a + k] + data[b + k :]


# ------------------------------------------------------------------------ the real files


def _nmea(name: str) -> Callable[[Path, Path], Path]:
    def make(data: Path, folder: Path) -> Path:
        return Path(shutil.copy(data / "nmea" / f"{name}.log", folder / f"{name}.log"))

    return make


def _dji(data: Path, folder: Path) -> Path:
    lines = gzip.decompress((data / "dji-airdata" / "air-2s.csv.gz").read_bytes()).splitlines()
    path = folder / "air-2s.csv"
    path.write_bytes(b"\n".join(lines[:1501]) + b"\n")
    return path


def _frames(data: Path) -> np.ndarray:
    import cv2

    names = sorted((data / "ir_small_targets" / "frames").glob("IR_DRONE_001_*.png"))
    return np.stack([cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in names]).astype(np.uint16)


def _tiff(data: Path, folder: Path) -> Path:
    import tifffile

    path = folder / "frames.tif"
    tifffile.imwrite(path, _frames(data))
    return path


def _raw(data: Path, folder: Path) -> Path:
    frames = _frames(data)
    path = folder / "frames.raw"
    path.write_bytes(frames.astype("<u2").tobytes())
    (folder / "frames.raw.json").write_text(
        json.dumps({"shape": list(frames.shape), "dtype": "uint16"})
    )
    return path


def _mp4(data: Path, folder: Path) -> Path:
    return Path(
        shutil.copy(data / "ir_small_targets" / "videos" / "IR_DRONE_001.mp4", folder / "c.mp4")
    )


def _ptw(name: str) -> Callable[[Path, Path], Path]:
    def make(data: Path, folder: Path) -> Path:
        return Path(shutil.copy(data / "pyradi" / f"{name}.ptw", folder / f"{name}.ptw"))

    return make


def _tlog(_data: Path, folder: Path) -> Path:
    from datetime import UTC, datetime, timedelta

    from snrmon.sim.flight import FlightPlan
    from snrmon.sim.flight_logs import flight_epochs, write_tlog

    u0 = datetime(2021, 9, 6, 2, 48, 9, tzinfo=UTC)
    times = [0.1 * k for k in range(40)]
    epochs = flight_epochs(FlightPlan(), times, [u0 + timedelta(seconds=t) for t in times])
    return write_tlog(folder / "flight.tlog", epochs)


def _session(_data: Path, folder: Path) -> Path:
    from tests.acquisition.session_factory import write_session

    return write_session(folder / "s.h5", ranges_m=(120.0,), hover_s=1.0, transit_s=0.5).path


def _read_stack(path: Path) -> None:
    from snrmon.acquisition.replay.stack_io import load_stack
    from snrmon.inputs import stack_file

    stack = load_stack(stack_file(path))
    np.asarray(stack[-1]).sum()  # the last frame's pixels read too


def _read_session(path: Path) -> None:
    from snrmon.acquisition.replay.batch import replay_session
    from snrmon.inputs import session_file

    replay_session(session_file(path), fast=True)


def _read_gps(kind: str) -> Callable[[Path], None]:
    def read(path: Path) -> None:
        from snrmon.acquisition.record.gps_import import read_log
        from snrmon.inputs import input_file

        read_log(kind, input_file(path, "flight log"))

    return read


def _flir(name: str) -> Callable[[Path, Path], Path]:
    def make(data: Path, folder: Path) -> Path:
        source = data / "field-formats" / "flir" / name
        if not source.exists():  # kept gzipped in git (over 2 MB raw)
            (folder / name).write_bytes(
                gzip.decompress(source.with_name(name + ".gz").read_bytes())
            )
            return folder / name
        return Path(shutil.copy(source, folder / name))

    return make


def _flir_jpeg(data: Path, folder: Path) -> Path:
    """The real little-endian FFF frame in the FLIR APP1 chunks of a radiometric JPEG."""
    import cv2

    fff = (data / "field-formats" / "flir" / "flirpy-frame_000000_le.fff").read_bytes()
    chunks = [fff[i : i + 60000] for i in range(0, len(fff), 60000)]
    app1 = b"".join(
        b"\xff\xe1"
        + (len(c) + 10).to_bytes(2, "big")
        + b"FLIR\0\x01"
        + bytes([i, len(chunks) - 1])
        + c
        for i, c in enumerate(chunks)
    )
    jpeg = cv2.imencode(".jpg", np.full((24, 32), 128, np.uint8))[1].tobytes()
    path = folder / "IR_0001.jpg"
    path.write_bytes(jpeg[:2] + app1 + jpeg[2:])
    return path


FILES: dict[str, tuple[Callable[[Path, Path], Path], Callable[[Path], None]]] = {
    **{f"nmea:{n}": (_nmea(n), _read_gps("nmea")) for n in ("mtk-3301", "nmea-rtk")},
    "dji": (_dji, _read_gps("dji_csv")),
    "tlog": (_tlog, _read_gps("tlog")),
    "tiff": (_tiff, _read_stack),
    "raw": (_raw, _read_stack),
    "mp4": (_mp4, _read_stack),
    "ptw:MWIR": (_ptw("PyradiSampleMWIR"), _read_stack),
    "ptw:LWIR": (_ptw("PyradiSampleLWIR"), _read_stack),
    "flir:seq": (_flir("flirpy-test.seq"), _read_stack),
    "flir:fff": (_flir("flirpy-frame_000000_le.fff"), _read_stack),
    "flir:jpg": (_flir_jpeg, _read_stack),
    "session": (_session, _read_session),
}


def _stack_reader_knows(path: Path) -> bool:
    """Whether the stack reader reads this format (the .ptw reader arrives separately): asked
    of the reader itself, so the format is fuzzed as soon as it reads it."""
    from snrmon.acquisition.replay.stack_io import load_stack

    try:
        load_stack(path)
    except ValueError as exc:
        if "unknown stack format" in str(exc):
            return False
    return True


def _guarded(call: Callable[[], object], what: str) -> object:
    def hung(*_):
        raise TimeoutError(f"{what} did not come back within {TIMEOUT_S} s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(TIMEOUT_S)
    try:
        return call()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("name", list(FILES))
def test_damaged_real_files_are_read_or_refused_as_bad_input(name, shared_data, tmp_path):
    make, read = FILES[name]
    original = make(shared_data, tmp_path)
    if original.suffix == ".ptw" and not _stack_reader_knows(original):
        pytest.skip("the stack reader does not read .ptw yet")
    _guarded(lambda: read(original), f"reading the undamaged {name}")  # the original reads
    data = original.read_bytes()
    rng = np.random.default_rng([SEED, sum(map(ord, name))])
    refused = []
    cases = [(how, k) for how in MUTATIONS for k in range(CASES_PER_MUTATION)] + [("empty", 0)]
    for how, k in cases:
        damaged = tmp_path / f"{how}-{k}" / original.name
        damaged.parent.mkdir()
        damaged.write_bytes(b"" if how == "empty" else mutate(data, how, rng))
        for extra in original.parent.glob(original.name + ".json"):  # a raw file's descriptor
            shutil.copy(extra, damaged.parent / extra.name)
        try:
            _guarded(lambda p=damaged: read(p), f"reading {how} {name}")
        except BAD_INPUT as exc:
            refused.append(how)
            text = str(exc)
            assert text.strip() and "Traceback" not in text, (how, name)
        except Exception as exc:  # anything else is a crash: exit 1, "internal error"
            pytest.fail(f"{how} {name}: {type(exc).__name__}: {exc}")
    # A log cut short or with a torn line still reads (that is how loggers leave files); an
    # empty file never does.
    assert "empty" in refused


def _one_line_or_ok(code: int, err: str, argv: list[str]) -> None:
    lines = [line for line in err.strip().splitlines() if ": warning: " not in line]
    assert code in (0, 2), f"snrmon {' '.join(argv)} -> exit {code}: {err}"
    if code == 2:
        assert len(lines) == 1 and ": error: " in lines[0], err
    assert "Traceback" not in err and "internal error" not in err


@pytest.mark.parametrize("how", MUTATIONS)
def test_damaged_files_through_the_commands(how, shared_data, tmp_path, capsys):
    """The same damage through the commands that read the files: exit 0, or 2 with one line."""
    rng = np.random.default_rng([SEED, MUTATIONS.index(how)])
    session = _session(shared_data, tmp_path)
    target = tmp_path / "target.h5"
    shutil.copyfile(session, target)
    runs = {
        "nmea": (_nmea("nmea-rtk"), ["gps-import", str(target), "--format", "nmea", "--replace"]),
        "dji": (_dji, ["gps-import", str(target), "--format", "dji_csv", "--replace"]),
        "tiff": (_tiff, ["measure", "--at", "60,60", "--json"]),
        "flir": (_flir("flirpy-test.seq"), ["measure", "--at", "363,92", "--json"]),
        "session": (_session, ["replay", "--fast", "--json"]),
    }
    for name, (make, argv) in runs.items():
        folder = tmp_path / name
        folder.mkdir()
        original = make(shared_data, folder)
        damaged = folder / "damaged" / original.name
        damaged.parent.mkdir()
        damaged.write_bytes(mutate(original.read_bytes(), how, rng))
        # gps-import takes the session, then the log
        full = [*argv[:2], str(damaged), *argv[2:]]
        if name in ("tiff", "flir"):
            full = ["measure", str(damaged), *argv[1:]]
        if name == "session":
            full = ["replay", str(damaged), "--fast", "--json"]
        code = _guarded(lambda a=full: main(a), f"snrmon {' '.join(full)}")
        _one_line_or_ok(code, capsys.readouterr().err, full)
