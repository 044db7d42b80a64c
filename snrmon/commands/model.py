"""``snrmon model``: the sensor model from the command line (paper Eqs. 1-3, sections 8-9).

Subcommands and their ``--json`` contracts (stdout):

* ``snr --sensor S --target T --ranges R1,R2,... [--atmosphere default|none|TAU|FILE]
  [--air-temp-c T] [--rh RH | --dew-point-c TD] [--pressure-hpa P] [--visibility-km V]
  [--aerosol rural|maritime|urban|none] [--season NAME] [--sky-temp-c T]
  [--spatial-noise E|Kx|none|low|medium|high]`` -> a list, one object per range: ``{"range_m",
  "resolved_small", "resolved_large", "snr_small", "snr_large", "snr_small_corrected",
  "snr_large_corrected", "signal_e": {curve: e}, "noise_e": {"background", "lens", "dark",
  "read", "temporal", "spatial"}, "transmission" (flat band average), "transmission_contrast"
  (weighted by a near-ambient target's contrast), "air_temp_k", "sky_temp_k",
  "sky_assumed_equal_to_air" (no --sky-temp-c: the sky taken as the air, the band widened by an
  8 K sky error), "pvf": {curve: average PVF or null where resolved}, "uncertainty": {corrected
  curve: [lower, upper]}}``; curves are small, large, small_corrected, large_corrected. The met
  readings drive the built-in LOWTRAN7 atmosphere (``model/atmosphere_table.py``); those not
  given are the season's standard atmosphere at sea level (US Standard 1976 by default).
* ``pvf --psf airy|gaussian|airy+gaussian ...`` -> ``{"average_pvf", "ensquared_energy"}``.
* ``radiance --band L1,L2 --temp-k T`` -> ``{"radiance_w_m2_sr", "photon_radiance",
  "d_radiance_dt", "d_photon_radiance_dt"}`` (SI, per steradian; photons s^-1 m^-2 sr^-1).
* ``netd --sensor S`` -> ``{"netd_mk", "temporal_noise_e", "temporal_noise_dn"}`` (noise against
  a 290 K sky unless ``--sky-temp-c``; NETD at the sensor's 300 K reference).
* ``plot --sensor S --target T -o FILE.png`` -> the four curves with the Fig. 12 band
  (``{"file"}`` with ``--json``).
"""

from __future__ import annotations

import argparse
import math

from snrmon.cli import UsageError
from snrmon.inputs import Number, NumberList, output_file
from snrmon.limits import FOOTPRINT_CHOICES
from snrmon.output import emit_json

NOISE_REFERENCE_SKY_K = 290.0
# the names of model/atmosphere_table.py (not imported here: the parser is built on every run)
SEASON_CHOICES = (
    "us_std_1976",
    "tropical",
    "midlat_summer",
    "midlat_winter",
    "subarctic_summer",
    "subarctic_winter",
)
AEROSOL_CHOICES = ("rural", "maritime", "urban", "none")


