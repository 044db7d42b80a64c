"""``snrmon measure``: paper Eq. (4) peak SNR on every frame of a stack file, with statistics.

JSON contract (``--json``), on stdout::

    {"n": N, "snr_mean": float, "snr_std": float,
     "frames": [{"index": i, "peak_x": int, "peak_y": int, "peak": float, "bg_mean": float,
                 "bg_std": float, "snr": float, "flags": [str, ...]}, ...]}

``snr_mean``/``snr_std`` (sample std, ddof=1) are over all frames whose SNR is defined (finite),
flagged or not; a value that is not a finite number (an undefined SNR) is written as ``null``.
The readable table adds the running mean/std over the last ``--window-frames`` valid frames.

``--track`` runs :func:`snrmon.acquisition.track.tracker.track_stack` from ``--at`` (the compact
object nearest the click, followed, measured against the background its extent allows, found
again after a loss; docs/tracking.md) instead of keeping the window fixed. The contract is the
same, the frames carry the tracker's flags (``lost``, ``gps_cued``) and each frame gains
``"background"`` (``"rim"``, ``"extent_rim"`` or ``"rect"``: what bg_mean and bg_std are of),
``"extent_w_px"``, ``"extent_h_px"`` (the segmented target's box, 0 when not segmented) and
``"track_state"`` (``"tracking"``, ``"occluded"``, ``"lost"``, ``"reacquiring"`` or
``"gps_cued"``: the state after that frame). A click with no compact object near it (a
saturated region, empty sky) is bad input: one line, exit 2.
"""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING

from snrmon.cli import UsageError
from snrmon.inputs import Number
from snrmon.limits import MAX_FRAME_PX, MAX_WINDOW_FRAMES
from snrmon.output import emit_json

if TYPE_CHECKING:  # the work's modules are imported when it runs: `--help` starts at once
    import numpy as np

    from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrMeter
    from snrmon.acquisition.measure.stack_snr import StackSnr
    from snrmon.acquisition.track.tracker import TrackStep


def _point(text: str) -> tuple[int, int]:
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        return int(parts[0]), int(parts[1])
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be X,Y (two integers), got {text!r}") from None


# An odd side in pixels, up to the largest frame (a box of a million pixels a side was a
# MemoryError); the frame's own size is checked when the stack is read.
ODD_PX = Number(1, MAX_FRAME_PX - 1, integer=True, odd=True, unit="px")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "measure",
        help="peak-pixel SNR (paper Eq. 4) of a target in a stack file",
        description=(
            "Per frame: the brightest pixel in a search window centred on X,Y; the box centred on "
            "it; SNR = (peak - mean(rim)) / std(rim), sample std (ddof=1). X is the column, Y the "
            "row, zero-based. STACK: .npy (N,H,W) or (H,W), multi-page TIFF, an Altair/ResearchIR "
            ".ptw recording, a FLIR .seq/.csq/.fff/radiometric .jpg (raw counts), PNG, a raw file "
            "with FILE.json beside it, or a video (8-bit)."
        ),
    )
    p.add_argument("stack", metavar="STACK", help="the frames")
    p.add_argument("--at", type=_point, required=True, metavar="X,Y", help="operator's point")
    p.add_argument(
        "--search",
        type=ODD_PX,
        default=11,
        metavar="N",
        help="search window's side, pixels, odd (default: %(default)s)",
    )
    p.add_argument(
        "--box",
        type=ODD_PX,
        default=7,
        metavar="N",
        help="box size, pixels, odd (default: %(default)s)",
    )
    p.add_argument(
        "--background",
        default="rim",
        metavar="rim|X0,Y0,X1,Y1",
        help="background pixels: the box rim or a clear-sky rectangle, corners included "
        "(default: %(default)s)",
    )
    p.add_argument("--detrend", action="store_true", help="remove a plane from the background")
    p.add_argument(
        "--window-frames",
        type=Number(1, MAX_WINDOW_FRAMES, integer=True),
        default=100,
        metavar="N",
        help="running window, frames (default: %(default)s)",
    )
    p.add_argument(
        "--saturation",
        type=Number(-1e12, 1e12),
        default=None,
        metavar="DN",
        help="saturation level",
    )
    p.add_argument("--json", action="store_true", help="print the JSON contract on stdout")
    p.add_argument(
        "--track",
        action="store_true",
        help="follow the object clicked at --at (adds background, extent and track_state per "
        "frame; docs/tracking.md)",
    )
    p.set_defaults(func=run)


def _meter(args: argparse.Namespace, shape: tuple[int, int]) -> PeakSnrMeter:
    from snrmon.acquisition.measure.background import parse_rect, validate_rect
    from snrmon.acquisition.measure.peak_snr import PeakSnrMeter

    if args.box < 3:
        raise UsageError(f"--box must be an odd integer >= 3, got {args.box}")
    if args.window_frames < 1:
        raise UsageError(f"--window-frames must be a positive integer, got {args.window_frames}")
    rows, cols = shape
    if args.box > min(rows, cols):  # no rim inside the frame: every frame would be undefined
        raise UsageError(f"--box {args.box} is larger than the {cols}x{rows} frames")
    background = None
    if args.background != "rim":
        background = validate_rect(parse_rect(args.background), shape)
    x, y = args.at
    if not (0 <= x < cols and 0 <= y < rows):
        raise UsageError(
            f"--at {x},{y} is off the {cols}x{rows} image (x must be 0..{cols - 1}, "
            f"y 0..{rows - 1})"
        )
    return PeakSnrMeter(
        window=args.window_frames,
        search_px=args.search,
        box_px=args.box,
        background=background,
        detrend=args.detrend,
        saturation_dn=args.saturation,
    )


