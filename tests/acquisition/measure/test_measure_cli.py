"""``snrmon measure``: the JSON contract, the table, and one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.measure.stack_snr import measure_stack
from snrmon.cli import main
from tests.helpers import strict_json

FRAME_KEYS = ["index", "peak_x", "peak_y", "peak", "bg_mean", "bg_std", "snr", "flags"]


@pytest.fixture
def stack_path(tmp_path):
    rng = np.random.default_rng(4)
    stack = np.rint(rng.normal(1000.0, 6.6, (12, 40, 50))).astype(np.uint16)
    stack[:, 20, 25] += 70
    stack[3, 20, 25] = 65535  # one saturated frame
    path = tmp_path / "stack.npy"
    np.save(path, stack)
    return path, stack


def test_json_follows_the_contract(stack_path, capsys):
    path, stack = stack_path
    assert main(["measure", str(path), "--at", "26,19", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert list(out) == ["n", "snr_mean", "snr_std", "frames"]
    assert out["n"] == 12 and len(out["frames"]) == 12
    expected = measure_stack(stack, (26, 19)).to_list()
    for i, (frame, r) in enumerate(zip(out["frames"], expected, strict=True)):
        assert list(frame) == FRAME_KEYS
        assert frame["index"] == i
        assert isinstance(frame["peak_x"], int) and isinstance(frame["peak_y"], int)
        assert (frame["peak_x"], frame["peak_y"]) == (25, 20)
        assert all(isinstance(frame[k], float) for k in ("peak", "bg_mean", "bg_std", "snr"))
        assert frame["snr"] == r.snr
        assert frame["flags"] == (["saturated"] if i == 3 else [])
    snrs = [f["snr"] for f in out["frames"]]
    assert out["snr_mean"] == pytest.approx(np.mean(snrs), rel=1e-12)
    assert out["snr_std"] == pytest.approx(np.std(snrs, ddof=1), rel=1e-12)


def test_undefined_snr_is_null_in_json(tmp_path, capsys):
    stack = np.full((2, 20, 20), 100, dtype=np.uint16)
    np.save(tmp_path / "flat.npy", stack)
    assert main(["measure", str(tmp_path / "flat.npy"), "--at", "10,10", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["snr_mean"] is None and out["frames"][0]["snr"] is None
    assert out["frames"][0]["flags"] == ["undefined"]


def test_table_and_options(stack_path, capsys):
    path, _ = stack_path
    args = ["measure", str(path), "--at", "26,19", "--background", "2,2,15,12", "--detrend"]
    assert main([*args, "--window-frames", "5", "--search", "5", "--box", "5"]) == 0
    out = capsys.readouterr().out
    assert "running, last 5 valid of window 5" in out and "saturated" in out
    assert len(out.strip().splitlines()) == 1 + 12 + 2


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["{missing}", "--at", "1,1"], "does not exist"),
        (["{bad}", "--at", "1,1"], "expected a stack (N,H,W) or a frame (H,W), got shape"),
        (["{good}", "--at", "50,3"], "--at 50,3 is off the 50x40 image"),
        (["{good}", "--at", "3,-1"], "--at 3,-1 is off the 50x40 image"),
        (["{good}", "--at", "3,3", "--background", "0,0,60,3"], "leaves the 50x40 image"),
    ],
)
def test_bad_input_is_one_line_on_stderr(tmp_path, stack_path, capsys, argv, message):
    np.save(tmp_path / "bad.npy", np.zeros((2, 2, 2, 2)))
    paths = {
        "missing": str(tmp_path / "missing.npy"),
        "bad": str(tmp_path / "bad.npy"),
        "good": str(stack_path[0]),
    }
    argv = [a.format(**paths) for a in argv]
    assert main(["measure", *argv]) != 0
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in captured.err
    assert captured.out == ""


def test_even_box_is_refused_by_the_parser(stack_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["measure", str(stack_path[0]), "--at", "3,3", "--box", "6"])
    assert exc.value.code != 0
    assert "argument --box: must be an odd integer from 1 to 8191 px, got '6' (even)" in (
        capsys.readouterr().err
    )
