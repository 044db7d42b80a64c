"""``snrmon characterize``: drone dimensions and temperature from a recorded close stop
(paper section 3).

    snrmon characterize SESSION.h5 --camera mwir --stop 1 [--calibration CAL.npz] [--json]
                        [--n-frames 100] [--min-frames 25] [--min-size-px 7]
                        [--method otsu|ksigma] [--target-out T.toml] [--apparent]
                        [--write | --no-record]

The session is replayed as recorded (``acquisition.replay.batch.replay_session``: the same
measurement, live track and stop table as live); the stop's range (rangefinder, else GPS) and
the tracked peak of each of its frames give the ROI; ``acquisition.calibrate.characterize``
segments the drone in every tracked frame of the stop and summarises the ``--n-frames`` where it
is at rest (``at_rest_frames``: range within the stop detector's tolerance, segmented size
steadiest), wherever they lie in the stop. JSON contract: ``{"camera",
"stop", "range_m", "n_frames", "small_m", "small_m_std", "large_m", "large_m_std",
"mean_temp_c", "mean_temp_c_std", "background_temp_c", "background_temp_c_std",
"rss_delta_t_k", "rss_delta_t_k_std", "method", "outline_temp_c", "core_pixels",
"core_seen_temp_c", "core_psf_share", "apparent_temp_c", "temperature_convention",
"at_rest_s", "psf_blur_px", "psf_source"}`` and, through the air, ``"transmission",
"air_temp_c"`` (``at_rest_s``: [first, last] frame of those used, seconds from the stop's
start); temperatures are null without a calibration.

What it cannot measure it refuses, exit 2 with the numbers and nothing kept: fewer than
``--min-frames`` (25) frames at rest, or a small or large dimension under ``--min-size-px``
(2 x the 3-px opening + 1 = 7 px) pixels (``acquisition.calibrate.characterize.unmeasurable``).

One convention for every temperature (``temperature_convention``): "path_corrected" (the
default) takes each pixel's radiance back through the air before reading it,
L = (L_app - (1 - tau) L_air) / tau with the model's contrast-weighted transmission at the
stop's range and the air of the session's [weather] (``--air-temp-c`` over it), so the
drone's temperature, its spread, the sky behind it and the RSS delta-T are all as a camera at
the drone would read them; ``apparent_temp_c`` keeps the drone as seen. "apparent"
(``--apparent``): every temperature as seen. ``mean_temp_c`` is read on the outline's core,
the pixels farthest from the sky (``acquisition.calibrate.characterize``), its contrast
corrected for the PSF's mixing with the camera's PSF measured from the flight (the session's
latest ``psf_measured`` or ``model_psf`` event of the camera: the Airy blurred by its
``blur_px``; ``--psf-blur-px`` to give one; none: no correction, ``psf_source`` null);
``core_seen_temp_c`` is the core before that correction, ``core_psf_share`` the share of the
contrast the PSF left it; ``outline_temp_c`` is the eroded outline's mean, low where the
drone's parts are only a few PSF widths across.

The result is kept beside the recording in ``FILE.analysis.json`` (the recording's bytes do not
change); ``--write`` adds it to the recording as a ``target_characterized`` event instead.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

from snrmon.cli import UsageError
from snrmon.inputs import input_file, output_file, session_file
from snrmon.limits import MIN_FRAMES_AT_REST
from snrmon.output import emit_json
from snrmon.results import add_result_options, keep_result

if TYPE_CHECKING:
    from snrmon.acquisition.calibrate.characterize import AirPath


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("characterize", help="drone size and temperature from a close stop")
    _add_stop_options(p)
    _add_temperature_options(p)
    _add_segmentation_options(p)
    p.add_argument(
        "--target-out", metavar="FILE.toml", help="write a target TOML (needs a calibration)"
    )
    p.add_argument(
        "--target-name",
        default="characterized",
        metavar="NAME",
        help="the name written into --target-out (default: %(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    add_result_options(p, "target_characterized")
    p.set_defaults(func=run)


def _add_stop_options(p: argparse.ArgumentParser) -> None:
    """Which recording, camera and stop, and the camera's calibration."""
    p.add_argument("session", metavar="SESSION.h5", help="a snrmon session file")
    p.add_argument(
        "--camera", required=True, metavar="NAME", help="camera of the session to characterize"
    )
    p.add_argument(
        "--stop", type=int, required=True, metavar="N", help="stop number as in the stop table"
    )
    p.add_argument(
        "--calibration",
        metavar="CAL.npz",
        help="calibration of this camera (default: the session's recorded one)",
    )