def _floats(text: str, what: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise UsageError(f"{what} must be comma-separated numbers, got {text!r}") from None
    if not values or any(not math.isfinite(v) for v in values):
        raise UsageError(f"{what} must be comma-separated finite numbers, got {text!r}")
    return values


def _band(text: str) -> tuple[float, float]:
    v = _floats(text, "--band")
    if len(v) != 2 or not 0 < v[0] < v[1]:
        raise UsageError(f"--band must be L1,L2 in um with 0 < L1 < L2, got {text!r}")
    return v[0], v[1]


def _bg_k(args) -> float | None:
    from snrmon.model.constants import ZERO_C_K

    if args.background_temp_c is None:
        return None
    t = args.background_temp_c + ZERO_C_K
    if not t > 0:
        raise UsageError(f"--sky-temp-c must be above -273.15, got {args.background_temp_c}")
    return t


MET_OPTIONS = (
    ("rh", "--rh", "rh_percent"),
    ("dew_point_c", "--dew-point-c", "dew_point_c"),
    ("pressure_hpa", "--pressure-hpa", "pressure_hpa"),
    ("visibility_km", "--visibility-km", "visibility_km"),
    ("aerosol", "--aerosol", "aerosol"),
    ("season", "--season", "season"),
)


def _weather(args):
    """The met readings given on the command line as a Weather (None: none given)."""
    from snrmon.model.atmosphere_table import Weather

    given = {field: getattr(args, dest) for dest, _, field in MET_OPTIONS}
    given = {k: v for k, v in given.items() if v is not None}
    if args.air_temp_c is not None:
        given["air_temp_c"] = args.air_temp_c
    if not given:
        return None
    return Weather(**given)


def _air_k(args) -> float | None:
    """--air-temp-c with a non-built-in atmosphere: the path temperature only."""
    from snrmon.model.constants import ZERO_C_K

    if args.air_temp_c is None or args.atmosphere == "default":
        return None
    t = args.air_temp_c + ZERO_C_K
    if not t > 0:
        raise UsageError(f"--air-temp-c must be above {-ZERO_C_K}, got {args.air_temp_c}")
    return t


def _atmosphere(args, sensor):
    from snrmon.model.atmosphere import resolve_atmosphere
    from snrmon.model.presets import load_atmosphere

    spec = args.atmosphere
    if spec != "default":
        for dest, flag, _ in MET_OPTIONS:
            if getattr(args, dest) is not None:
                raise UsageError(
                    f"{flag} sets the built-in LOWTRAN7 atmosphere; it has no meaning with "
                    f"--atmosphere {spec} (give the air along the path with --air-temp-c)"
                )
    else:
        return resolve_atmosphere(_weather(args), sensor.band_um)
    if spec == "none":
        return resolve_atmosphere(spec, sensor.band_um)
    try:
        return resolve_atmosphere(float(spec), sensor.band_um)
    except ValueError as exc:
        if "transmission" in str(exc):
            raise
    return load_atmosphere(spec, sensor.band_um, args.atmosphere_path_m)


def _emit(args, obj, table: str) -> int:
    if args.json:
        return emit_json(obj)
    print(table)
    return 0


def _add_common(p: argparse.ArgumentParser, target: bool = True) -> None:
    p.add_argument("--sensor", required=True, metavar="mwir|lwir|FILE", help="sensor preset")
    if target:
        p.add_argument("--target", required=True, metavar="uav1|uav2|FILE", help="target preset")
        add_footprint_option(p)
        p.add_argument(
            "--atmosphere",
            default="default",
            metavar="default|none|TAU|FILE",
            help="built-in LOWTRAN7 table for the met readings below, none, a constant "
            "transmission, or a TOML/tape7/CSV file (default: %(default)s)",
        )
        p.add_argument(
            "--air-temp-c", type=float, default=None, metavar="T", help="air temperature, C"
        )
        hum = p.add_mutually_exclusive_group()
        hum.add_argument(
            "--rh", type=float, default=None, metavar="PCT", help="relative humidity, %%"
        )
        hum.add_argument(
            "--dew-point-c", type=float, default=None, metavar="TD", help="dew point, C"
        )
        p.add_argument(
            "--pressure-hpa", type=float, default=None, metavar="P", help="air pressure, hPa"
        )
        p.add_argument(
            "--visibility-km",
            type=float,
            default=None,
            metavar="V",
            help="meteorological visibility, km (default: 23, LOWTRAN7's clear rural day)",
        )
        p.add_argument(
            "--aerosol",
            default=None,
            choices=AEROSOL_CHOICES,
            metavar="|".join(AEROSOL_CHOICES),
            help="LOWTRAN7 aerosol model at the visibility, or none: no aerosol (rural)",
        )
        p.add_argument(
            "--season",
            default=None,
            choices=SEASON_CHOICES,
            metavar="|".join(SEASON_CHOICES),
            help="standard atmosphere whose sea-level air stands in for readings not given "
            "(us_std_1976)",
        )
        p.add_argument(
            "--atmosphere-path-m",
            type=float,
            default=None,
            metavar="M",
            help="path length of a tape7/CSV spectrum",
        )
        p.add_argument(
            "--spatial-noise",
            default=None,
            metavar="E|Kx|CLUTTER",
            help="spatial noise: electrons, K x temporal, or a clutter category "
            "none/low/medium/high",
        )
    p.add_argument(
        "--sky-temp-c",
        dest="background_temp_c",
        type=float,
        default=None,
        metavar="T",
        help="measured background (sky) temperature, C (none: assumed equal to the air, "
        "with an 8 K uncertainty in the band)",
    )
    p.add_argument("--json", action="store_true", help="JSON on stdout")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "model",
        help="the sensor model: SNR vs range, PVF, radiance, NETD, plots",
        description=__doc__.split("\n\n")[0],
    )
    msub = p.add_subparsers(dest="model_command", metavar="SUBCOMMAND", required=True)

    _register_snr(msub)
    _register_pvf(msub)
    _register_radiance(msub)
    _register_netd(msub)
    _register_plot(msub)


def _register_snr(msub: argparse._SubParsersAction) -> None:
    """``model snr``."""
    s = msub.add_parser("snr", help="the four SNR curves at given ranges (Eqs. 1-3)")
    _add_common(s)
    s.add_argument(
        "--ranges",
        type=NumberList(Number(1.0, 100_000.0, above=True, unit="m"), 10_000),
        default="37,126,199,336,393,451,508",
        metavar="R,...",
        help="slant ranges in metres (default: the paper's stops, %(default)s)",
    )
    s.set_defaults(func=run_snr)


