"""``snrmon noise``: the JSON contract on the two real .ptw recordings (against the reference
3D noise written from the definitions in tests/acquisition/measure/test_noise3d.py), frame
spans and regions of stacks and session files, and one-line errors with exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from snrmon.acquisition.measure.noise3d import noise_3d
from snrmon.cli import main
from tests.acquisition.measure.test_noise3d import reference_figures
from tests.acquisition.session_factory import write_session
from tests.helpers import strict_json

DATA = Path(__file__).parent / "data" / "pyradi"
KEYS = ["t", "v", "h", "tv", "th", "vh", "tvh", "total"]


@pytest.mark.parametrize(
    ("name", "shape"),
    [("PyradiSampleMWIR.ptw", (100, 64, 69)), ("PyradiSampleLWIR.ptw", (100, 68, 75))],
)
def test_ptw_json_is_the_contract_and_the_reference(name, shape, capsys):
    from snrmon.acquisition.replay.ptw import load_ptw

    assert main(["noise", str(DATA / name), "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert list(out) == [
        "frames",
        "rows",
        "cols",
        "mean_dn",
        "sigma_dn",
        "sigma_corrected_dn",
        "ci95_dn",
    ]
    assert (out["frames"], out["rows"], out["cols"]) == shape
    for part in ("sigma_dn", "sigma_corrected_dn", "ci95_dn"):
        assert list(out[part]) == KEYS
    stack = np.asarray(load_ptw(DATA / name)[0], float)
    sigma, corrected = reference_figures(stack)
    assert out["mean_dn"] == pytest.approx(stack.mean(), rel=1e-12)
    for k in KEYS:
        assert out["sigma_dn"][k] == pytest.approx(sigma[k], rel=1e-9)
        assert out["sigma_corrected_dn"][k] == pytest.approx(corrected[k], rel=1e-9, abs=1e-12)
        lo, hi = out["ci95_dn"][k]
        assert lo <= out["sigma_corrected_dn"][k] <= hi
    # the readable table names the header's camera
    assert main(["noise", str(DATA / name)]) == 0
    text = capsys.readouterr().out
    assert "camera Jade (50 mm" in text and "tvh" in text


def test_frames_and_region_of_a_stack(capsys):
    from snrmon.acquisition.replay.stack_io import load_stack

    path = DATA / "PyradiSampleLWIR.ptw"
    assert main(["noise", str(path), "--frames", "10:60", "--roi", "5,3,40,30", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    want = noise_3d(load_stack(path)[10:60, 3:31, 5:41])
    assert (out["frames"], out["rows"], out["cols"]) == (50, 28, 36)
    assert out["sigma_corrected_dn"] == dict(want.sigma_corrected)
    assert out["ci95_dn"] == {k: list(v) for k, v in want.ci95.items()}


@pytest.fixture(scope="module")
def session(module_tmp):
    return write_session(module_tmp("noise") / "s.h5", ranges_m=(120.0,))


def test_a_session_cameras_span_of_frames_or_seconds(session, capsys):
    argv = ["noise", str(session.path), "--camera", "lwir", "--roi", "0,0,9,39", "--json"]
    assert main([*argv, "--frames", "20:120"]) == 0
    out = strict_json(capsys.readouterr().out)
    want = noise_3d(session.frames["lwir"][20:120, :, :10])
    assert out["sigma_dn"] == dict(want.sigma)
    # white sky noise only (5 DN, rounded): sigma_tvh is all of it
    assert out["sigma_corrected_dn"]["tvh"] == pytest.approx((25 + 1 / 12) ** 0.5, rel=0.03)
    assert main([*argv, "--seconds", "1:6"]) == 0  # 20 fps: frames 20-119 again
    assert strict_json(capsys.readouterr().out) == out


def test_bad_input_is_one_line_and_exit_2(session, tmp_path, capsys):
    raw = (DATA / "PyradiSampleMWIR.ptw").read_bytes()
    cut = tmp_path / "cut.ptw"
    cut.write_bytes(raw[:500_000])
    foreign = tmp_path / "photo.ptw"
    foreign.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(4000))
    mwir = str(DATA / "PyradiSampleMWIR.ptw")
    cases = [
        ([str(cut)], "cut.ptw: PTW file truncated: 500000 bytes hold 50 whole frames"),
        ([str(foreign)], "photo.ptw: not a Cedip/Altair PTW file"),
        ([mwir, "--frames", "5:3"], "--frames 5:3 is outside the 100 frames"),
        ([mwir, "--frames", "7:8"], "3D noise needs at least 2 frames"),
        ([mwir, "--roi", "0,0,80,3"], "--roi: region (0, 0, 80, 3) leaves the 69x64 image"),
        ([mwir, "--stop", "0"], "--stop needs a session file"),
        ([str(session.path)], "choose one with --camera"),
        ([str(session.path), "--camera", "swir"], "--camera 'swir': the session holds"),
        ([str(session.path), "--camera", "mwir", "--stop", "0"], "records no stops (use --frames)"),
        ([str(tmp_path / "none.ptw")], "none.ptw does not exist"),
    ]
    for argv, message in cases:
        assert main(["noise", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, (argv, err)