def _add_temperature_options(p: argparse.ArgumentParser) -> None:
    """How the drone's temperature is read: through the air or as seen, the sensor, the PSF."""
    p.add_argument(
        "--air-temp-c",
        type=float,
        metavar="T",
        help="air along the path, C, for the atmospheric correction of the drone's "
        "temperature (default: the session's [weather], else the atmosphere's)",
    )
    p.add_argument(
        "--apparent",
        action="store_true",
        help="report every temperature as seen, through the air (default: all corrected "
        "for the air in front of the drone)",
    )
    p.add_argument(
        "--sensor",
        metavar="mwir|lwir|FILE",
        help="sensor preset or TOML file (default: the session's, else --camera)",
    )
    p.add_argument(
        "--psf-blur-px",
        type=float,
        metavar="PX",
        help="the camera's PSF for the core's correction: its Airy blurred by this Gaussian "
        "(default: the session's measured PSF, snrmon psf)",
    )
    p.add_argument(
        "--no-psf-correction",
        action="store_true",
        help="read the core as seen, without correcting for the PSF's mixing",
    )


def _add_segmentation_options(p: argparse.ArgumentParser) -> None:
    """Which frames are used and how the drone is cut from the sky in each."""
    p.add_argument(
        "--n-frames",
        type=int,
        default=100,
        metavar="N",
        help="frames of the stop to use (default: %(default)s)",
    )
    p.add_argument(
        "--min-frames",
        type=int,
        default=MIN_FRAMES_AT_REST,
        metavar="N",
        help="refuse (exit 2) with fewer frames of the drone at rest (default: %(default)s: "
        "the frames' std then known to 14 %%)",
    )
    p.add_argument(
        "--min-size-px",
        type=float,
        metavar="PX",
        help="refuse (exit 2) a drone whose small or large dimension is under this many pixels "
        "(default 7: twice the 3-px opening plus one; smaller, the opening has eaten its parts)",
    )
    p.add_argument(
        "--method",
        choices=("otsu", "ksigma"),
        default="otsu",
        metavar="otsu|ksigma",
        help="segmentation of the drone from the sky: Otsu's threshold or k sigma "
        "(default: %(default)s)",
    )
    p.add_argument(
        "--roi-px",
        type=int,
        default=32,
        metavar="PX",
        help="half size of the region around the drone, pixels (default: %(default)s)",
    )


def _weather(args):
    """The met readings of the session's [weather] (None: none), --air-temp-c over its air."""
    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.prediction import Weather
    from snrmon.acquisition.record.reader import open_session

    with open_session(args.session) as f:
        raw = f.config.get("session") if isinstance(f.config, dict) else None
    weather = session_config_from_dict(raw).weather if raw else None
    if args.air_temp_c is not None:
        weather = dataclasses.replace(weather or Weather(), air_temp_c=args.air_temp_c)
    return weather


def air_path(sensor, range_m: float, weather=None) -> AirPath:
    """The air in front of the drone at the stop (paper sections 8-9): the model's
    contrast-weighted band transmission at ``range_m`` through the day's met readings
    ``weather`` (None: the model's default atmosphere), and the air's temperature. The
    calibrated camera sees L_app = tau L_t + (1 - tau) L_air (``model.contrast``)."""
    from snrmon.acquisition.calibrate.characterize import AirPath
    from snrmon.model.atmosphere import resolve_atmosphere

    atm = resolve_atmosphere(weather, tuple(sensor.band_um))
    return AirPath(float(atm.contrast_transmission(range_m)), float(atm.air_temp_k))


def _measured_psf(args, sensor) -> tuple[object | None, float | None, str | None]:
    """(PSF, blur_px, where it came from): ``--psf-blur-px``, else the session's latest
    ``psf_measured`` / ``model_psf`` event of the camera; (None, None, None) without one."""
    from snrmon.acquisition.record.reader import open_session
    from snrmon.model.psf import AiryGaussianPsf

    if args.no_psf_correction:
        return None, None, None
    blur, source = args.psf_blur_px, "--psf-blur-px"
    if blur is None:
        with open_session(args.session) as f:
            events = [
                e
                for e in f.event_list()
                if e.get("kind") in ("psf_measured", "model_psf")
                and e.get("camera") == args.camera
                and isinstance(e.get("payload"), dict)
                and e["payload"].get("blur_px") is not None
            ]
        if not events:
            return None, None, None
        last = events[-1]  # the latest: events are in the order they were added
        blur, source = float(last["payload"]["blur_px"]), f"{last['kind']} event"
    if not (blur >= 0 and math.isfinite(blur)):
        raise UsageError(f"--psf-blur-px must be >= 0 px, got {blur}")
    return AiryGaussianPsf(sensor.diffraction_psf(), float(blur)), float(blur), source