def _register_pvf(msub: argparse._SubParsersAction) -> None:
    """``model pvf``."""
    v = msub.add_parser("pvf", help="average PVF and ensquared energy of a PSF")
    v.add_argument(
        "--psf",
        required=True,
        choices=("airy", "gaussian", "airy+gaussian"),
        metavar="airy|gaussian|airy+gaussian",
        help="diffraction (Airy), Gaussian blur, or both convolved",
    )
    v.add_argument(
        "--f-number", type=float, default=None, metavar="N", help="optics f-number (Airy)"
    )
    v.add_argument(
        "--pitch-um", type=float, default=None, metavar="UM", help="detector pitch in um (Airy)"
    )
    g = v.add_mutually_exclusive_group()
    g.add_argument(
        "--wavelength-um",
        type=float,
        default=None,
        metavar="UM",
        help="one wavelength in um (monochromatic Airy)",
    )
    g.add_argument(
        "--band",
        type=str,
        default=None,
        metavar="L1,L2",
        help="band in um (polychromatic Airy over the band)",
    )
    v.add_argument(
        "--sigma-px", type=float, default=None, metavar="PX", help="Gaussian sigma in pixels"
    )
    v.add_argument(
        "--fill-factor",
        type=float,
        default=1.0,
        metavar="F",
        help="area fill factor (default: %(default)s)",
    )
    v.add_argument(
        "--target-size-px",
        type=float,
        default=0.0,
        metavar="D",
        help="Gaussian target of sigma D/2 convolved with the PSF (default: %(default)s)",
    )
    v.add_argument("--json", action="store_true", help="JSON on stdout")
    v.set_defaults(func=run_pvf)


def _register_radiance(msub: argparse._SubParsersAction) -> None:
    """``model radiance``."""
    r = msub.add_parser("radiance", help="blackbody band radiance and its derivative")
    r.add_argument("--band", required=True, metavar="L1,L2", help="band in um")
    r.add_argument(
        "--temp-k", required=True, type=float, metavar="K", help="blackbody temperature in K"
    )
    r.add_argument("--json", action="store_true", help="JSON on stdout")
    r.set_defaults(func=run_radiance)


def _register_netd(msub: argparse._SubParsersAction) -> None:
    """``model netd``."""
    n = msub.add_parser("netd", help="the model's NETD and temporal noise of a sensor")
    _add_common(n, target=False)
    n.set_defaults(func=run_netd)


def _register_plot(msub: argparse._SubParsersAction) -> None:
    """``model plot``."""
    pl = msub.add_parser("plot", help="SNR vs range figure like Figs. 7-10")
    _add_common(pl)
    pl.add_argument(
        "--max-range-m",
        type=Number(10.0, 100_000.0, above=True, unit="m"),
        default=600.0,
        metavar="M",
        help="last range plotted, metres (default: %(default)s)",
    )
    pl.add_argument(
        "-o",
        "--out",
        required=True,
        metavar="PATH",
        help="figure to write (.png, .pdf or .svg)",
    )
    pl.set_defaults(func=run_plot)


def add_footprint_option(p: argparse.ArgumentParser) -> None:
    """``--footprint``: the model's small target, the paper's square or the target file's
    outline (shared with ``snrmon hil``)."""
    p.add_argument(
        "--footprint",
        default="square",
        choices=FOOTPRINT_CHOICES,
        metavar="|".join(FOOTPRINT_CHOICES),
        help="the small target's footprint: the paper's square of the small dimension, or the "
        "outline a close stop measured (a target file from snrmon characterize --target-out), "
        "scaled by range (default: %(default)s)",
    )


def check_footprint(footprint: str, target) -> None:
    """A usage error when ``--footprint outline`` is asked of a target without an outline."""
    if footprint == "outline" and target.outline is None:
        raise UsageError(
            f"--footprint outline needs a target with an outline; {target.name!r} has none "
            "(snrmon characterize --target-out writes one from a close stop)"
        )


def _load(args):
    from snrmon.model.presets import load_sensor, load_target

    sensor = load_sensor(args.sensor)
    target = load_target(args.target) if getattr(args, "target", None) else None
    if target is not None:
        check_footprint(args.footprint, target)
    return sensor, target


