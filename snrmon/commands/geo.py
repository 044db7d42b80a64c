"""``snrmon geo``: project a GPS position into a camera, and calibrate a camera's pointing.

``snrmon geo pixel --site LAT,LON,ALT --pointing AZ,EL,ROLL --sensor mwir|lwir|FILE
--target-at LAT,LON,ALT [--json]`` prints, with ``--json``, exactly
``{"x": float, "y": float, "range_m": float, "in_view": bool}`` (x column, y row, zero-based;
x and y are ``null`` when the target is behind the camera). ``--intrinsics F_M,PITCH_UM,W,H`` gives
the intrinsics directly instead of a sensor preset.

``snrmon geo calibrate --pairs FILE.csv --site LAT,LON,ALT --sensor ... [--initial AZ,EL,ROLL]
[--json]``: least-squares pointing from a CSV with the header ``x_px,y_px,lat_deg,lon_deg,alt_m``
(one tracked pixel and its GPS position per row); prints the pointing and the residual in pixels.

Angles are degrees; conventions in :mod:`snrmon.acquisition.geo.projection`.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path
from typing import TYPE_CHECKING

from snrmon.cli import UsageError
from snrmon.inputs import input_file
from snrmon.output import emit_json

if TYPE_CHECKING:  # imported when a subcommand runs: `--help` starts at once
    from snrmon.acquisition.geo.projection import CameraIntrinsics

PAIR_COLUMNS = ("x_px", "y_px", "lat_deg", "lon_deg", "alt_m")


# Options are parsed in run(), not by argparse types, so a bad value is one line on stderr
# (argparse would add its usage block).


def camera_of(text: str) -> CameraIntrinsics:
    """``F_M,PITCH_UM,W,H`` -> intrinsics; anything else is a ValueError naming --intrinsics."""
    from snrmon.acquisition.geo.projection import CameraIntrinsics

    parts = text.split(",")
    try:
        if len(parts) != 4:
            raise ValueError
        f_m, pitch_um, w, h = float(parts[0]), float(parts[1]), int(parts[2]), int(parts[3])
    except ValueError:
        raise ValueError(
            f"--intrinsics must be F_M,PITCH_UM,W,H (e.g. 0.016,8,1280,720), got {text!r}"
        ) from None
    return CameraIntrinsics(f_m, pitch_um * 1e-6, w, h)


def intrinsics_of(args: argparse.Namespace) -> CameraIntrinsics:
    """The intrinsics from ``--intrinsics`` or from the sensor preset/file of ``--sensor``."""
    from snrmon.acquisition.geo.projection import CameraIntrinsics

    if args.intrinsics is not None:
        return camera_of(args.intrinsics)
    if args.sensor is None:
        raise UsageError("give --sensor mwir|lwir|FILE or --intrinsics F_M,PITCH_UM,W,H")
    try:
        from snrmon.model.presets import load_sensor
    except ImportError as exc:
        raise UsageError(
            f"--sensor needs the sensor presets (model.presets), not available here: {exc}; "
            "use --intrinsics F_M,PITCH_UM,W,H"
        ) from None
    return CameraIntrinsics.from_sensor(load_sensor(args.sensor))


def _add_camera_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--site",
        required=True,
        metavar="LAT,LON,ALT",
        help="camera position: degrees, degrees, metres (same datum as the GPS)",
    )
    p.add_argument("--sensor", metavar="mwir|lwir|FILE", help="sensor preset or TOML file")
    p.add_argument(
        "--intrinsics",
        metavar="F_M,PITCH_UM,W,H",
        help="intrinsics given directly instead of --sensor",
    )
    p.add_argument("--json", action="store_true", help="print JSON on stdout")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("geo", help="GPS position -> camera pixel; pointing calibration")
    geo_sub = p.add_subparsers(dest="geo_command", metavar="SUBCOMMAND", required=True)

    px = geo_sub.add_parser(
        "pixel",
        help="where a GPS position lands in a camera",
        description=(
            "Project a geodetic target into a camera: azimuth clockwise from north, elevation "
            "above the horizon, roll positive clockwise seen from behind the camera; x = column, "
            "y = row (down), optical axis at ((W-1)/2, (H-1)/2)."
        ),
    )
    _add_camera_options(px)
    px.add_argument("--pointing", required=True, metavar="AZ,EL,ROLL", help="degrees")
    px.add_argument(
        "--target-at",
        required=True,
        metavar="LAT,LON,ALT",
        help="the target's position: degrees, degrees, metres",
    )
    px.set_defaults(func=run_pixel)

    cal = geo_sub.add_parser(
        "calibrate",
        help="least-squares pointing from (pixel, GPS) pairs",
        description="CSV header: " + ",".join(PAIR_COLUMNS) + "; at least 3 rows.",
    )
    _add_camera_options(cal)
    cal.add_argument("--pairs", type=Path, required=True, metavar="FILE.csv", help="the pairs")
    cal.add_argument(
        "--initial",
        metavar="AZ,EL,ROLL",
        help="starting pointing in degrees (default: mean line of sight)",
    )
    cal.set_defaults(func=run_calibrate)


def run_pixel(args: argparse.Namespace) -> int:
    from snrmon.acquisition.geo.projection import Pointing, Site, parse_triple, project_to_pixel

    cam = intrinsics_of(args)
    site = Site(*parse_triple(args.site, "--site"))
    pointing = Pointing(*parse_triple(args.pointing, "--pointing"))
    p = project_to_pixel(site, pointing, cam, *parse_triple(args.target_at, "--target-at"))
    if args.json:
        return emit_json({"x": p.x, "y": p.y, "range_m": p.range_m, "in_view": p.in_view})
    else:
        where = "behind the camera" if math.isnan(p.x) else f"x={p.x:.2f}  y={p.y:.2f}"
        seen = "in view" if p.in_view else "NOT in view"
        print(f"{where}  range={p.range_m:.2f} m  ({seen}, {cam.width_px}x{cam.height_px})")
    return 0


def read_pairs(path: Path) -> list[tuple[float, float, float, float, float]]:
    """Rows of a pairs CSV (header :data:`PAIR_COLUMNS`) as floats; bad rows are a ValueError
    naming the file and line."""
    from snrmon.acquisition.config import utf8_text

    with io.StringIO(utf8_text(path, "--pairs"), newline="") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in PAIR_COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: missing column(s) {', '.join(missing)}")
        rows = []
        for row in reader:
            try:
                rows.append(tuple(float(row[c]) for c in PAIR_COLUMNS))
            except (TypeError, ValueError):
                raise ValueError(f"{path}, line {reader.line_num}: not numbers: {row}") from None
    return rows  # type: ignore[return-value]


def run_calibrate(args: argparse.Namespace) -> int:
    from snrmon.acquisition.geo.pointing import calibrate_pointing
    from snrmon.acquisition.geo.projection import Pointing, Site, parse_triple

    cam = intrinsics_of(args)
    site = Site(*parse_triple(args.site, "--site"))
    initial = (
        Pointing(*parse_triple(args.initial, "--initial")) if args.initial is not None else None
    )
    fit = calibrate_pointing(read_pairs(input_file(args.pairs, "--pairs")), site, cam, initial)
    if args.json:
        return emit_json(
            {
                "az_deg": fit.az_deg,
                "el_deg": fit.el_deg,
                "roll_deg": fit.roll_deg,
                "residual_px_rms": fit.residual_px_rms,
                "residual_px_max": fit.residual_px_max,
                "residuals_px": list(fit.residuals_px),
                "n_pairs": fit.n_pairs,
            }
        )
    else:
        print(
            f"pointing az={fit.az_deg:.4f} el={fit.el_deg:.4f} roll={fit.roll_deg:.4f} deg  "
            f"residual rms={fit.residual_px_rms:.2f} px max={fit.residual_px_max:.2f} px "
            f"({fit.n_pairs} pairs)"
        )
    return 0