def _sensor_name(path: str, camera: str) -> str:
    from snrmon.acquisition.record.reader import open_session

    with open_session(path) as f:
        cams = (f.config.get("session") or {}).get("cameras") or {}
        return str((cams.get(camera) or {}).get("sensor", camera))


def _check_inputs(args: argparse.Namespace) -> None:
    """Every option and file before the replay starts (exit 2 naming the one that is wrong)."""
    if args.n_frames < 1:
        raise UsageError(f"--n-frames must be >= 1, got {args.n_frames}")
    if args.roi_px < 1:
        raise UsageError(f"--roi-px must be >= 1, got {args.roi_px}")
    if args.min_frames < 2:
        raise UsageError(f"--min-frames must be >= 2, got {args.min_frames}")
    if args.min_size_px is not None and not args.min_size_px > 0:
        raise UsageError(f"--min-size-px must be > 0, got {args.min_size_px}")
    session_file(args.session, camera=args.camera)
    if args.calibration:
        input_file(args.calibration, "--calibration")
    if args.target_out:  # (a calibration comes from the session, or from --calibration)
        output_file(args.target_out, "--target-out", suffixes=(".toml",))


def _stop_row(args: argparse.Namespace, replay) -> tuple[object, float]:
    """The stop's row of the replayed stop table and its range (rangefinder, else GPS)."""
    if args.camera not in replay.cameras:
        raise UsageError(
            f"camera {args.camera!r} not in {args.session} ({', '.join(replay.cameras)})"
        )
    rows = [r for r in replay.stops if r.camera == args.camera]
    row = next((r for r in rows if r.stop == args.stop), None)
    if row is None:
        known = ", ".join(str(r.stop) for r in rows) or "none"
        raise UsageError(
            f"no stop {args.stop} for {args.camera} in {args.session} (stops: {known})"
        )
    range_m = row.range_m
    if range_m is None:
        raise UsageError(f"stop {args.stop} has no range (no rangefinder or GPS readings)")
    return row, float(range_m)


def _tracked_frames(args: argparse.Namespace, replay, row) -> list[tuple]:
    """(t_host_ns, peak (x, y), range_m) of every tracked frame of the stop (those where the
    drone is at rest are chosen later)."""
    import numpy as np

    from snrmon.acquisition.measure.peak_snr import FLAG_EDGE, FLAG_LOST

    # A resolved drone fills the 7x7 rim, so rim_contaminated/undefined are expected at a close
    # stop; only a frame without a trustworthy position is skipped.
    no_position = frozenset({FLAG_LOST, FLAG_EDGE})
    end = row.place.t_end_ns if row.place.t_end_ns is not None else np.iinfo(np.int64).max
    picks = [
        (m.t_host_ns, (m.result.peak_x, m.result.peak_y), m.range_m)
        for m in replay.cameras[args.camera].tally.measurements
        if row.place.t_start_ns <= m.t_host_ns < end and not (m.result.flags & no_position)
    ]
    if not picks:
        raise UsageError(f"stop {args.stop} holds no tracked frames of {args.camera}")
    return picks


@dataclasses.dataclass
class _Segmented:
    """The stop's frames the file holds, each segmented (None where no drone was found)."""

    targets: list  # TargetFrame | None, one per held frame
    held: list[tuple]  # (frame index in the file, t_host_ns, peak (x, y), range_m)
    calibration: object | None
    calibration_source: str | None
    config: object  # CharacterizeConfig


def _segmented(args, sensor, range_m: float, picks, psf, path) -> _Segmented:
    """Each tracked frame the file holds read by its exact receipt time and segmented."""
    import numpy as np

    from snrmon.acquisition.calibrate.characterize import CharacterizeConfig, characterize_frame
    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.recorded import recorded_calibration

    with open_session(args.session) as f:
        cam = f.cameras[args.camera]
        found = recorded_calibration(f, args.camera, args.calibration, sensor)
        cal, cal_source = found if found is not None else (None, None)
        if cal is None and args.target_out:
            raise UsageError(
                f"stop {args.stop} of {args.camera}: the session has no calibration and none was "
                "given (--calibration): a target file needs the drone's temperature"
            )
        # The replay measures frames the recorder dropped too (from its recorded state); only
        # the frames the file holds can be read: each pick by its exact receipt time.
        t_file = np.asarray(cam.t_host_ns[: cam.frames.shape[0]])
        index = np.searchsorted(t_file, [t for t, _, _ in picks])
        held = [
            (int(i), t, at, rng)
            for i, (t, at, rng) in zip(index, picks, strict=True)
            if i < t_file.size and t_file[i] == t
        ]
        if not held:
            raise UsageError(f"stop {args.stop}: none of its tracked frames is in {args.session}")
        if cal is not None and cal.camera != args.camera:
            raise ValueError(f"calibration is for camera {cal.camera!r}, not {args.camera!r}")
        config = CharacterizeConfig(roi_half_px=args.roi_px, method=args.method)
        targets = [
            characterize_frame(
                cam.frames[i],
                at,
                range_m=range_m,
                ifov_rad=sensor.ifov_rad,
                calibration=cal,
                config=config,
                psf=psf,
                fill_factor=sensor.fill_factor,
                path=path,
            )
            for i, _, at, _ in held
        ]
    return _Segmented(targets, held, cal, cal_source, config)


