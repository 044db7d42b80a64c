"""How well a stop row's expected Eq. (4) reading follows the sub-pixel phases its frames had,
against the digital twin's truth: one simulated day, then per unresolved fitted-PSF row.

    python tools/stop_phase_truth.py SEED [--stops M,M,...] [--size WxH] [--speed S] [flight]

runs ``snrmon hil --seed SEED --speed max`` (or ``--speed S``; ``--transit-mps``, ``--start-m``
and ``--hover-s``: the flight's transit speed, first range and hover time) in-process (the
paper's stops unless given) and prints one JSON object per fitted-PSF row of an unresolved
stop: the row's measured mean over the expected reading of its rule over the whole cell
(``cell``), over the phases measured from its frames (``stop_phases``, what the row is held to:
``acquisition.calibrate.stop_phases``) and over the twin's true phases of the same frames
(``true_phases``); the measured phases' error (median |folded error| and mean folded error per
axis, px: negative is toward the pixel's centre); the twin's noise-free truth over the model's
noise-free peak SNR at the true phases (``truth_over_peak_true_phases``: the fitted PSF's peak
share against the twin's optics, the noise and the radiometry, with no phase and no estimator
in it); and the row's fitted blur (``fitted_blur_px``, the Gaussian of its Airy-plus-Gaussian
PSF).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from snrmon.acquisition.calibrate.psf_estimate import StopCrops, observed_phases, target_px
from snrmon.model.snr import predict
from snrmon.rig.rig import HilOptions, HilRig, _peak_snr_at_phases


def _folded(p: np.ndarray) -> np.ndarray:
    """Offsets from a pixel centre folded into the half cell [0, 0.5] (as the model bins them)."""
    return np.abs((p + 0.5) % 1.0 - 0.5)


def _row_figures(rig: HilRig, row) -> dict | None:
    """The figures of one row (module docstring); None for a row that has none."""
    cam = rig.cameras[row.camera]
    sensor, psf, range_m = cam.sensor, row.model.model_psf, row.range_m
    if psf is None or range_m is None or row.agreement is None:
        return None
    d_px = target_px(rig.predictor.target, range_m, sensor.ifov_rad)
    counters = {t: c for t, c, _, _ in list(cam.log)}
    crops = dict(list(rig.session.flight_psf.logs[row.camera].crops))
    times = [t for t, _ in rig.session.stop_table.run_of(row.stop, row.camera)]
    times = [t for t in times if t in crops and t in counters]
    if d_px >= 1.0 or len(times) < 50:
        return None
    truths = [cam.feed.truth(counters[t]) for t in times]
    true = np.array([[v.x_px - round(v.x_px), v.y_px - round(v.y_px)] for v in truths])
    measured = observed_phases(
        StopCrops("", np.stack([crops[t] for t in times]), d_px), psf, sensor.fill_factor
    )
    options = {
        "corrected_psf": psf,
        "background_temp_k": rig.predictor.background_temp_k.get(row.camera),
        "air_temp_k": rig.opts.scenario.air_temp_k,
        "band": False,
    }
    rule = f"expected_eq4_{row.expected_eq4_rule}"
    target = rig.predictor.target
    at_true = predict(sensor, target, [range_m], phases_xy=true, **options)
    err = _folded(measured) - _folded(true)
    truth_snr = float(np.mean([v.truth_snr for v in truths]))
    return {
        "camera": row.camera,
        "range_m": round(float(range_m), 1),
        "frames": len(times),
        "fitted_blur_px": float(getattr(psf, "sigma_px", math.nan)),  # the Airy's Gaussian blur
        "cell": row.reading.snr_mean / row.model.model_snr[rule],
        "stop_phases": row.agreement.ratio,
        "true_phases": row.reading.snr_mean / float(at_true.snr(rule)[0]),
        "phase_error_median_abs_px": float(np.median(np.abs(err))),
        "phase_error_mean_px": [float(v) for v in err.mean(axis=0)],
        "truth_over_peak_true_phases": truth_snr
        / _peak_snr_at_phases(at_true, psf, sensor.fill_factor, d_px, true),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seed", type=int)
    parser.add_argument("--stops", default=None, help="hover ranges in metres, M,M,...")
    parser.add_argument("--size", default=None, help="a sub-array WxH")
    parser.add_argument("--speed", default="max", help="x real time, or max (the default)")
    parser.add_argument("--transit-mps", type=float, default=None, help="transit speed, m/s")
    parser.add_argument("--start-m", type=float, default=None, help="the flight's first range, m")
    parser.add_argument("--hover-s", type=float, default=None, help="hover at each stop, s")
    args = parser.parse_args(argv)
    kw: dict = {"seed": args.seed, "speed": 8.0, "speed_max": True}
    if args.speed != "max":
        kw.update(speed=float(args.speed), speed_max=False)
    if args.stops:
        kw["stops_m"] = tuple(float(v) for v in args.stops.split(","))
    for name, option in (
        ("transit_mps", args.transit_mps),
        ("start_range_m", args.start_m),
        ("hover_s", args.hover_s),
    ):
        if option is not None:
            kw[name] = option
    if args.size:
        kw["window_px"] = tuple(int(v) for v in args.size.lower().split("x"))
    with HilRig(HilOptions(**kw)) as rig:
        rig.run()
        for row in rig.session.stops():
            figures = _row_figures(rig, row)
            if figures is not None:
                print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
