"""``snrmon hil``: the simulated collection day through the real console code.

Simulated cameras (shared-memory frame rings written by separate processes), an NMEA GPS and an
LDM rangefinder (pseudo-terminals) fly the paper's stops; the ordinary Session measures, tracks,
detects the stops and builds the SNR-versus-range table, printed with the simulator's truth and
the model's prediction beside each measurement.
"""

from __future__ import annotations

import argparse
import math

from snrmon.cli import UsageError
from snrmon.commands.model import AEROSOL_CHOICES, add_footprint_option, check_footprint
from snrmon.commands.recording_options import add_compression_option
from snrmon.inputs import Number, Size, output_file, seed, stop_ranges
from snrmon.output import emit_json
from snrmon.progress import say


def _floats(text: str, what: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UsageError(f"{what} must be comma-separated numbers, got {text!r}") from None
    if not values:
        raise UsageError(f"{what} must be comma-separated numbers, got {text!r}")
    for v in values:
        if not math.isfinite(v):
            raise UsageError(f"{what} must be finite numbers, got {v:g} in {text!r}")
        if v <= 0:
            sign = "negative" if v < 0 else "zero"
            raise UsageError(f"{what} must be positive, got {v:g} in {text!r} ({sign})")
    return values


def _kelvin(celsius: float, what: str) -> float:
    from snrmon.model.constants import ZERO_C_K

    if not (math.isfinite(celsius) and -100.0 < celsius < 100.0):
        raise UsageError(f"{what} must be a temperature in C, got {celsius}")
    return celsius + ZERO_C_K


PAPER_STOPS_M = "37,126,199,336,393,451,508"


def add_flight_options(p: argparse.ArgumentParser) -> None:
    """``--seed`` and ``--stops`` of a simulated flight, shared with ``snrmon demo``."""
    p.add_argument(
        "--seed",
        type=seed(),
        default=0,
        metavar="N",
        help="seed of every simulated device (default: %(default)s)",
    )
    p.add_argument(
        "--stops",
        type=stop_ranges(),
        default=PAPER_STOPS_M,
        metavar="M,M,...",
        help="hover ranges in metres (default: the paper's, %(default)s)",
    )


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("hil", help="run the simulated field test through the real console")
    p.add_argument(
        "--headless", action="store_true", help="no window (always: `snrmon demo` has the console)"
    )
    add_flight_options(p)
    _add_day_options(p)
    _add_weather_options(p)
    _add_camera_options(p)
    p.add_argument(
        "-o", "--out", metavar="PATH", help="record the run into this new session file (.h5)"
    )
    add_compression_option(p)
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def _add_day_options(p: argparse.ArgumentParser) -> None:
    """The day's pace, cameras, target and flight."""
    p.add_argument(
        "--speed",
        default="1",
        metavar="X",
        help="flight time per wall-clock second (e.g. 2), or max: as fast as the console takes "
        "the frames (at most 8x). A simulated day never drops a frame: where the machine is "
        "busier than the speed needs, the day slows down (said on stderr and in the JSON) "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--cameras",
        default="mwir,lwir",
        metavar="NAME,...",
        help="cameras to simulate (default: %(default)s)",
    )
    p.add_argument(
        "--target",
        default="uav1",
        metavar="uav1|uav2|FILE",
        help="target preset or TOML file (default: %(default)s)",
    )
    add_footprint_option(p)
    p.add_argument(
        "--hover-s",
        type=Number(0.0, 3600.0, above=True, unit="s"),
        default=7.0,
        metavar="S",
        help="hover time per stop, flight seconds (default: %(default)s)",
    )
    p.add_argument(
        "--transit-mps",
        type=Number(0.0, 100.0, above=True, unit="m/s"),
        default=8.0,
        metavar="M_S",
        help="transit speed between stops, m/s (default: %(default)s)",
    )


def _add_weather_options(p: argparse.ArgumentParser) -> None:
    """The scenario's sky and air (what the twin renders and the model is told)."""
    p.add_argument(
        "--sky-temp-c",
        type=float,
        default=6.85,
        metavar="T",
        help="the scenario's clear-sky apparent temperature, C (default: %(default)s)",
    )
    p.add_argument(
        "--air-temp-c",
        type=float,
        default=15.0,
        metavar="T",
        help="the scenario's air temperature along the path, C (default: %(default)s)",
    )
    p.add_argument(
        "--rh",
        type=float,
        default=None,
        metavar="PCT",
        help="the scenario's relative humidity, %% (default: the US Standard atmosphere's 46)",
    )
    p.add_argument(
        "--pressure-hpa",
        type=float,
        default=None,
        metavar="P",
        help="the scenario's air pressure, hPa (default: 1013.25)",
    )
    p.add_argument(
        "--visibility-km",
        type=float,
        default=23.0,
        metavar="V",
        help="the scenario's visibility, km (default: %(default)s, LOWTRAN7's clear day)",
    )
    p.add_argument(
        "--aerosol",
        default="rural",
        choices=AEROSOL_CHOICES,
        metavar="|".join(AEROSOL_CHOICES),
        help="the scenario's LOWTRAN7 aerosol model, none: no aerosol (default: %(default)s)",
    )


def _add_camera_options(p: argparse.ArgumentParser) -> None:
    """What the simulated cameras read and how the console follows the drone."""
    p.add_argument(
        "--size",
        type=Size(64),
        metavar="WxH",
        help="read a sub-array of W x H pixels around the line of sight (default: the whole frame)",
    )
    p.add_argument(
        "--no-calibration",
        action="store_true",
        help="skip the blackbody calibration before the flight",
    )
    p.add_argument("--fpn", action="store_true", help="add fixed-pattern noise to the frames")
    p.add_argument(
        "--no-track",
        action="store_true",
        help="keep the search window where clicked (re-clicked at every stop)",
    )


def run(args: argparse.Namespace) -> int:
    from snrmon.rig.flight_clock import MAX_SPEED
    from snrmon.rig.rig import HilOptions, HilRig
    from snrmon.rig.table import format_result

    speed_max = args.speed == "max"
    speed = MAX_SPEED if speed_max else _floats(args.speed, "--speed")[0]
    if args.out is not None:
        output_file(args.out, "--out", suffixes=(".h5",), new=True)
    cameras = tuple(c.strip() for c in args.cameras.split(",") if c.strip())
    unknown = [c for c in cameras if c not in ("mwir", "lwir")]
    if unknown or not cameras:
        raise UsageError(f"--cameras must name mwir and/or lwir, got {args.cameras!r}")
    from snrmon.model.presets import load_target

    check_footprint(args.footprint, load_target(args.target))
    opts = HilOptions(
        seed=args.seed,
        footprint=args.footprint,
        speed=speed,
        stops_m=args.stops,
        cameras=cameras,
        target=args.target,
        hover_s=args.hover_s,
        transit_mps=args.transit_mps,
        sky_temp_k=_kelvin(args.sky_temp_c, "--sky-temp-c"),
        air_temp_k=_kelvin(args.air_temp_c, "--air-temp-c"),
        rh_percent=args.rh,
        pressure_hpa=args.pressure_hpa,
        visibility_km=args.visibility_km,
        aerosol=args.aerosol,
        window_px=args.size,
        calibrate=not args.no_calibration,
        fpn=args.fpn,
        track=not args.no_track,
        out=args.out,
        compression=args.compression,
        speed_max=speed_max,
    )
    rig = HilRig(opts)
    with rig:
        if not args.json:
            pace = f"at most {speed:g}x, as fast as the console takes it" if speed_max else ""
            say(
                f"simulated flight: {len(opts.stops_m)} stops, "
                f"{rig.plan.duration_s / speed:.0f} s at speed {speed:g}"
                + (f" ({pace})" if pace else "")
            )
        result = rig.run()
    achieved = result["speed"]["achieved"]
    if not args.json and achieved is not None:
        say(
            f"the day ran at {achieved:.2f}x (held back {result['speed']['held_back_s']:.1f} s "
            "by the console)"
        )
    if rig.recording is not None:
        result["recording"] = rig.recording
    if not opts.track:
        result["note"] = "tracking off: the simulator re-clicked the drone at every stop"
    if args.json:
        emit_json(result)  # a stop without truth or model: null, not NaN
        return _failed(rig)
    print(format_result(result))
    if rig.recording is not None:
        for cam, acc in result["frames"].items():
            lost = ", ".join(f"{k} {v}" for k, v in acc["dropped"].items() if v) or "none"
            print(
                f"recording {cam}: {acc['received']} frames received: {acc['written']} written, "
                f"dropped {lost}, {acc['before_recording']} before the recording"
            )
    return _failed(rig)


def _failed(rig) -> int:
    """0, or the day's failure raised (exit 1, one line): :meth:`HilRig.check_failures`."""
    rig.check_failures()
    return 0