def _summary_at_rest(args, sensor, row, range_m: float, seg: _Segmented, convention: str):
    """(the summary of the frames where the drone is at rest, their indexes in ``seg.held``,
    those frames segmented); a stop that cannot be measured is refused (exit 2, nothing kept)."""
    import numpy as np

    from snrmon.acquisition.calibrate.characterize import (
        at_rest_frames,
        summarise_frames,
        unmeasurable,
    )
    from snrmon.acquisition.stops.detector import StopConfig

    source = "lrf" if row.place.lrf_range_m is not None else "gps"
    rest = at_rest_frames(
        [None if f is None else float(np.sqrt(f.area_px)) for f in seg.targets],
        [rng for _, _, _, rng in seg.held],
        args.n_frames,
        stop_range_m=range_m,
        range_tolerance_m=StopConfig().tolerance_m(source),
    )
    used = [seg.targets[k] for k in rest if seg.targets[k] is not None]
    try:
        result = summarise_frames(
            used, camera=args.camera, range_m=range_m, method=args.method, convention=convention
        )
    except ValueError as exc:
        raise UsageError(f"stop {args.stop}: {exc}") from None
    why = unmeasurable(
        result,
        pixel_m=range_m * sensor.ifov_rad,
        min_frames=args.min_frames,
        min_size_px=args.min_size_px,
        config=seg.config,
    )
    if why is not None:  # nothing is kept: a figure that is not measured is not a result
        raise UsageError(f"stop {args.stop}: {why}")
    return result, rest, used


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.calibrate.characterize import median_outline, target_toml
    from snrmon.acquisition.replay.batch import replay_session
    from snrmon.model.constants import ZERO_C_K
    from snrmon.model.presets import load_sensor

    _check_inputs(args)
    sensor = load_sensor(args.sensor or _sensor_name(args.session, args.camera))
    # As recorded: the live track (it follows a resolved drone) gives each frame's
    # position. A fixed window at the click would sit where the operator clicked, which at a
    # close stop can be tens of pixels off the drone (a click on its GPS position).
    replay = replay_session(args.session, fast=True)
    row, range_m = _stop_row(args, replay)
    psf, blur, psf_source = _measured_psf(args, sensor)
    # one convention for every temperature: through the air (as a camera at the drone would
    # read them), or, with --apparent, all as seen
    path = None if args.apparent else air_path(sensor, range_m, _weather(args))
    picks = _tracked_frames(args, replay, row)
    seg = _segmented(args, sensor, range_m, picks, psf, path)
    cal = seg.calibration
    convention = "path_corrected" if path is not None and cal is not None else "apparent"
    result, rest, used = _summary_at_rest(args, sensor, row, range_m, seg, convention)
    out = {"stop": args.stop, **result.as_dict(), "calibration": seg.calibration_source}
    out["at_rest_s"] = [(seg.held[k][1] - row.place.t_start_ns) / 1e9 for k in (rest[0], rest[-1])]
    corrected = cal is not None and psf is not None  # a PSF corrects a temperature
    out["psf_blur_px"], out["psf_source"] = (blur, psf_source) if corrected else (None, None)
    if path is not None and cal is not None:
        out["transmission"], out["air_temp_c"] = path.transmission, path.air_temp_k - ZERO_C_K
    if args.target_out:
        # the drone's segmented outline at this stop, for the model's "outline" footprint
        outline = median_outline(used, range_m * sensor.ifov_rad)
        Path(args.target_out).write_text(target_toml(result, args.target_name, outline=outline))
        out["target_file"] = args.target_out
    # The characterization belongs to the session it was measured from: beside it, or in it
    # with --write.
    keep_result(args, "target_characterized", args.camera, out)
    if args.json:
        return emit_json(out)
    for key, value in out.items():
        print(f"{key:>22}: {value:.4g}" if isinstance(value, float) else f"{key:>22}: {value}")
    return 0
