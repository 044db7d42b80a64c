"""The HIL scenario's met readings (snrmon hil --rh --pressure-hpa --visibility-km): the twin's
drone is seen through that air, the session is told the same readings ([weather]) and the model
uses them; a bad reading is one line, exit 2, before any device starts."""

from __future__ import annotations

import pytest

from snrmon.cli import main
from snrmon.model.atmosphere_table import Weather
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.snr import target_contrast_electrons
from snrmon.rig.rig import HilOptions
from snrmon.sim.twin import Scenario, twin_scene_config

UAV1 = load_target("uav1")


def test_the_scenario_weather_reaches_the_twin_and_the_record():
    opts = HilOptions(air_temp_k=298.15, rh_percent=90.0, pressure_hpa=1000.0, visibility_km=10.0)
    want = Weather(air_temp_c=25.0, rh_percent=90.0, pressure_hpa=1000.0, visibility_km=10.0)
    assert opts.weather == want and opts.scenario.weather == want
    record = opts.scenario.record(("mwir",))
    assert record["weather"] == {k: v for k, v in want.as_dict().items() if v is not None}
    # the twin's drone through humid hazy air: the model's signal through the same air
    sensor = load_sensor("mwir")
    humid = twin_scene_config(sensor, UAV1, opts.scenario, width_px=64, height_px=48)
    plain = twin_scene_config(sensor, UAV1, Scenario(air_temp_k=298.15), width_px=64, height_px=48)
    for r in (200.0, 800.0):
        kw = {"background_temp_k": 280.0}
        want_ratio = target_contrast_electrons(
            sensor, UAV1, r, atmosphere=want, **kw
        ) / target_contrast_electrons(sensor, UAV1, r, air_temp_k=298.15, **kw)
        got = humid.target.electrons_at(r) / plain.target.electrons_at(r)
        assert got == pytest.approx(want_ratio, rel=0.01)  # the scene tabulates it in range
        assert got < 0.95


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--rh", "150"], "relative humidity must be 0 to 100 %, got 150"),
        (["--visibility-km", "0.1"], "visibility must be 0.5 to 300 km, got 0.1"),
        (["--pressure-hpa", "2000"], "pressure must be 700 to 1060 hPa, got 2000"),
    ],
)
def test_bad_readings_are_one_line(capsys, argv, needle):
    assert main(["hil", "--stops", "37", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err
