"""Unbounded numbers refused before any work: each case a command line, its exit code and the
one line it must print, and a property test of the numeric options' ranges.

Each of these used to hang, ask for terabytes or fail without naming the option: ``model snr
--ranges 0.0001`` hung and ``--ranges 0.01`` was a MemoryError; ``hil --stops 1e9`` planned
125 000 000 s; ``hil --window 99999x99999`` and ``measure --box 1000001`` were MemoryErrors;
``record --duration inf`` and ``listen --timeout nan`` never ended; a config ``window =
1000000000000`` was a MemoryError; ``hil --seed -1`` did not name the option. The ranges are
``snrmon.inputs``'s shared argparse types.

And damaged or wrong files, each refused by the input check naming the file: a session with 0
frames was an internal TypeError in ``replay``; a truncated session was exit 1 with the HDF5
library's text in ``noise``; a non-video ``.mp4`` printed FFmpeg's ``moov atom not found`` before
the error; ``record`` took ``target = "uav9"`` or a missing target file and opened its devices;
three identical pairs gave ``geo calibrate`` a pointing with zero residual; a non-UTF-8 session
TOML, pairs CSV or raw-stack descriptor was the codec's bare message. An all-NaN stack gave noise
0.0 within [0, 0]: it is null now.

And damaged 3-D TIFFs: a stack written as one page of several planes (separate samples, or an
ImageDepth volume) read as 1 frame, and a TIFF cut in half gave ``n = 1`` with exit 0 (or, cut
inside compressed data, an internal DeflateError). Each is now read as its frames, read to the
frame it breaks at with one warning naming that frame and the count, or, with no whole frame to
read, refused naming the frame.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
import tifffile
from hypothesis import given, settings
from hypothesis import strategies as st

import snrmon
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.cli import build_parser, main
from snrmon.examples import example_session

MODEL_SNR = ["model", "snr", "--sensor", "mwir", "--target", "uav1"]
RECORD = ["record", "--config", "{config}", "--out", "{out}"]
LISTEN = ["listen", "gps", "--port", "/dev/null"]
MEASURE = ["measure", "{stack}", "--at", "5,5"]
MONTH_S = "2678400 s"
GEO = ["geo", "calibrate", "--site", "32.38,-106.48,1200", "--sensor", "mwir", "--pairs"]
PAIRS_HEADER = "x_px,y_px,lat_deg,lon_deg,alt_m\n"

# (argv, exit code, a fragment of the one line on stderr)
CASES = [
    (
        [*MODEL_SNR, "--ranges", "0.0001"],
        2,
        "argument --ranges: each must be a number above 1 and up to 100000 m, got '0.0001'",
    ),
    ([*MODEL_SNR, "--ranges", "0.01"], 2, "argument --ranges: each must be a number above 1"),
    ([*MODEL_SNR, "--ranges", "100,nan"], 2, "got 'nan' in '100,nan'"),
    (
        [*MODEL_SNR[:1], "plot", *MODEL_SNR[2:], "-o", "p.png", "--max-range-m", "inf"],
        2,
        "argument --max-range-m: must be a number above 10 and up to 100000 m, got 'inf'",
    ),
    (
        ["hil", "--stops", "1e9"],
        2,
        "argument --stops: each must be a number above 0 and up to 5000 m, got '1e9'",
    ),
    (["hil", "--stops", "-100,200"], 2, "got '-100' (negative) in '-100,200'"),
    (["hil", "--stops", ",".join(["100"] * 51)], 2, "must be 1 to 50 comma-separated numbers"),
    (
        ["hil", "--size", "99999x99999"],
        2,
        "argument --size: must be WxH in pixels, 64 to 8192 each, got '99999x99999'",
    ),
    (["hil", "--window", "99999x99999"], 2, "argument --window: must be WxH in pixels"),
    (
        ["hil", "--seed", "-1"],
        2,
        "argument --seed: must be an integer from 0 to 2147483647, got '-1' (negative)",
    ),
    (["hil", "--seed", "1.5"], 2, "argument --seed: must be an integer"),
    (["hil", "--hover-s", "1e9"], 2, "argument --hover-s: must be a number above 0 and up to"),
    (["hil", "--transit-mps", "0"], 2, "argument --transit-mps: must be a number above 0"),
    (["demo", "--seed", "-1"], 2, "argument --seed: must be an integer from 0"),
    (
        ["demo", "--duration", "nan"],
        2,
        f"argument --duration: must be a number above 0 and up to {MONTH_S}",
    ),
    (["gui", "--duration", "inf"], 2, "argument --duration: must be a number above 0"),
    (
        [*MEASURE, "--box", "1000001"],
        2,
        "argument --box: must be an odd integer from 1 to 8191 px, got '1000001'",
    ),
    (
        [*MEASURE, "--box", "8"],
        2,
        "argument --box: must be an odd integer from 1 to 8191 px, got '8' (even)",
    ),
    ([*MEASURE, "--box", "17"], 2, "--box 17 is larger than the 16x16 frames"),
    ([*MEASURE, "--search", "-3"], 2, "argument --search: must be an odd integer"),
    (
        [*MEASURE, "--window-frames", "1000000000000"],
        2,
        "argument --window-frames: must be an integer from 1 to 100000, got '1000000000000'",
    ),
    ([*MEASURE, "--saturation", "nan"], 2, "argument --saturation: must be a number"),
    (
        [*RECORD, "--duration", "inf"],
        2,
        f"argument --duration: must be a number above 0 and up to {MONTH_S}, got 'inf'",
    ),
    (
        ["record", "--config", "{window_config}", "--out", "{out}"],
        2,
        "[measurement] window_frames = 1000000000000: expected an integer from 1 to 100000",
    ),
    (
        [*LISTEN, "--timeout", "nan"],
        2,
        f"argument --timeout: must be a number above 0 and up to {MONTH_S}, got 'nan'",
    ),
    ([*LISTEN, "--count", "0"], 2, "argument --count: must be an integer from 1 to 1000000000"),
    (["replay", "{zero}"], 2, "session file {zero}: no frames in it (frames per camera: mwir 0)"),
    (["report", "{zero}", "-o", "{dir}/r.pdf"], 2, "{zero}: no frames in it"),
    (["noise", "{truncated}"], 2, "STACK {truncated}: truncated HDF5 file (Unable to"),
    (["noise", "{mp4}"], 2, "{mp4}: OpenCV cannot open this video"),
    (["measure", "{mp4}", "--at", "5,5"], 2, "{mp4}: OpenCV cannot open this video"),
    (
        ["record", "--config", "{uav9}", "--out", "{out}"],
        2,
        "{uav9}: target = \"uav9\": unknown target 'uav9'; known: uav1, uav2",
    ),
    (
        ["record", "--config", "{no_target}", "--out", "{out}"],
        2,
        '{no_target}: target = "gone.toml": target file not found: gone.toml',
    ),
    (
        [*GEO, "{same_pairs}"],
        2,
        "needs at least 3 distinct (pixel, GPS) pairs for azimuth, elevation and roll, got 1 "
        "distinct of 3",
    ),
    ([*GEO, "{line_pairs}"], 2, "the 3 distinct pairs' GPS positions lie on one line of sight"),
    (
        ["record", "--config", "{latin1_config}", "--out", "{out}"],
        2,
        "session config {latin1_config}: not UTF-8 text (byte 0xe9 at offset",
    ),
    ([*GEO, "{latin1_pairs}"], 2, "--pairs {latin1_pairs}: not UTF-8 text (byte 0xe9 at offset"),
    (
        ["noise", "{raw}"],
        2,
        "descriptor {raw}.json: not UTF-8 text (byte 0xe9 at offset",
    ),
    (
        ["noise", "{tif_volume_cut}"],
        2,
        "{tif_volume_cut}: the file is cut short in frame 2 (page 0: TiffFileError: corrupted tile",
    ),
    (
        ["measure", "{tif_volume_cut}", "--at", "5,5"],
        2,
        "frames 0-1 share its page, decoded whole or not at all: no frame read",
    ),
    (["noise", "{tif_first_cut}"], 2, "{tif_first_cut}: the file is cut short in frame 0 ("),
]

# Six frames of 16 x 20 px written by tifffile in each layout a 3-D TIFF comes in (the keyword
# arguments of tifffile.imwrite), each also cut in half as an interrupted copy leaves it.
TIFF_FRAMES = np.random.default_rng(6).integers(0, 4000, (6, 16, 20)).astype(np.uint16)
TIFF_LAYOUTS = {
    "pages": {},
    "planes": {"planarconfig": "separate"},
    "volume": {"volumetric": True, "tile": (16, 16)},
    "zlib": {"compression": "zlib"},
    "imagej": {"imagej": True},
}
# (layout of the cut file, frames read, the warning's reason; {size} the cut file's bytes)
CUT_TIFFS = [
    ("pages", 3, "it declares 6 frames, its {size} bytes hold 3"),
    ("planes", 2, "it declares 6 frames, its {size} bytes hold 2"),
    ("imagej", 3, "it declares 6 frames, its {size} bytes hold 3"),
    ("zlib", 2, "page 2: DeflateError:"),
]


def _write_tiffs(folder: Path) -> dict[str, str]:
    """Each layout whole (``tif_NAME``) and cut in half (``tif_NAME_cut``); ``tif_first_cut``
    ends inside the first frame's pixels."""
    names = {}
    for layout, options in TIFF_LAYOUTS.items():
        whole = folder / f"{layout}.tif"
        tifffile.imwrite(whole, TIFF_FRAMES, photometric="minisblack", **options)
        data = whole.read_bytes()
        (folder / f"{layout}_cut.tif").write_bytes(data[: len(data) // 2])
        names[f"tif_{layout}"] = str(whole)
        names[f"tif_{layout}_cut"] = str(folder / f"{layout}_cut.tif")
    first = folder / "first_cut.tif"
    first.write_bytes((folder / "pages.tif").read_bytes()[:400])
    names["tif_first_cut"] = str(first)
    return names


@pytest.fixture(scope="module")
def paths(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("bad-input-table")
    stack = d / "stack.npy"
    np.save(stack, np.random.default_rng(5).normal(100.0, 2.0, (3, 16, 16)).astype(np.float32))
    camera = '[cameras.mwir]\nsource = "shm"\naddress = "nowhere"\nsensor = "mwir"\n'
    (d / "session.toml").write_text(camera)
    (d / "window.toml").write_text(camera + "[measurement]\nwindow_frames = 1000000000000\n")
    (d / "uav9.toml").write_text('target = "uav9"\n' + camera)
    (d / "no_target.toml").write_text('target = "gone.toml"\n' + camera)
    (d / "latin1.toml").write_bytes('target = "uav1" # café\n'.encode("latin-1") + camera.encode())
    # the same pair three times; three positions on one line of sight from the site
    (d / "same.csv").write_text(PAIRS_HEADER + "640,360,32.381,-106.48,1250\n" * 3)
    on_line = [f"640,360,{32.38 + 0.001 * k},-106.48,{1200 + 50 * k}\n" for k in (1, 2, 3)]
    (d / "line.csv").write_text(PAIRS_HEADER + "".join(on_line))
    (d / "latin1.csv").write_bytes(
        PAIRS_HEADER.encode() + "640,360,32.381,-106.48,1250 é\n".encode("latin-1")
    )
    (d / "raw.bin").write_bytes(bytes(64))
    (d / "raw.bin.json").write_bytes(
        '{"shape": [2, 4, 4], "dtype": "uint16", "by": "é"}'.encode("latin-1")
    )
    # an ISO-BMFF header and no movie box: what a copy cut before its end looks like to FFmpeg
    (d / "cut.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42" + bytes(200))
    session = example_session(d / "s.h5", ranges_m=(120.0,), hover_s=2.0, cameras=("mwir",)).path
    data = session.read_bytes()
    (d / "truncated.h5").write_bytes(data[: len(data) // 2])
    SessionRecorder(
        d / "zero.h5",
        config={"session": {"cameras": {"mwir": {"source": "shm", "sensor": "mwir"}}}},
        cameras={"mwir": (40, 56)},
        fsync=False,
    ).stop()
    return {
        **_write_tiffs(d),
        "stack": str(stack),
        "config": str(d / "session.toml"),
        "window_config": str(d / "window.toml"),
        "out": str(d / "new.h5"),
        "dir": str(d),
        "zero": str(d / "zero.h5"),
        "truncated": str(d / "truncated.h5"),
        "mp4": str(d / "cut.mp4"),
        "uav9": str(d / "uav9.toml"),
        "no_target": str(d / "no_target.toml"),
        "latin1_config": str(d / "latin1.toml"),
        "same_pairs": str(d / "same.csv"),
        "line_pairs": str(d / "line.csv"),
        "latin1_pairs": str(d / "latin1.csv"),
        "raw": str(d / "raw.bin"),
    }


@pytest.mark.parametrize(
    ("argv", "code", "says"), CASES, ids=lambda v: " ".join(v)[:60] if isinstance(v, list) else None
)
def test_refused_with_one_line_naming_the_option_and_value(
    argv, code, says, paths, capfd, record_property
):
    # capfd, not capsys: a C library's own line (FFmpeg's, HDF5's) goes to file descriptor 2
    argv = [a.format(**paths) for a in argv]
    says = says.format(**paths)
    try:
        got = main(argv)
    except SystemExit as exc:  # argparse's own refusal
        got = exc.code
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    # the whole answer, for comparing two runs (--junitxml): idle and under load
    record_property("answer", f"exit {got}: {err.strip()}")
    assert got == code, err
    assert len(lines) == 1 and lines[0].startswith(f"snrmon {argv[0]}"), err
    assert ": error: " in lines[0] and says in lines[0], lines[0]
    assert out == ""
    assert not Path(paths["out"]).exists() and not Path(paths["dir"], "r.pdf").exists()


@pytest.mark.parametrize("layout", TIFF_LAYOUTS)
def test_a_3d_tiff_reads_as_its_frames_in_every_layout(layout, paths, capfd):
    assert main(["noise", paths[f"tif_{layout}"], "--json"]) == 0
    out, err = capfd.readouterr()
    assert json.loads(out)["frames"] == 6 and err == ""
    np.testing.assert_array_equal(snrmon.load_stack(paths[f"tif_{layout}"]).values, TIFF_FRAMES)


@pytest.mark.parametrize(("layout", "frames", "why"), CUT_TIFFS)
def test_a_cut_tiff_reads_to_the_frame_it_breaks_at_with_one_warning(
    layout, frames, why, paths, capfd, record_property
):
    path = paths[f"tif_{layout}_cut"]
    why = why.format(size=Path(path).stat().st_size)
    assert main(["noise", path, "--json"]) == 0
    out, err = capfd.readouterr()
    record_property("answer", f"exit 0: {err.strip()} {json.loads(out)['frames']} frames")
    assert json.loads(out)["frames"] == frames
    lines = err.splitlines()
    start = f"snrmon noise: warning: {path}: the file is cut short in frame {frames} ({why}"
    assert len(lines) == 1 and lines[0].startswith(start), err
    assert lines[0].endswith(f"): read its {frames} whole frames"), err
    np.testing.assert_array_equal(snrmon.load_stack(path).values, TIFF_FRAMES[:frames])


def test_an_all_nan_stack_has_no_noise_figure_not_zero(tmp_path, capsys):
    stack = tmp_path / "nan.tif"
    tifffile.imwrite(stack, np.full((4, 8, 8), np.nan, np.float32), photometric="minisblack")
    assert main(["noise", str(stack), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["frames"] == 4 and got["mean_dn"] is None
    for key in ("sigma_dn", "sigma_corrected_dn"):
        assert set(got[key].values()) == {None}, got[key]
    assert all(pair == [None, None] for pair in got["ci95_dn"].values()), got["ci95_dn"]
    assert main(["noise", str(stack)]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert "mean n/a DN" in rows[0]
    tvh = next(r for r in rows if r.split()[0] == "tvh").split()
    assert tvh[1:6] == ["n/a", "n/a", "n/a", "-", "n/a"], tvh


# The numeric options and their documented ranges, independent of the types that check them:
# (the command line before the option, the option, lowest, highest, lowest excluded, integer).
RANGES = [
    (MODEL_SNR, "--ranges", 1.0, 100_000.0, True, False),
    (["hil"], "--stops", 0.0, 5000.0, True, False),
    (["hil"], "--seed", 0, 2**31 - 1, False, True),
    (["hil"], "--hover-s", 0.0, 3600.0, True, False),
    (["demo"], "--seed", 0, 2**31 - 1, False, True),
    (["record", "--config", "c.toml", "--out", "s.h5"], "--duration", 0.0, 2678400.0, True, False),
    (["listen", "gps", "--port", "/dev/null"], "--timeout", 0.0, 2678400.0, True, False),
    (["measure", "s.npy", "--at", "1,1"], "--window-frames", 1, 100_000, False, True),
]
PARSER = build_parser()


def _parsed(argv: list[str]) -> tuple[int, str, object]:
    """(exit code, stderr, namespace or None) of parsing ``argv`` (the parser only: no work)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            args, extra = PARSER.parse_known_args(argv)
        except SystemExit as exc:
            return int(exc.code or 0), err.getvalue(), None
    assert not extra
    return 0, err.getvalue(), args


numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**15), max_value=10**15),
    st.floats(min_value=-10.0, max_value=10.0),
)


@pytest.mark.parametrize(("before", "option", "lo", "hi", "above", "integer"), RANGES)
@settings(max_examples=60, deadline=None)
@given(value=numbers)
def test_numeric_options_take_their_range_and_refuse_the_rest(
    before, option, lo, hi, above, integer, value
):
    text = repr(value) if isinstance(value, float) else str(value)
    code, err, args = _parsed([*before, option, text])
    number = float(value)
    inside = (lo < number if above else lo <= number) and number <= hi
    if integer:
        inside = inside and isinstance(value, int)
    if math.isfinite(number) and inside:
        assert code == 0, err
        got = getattr(args, option.lstrip("-").replace("-", "_"))
        got = got[0] if isinstance(got, tuple) else got
        assert got == (int(text) if integer else float(text))
    else:
        line = err.strip().splitlines()
        assert code == 2 and len(line) == 1, err
        assert f"argument {option}: " in line[0] and repr(text) in line[0], line[0]
