"""The flight PSF fit and the per-frame phase estimate on crops of the twin's own drone, with the
twin's optics, at known sub-pixel phases: what the fit's square target does at each stop size.

    python tools/psf_fit_footprint.py CAMERA [--sizes D,D,...] [--amplitude A] [--seed N]

renders, per stop size D (the drone's small dimension in px), 100 frames of the twin's
silhouette through the twin's optics (``sim.optics.TwinSpread``, its aberration blur
``sim.optics.TWIN_ABERRATION_PX``) at phases uniform over the pixel, scaled to ``A`` x unit
noise on a flat background, each 13 x 13 crop centred on its brightest pixel as the console's
crop log centres them; fits the PSF to all the stops pooled as the console does
(``psf_estimate.estimate_psf``: the drone a square of side D) and measures the phases with the
fitted PSF (``psf_estimate.observed_phases``; ``--blur B``: with the Airy and a blur of B px
instead). Prints one JSON object: the twin's blur, the
fitted one, and per stop the measured phases' error against the rendered ones (median |folded
error|, mean folded error per axis, px: negative is toward the pixel's centre).
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from snrmon.acquisition.calibrate.psf_estimate import (
    StopCrops,
    estimate_psf,
    observed_phases,
    psf_from_record,
)
from snrmon.model.presets import load_sensor, load_target
from snrmon.sim.optics import TWIN_ABERRATION_PX, TwinSpread, twin_optics
from snrmon.sim.silhouette import silhouette_for

FIELD_HALF = 10  # the rendered field around the drone's nearest pixel (px)
CROP_HALF = 6  # the console's crops: 13 x 13


def _folded(p: np.ndarray) -> np.ndarray:
    """Offsets from a pixel centre folded into the half cell [0, 0.5] (as the model bins them)."""
    return np.abs((p + 0.5) % 1.0 - 0.5)


def _stop(spread: TwinSpread, d_px: float, amplitude: float, rng) -> tuple[StopCrops, np.ndarray]:
    """100 crops of the drone ``d_px`` across at uniform phases, and each one's true offset
    from its crop's centre pixel (x, y)."""
    n, c = 100, FIELD_HALF
    phases = rng.uniform(-0.5, 0.5, size=(n, 2))
    crops = np.empty((n, 2 * CROP_HALF + 1, 2 * CROP_HALF + 1))
    offsets = np.empty((n, 2))
    for k, (x, y) in enumerate(phases):
        fractions = spread.fractions(x, y, d_px)
        h = min((fractions.shape[0] - 1) // 2, c)
        mid = (fractions.shape[0] - 1) // 2
        field = np.zeros((2 * c + 1, 2 * c + 1))
        field[c - h : c + h + 1, c - h : c + h + 1] = fractions[
            mid - h : mid + h + 1, mid - h : mid + h + 1
        ]
        image = amplitude * field + rng.standard_normal(field.shape)
        window = image[c - 1 : c + 2, c - 1 : c + 2]
        iy, ix = np.unravel_index(int(np.argmax(window)), window.shape)
        cy, cx = c - 1 + int(iy), c - 1 + int(ix)  # the brightest pixel, as the crop log's peak
        crops[k] = image[cy - CROP_HALF : cy + CROP_HALF + 1, cx - CROP_HALF : cx + CROP_HALF + 1]
        offsets[k] = (x - (cx - c), y - (cy - c))
    return StopCrops(f"D {d_px:g} px", crops, d_px), offsets


def figures(
    camera: str, sizes_px: list[float], amplitude: float, seed: int, blur_px: float | None = None
) -> dict:
    """The module docstring's figures for ``camera``'s twin at these stop sizes (the phases
    measured with the Airy and ``blur_px`` instead of the fitted PSF where given)."""
    sensor, target = load_sensor(camera), load_target("uav1")
    optics = twin_optics(sensor, 308.0, 280.0)
    spread = TwinSpread(optics, silhouette_for(target), target.small_m)
    rng = np.random.default_rng(seed)
    stops = [_stop(spread, d, amplitude, rng) for d in sizes_px]
    fit = estimate_psf([s for s, _ in stops], sensor)
    psf = psf_from_record(fit.as_dict() | ({} if blur_px is None else {"blur_px": blur_px}))
    per_stop = []
    for stop, true in stops:
        err = _folded(observed_phases(stop, psf, sensor.fill_factor)) - _folded(true)
        per_stop.append(
            {
                "d_px": stop.target_px,
                "phase_error_median_abs_px": round(float(np.median(np.abs(err))), 4),
                "phase_error_mean_px": [round(float(v), 4) for v in err.mean(axis=0)],
            }
        )
    return {
        "camera": camera,
        "twin_blur_px": TWIN_ABERRATION_PX.get(camera, 0.0),
        "fitted_blur_px": round(fit.blur_px, 4),
        "stops": per_stop,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("camera", choices=sorted(TWIN_ABERRATION_PX))
    parser.add_argument("--sizes", default="0.46,0.40,0.34", help="stop sizes in px, D,D,...")
    parser.add_argument("--amplitude", type=float, default=200.0, help="drone light / noise")
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument(
        "--blur", type=float, default=None, help="measure the phases with this blur"
    )
    args = parser.parse_args(argv)
    sizes = [float(v) for v in args.sizes.split(",")]
    print(json.dumps(figures(args.camera, sizes, args.amplitude, args.seed, args.blur)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
