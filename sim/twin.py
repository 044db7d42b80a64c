"""The digital twin of one of the paper's cameras on the collection day: its own optics
(:mod:`snrmon.sim.optics`), the drone's outline (:mod:`snrmon.sim.silhouette`), and the scenario's
sky and air as two temperatures.

Owns :class:`Scenario` (every input of the simulated day that the console must not be told:
the apparent sky temperature, the air temperature along the path, the twin's aberration) and
:func:`twin_scene_config`, the :class:`snrmon.sim.scene.SceneConfig` of one camera:

* the sky: the model's detector chain (``model.detector.background_electrons``) at the sky
  temperature, what a calibrated camera measures as the background;
* the drone: its contrast through the air, tau (L_t - L_air) + (L_air - L_sky) over the
  outline's area (``model.contrast``, Planck and the band's response; sim may use the model's
  physics constants) with the contrast-weighted transmission of the built-in atmosphere;
* its light on the pixels: the outline convolved with the twin's pixel response, NOT a model
  PSF: the model may assume diffraction-limited optics, a 0.082 PVF or anything else, and the
  measurement has to find out.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from snrmon.model.atmosphere_table import Weather
from snrmon.sim.from_model import DEFAULT_SKY_TEMP_K, scene_config_from_model
from snrmon.sim.optics import TWIN_ABERRATION_PX, TwinSpread, twin_optics
from snrmon.sim.scene import SceneConfig
from snrmon.sim.silhouette import silhouette_for

DEFAULT_AIR_TEMP_K = 288.15
"""The air along the path (US Standard 1976 sea level, the model's own default)."""


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


def twin_scene_config(sensor, target, scenario: Scenario, **overrides) -> SceneConfig:
    """The twin of ``sensor`` (``model.presets.load_sensor``) watching ``target`` fly against
    the scenario's sky; any :class:`SceneConfig` field may be overridden by keyword."""
    from snrmon.model.atmosphere import band_key

    t_target = target.temp_k(band_key(sensor.band_um))
    optics = twin_optics(sensor, t_target, scenario.sky_temp_k, scenario.blur_px(sensor.name))
    spread = TwinSpread(optics, silhouette_for(target), target.small_m)
    return scene_config_from_model(
        sensor,
        target,
        size="small",  # the outline's area is small^2: all of the drone's light
        sky_temp_k=scenario.sky_temp_k,
        air_temp_k=scenario.air_temp_k,
        **({} if scenario.weather is None else {"atmosphere": scenario.weather}),
        psf_sigma_px=max(0.42 * sensor.f_lambda_over_d, scenario.blur_px(sensor.name)),
        spread=spread,
        **overrides,
    )
