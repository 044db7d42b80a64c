"""Which model curves the console draws, and from which predictors (no Qt; no number made here).

The console asks; the session's engine builds and owns the model
(:class:`snrmon.acquisition.prediction.ModelRequest`, ``ConsoleSession.set_model``): two
predictors on the same sensors, target and options, which the console only reads:

* ``own`` (the session's ``reference_predictor``): the model's own background temperature (or
  the operator's, from the model options); nothing moves it;
* ``sky`` (the session's ``predictor``: its stop table's model values), whose engine alone
  makes its background follow each camera's measured sky temperature (with a calibration): the
  paper's path-radiance correction (sections 8-9). The console reads the temperature followed
  (``ConsoleSession.model_sky_temp_k``) to label the curves; it never sets one, and a new model
  it asks for takes the followed sky over in the engine.

:meth:`ModelCurves.curves` returns what :class:`snrmon.gui.range_plot.RangePlot` draws: the chosen
curves of ``own`` under their model names, and, where the sky is known, the same curves of
``sky`` labelled ``"<name> @ sky <T> K"``.

The noise in the model (:attr:`ModelOptions.noise`): the model's own, or "measured": each
camera's 3D noise of the background around the target (``CameraStatus.figures.noise_3d``,
bias-corrected sigma_tvh and sigma_vh of the last block of frames) as the model's noise in both
predictors (:func:`measured_noise_now`); the session records it (``model_noise``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from snrmon.acquisition.measure.track_noise import FRAMES_3D
from snrmon.acquisition.prediction import (
    CURVES,
    EXPECTED_CURVES,
    EXPECTED_EXTENT,
    EXPECTED_RIM,
    NOISE_SOURCES,
    PAPER_CURVES,
    MeasuredNoise,
    ModelRequest,
    Predictor,
    Weather,
)
from snrmon.acquisition.protocols import ConsoleSession

CURVE_LABELS = {
    "small": "small dimension, uncorrected",
    "large": "large dimension, uncorrected",
    "small_corrected": "small dimension, corrected",
    "large_corrected": "large dimension, corrected",
    EXPECTED_RIM: "expected Eq. (4), paper's 7x7 rim",
    EXPECTED_EXTENT: "expected Eq. (4), console's target-aware rim",
    "paper_small": "paper's switched small",
    "paper_large": "paper's switched large",
    "paper_small_corrected": "paper's switched small, corrected",
    "paper_large_corrected": "paper's switched large, corrected",
}
ALL_CURVES = (*CURVES, *EXPECTED_CURVES, *PAPER_CURVES)
DEFAULT_SHOWN = (*CURVES, EXPECTED_EXTENT)
SKY_STEP_K = 0.5  # a smaller change of the measured sky does not redraw the curves


@dataclass(frozen=True)
class ModelOptions:
    """The operator's model choices: target preset, curves shown, background temperature, the
    day's met readings (the model's atmosphere; the session records them) and the noise (the
    model's own or the cameras' measured 3D noise; the session records it)."""

    target: str = "uav1"
    shown: tuple[str, ...] = DEFAULT_SHOWN
    background_temp_k: float | None = None  # None: the model's own
    weather: Weather | None = None  # None: the model's default atmosphere
    noise: str = "model"  # NOISE_SOURCES: "model" (Eq. 1 and the spatial term) or "measured"

    def __post_init__(self) -> None:
        unknown = [c for c in self.shown if c not in ALL_CURVES]
        if unknown:
            known = ", ".join(ALL_CURVES)
            raise ValueError(f"unknown model curve {unknown[0]!r} (known: {known})")
        if self.noise not in NOISE_SOURCES:
            known = ", ".join(NOISE_SOURCES)
            raise ValueError(f"the model's noise must be one of {known}, got {self.noise!r}")


def parse_background_temp(text: str) -> float | None:
    """The background temperature field: empty = the model's own (None), else kelvin > 0."""
    text = text.strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise ValueError(
            f"background temperature must be a number of kelvin (or empty), got {text!r}"
        ) from None
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"background temperature must be > 0 K, got {text!r}")
    return value


MET_FIELDS = (
    ("air_temp_c", "air temperature", "C"),
    ("rh_percent", "relative humidity", "%"),
    ("pressure_hpa", "pressure", "hPa"),
    ("visibility_km", "visibility", "km"),
)