def _measure_frames(args: argparse.Namespace, stack: np.ndarray, meter: PeakSnrMeter) -> StackSnr:
    """The operator's point stays fixed (no tracking): the vectorised stack path."""
    from snrmon.acquisition.measure.stack_snr import measure_stack

    return measure_stack(stack, args.at, meter=meter)


def _track_frames(
    args: argparse.Namespace, stack: np.ndarray, meter: PeakSnrMeter
) -> tuple[list[PeakSnr], list[TrackStep]]:
    """The window follows the object (acquisition.track.tracker); the meter's settings carry
    over. A click the tracker finds nothing compact near is a UsageError."""
    from snrmon.acquisition.measure.peak_snr import saturation_level
    from snrmon.acquisition.track.tracker import Tracker, TrackerConfig, track_stack

    first = Tracker(args.at, measurement=meter.config).update(stack[0])
    if first.reason == "no_object":
        x, y = args.at
        value = stack[0][y, x]
        sat = saturation_level(meter.config, stack.dtype)
        why = (
            f"the click is on a saturated region ({value} DN)"
            if sat is not None and value >= sat
            else "nothing there stands out of its background as a compact object"
        )
        radius = TrackerConfig().click_radius_px
        raise UsageError(
            f"--at {x},{y}: no compact object within {radius} px of the click on frame 0 "
            f"({why}); click on the drone"
        )
    steps = track_stack(stack, args.at, measurement=meter.config)
    return [s.peak_snr for s in steps], steps


def _num(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _summary(snr: np.ndarray) -> tuple[float, float]:
    import numpy as np

    finite = snr[np.isfinite(snr)]
    mean = float(finite.mean()) if finite.size else math.nan
    std = float(finite.std(ddof=1)) if finite.size > 1 else math.nan
    return mean, std


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from snrmon.acquisition.measure.peak_snr import FLAG_NAMES, RUNNING_EXCLUDED
    from snrmon.acquisition.measure.running_stats import RunningSnr
    from snrmon.acquisition.replay.stack_io import load_stack
    from snrmon.inputs import stack_file

    stack = load_stack(stack_file(args.stack))
    meter = _meter(args, stack.shape[1:])
    steps: list[TrackStep] | None = None
    if getattr(args, "track", False):
        results, steps = _track_frames(args, stack, meter)
        running = RunningSnr(args.window_frames)
        for r in results:
            if not r.flags & RUNNING_EXCLUDED:
                running.push(r.snr)
    else:
        stack_result = _measure_frames(args, stack, meter)
        results, running = stack_result.to_list(), meter.running
    snr = np.array([r.snr for r in results], dtype=float)
    mean, std = _summary(snr)
    if args.json:
        frames = []
        for i, r in enumerate(results):
            frame = {
                "index": i,
                "peak_x": r.peak_x,
                "peak_y": r.peak_y,
                "peak": _num(r.peak),
                "bg_mean": _num(r.bg_mean),
                "bg_std": _num(r.bg_std),
                "snr": _num(r.snr),
                "flags": [f for f in FLAG_NAMES if f in r.flags],
            }
            if steps is not None:
                frame["background"] = r.background
                frame["extent_w_px"] = r.extent_w_px
                frame["extent_h_px"] = r.extent_h_px
                frame["track_state"] = steps[i].state.value
            frames.append(frame)
        out = {"n": len(results), "snr_mean": _num(mean), "snr_std": _num(std), "frames": frames}
        return emit_json(out)
    state_head = f" {'background':>10} {'state':>11}" if steps is not None else ""
    print(
        f"{'frame':>6} {'x':>5} {'y':>5} {'peak':>10} {'bg_mean':>10} {'bg_std':>8} "
        f"{'snr':>8}{state_head}  flags"
    )
    for i, r in enumerate(results):
        flags = ",".join(f for f in FLAG_NAMES if f in r.flags)
        state = f" {r.background:>10} {steps[i].state.value:>11}" if steps is not None else ""
        print(
            f"{i:6d} {r.peak_x:5d} {r.peak_y:5d} {r.peak:10.2f} {r.bg_mean:10.2f} "
            f"{r.bg_std:8.3f} {r.snr:8.3f}{state}  {flags}"
        )
    finite = int(np.isfinite(snr).sum())
    print(f"all frames: n={len(results)} (defined {finite})  SNR mean {mean:.3f}  std {std:.3f}")
    print(
        f"running, last {running.count} valid of window {running.window}: "
        f"SNR mean {running.mean:.3f}  std {running.std:.3f}"
    )
    return 0
