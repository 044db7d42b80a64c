"""Unbounded numbers refused before any work: each case a command line, its exit code and the
one line it must print, and a property test of the numeric options' ranges.

Each of these used to hang, ask for terabytes or fail without naming the option: ``model snr
--ranges 0.0001`` hung and ``--ranges 0.01`` was a MemoryError; ``hil --stops 1e9`` planned
125 000 000 s; ``hil --window 99999x99999`` and ``measure --box 1000001`` were MemoryErrors;
``record --duration inf`` and ``listen --timeout nan`` never ended; a config ``window =
1000000000000`` was a MemoryError; ``hil --seed -1`` did not name the option. The ranges are
``snrmon.inputs``'s shared argparse types.
"""

from __future__ import annotations

import contextlib
import io
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snrmon.cli import build_parser, main

MODEL_SNR = ["model", "snr", "--sensor", "mwir", "--target", "uav1"]
RECORD = ["record", "--config", "{config}", "--out", "{out}"]
LISTEN = ["listen", "gps", "--port", "/dev/null"]
MEASURE = ["measure", "{stack}", "--at", "5,5"]
MONTH_S = "2678400 s"

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
]


@pytest.fixture(scope="module")
def paths(tmp_path_factory) -> dict[str, str]:
    d = tmp_path_factory.mktemp("bad-input-table")
    stack = d / "stack.npy"
    np.save(stack, np.random.default_rng(5).normal(100.0, 2.0, (3, 16, 16)).astype(np.float32))
    camera = '[cameras.mwir]\nsource = "shm"\naddress = "nowhere"\nsensor = "mwir"\n'
    (d / "session.toml").write_text(camera)
    (d / "window.toml").write_text(camera + "[measurement]\nwindow_frames = 1000000000000\n")
    return {
        "stack": str(stack),
        "config": str(d / "session.toml"),
        "window_config": str(d / "window.toml"),
        "out": str(d / "new.h5"),
    }


@pytest.mark.parametrize(
    ("argv", "code", "says"), CASES, ids=lambda v: " ".join(v)[:60] if isinstance(v, list) else None
)
def test_refused_with_one_line_naming_the_option_and_value(argv, code, says, paths, capsys):
    argv = [a.format(**paths) for a in argv]
    try:
        got = main(argv)
    except SystemExit as exc:  # argparse's own refusal
        got = exc.code
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert got == code, err
    assert len(lines) == 1 and lines[0].startswith(f"snrmon {argv[0]}"), err
    assert ": error: " in lines[0] and says in lines[0], lines[0]
    assert out == ""


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
