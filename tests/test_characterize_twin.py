"""``snrmon characterize`` on the digital twin's own recording: the drone's
characteristic dimensions and temperature at the 37 m stop, from the session's calibration and
the live track.

The twin renders UAV1 as two crossing bars 6 cm thick (sim/silhouette.py) whose outline's area
is 15.7^2 cm^2 and whose box is 23.8^2 cm^2. Characterize once read the stop through a fixed
window at the operator's click, which at 37 m sat 30 px off the drone (the HIL clicks the GPS
position): it segmented noise (small 13.6 cm +- 4.1 cm, SNR 2.8). It now follows the recorded
track.

The bars are 3.2 MWIR pixels thick at 37 m, so no pixel of the eroded outline is free of the
PSF's mixing with the sky: its mean reads 34.5 C against the 36.7 C rendered. The temperature is
read on the outline's core (the crossing, farthest from the edge): 36.4 C (docs/calibration.md).
"""

from __future__ import annotations

import pytest

from snrmon.cli import main
from snrmon.model.presets import load_target
from tests.helpers import strict_json, twin_recording

UAV1 = load_target("uav1")


@pytest.fixture(scope="module")
def close_stop(tmp_path_factory):
    """``snrmon hil --out`` of the 37 m stop alone (seed 0, a 4 s hover at speed 2, both
    cameras, calibrated)."""
    return twin_recording(tmp_path_factory.mktemp("twin-37m") / "s.h5", stops="37", speed=2)


@pytest.mark.slow
def test_the_twins_drone_dimensions_from_its_close_stop(close_stop, capsys):
    capsys.readouterr()
    argv = [
        "characterize",
        str(close_stop),
        "--camera",
        "mwir",
        "--stop",
        "0",
        "--json",
        "--no-record",
    ]
    assert main(argv) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["range_m"] == pytest.approx(37.0, abs=1.0)
    assert out["n_frames"] >= 50
    assert out["small_m"] == pytest.approx(UAV1.small_m, rel=0.10)
    assert out["large_m"] == pytest.approx(UAV1.large_m, rel=0.10)
    assert out["small_m_std"] < 0.1 * out["small_m"]  # every frame segmented the drone
    assert out["calibration"] is not None
    t_c = UAV1.temp_k("mwir") - 273.15  # 36.7 C, through the air (the session's 15 C)
    assert out["mean_temp_c"] == pytest.approx(t_c, abs=0.5)
    assert out["outline_temp_c"] < t_c - 1.0  # the eroded outline mixes in the sky