def parse_met_readings(texts: dict[str, str], aerosol: str, season: str) -> Weather | None:
    """The met readings as typed (``texts`` by :data:`MET_FIELDS` name; empty = not read): a
    Weather, or None when nothing was read and the season is the default; ValueError naming
    the reading for a bad entry."""
    values: dict[str, float] = {}
    for key, what, unit in MET_FIELDS:
        text = texts.get(key, "").strip()
        if not text:
            continue
        try:
            values[key] = float(text)
        except ValueError:
            raise ValueError(
                f"{what} must be a number of {unit} (or empty), got {text!r}"
            ) from None
    if not values and season == "us_std_1976" and aerosol == Weather().aerosol:
        return None
    return Weather(aerosol=aerosol, season=season, **values)


def sky_label(name: str, temp_k: float) -> str:
    return f"{name} @ sky {temp_k:.1f} K"


def split_sky(name: str) -> tuple[str, str]:
    """``("<curve>", "sky <T> K")`` of a :func:`sky_label`; ``(name, "")`` for the model's own."""
    base, _, sky = name.partition(" @ ")
    return base, sky


def curve_label(name: str) -> str:
    """A model curve's name in words (:data:`CURVE_LABELS`; a name the console does not know
    yet, e.g. a new expected Eq. (4) rule, as it is, underscores as spaces)."""
    return CURVE_LABELS.get(name, name.replace("_", " "))


def is_expected(name: str) -> bool:
    """An expected Eq. (4) reading (whatever its background rule), not one of the curves."""
    return name.startswith("expected")


class ModelCurves:
    """The console's model: the operator's options and the curves drawn from the session's two
    predictors, which the session's engine builds from the request the console makes
    (:meth:`apply`; :class:`snrmon.acquisition.prediction.ModelRequest`): the console asks, it
    never builds or holds a predictor. ``measured_noise``: {camera: MeasuredNoise} the model
    was asked to use in place of its noise (a camera not in it keeps the model's)."""

    def __init__(
        self,
        session: ConsoleSession,
        options: ModelOptions,
        *,
        measured_noise: Mapping[str, MeasuredNoise] | None = None,
    ) -> None:
        self.session = session
        self.sensors = session_sensors(session)
        self.options = options
        self.measured_noise = dict(measured_noise or {})
        self.sky_temp_k: dict[str, float] = {}

    @property
    def own(self) -> Predictor:
        """The model at its own background (or the operator's): the session never moves it."""
        predictor = self.session.reference_predictor
        assert predictor is not None, "the session's model was asked for"
        return predictor

    @property
    def sky(self) -> Predictor:
        """The session's predictor: its engine alone makes its background follow the sky."""
        predictor = self.session.predictor
        assert predictor is not None, "the session's model was asked for"
        return predictor

    def apply(
        self, options: ModelOptions, measured_noise: Mapping[str, MeasuredNoise] | None = None
    ) -> None:
        """Ask the session for the model of ``options`` and ``measured_noise`` (a ValueError
        from the model leaves the current one in place)."""
        noise = dict(measured_noise or {})
        self.session.set_model(model_request(options, noise))
        self.options, self.measured_noise = options, noise

    @property
    def version(self) -> tuple[int, int]:
        """Changes whenever either predictor swapped in new curves (they may be computed in
        the background: a new sky, a PSF measured from the flight)."""
        return (self.own.version, self.sky.version)

    def sky_changed(self, camera: str, temp_k: float | None) -> bool:
        """``temp_k``: the sky temperature ``camera``'s model follows now (the session's,
        ``ConsoleSession.model_sky_temp_k``; None: not following). True when the curves drawn
        for it are out of date (a change over :data:`SKY_STEP_K`)."""
        if temp_k is None or not math.isfinite(temp_k):
            return False
        last = self.sky_temp_k.get(camera)
        if last is not None and abs(temp_k - last) <= SKY_STEP_K:
            return False
        self.sky_temp_k[camera] = temp_k
        return True

    def curves(self, camera: str) -> dict[str, tuple]:
        """The chosen curves of ``camera`` (and their uncertainty bands), own then sky."""
        out: dict[str, tuple] = {}
        sources = [(self.own, None)]
        if camera in self.sky_temp_k:
            sources.append((self.sky, self.sky_temp_k[camera]))
        for predictor, temp in sources:
            data = predictor.curve(camera)
            for name in self.options.shown:
                for key in (name, f"{name} band"):
                    if key in data:
                        out[key if temp is None else sky_label(key, temp)] = data[key]
        return out


def session_sensors(session: ConsoleSession) -> dict[str, str]:
    """{camera: sensor preset} of a Session or ReplayPlayer (its config names them)."""
    return {c.name: c.sensor for c in session.config.cameras}


