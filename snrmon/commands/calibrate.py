"""``snrmon calibrate``: per-pixel radiometric calibration from blackbody stacks.

    snrmon calibrate --sensor mwir --blackbody T1.npy:15 --blackbody T2.npy:40 -o CAL.npz [--json]

Each ``--blackbody`` is a stack file (any format of ``acquisition.replay.stack_io.load_stack``) and
the
blackbody temperature in degrees C. Writes CAL.npz and CAL.toml and prints the quality report
(residual non-uniformity in DN and mK, fit residual, measured NETD beside Table 1's) and each
capture's 3D noise (bias-corrected components with 95 % intervals) with the NETD from its
sigma_tvh. With ``--json`` the report is the JSON of ``CalibrationQuality.as_dict()`` plus
``"file"`` (per temperature ``sigma_tvh_dn``, ``netd_tvh_mk``, ``netd_tvh_ci95_mk`` and
``noise_3d``, the fields of ``snrmon noise --json``).
"""

from __future__ import annotations

import argparse

from snrmon.cli import UsageError
from snrmon.inputs import output_file, stack_file
from snrmon.output import emit_json


def _blackbody(text: str) -> tuple[str, float]:
    path, sep, temp = text.rpartition(":")
    try:
        if not sep or not path:
            raise ValueError
        return path, float(temp)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--blackbody must be STACK:TEMP_C (e.g. bb15.npy:15), got {text!r}"
        ) from None


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="radiometric calibration from blackbody stacks")
    p.add_argument(
        "--sensor", required=True, metavar="mwir|lwir|FILE", help="sensor preset or TOML file"
    )
    p.add_argument(
        "--blackbody",
        type=_blackbody,
        action="append",
        required=True,
        metavar="STACK:TEMP_C",
        help="a stack of the blackbody and its temperature in C (repeat: two or more)",
    )
    p.add_argument(
        "-o", "--out", required=True, metavar="PATH", help="calibration file to write (.npz)"
    )
    p.add_argument("--json", action="store_true", help="print the quality report as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from snrmon.acquisition.calibrate.calibration import BlackbodyCapture, calibrate_sensor
    from snrmon.acquisition.calibrate.calibration_file import save_calibration
    from snrmon.acquisition.calibrate.quality import calibration_quality
    from snrmon.acquisition.replay.stack_io import load_stack
    from snrmon.model.constants import ZERO_C_K
    from snrmon.model.presets import load_sensor

    sensor = load_sensor(args.sensor)
    if not str(args.out).endswith(".npz"):
        raise UsageError(f"-o/--out must name a .npz file, got {args.out!r}")
    output_file(args.out, "-o/--out")
    for path, _ in args.blackbody:
        stack_file(path, "--blackbody")
    captures = [
        BlackbodyCapture(temp_c + ZERO_C_K, load_stack(path)) for path, temp_c in args.blackbody
    ]
    cal = calibrate_sensor(captures, sensor)
    path = save_calibration(cal, args.out)
    q = calibration_quality(cal, captures, sensor.netd_mk)
    if args.json:
        return emit_json({"file": str(path), **q.as_dict()})
    print(f"calibration of {cal.camera} written to {path} (+ {path.with_suffix('.toml').name})")
    print(
        f"bad pixels: {q.bad_counts['total']} (dead {q.bad_counts['dead']}, hot "
        f"{q.bad_counts['hot']}, noisy {q.bad_counts['noisy']}); fit residual median "
        f"{q.fit_rms_median_dn:.2f} DN, max {q.fit_rms_max_dn:.2f} DN"
    )
    print(
        " T [C]   raw FPN  corrected  temporal  residual     residual  NETD meas  sigma_tvh  "
        "NETD tvh  Table 1"
    )
    print(
        "          [DN]      [DN]       [DN]      [DN]         [mK]       [mK]       [DN]  "
        "    [mK]     [mK]"
    )
    for r in q.temperatures:
        print(
            f"{r.temp_k - ZERO_C_K:6.2f} {r.raw_spatial_dn:9.2f} {r.corrected_spatial_dn:10.2f} "
            f"{r.temporal_noise_dn:9.2f} {r.residual_fpn_dn:9.2f} {r.residual_fpn_mk:12.1f} "
            f"{r.netd_mk:10.1f} {r.sigma_tvh_dn:10.3f} {r.netd_tvh_mk:9.1f} "
            f"{q.netd_table_mk:8.1f}"
        )
    comps = ("t", "v", "h", "tv", "th", "vh", "tvh", "total")
    print("3D noise of the blackbody frames, bias-corrected [DN] (95 % interval of sigma_tvh):")
    print(" T [C]  frames " + " ".join(f"{c:>7}" for c in comps))
    for r in q.temperatures:
        n = r.noise_3d
        lo, hi = n["ci95_dn"]["tvh"]
        values = " ".join(f"{n['sigma_corrected_dn'][c]:7.3f}" for c in comps)
        print(f"{r.temp_k - ZERO_C_K:6.2f} {n['frames']:7d} {values}  ({lo:.3f}-{hi:.3f})")
    return 0
