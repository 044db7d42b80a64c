"""``snrmon psf``: the camera's PSF from a recorded stop of an unresolved drone.

    snrmon psf SESSION.h5 --camera C --stop N [--stop M ...] [--calibration CAL.npz]
               [--min-frames 50] [--json] [--write | --no-record]

The session is replayed like ``snrmon characterize`` (the same stop table as live); the stop's
frames with a valid measurement give 13 x 13 crops around their peaks, non-uniformity corrected
by the session's recorded calibration (or ``--calibration``); ``acquisition.calibrate.
psf_estimate`` fits them. JSON contract: ``{"sigma_px", "pvf", "pvf_std", "n_frames"}`` plus
``"sigma_px_std"``, ``"blur_px"``, ``"blur_px_std"``, ``"chi2_per_dof"``, ``"camera"``,
``"stops"``, ``"range_m"`` (one per stop), ``"target_px"``. A resolved drone, a stop with
too few frames or without a range is one message naming the stop and why (exit 2).

The result (and the fit as the model takes it, ``estimate``) is kept beside the recording in
``FILE.analysis.json`` (the recording is raw data: its bytes do not change); ``--write`` adds it
to the recording as a ``psf_measured`` event instead. A replay, a report and a campaign of the
session use the fitted PSF as the camera's corrected PSF (docs/session-format.md).
"""

from __future__ import annotations

import argparse

from snrmon.cli import UsageError
from snrmon.inputs import input_file, session_file
from snrmon.output import emit_json
from snrmon.results import add_result_options, keep_result


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("psf", help="the PSF and its average PVF from an unresolved stop")
    p.add_argument("session", metavar="SESSION.h5", help="a snrmon session file")
    p.add_argument(
        "--camera", required=True, metavar="NAME", help="the recorded camera (mwir, lwir, ...)"
    )
    p.add_argument(
        "--stop",
        type=int,
        action="append",
        required=True,
        metavar="N",
        help="stop number as in the stop table (repeat to pool stops)",
    )
    p.add_argument("--calibration", metavar="CAL.npz", help="calibration (default: the session's)")
    p.add_argument(
        "--sensor", metavar="mwir|lwir|FILE", help="sensor preset or TOML (default: the session's)"
    )
    p.add_argument(
        "--target", metavar="uav1|uav2|FILE", help="target preset or TOML (default: the session's)"
    )
    p.add_argument(
        "--min-frames",
        type=int,
        default=50,
        metavar="N",
        help="fewest valid frames a stop must give, at least 10 (default: %(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    add_result_options(p, "psf_measured")
    p.set_defaults(func=run)


def _stop_crops(args, rows: dict, rep, cam, cal, sensor, target, n: int):
    """Stop ``n``'s crops around the measured peak of each of its valid frames (flags none,
    SNR finite), as the PSF fit takes them, and its row."""
    import numpy as np

    from snrmon.acquisition.calibrate.psf_estimate import (
        PsfEstimateError,
        StopCrops,
        crop_frames,
        target_px,
    )

    row = rows.get(n)
    if row is None:
        known = ", ".join(str(k) for k in sorted(rows)) or "none"
        raise UsageError(f"no stop {n} for {args.camera} in {args.session} (stops: {known})")
    label = f"stop {n} of {args.camera}"
    try:
        d = target_px(target, row.range_m, sensor.ifov_rad)
    except PsfEstimateError as exc:
        raise UsageError(f"{label}: {exc}") from None
    lo = np.searchsorted(rep.t_host_ns, row.place.t_start_ns)
    hi = (
        len(rep.t_host_ns)
        if row.place.t_end_ns is None
        else np.searchsorted(rep.t_host_ns, row.place.t_end_ns)
    )
    picks = [
        (t, r)
        for t, r in zip(rep.t_host_ns[lo:hi], rep.results[lo:hi], strict=True)
        if not r.flags and np.isfinite(r.snr)
    ]
    index = np.searchsorted(cam.t_host_ns, [t for t, _ in picks])
    crops = crop_frames(
        (cam.frames[int(i)] for i in index), [(r.peak_x, r.peak_y) for _, r in picks], cal
    )
    return StopCrops(f"{label} at {row.range_m:.1f} m", crops, d), row


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.calibrate.psf_estimate import PsfEstimateError, estimate_psf
    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.batch import replay_session
    from snrmon.acquisition.replay.recorded import recorded_calibration
    from snrmon.acquisition.report.data import session_models
    from snrmon.model.presets import load_sensor, load_target

    if args.min_frames < 10:
        raise UsageError(f"--min-frames must be >= 10, got {args.min_frames}")
    session_file(args.session, camera=args.camera)
    if args.calibration:
        input_file(args.calibration, "--calibration")
    sensors, target_name = session_models(args.session, args.target)
    if args.camera not in sensors:
        raise UsageError(f"camera {args.camera!r} not in {args.session} ({', '.join(sensors)})")
    sensor = load_sensor(args.sensor or sensors[args.camera])
    target = load_target(target_name)
    replay = replay_session(args.session)
    rows = {r.stop: r for r in replay.stops if r.camera == args.camera}
    rep = replay.cameras[args.camera]
    stops, ranges = [], []
    with open_session(args.session) as f:
        cam = f.cameras[args.camera]
        found = recorded_calibration(f, args.camera, args.calibration, sensor)
        cal = found[0] if found is not None else None
        for n in args.stop:
            crops, row = _stop_crops(args, rows, rep, cam, cal, sensor, target, n)
            stops.append(crops)
            ranges.append(row.range_m)
    try:
        est = estimate_psf(stops, sensor, min_frames=args.min_frames)
    except PsfEstimateError as exc:
        raise UsageError(str(exc)) from None
    out = {
        "sigma_px": est.sigma_px,
        "pvf": est.pvf,
        "pvf_std": est.pvf_std,
        "n_frames": est.n_frames,
        "sigma_px_std": est.sigma_px_std,
        "blur_px": est.blur_px,
        "blur_px_std": est.blur_px_std,
        "chi2_per_dof": est.chi2_per_dof,
        "camera": args.camera,
        "stops": list(args.stop),
        "range_m": ranges,
        "target_px": [s.target_px for s in stops],
        "calibrated": cal is not None,
    }
    # The fit as the model takes it (a replay of the session uses it as the corrected PSF).
    keep_result(args, "psf_measured", args.camera, {**out, "estimate": est.as_dict()})
    if args.json:
        return emit_json(out)
    for key, value in out.items():
        print(f"{key:>14}: {value:.4g}" if isinstance(value, float) else f"{key:>14}: {value}")
    return 0
