"""The campaign report (PDF or PNG): every session's stops against the model, and the fit
statistics per session.

Pages (8.5 x 11 in, :func:`snrmon.acquisition.report.plot.write_pages`):

1. summary: the settings, the sessions and the failures, and per session and camera the fit
   statistics against the corrected small-dimension curve (the paper's best fit, section 9):
   the number of stops with a range and a measurement, the median and geometric-mean ratio
   measured / model, the RMS of log10 of that ratio (dex), and the fraction of stops whose mean
   lies inside the curve's Fig. 12 band;
2. per camera, sensor and target: measured peak SNR (mean, error bar = sample std over the
   stop's 100 frames) against range for every session (one marker and colour each) over the
   model's four curves and the bands of the corrected ones (paper Figs. 7-10 and 12), with the
   analysis's model options.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np

from snrmon.acquisition.prediction import CURVES
from snrmon.acquisition.report.data import model_curves, model_range_grid
from snrmon.acquisition.report.plot import _STYLE, _figure, _fmt, draw_table, write_pages

FIT_CURVE = "small_corrected"
MARKERS = "osD^v<>pPX*h"
# Not the model curves' blue and orange: a session's points never read as a curve's.
SESSION_COLOURS = (
    "k",
    "tab:green",
    "tab:red",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:olive",
    "tab:cyan",
    "tab:gray",
)


def fit_statistics(rows: list[dict], curves: dict) -> list[dict]:
    """Per (session, camera): the fit of its stops to :data:`FIT_CURVE` (module docstring).
    ``curves[(camera, sensor, target)]`` is the :class:`ModelCurves` the band comes from."""
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in rows:
        groups[(r["session"], r["camera"])].append(r)
    out = []
    for (session, camera), rs in sorted(groups.items()):
        ok = [
            r
            for r in rs
            if r["range_m"]
            and r["snr_mean"] is not None
            and r[f"model_{FIT_CURVE}"]
            and r["snr_mean"] > 0
        ]
        ratios = np.array([r["snr_mean"] / r[f"model_{FIT_CURVE}"] for r in ok])
        inside = []
        for r in ok:
            m = curves.get((r["camera"], r["sensor"], r["target"]))
            if m is not None and FIT_CURVE in m.lower:
                x = np.log(r["range_m"])
                lo = np.interp(x, np.log(m.ranges_m), m.lower[FIT_CURVE])
                hi = np.interp(x, np.log(m.ranges_m), m.upper[FIT_CURVE])
                inside.append(lo <= r["snr_mean"] <= hi)
        log_r = np.log10(ratios) if len(ratios) else ratios
        out.append(
            {
                "session": session,
                "camera": camera,
                "stops": len(rs),
                "fitted": len(ok),
                "median_ratio": float(np.median(ratios)) if len(ratios) else None,
                "geomean_ratio": float(10 ** np.mean(log_r)) if len(ratios) else None,
                "rms_log10_ratio": float(np.sqrt(np.mean(log_r**2))) if len(ratios) else None,
                "in_band": (sum(inside) / len(inside)) if inside else None,
            }
        )
    return out


def campaign_curves(rows: list[dict], model_options: dict) -> dict:
    """The model curves of each (camera, sensor, target) in the table, over a range grid that
    holds every stop."""
    grid = model_range_grid([r["range_m"] for r in rows if r["range_m"]])
    keys = sorted({(r["camera"], r["sensor"], r["target"]) for r in rows})
    return {k: model_curves(k[0], k[1], k[2], grid, **model_options) for k in keys}


def _summary_page(rows, fits, settings: dict, campaign: dict):
    fig = _figure()
    fig.text(0.06, 0.96, "snrmon campaign report", fontsize=14, weight="bold")
    sessions = campaign.get("sessions", [])
    failures = campaign.get("failures", [])
    lines = [
        f"{len(sessions)} sessions, {len(rows)} stop rows, {len(failures)} failed tasks; run on "
        f"{campaign.get('executor')} in {campaign.get('seconds', 0):.1f} s",
        "SNR = (peak - mean(bg)) / std(bg) per frame (Eq. 4), mean and sample std over the first "
        "100 consecutive valid frames of each stop.",
        f"fit: measured mean / model '{FIT_CURVE}' at the stop's range (rangefinder, else GPS); "
        "in band: inside the curve's Fig. 12 band.",
        f"settings: {settings.get('source') or 'as recorded in each session'}",
        f"  measurement {settings.get('measurement') or '(recorded)'}; calibrations "
        f"{settings.get('calibrations') or '(recorded)'}",
        f"  model target {settings.get('target') or '(recorded)'}, sensors "
        f"{settings.get('sensors') or '(recorded)'}, options {settings.get('model_options') or {}}"
        f"; track {settings.get('track')}, fast {settings.get('fast')}",
    ]
    for f in failures[:6]:
        cam = f" {f['camera']}" if f.get("camera") else ""
        lines.append(f"FAILED {f['session']}{cam}: {f['error']}"[:150])
    for i, line in enumerate(lines):
        fig.text(0.06, 0.925 - 0.02 * i, line, fontsize=7.5)
    head = ["session", "camera", "stops", "fitted", "median ratio", "geomean", "rms dex", "in band"]
    cells = [
        [
            f["session"][-28:],
            f["camera"],
            str(f["stops"]),
            str(f["fitted"]),
            _fmt(f["median_ratio"], ".3f"),
            _fmt(f["geomean_ratio"], ".3f"),
            _fmt(f["rms_log10_ratio"], ".3f"),
            "-" if f["in_band"] is None else f"{100 * f['in_band']:.0f}%",
        ]
        for f in fits
    ]
    draw_table(
        fig,
        (0.04, 0.05, 0.92, 0.7),
        head,
        cells,
        max_rows=45,
        fontsize=7,
        more="more sessions' rows in stops.parquet",
        empty="no stop was found in any session",
    )
    return fig


def _curves_axes(ax, rows: list[dict], m, sessions: list[str]) -> None:
    for curve in CURVES:
        color, ls, label = _STYLE[curve]
        ax.plot(m.ranges_m, m.snr[curve], color=color, ls=ls, lw=1.2, label=f"{label} {m.target}")
        if curve in m.lower:
            ax.fill_between(m.ranges_m, m.lower[curve], m.upper[curve], color=color, alpha=0.12)
    colours = [SESSION_COLOURS[i % len(SESSION_COLOURS)] for i in range(len(sessions))]
    for i, s in enumerate(sessions):
        pts = [r for r in rows if r["session"] == s and r["range_m"] and r["snr_mean"] is not None]
        if not pts:
            continue
        rng = np.array([r["range_m"] for r in pts])
        mean = np.array([r["snr_mean"] for r in pts])
        std = np.array([r["snr_std"] if r["snr_std"] is not None else math.nan for r in pts])
        ax.errorbar(
            rng,
            mean,
            yerr=np.nan_to_num(std),
            fmt=MARKERS[i % len(MARKERS)],
            color=colours[i],
            ms=4,
            capsize=2,
            label=s[-24:],
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("peak SNR")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, loc="lower left", ncol=2)
    ax.set_title(
        f"{m.camera} ({m.sensor}) - target {m.target}; atmosphere {m.atmosphere}, "
        f"background {m.background_temp_k:.1f} K",
        fontsize=8.5,
    )


def report_pages(rows: list[dict], settings: dict, campaign: dict):
    curves = campaign_curves(rows, settings.get("model_options") or {}) if rows else {}
    yield _summary_page(rows, fit_statistics(rows, curves), settings, campaign)
    keys = list(curves)
    for i in range(0, len(keys), 2):
        fig = _figure()
        fig.suptitle("Campaign: measured peak SNR vs model (paper Figs. 7-10, 12)", fontsize=11)
        axes = fig.subplots(2, 1)
        for ax, key in zip(axes, keys[i : i + 2], strict=False):
            sub = [r for r in rows if (r["camera"], r["sensor"], r["target"]) == key]
            _curves_axes(ax, sub, curves[key], sorted({r["session"] for r in sub}))
        for ax in axes[len(keys[i : i + 2]) :]:
            ax.axis("off")
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        yield fig


def write_campaign_report(path: Path, rows: list[dict], settings: dict, campaign: dict) -> Path:
    return write_pages(report_pages(rows, settings, campaign), path)