def model_request(
    options: ModelOptions, measured_noise: Mapping[str, MeasuredNoise] | None = None
) -> ModelRequest:
    """What the console asks the session's engine to build for ``options`` and
    ``measured_noise`` (the curves shown are the console's own choice, not the model's)."""
    return ModelRequest(
        options.target,
        background_temp_k=options.background_temp_k,
        weather=options.weather,
        measured_noise=tuple(sorted((measured_noise or {}).items())),
    )


def model_for_session(session: ConsoleSession) -> ModelCurves | None:
    """The console's model on ``session``'s predictor (the one the session started with, from
    its config), the session asked for the reference at the model's own background beside it;
    None when the session has no predictor to follow."""
    if session.predictor is None:
        return None
    options = default_options(session)
    model = ModelCurves(session, options, measured_noise=session.measured_noise)
    if session.reference_predictor is None:
        session.set_model(model_request(options, session.measured_noise), reference_only=True)
    return model


def default_options(session: ConsoleSession) -> ModelOptions:
    weather = session.met_readings or session.config.weather
    noise = "measured" if session.measured_noise else "model"
    return ModelOptions(target=str(session.config.target), weather=weather, noise=noise)


def measured_noise_now(
    session: ConsoleSession, options: ModelOptions
) -> tuple[dict[str, MeasuredNoise], dict[str, str]]:
    """(the measured noise ``options`` asks for, per camera: with "measured", each camera's
    latest 3D noise of the background around the target, its bias-corrected sigma_tvh and
    sigma_vh; why each camera without a usable one keeps the model's noise). Both empty for
    "model"."""
    if options.noise != "measured":
        return {}, {}
    cameras = session.status().cameras
    noise: dict[str, MeasuredNoise] = {}
    kept: dict[str, str] = {}
    for camera in session_sensors(session):
        status = cameras.get(camera)
        region = status.figures.noise_3d if status is not None else None
        if region is None:
            kept[camera] = f"no 3D noise yet ({FRAMES_3D} frames of background)"
            continue
        sigma = region.noise.sigma_corrected
        try:
            noise[camera] = MeasuredNoise(
                temporal_dn=float(sigma["tvh"]), spatial_dn=float(sigma["vh"])
            )
        except ValueError as exc:  # e.g. 0 DN: a flat region (a saturated or dead band)
            kept[camera] = str(exc)
    return noise, kept


def applied_model(
    model: ModelCurves | None,
    session: ConsoleSession,
    options: ModelOptions,
    measured_noise: Mapping[str, MeasuredNoise] | None = None,
) -> ModelCurves:
    """``model`` (a new one when None) for ``options`` and ``measured_noise`` ({camera:
    MeasuredNoise}, from :func:`measured_noise_now`; a camera not in it keeps the model's
    noise), the session asked to build it; a ValueError (nothing changed) for options the
    model refuses."""
    noise = dict(measured_noise or {})
    if model is None:
        if not session_sensors(session):
            raise ValueError("the session names no camera sensor presets: no model to build")
        model = ModelCurves(session, options, measured_noise=noise)
    model.apply(options, noise)
    if options.weather is not None and options.weather != session.met_readings:
        session.set_met_readings(options.weather)  # a live session records them
    for camera in model.sensors:
        if noise.get(camera) != session.measured_noise.get(camera):
            session.set_measured_noise(camera, noise.get(camera))  # recorded, likewise
    return model


def describe(options: ModelOptions) -> str:
    bg = options.background_temp_k
    background = "the model's own" if bg is None else f"{bg:g} K"
    air = "default atmosphere" if options.weather is None else options.weather.describe()
    noise = "the model's own" if options.noise == "model" else "measured (3D noise)"
    return (
        f"target {options.target}, background {background}, air {air}, noise {noise}, curves "
        f"{', '.join(options.shown)}"
    )


def describe_noise(noise: Mapping[str, MeasuredNoise], kept: Mapping[str, str]) -> str:
    """What the model's noise is per camera after a "measured" choice: the figures used, and
    why a camera keeps the model's noise (named)."""
    parts = [
        f"{camera}: noise sigma_tvh {n.temporal_dn:.3g} DN, sigma_vh {n.spatial_dn:.3g} DN"
        for camera, n in noise.items()
    ]
    parts += [f"{camera}: {why}: the model's noise kept" for camera, why in kept.items()]
    return "; ".join(parts)