def run_snr(args) -> int:
    from snrmon.model.snr import predict

    sensor, target = _load(args)
    pred = predict(
        sensor,
        target,
        list(args.ranges),
        atmosphere=_atmosphere(args, sensor),
        background_temp_k=_bg_k(args),
        air_temp_k=_air_k(args),
        spatial_noise=args.spatial_noise,
        footprint=args.footprint,
    )
    records = pred.to_records()
    head = f"{'range_m':>8} {'res_s':>5} {'res_l':>5} {'small':>9} {'large':>9} {'small_c':>9} "
    head += f"{'large_c':>9} {'tau':>6} {'tau_c':>6}"
    sky = (
        f"sky assumed equal to the air {pred.air_temp_k:.2f} K (+-8 K in the band)"
        if pred.sky_assumed
        else f"sky {pred.background_temp_k:.2f} K, air {pred.air_temp_k:.2f} K"
    )
    title = (
        f"{sensor.name} / {target.name}, atmosphere {pred.atmosphere_name}; {sky}; temporal "
        f"noise {pred.noise.temporal:.4g} e-"
    )
    lines = [title, head]
    for rec in records:
        lines.append(
            f"{rec['range_m']:8.1f} {rec['resolved_small']!s:>5} {rec['resolved_large']!s:>5} "
            f"{rec['snr_small']:9.3f} {rec['snr_large']:9.3f} {rec['snr_small_corrected']:9.3f} "
            f"{rec['snr_large_corrected']:9.3f} {rec['transmission']:6.3f} "
            f"{rec['transmission_contrast']:6.3f}"
        )
    return _emit(args, records, "\n".join(lines))


def run_pvf(args) -> int:
    from snrmon.model.psf import AiryGaussianPsf, AiryPsf, GaussianPsf
    from snrmon.model.pvf import average_pvf, ensquared_energy

    airy = None
    if args.psf in ("airy", "airy+gaussian"):
        if args.f_number is None or args.pitch_um is None:
            raise UsageError(f"--psf {args.psf} needs --f-number and --pitch-um")
        if args.wavelength_um is not None:
            airy = AiryPsf.monochromatic(args.f_number, args.pitch_um, args.wavelength_um)
        elif args.band is not None:
            airy = AiryPsf.polychromatic(args.f_number, args.pitch_um, _band(args.band))
        else:
            raise UsageError(f"--psf {args.psf} needs --wavelength-um or --band")
    if args.psf in ("gaussian", "airy+gaussian") and args.sigma_px is None:
        raise UsageError(f"--psf {args.psf} needs --sigma-px")
    if args.psf == "airy":
        psf = airy
    elif args.psf == "gaussian":
        psf = GaussianPsf(args.sigma_px)
    else:
        psf = AiryGaussianPsf(airy, args.sigma_px)
    if args.target_size_px < 0:
        raise UsageError(f"--target-size-px must be >= 0, got {args.target_size_px}")
    st = 0.5 * args.target_size_px
    out = {
        "average_pvf": average_pvf(psf, args.fill_factor, st),
        "ensquared_energy": ensquared_energy(psf, args.fill_factor, st),
    }
    return _emit(args, out, "\n".join(f"{k}: {v:.6f}" for k, v in out.items()))


def run_radiance(args) -> int:
    from snrmon.model import radiometry as rad

    band = _band(args.band)
    if not (args.temp_k > 0 and math.isfinite(args.temp_k)):
        raise UsageError(f"--temp-k must be > 0, got {args.temp_k}")
    out = {
        "radiance_w_m2_sr": rad.band_radiance(band, args.temp_k),
        "photon_radiance": rad.band_photon_radiance(band, args.temp_k),
        "d_radiance_dt": rad.band_radiance_dt(band, args.temp_k),
        "d_photon_radiance_dt": rad.band_photon_radiance_dt(band, args.temp_k),
    }
    return _emit(args, out, "\n".join(f"{k}: {v:.6g}" for k, v in out.items()))


def run_netd(args) -> int:
    from snrmon.model.noise import model_netd_mk, temporal_noise_e

    sensor, _ = _load(args)
    bg = _bg_k(args) or NOISE_REFERENCE_SKY_K
    noise = temporal_noise_e(sensor, bg)
    out = {
        "netd_mk": model_netd_mk(sensor),
        "temporal_noise_e": noise,
        "temporal_noise_dn": noise / sensor.gain_e_per_dn,
    }
    table = "\n".join(f"{k}: {v:.4g}" for k, v in out.items())
    table += f"\n(spec NETD {sensor.netd_mk:g} mK; noise against a {bg:.2f} K background)"
    return _emit(args, out, table)


def run_plot(args) -> int:
    import numpy as np

    from snrmon.model.plot import plot_prediction
    from snrmon.model.snr import predict

    sensor, target = _load(args)
    output_file(args.out, "-o/--out", suffixes=(".png", ".pdf", ".svg"))
    ranges = np.linspace(10.0, args.max_range_m, 500)
    pred = predict(
        sensor,
        target,
        ranges,
        atmosphere=_atmosphere(args, sensor),
        background_temp_k=_bg_k(args),
        air_temp_k=_air_k(args),
        spatial_noise=args.spatial_noise,
        footprint=args.footprint,
    )
    path = plot_prediction(pred, args.out)
    return _emit(args, {"file": str(path)}, str(path))
