"""``snrmon noise``: the 3D noise of a stack, a recorded camera or blackbody frames.

    snrmon noise STACK [--frames START:STOP] [--roi X0,Y0,X1,Y1] [--calibration CAL.npz] [--json]
    snrmon noise SESSION.h5 [--camera NAME] [--frames START:STOP | --seconds START:STOP
                            | --stop N] [--roi ...]

D'Agostino and Webb's seven components (sigma_t ... sigma_tvh), each directional estimate and its
finite-size bias removed (Haefner and Burks) with a 95 % confidence interval, and the total
(:mod:`snrmon.acquisition.measure.noise3d`, docs/measurement.md). A STACK is any file
``snrmon measure`` reads (.npy, TIFF, .ptw, FLIR .seq/.csq/.fff/.jpg, raw + JSON, video); a
session file gives one camera's frames over a span of frames or seconds, or a stop's background:
the frames the stop's SNR summarises, in the largest region clear of the target (``--roi``
replaces it).

With a radiometric calibration (``--calibration``, or the one the session's camera was measured
with) every figure is also given in kelvin and NETD = sigma_tvh / SiTF, the SiTF [DN/K] being the
calibration's responsivity at the region's median apparent temperature.

JSON contract (``--json``), DN unless named otherwise::

    {"frames": T, "rows": V, "cols": H, "mean_dn": float,
     "sigma_dn": {"t", "v", "h", "tv", "th", "vh", "tvh", "total"},
     "sigma_corrected_dn": {... the same keys},
     "ci95_dn": {"t": [lo, hi], ... the same keys}}

and, with a calibration, ``"scene_temp_k"``, ``"sitf_dn_per_k"``, ``"netd_mk"``,
``"netd_ci95_mk"`` and ``"sigma_k"``, ``"sigma_corrected_k"``, ``"ci95_k"``.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

from snrmon.cli import UsageError
from snrmon.inputs import input_file, is_hdf5, session_file
from snrmon.output import emit_json

if TYPE_CHECKING:  # imported when the work runs: `--help` starts at once
    import numpy as np

    from snrmon.acquisition.measure.noise3d import Noise3d

FIGURE_NOTES = {
    "t": "frame-to-frame flicker",
    "v": "fixed row noise",
    "h": "fixed column noise",
    "tv": "row noise changing every frame",
    "th": "column noise changing every frame",
    "vh": "fixed pattern, pixel to pixel",
    "tvh": "random spatio-temporal noise",
    "total": "one pixel sample",
}


def _span(text: str) -> tuple[str, str]:
    lo, sep, hi = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(
            f"must be START:STOP (either may be left out), got {text!r}"
        )
    return lo.strip(), hi.strip()


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "noise",
        help="3D noise (seven components, bias-corrected, 95 %% intervals) of frames",
        description=(
            "The 3D noise (D'Agostino and Webb) of a stack file, a recorded camera or blackbody "
            "frames: the seven directional estimates, the bias-corrected ones with 95 %% "
            "intervals, the total, and NETD with a calibration. STACK: .npy, TIFF, .ptw, FLIR "
            ".seq/.csq/.fff/.jpg, raw + JSON, video, or a snrmon session file (.h5)."
        ),
    )
    p.add_argument("stack", metavar="STACK", help="the frames: a stack file or a session file")
    p.add_argument(
        "--frames",
        type=_span,
        metavar="START:STOP",
        help="frames START to STOP-1 (zero-based; either may be left out)",
    )
    p.add_argument(
        "--seconds",
        type=_span,
        metavar="START:STOP",
        help="session: the camera's frames from START to STOP seconds after its first frame",
    )
    p.add_argument(
        "--stop",
        type=int,
        metavar="N",
        help="session: stop N's summary frames, in the region clear of the target",
    )
    p.add_argument("--camera", metavar="NAME", help="session: the camera (needed if several)")
    p.add_argument(
        "--roi",
        metavar="X0,Y0,X1,Y1",
        help="the region (x columns, y rows, both corners included; default the whole frame)",
    )
    p.add_argument(
        "--calibration",
        metavar="CAL.npz",
        help="radiometric calibration for kelvin and NETD (default: the session camera's)",
    )
    p.add_argument("--json", action="store_true", help="print the JSON contract on stdout")
    p.set_defaults(func=run)


def _frame_range(span: tuple[str, str] | None, count: int, what: str) -> tuple[int, int]:
    if span is None:
        return 0, count
    try:
        lo = int(span[0]) if span[0] else 0
        hi = int(span[1]) if span[1] else count
    except ValueError:
        raise UsageError(
            f"{what} must be START:STOP with integers, got {':'.join(span)!r}"
        ) from None
    if not 0 <= lo < hi <= count:
        raise UsageError(
            f"{what} {':'.join(span)} is outside the {count} frames (0 <= START < STOP <= {count})"
        )
    return lo, hi


def _roi(text: str | None, shape: tuple[int, int]):
    from snrmon.acquisition.measure.background import parse_rect, validate_rect

    if text is None:
        return (0, 0, shape[1] - 1, shape[0] - 1)
    try:
        return validate_rect(parse_rect(text), shape, min_pixels=4)
    except ValueError as exc:
        raise UsageError(f"--roi: {str(exc).replace('background rectangle', 'region')}") from None


def _stack_noise(args: argparse.Namespace):
    """(source line, region, sums, (calibration, its source) or None) of a stack file."""
    from snrmon.acquisition.measure.noise3d import Noise3dSums
    from snrmon.acquisition.replay.stack_io import read_stack

    for opt in ("seconds", "stop", "camera"):
        if getattr(args, opt) is not None:
            raise UsageError(f"--{opt} needs a session file; {args.stack} is a stack")
    stack_file = read_stack(args.stack)
    stack = stack_file.frames
    lo, hi = _frame_range(args.frames, stack.shape[0], "--frames")
    region = _roi(args.roi, stack.shape[1:])
    x0, y0, x1, y1 = region
    sums = Noise3dSums(y1 - y0 + 1, x1 - x0 + 1)
    sums.add(stack[lo:hi, y0 : y1 + 1, x0 : x1 + 1])
    source = f"{Path(args.stack).name}: frames {lo}-{hi - 1}"
    if stack_file.camera_line():
        source += f", {stack_file.camera_line()}"
    calibration = None
    if args.calibration is not None:
        from snrmon.acquisition.calibrate.calibration_file import load_calibration

        shape = (int(stack.shape[1]), int(stack.shape[2]))
        calibration = load_calibration(args.calibration, frame_shape=shape), args.calibration
    return source, region, sums, calibration


def _camera(f, name: str | None):
    if name is None:
        if len(f.cameras) != 1:
            raise UsageError(
                f"the session holds cameras {', '.join(f.cameras)}: choose one with --camera"
            )
        name = next(iter(f.cameras))
    if name not in f.cameras:
        raise UsageError(f"--camera {name!r}: the session holds {', '.join(f.cameras)}")
    return f.cameras[name]


def _seconds_range(span: tuple[str, str], t_ns: np.ndarray) -> tuple[int, int]:
    import numpy as np

    try:
        lo = float(span[0]) if span[0] else 0.0
        hi = float(span[1]) if span[1] else np.inf
    except ValueError:
        raise UsageError(
            f"--seconds must be START:STOP in seconds, got {':'.join(span)!r}"
        ) from None
    t_s = (t_ns - t_ns[0]) / 1e9
    a, b = int(np.searchsorted(t_s, lo)), int(np.searchsorted(t_s, hi))
    if not (lo < hi and b - a >= 2):
        raise UsageError(
            f"--seconds {':'.join(span)} holds {max(b - a, 0)} frames (the camera's run "
            f"{t_s[-1]:.2f} s); 3D noise needs at least 2"
        )
    return a, b


def _session_noise(args: argparse.Namespace):
    """(source line, region, sums, (calibration, its source) or None) of a session's camera."""
    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.recorded import recorded_calibration, recorded_inputs
    from snrmon.acquisition.replay.stop_noise import (
        background_region,
        recorded_stop_run,
        region_sums,
    )

    chosen = [o for o in ("frames", "seconds", "stop") if getattr(args, o) is not None]
    if len(chosen) > 1:
        raise UsageError(f"give one of --frames, --seconds, --stop, not {' and '.join(chosen)}")
    with open_session(args.stack) as f:
        cam = _camera(f, args.camera)
        shape = (int(cam.frames.shape[1]), int(cam.frames.shape[2]))
        calibration = recorded_calibration(f, cam.name, args.calibration)
        name = f"{Path(args.stack).name} {cam.name}"
        if args.stop is not None:
            stops = {s.index: s for _, s in recorded_inputs(f).stops}
            if args.stop not in stops:
                have = ", ".join(map(str, sorted(stops)))
                what = f"records stops {have}" if stops else "records no stops (use --frames)"
                raise UsageError(f"--stop {args.stop}: {Path(args.stack).name} {what}")
            s = stops[args.stop]
            index, run = recorded_stop_run(cam, s.t_start_ns, s.t_end_ns)
            if index.size < 2:
                raise UsageError(
                    f"--stop {args.stop}: {index.size} valid measured frames of {cam.name} "
                    "(3D noise needs 2)"
                )
            region = _roi(args.roi, shape) if args.roi else background_region(shape, run)
            if region is None:
                raise UsageError(f"--stop {args.stop}: no region clear of the target: give --roi")
            source = f"{name}, stop {args.stop}: frames {index[0]}-{index[-1]}"
            return source, region, region_sums(cam, index, region), calibration
        if args.seconds is not None:
            lo, hi = _seconds_range(args.seconds, cam.t_host_ns)
        else:
            lo, hi = _frame_range(args.frames, cam.n_frames, "--frames")
        if hi - lo < 2:
            raise UsageError(f"{name}: {hi - lo} frames; 3D noise needs 2")
        region = _roi(args.roi, shape)
        source = f"{name}: frames {lo}-{hi - 1}"
        return source, region, region_sums(cam, range(lo, hi), region), calibration


