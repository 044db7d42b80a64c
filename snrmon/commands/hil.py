"""``snrmon hil``: the simulated collection day through the real console code.

Simulated cameras (shared-memory frame rings written by separate processes), an NMEA GPS and an
LDM rangefinder (pseudo-terminals) fly the paper's stops; the ordinary Session measures, tracks,
detects the stops and builds the SNR-versus-range table, printed with the simulator's truth and
the model's prediction beside each measurement.
"""

from __future__ import annotations

import argparse
import math
import sys

from snrmon.cli import UsageError
from snrmon.commands.recording_options import add_compression_option
from snrmon.inputs import output_file
from snrmon.output import emit_json


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
    if not (math.isfinite(celsius) and -100.0 < celsius < 100.0):
        raise UsageError(f"{what} must be a temperature in C, got {celsius}")
    return celsius + 273.15


def _window(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UsageError(f"--window must be WxH in pixels, e.g. 256x192, got {text!r}") from None
    if w < 64 or h < 64:
        raise UsageError(f"--window must be at least 64x64 pixels, got {text!r}")
    return w, h


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("hil", help="run the simulated field test through the real console")
    p.add_argument(
        "--headless", action="store_true", help="no window (always: `snrmon demo` has the console)"
    )
    p.add_argument("--seed", type=int, default=0, help="seed of every simulated device")
    p.add_argument(
        "--speed",
        default="1",
        help="flight time per wall-clock second (e.g. 2), or max: as fast as the console takes "
        "the frames (at most 8x). A simulated day never drops a frame: where the machine is "
        "busier than the speed needs, the day slows down (said on stderr and in the JSON)",
    )
    p.add_argument(
        "--stops",
        default="37,126,199,336,393,451,508",
        metavar="M,M,...",
        help="hover ranges in metres",
    )
    p.add_argument("--camera", default="mwir,lwir", help="cameras to simulate")
    p.add_argument("--target", default="uav1", help="target preset or TOML file")
    p.add_argument("--hover-s", type=float, default=7.0, help="hover time per stop (flight s)")
    p.add_argument("--transit-mps", type=float, default=8.0, help="transit speed between stops")
    p.add_argument(
        "--sky-temp-c",
        type=float,
        default=280.0 - 273.15,
        help="the scenario's clear-sky apparent temperature, C (6.85)",
    )
    p.add_argument(
        "--air-temp-c",
        type=float,
        default=15.0,
        help="the scenario's air temperature along the path, C (15)",
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
        help="the scenario's air pressure, hPa (1013.25)",
    )
    p.add_argument(
        "--visibility-km",
        type=float,
        default=None,
        metavar="V",
        help="the scenario's visibility (rural aerosol), km (default: no aerosol)",
    )
    p.add_argument(
        "--window", metavar="WxH", help="read a sub-array of W x H pixels around the line of sight"
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
    p.add_argument("--out", metavar="FILE.h5", help="record the run into a session file")
    add_compression_option(p)
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from snrmon.rig.flight_clock import MAX_SPEED
    from snrmon.rig.rig import HilOptions, HilRig
    from snrmon.rig.table import format_result

    speed_max = args.speed == "max"
    speed = MAX_SPEED if speed_max else _floats(args.speed, "--speed")[0]
    if args.out is not None:
        output_file(args.out, "--out", suffixes=(".h5",), new=True)
    for option, value in (("--hover-s", args.hover_s), ("--transit-mps", args.transit_mps)):
        if not value > 0:
            raise UsageError(f"{option} must be positive, got {value}")
    cameras = tuple(c.strip() for c in args.camera.split(",") if c.strip())
    unknown = [c for c in cameras if c not in ("mwir", "lwir")]
    if unknown or not cameras:
        raise UsageError(f"--camera must name mwir and/or lwir, got {args.camera!r}")
    opts = HilOptions(
        seed=args.seed,
        speed=speed,
        stops_m=_floats(args.stops, "--stops"),
        cameras=cameras,
        target=args.target,
        hover_s=args.hover_s,
        transit_mps=args.transit_mps,
        sky_temp_k=_kelvin(args.sky_temp_c, "--sky-temp-c"),
        air_temp_k=_kelvin(args.air_temp_c, "--air-temp-c"),
        rh_percent=args.rh,
        pressure_hpa=args.pressure_hpa,
        visibility_km=args.visibility_km,
        window_px=_window(args.window),
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
            print(
                f"simulated flight: {len(opts.stops_m)} stops, "
                f"{rig.plan.duration_s / speed:.0f} s at speed {speed:g}"
                + (f" ({pace})" if pace else ""),
                file=sys.stderr,
            )
        result = rig.run()
    achieved = result["speed"]["achieved"]
    if not args.json and achieved is not None:
        print(
            f"the day ran at {achieved:.2f}x (held back {result['speed']['held_back_s']:.1f} s "
            "by the console)",
            file=sys.stderr,
        )
    if rig.recording is not None:
        result["recording"] = rig.recording
    if not opts.track:
        result["note"] = "tracking off: the simulator re-clicked the drone at every stop"
    if args.json:
        return emit_json(result)  # a stop without truth or model: null, not NaN
    print(format_result(result))
    if rig.recording is not None:
        r = rig.recording
        for cam, written in r["frames_written"].items():
            acc = (r.get("accounting") or {}).get(cam, {})
            dropped = {k: v for k, v in acc.get("dropped", r["dropped"].get(cam, {})).items() if v}
            lost = ", ".join(f"{k} {v}" for k, v in dropped.items()) or "none"
            print(
                f"recording {cam}: {acc.get('received', '?')} frames received: {written} written, "
                f"dropped {lost}, {acc.get('before_recording', 0)} before the recording"
            )
    return 0
