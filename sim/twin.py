"""The digital twin of one of the paper's cameras on the collection day: its own optics
(:mod:`snrmon.sim.optics`), the drone's outline (:mod:`snrmon.sim.silhouette`), its own
radiometry (:mod:`snrmon.sim.radiometry`), and the scenario's sky and air as two temperatures.

Owns :class:`Scenario` (every input of the simulated day that the console must not be told:
the apparent sky temperature, the air temperature along the path, the twin's aberration),
:func:`twin_scene_config`, the :class:`snrmon.sim.scene.SceneConfig` of one camera, and
:func:`blackbody_scene` (the same camera looking into a calibration blackbody):

* the sky: a blackbody at the sky's apparent temperature filling the pixel's view, plus the
  camera's pedestal (lens, cold shield, dark current), in the twin's photon chain;
* the noise: Poisson in the pixel's charge plus the read noise (the bolometer: its NETD);
* the drone: its light through the air, tau L_t + path - L_sky, integrated over the band on the
  atmosphere data's own grid (``model.atmosphere.line_of_sight``: the tables the model reads,
  not its band integrals), over the outline's area, tabulated against range;
* its light on the pixels: the outline convolved with the twin's pixel response, NOT a model
  PSF: the model may assume diffraction-limited optics, a 0.082 PVF or anything else, and the
  measurement has to find out.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass

import numpy as np

from snrmon.model.atmosphere_table import Weather
from snrmon.sim.optics import TWIN_ABERRATION_PX, TwinSpread, twin_optics
from snrmon.sim.radiometry import TwinCamera
from snrmon.sim.scene import SceneConfig, TargetSignal
from snrmon.sim.silhouette import silhouette_for

DEFAULT_SKY_TEMP_K = 280.0
"""The simulated clear sky's apparent temperature: a cold clear sky (the paper's LWIR sky read
29.5-33.5 C in a cloud gap; a scenario sets its own)."""
DEFAULT_AIR_TEMP_K = 288.15
"""The air along the path (US Standard 1976 sea level, the model's own default)."""
SIGNAL_RANGES_M = tuple(float(r) for r in np.geomspace(5.0, 3000.0, 48))
"""The ranges the drone's contrast is computed at (log-log interpolated between)."""


@dataclass(frozen=True)
class Scenario:
    """The simulated day's inputs that the console must measure or be told (docs/simulation.md).
    ``aberration_px`` maps a camera to its twin's blur (None: :data:`TWIN_ABERRATION_PX`)."""

    sky_temp_k: float = DEFAULT_SKY_TEMP_K
    air_temp_k: float = DEFAULT_AIR_TEMP_K
    aberration_px: tuple[tuple[str, float], ...] | None = None
    weather: Weather | None = (
        None  # the day's met readings: the atmosphere the drone is seen through
    )

    def __post_init__(self) -> None:
        for name in ("sky_temp_k", "air_temp_k"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"scenario {name} must be > 0 K, got {v!r}")

    def blur_px(self, camera: str) -> float:
        table = dict(self.aberration_px or ())
        return float(table.get(camera, TWIN_ABERRATION_PX.get(camera, 0.0)))

    def record(self, cameras: tuple[str, ...]) -> dict:
        """What the session records of the scenario (its [simulation] table)."""
        out = asdict(self)
        out["aberration_px"] = {c: self.blur_px(c) for c in cameras}
        if self.weather is None:
            del out["weather"]
        else:  # TOML has no null
            out["weather"] = {k: v for k, v in self.weather.as_dict().items() if v is not None}
        return out


def _line_of_sight(atmosphere, band_um: tuple[float, float]):
    from snrmon.model.atmosphere import line_of_sight, resolve_atmosphere

    atm = resolve_atmosphere(atmosphere, band_um)
    return lambda range_m: line_of_sight(atm, range_m, band_um)


def twin_scene_config(
    sensor, target, scenario: Scenario, *, atmosphere=None, **overrides
) -> SceneConfig:
    """The twin of ``sensor`` (``model.presets.load_sensor``) watching ``target`` fly against
    the scenario's sky through ``atmosphere`` (as ``model.atmosphere.resolve_atmosphere``
    takes it; None: the scenario's met readings, else the built-in one); any
    :class:`SceneConfig` field may be overridden by keyword."""
    from snrmon.model.atmosphere import band_key

    camera = TwinCamera.from_sensor(sensor)
    t_target = target.temp_k(band_key(sensor.band_um))
    optics = twin_optics(sensor, t_target, scenario.sky_temp_k, scenario.blur_px(sensor.name))
    spread = TwinSpread(optics, silhouette_for(target), target.small_m)
    sky_e = camera.pixel_electrons(scenario.sky_temp_k)
    # the day's met readings are the atmosphere the drone is seen through (None: the built-in)
    path = _line_of_sight(
        atmosphere if atmosphere is not None else scenario.weather, camera.band_um
    )
    area_m2 = float(target.small_m) ** 2  # the outline's area: all of the drone's light
    electrons = []
    for r in SIGNAL_RANGES_M:
        line = dataclasses.replace(path(r), air_temp_k=scenario.air_temp_k)
        electrons.append(camera.contrast_electrons(line, t_target, scenario.sky_temp_k, area_m2))
    config = SceneConfig(
        name=str(sensor.name),
        width_px=int(sensor.width_px),
        height_px=int(sensor.height_px),
        gain_e_per_dn=float(sensor.gain_e_per_dn),
        dn_offset=float(sensor.dn_offset),
        sky_e=sky_e,
        floor_noise_e=camera.floor_noise_e(),
        fill_factor=float(sensor.fill_factor),
        psf_sigma_px=max(0.42 * sensor.f_lambda_over_d, scenario.blur_px(sensor.name)),
        ifov_rad=camera.ifov_rad,
        bit_depth=int(sensor.bit_depth),
        target=TargetSignal(float(target.small_m), SIGNAL_RANGES_M, tuple(electrons)),
        spread=spread,
        poisson_shot_noise=True,
    )
    return dataclasses.replace(config, **overrides) if overrides else config


def blackbody_scene(config: SceneConfig, sensor, temp_k: float) -> SceneConfig:
    """``config`` looking into a uniform blackbody at ``temp_k`` (a calibration capture): the
    twin camera's charge from it, through the same fixed pattern and noise floor."""
    if not temp_k > 0:
        raise ValueError(f"blackbody temperature must be > 0 K, got {temp_k}")
    return dataclasses.replace(
        config, blackbody_e=TwinCamera.from_sensor(sensor).pixel_electrons(temp_k)
    )