def _defined(noise: Noise3d) -> Noise3d:
    """``noise``, or with every figure NaN (JSON null, "n/a" in text) when a pixel of the frames
    is not a number: the sums are then NaN and the rounding floor would turn each figure into a
    0.0, which reads as a noiseless camera (all-NaN frames gave 0.0 within [0, 0])."""
    if math.isfinite(noise.mean):
        return noise
    nan = math.nan
    return dataclasses.replace(
        noise,
        sigma=dict.fromkeys(noise.sigma, nan),
        sigma_corrected=dict.fromkeys(noise.sigma_corrected, nan),
        ci95=dict.fromkeys(noise.ci95, (nan, nan)),
    )


def _number(value: float, width: int, digits: int) -> str:
    """``value`` in ``width`` characters, "n/a" when it is not a number."""
    return f"{value:{width}.{digits}f}" if math.isfinite(value) else f"{'n/a':>{width}}"


def _kelvin(calibration: tuple, region, mean_image: np.ndarray, noise) -> dict:
    """The kelvin figures and NETD from ``calibration``, (a calibration, its source) (module
    docstring)."""
    import numpy as np

    cal, source = calibration
    x0, y0, x1, y1 = region
    rows, cols = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
    temps = cal.pixels_temperature_k(mean_image.ravel(), rows.ravel(), cols.ravel())
    scene_k = float(np.nanmedian(temps)) if np.isfinite(temps).any() else float("nan")
    if not np.isfinite(scene_k):
        raise ValueError(f"{source}: the region's mean level is outside the calibration")
    sitf = cal.dn_per_k(scene_k)
    k = noise.scaled(1.0 / sitf)
    lo, hi = k.ci95["tvh"]
    return {
        "scene_temp_k": scene_k,
        "sitf_dn_per_k": sitf,
        "netd_mk": 1e3 * k.sigma_corrected["tvh"],
        "netd_ci95_mk": [1e3 * lo, 1e3 * hi],
        **k.figures("k"),
    }


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.measure.noise3d import FIGURES

    input_file(args.stack, "STACK")
    if is_hdf5(args.stack):
        session_file(args.stack, "STACK")  # a truncated or damaged one named, not an HDF5 error
        source, region, sums, calibration = _session_noise(args)
    else:
        source, region, sums, calibration = _stack_noise(args)
    if sums.frames < 2:
        raise UsageError(f"{source}: 3D noise needs at least 2 frames")
    noise = _defined(sums.result())
    out: dict = {
        "frames": noise.frames,
        "rows": noise.rows,
        "cols": noise.cols,
        "mean_dn": noise.mean,
        **noise.figures("dn"),
    }
    if calibration is not None:
        out.update(_kelvin(calibration, region, sums.mean_image(), noise))
    if args.json:
        return emit_json(out)
    x0, y0, x1, y1 = region
    print(
        f"{source}; region x {x0}-{x1}, y {y0}-{y1}: {noise.frames} frames x {noise.rows} rows x "
        f"{noise.cols} columns, mean {_number(noise.mean, 0, 2)} DN"
    )
    kelvin = "sigma_k" in out
    head = f"{'':>6} {'sigma':>10} {'corrected':>10} {'95 % interval':>21}"
    print(f"{head}  {'corrected':>10}" if kelvin else head)
    unit = f"{'':>6} {'[DN]':>10} {'[DN]':>10} {'[DN]':>21}"
    print(f"{unit}  {'[mK]':>10}" if kelvin else unit)
    for k in FIGURES:
        lo, hi = noise.ci95[k]
        line = (
            f"{k:>6} {_number(noise.sigma[k], 10, 4)} {_number(noise.sigma_corrected[k], 10, 4)} "
            f"{_number(lo, 10, 4)} - {_number(hi, 8, 4)}"
        )
        if kelvin:
            line += f"  {1e3 * out['sigma_corrected_k'][k]:10.2f}"
        print(f"{line}  {FIGURE_NOTES[k]}")
    if kelvin:
        lo, hi = out["netd_ci95_mk"]
        print(
            f"NETD = sigma_tvh / SiTF = {out['netd_mk']:.1f} mK (95 %: {lo:.1f}-{hi:.1f}); SiTF "
            f"{out['sitf_dn_per_k']:.2f} DN/K at {out['scene_temp_k']:.2f} K"
        )
    return 0
