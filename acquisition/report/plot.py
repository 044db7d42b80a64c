"""The report's pages drawn with matplotlib (Agg, no display): a PDF of pages or one tall PNG.

Pages, in order (all 8.5 x 11 in):

1. summary: session, target, sensors and the stop table (the CSV's numbers, rounded);
2. the 3D noise of each stop's background per camera (bias-corrected components, the 95 %
   interval of sigma_tvh, sqrt(sigma_tvh^2 + sigma_vh^2)) and per camera over its stops, and
   which noise the model's values use (its own, or the measured one);
3. Figs. 7-10: per camera, measured peak SNR (mean, error bar = the error of the mean with
   the frames' autocorrelation) against range over the model's continuous curves (small/large x
   uncorrected solid / corrected dashed), their Monte-Carlo band, the expected Eq. (4) reading,
   the paper's switched curves dotted (``paper_curves``), the D = 1 px ranges as dotted
   verticals and the chi^2/dof of the unresolved stops against each curve; two cameras a page;
4. the paper's reference numbers beside ours with the reasons, and Pd versus range;
5. Fig. 12: the uncertainty budget per camera, term by term, at each stop's range;
6. Fig. 6: per stop, one column per camera, rows peak value, background mean, background std,
   peak SNR over the stop's 100 frames.

``.pdf`` writes every page into one file (``PdfPages``). ``.png`` writes ONE tall image: the
same pages stacked top to bottom, so a report is always one file whatever its format.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from snrmon.acquisition.prediction import CURVES
from snrmon.acquisition.report.data import BUDGET_TERMS, ReportData, StopSeries

PAGE_IN = (8.5, 11.0)
PNG_DPI = 100
_STYLE = {  # as model/plot.py draws them, so the report's curves read the same
    "small": ("tab:blue", "-", "model small"),
    "large": ("tab:orange", "-", "model large"),
    "small_corrected": ("tab:blue", "--", "corrected small"),
    "large_corrected": ("tab:orange", "--", "corrected large"),
    "expected_eq4_rim": ("grey", "-.", "expected Eq. (4), paper's 7x7 rim"),
    "expected_eq4_extent": ("black", "-.", "expected Eq. (4), console's target-aware rim"),
}
_PAPER_STYLE = {
    "paper_small": ("tab:blue", "paper's switched small"),
    "paper_small_corrected": ("tab:cyan", "paper's switched corrected small"),
}
FORMATS = (".pdf", ".png")


def _figure():
    from matplotlib.figure import Figure

    return Figure(figsize=PAGE_IN, dpi=PNG_DPI)


def _background(methods: object) -> str:
    """A stop's background methods, short: rim, ext (extent_rim), rect; "--" when none."""
    if not methods:
        return "--"
    return str(methods).replace("extent_rim", "ext")


def _fmt(v, spec: str) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return format(v, spec)


def summary_page(data: ReportData):
    fig = _figure()
    fig.text(0.06, 0.96, "snrmon SNR-versus-range report", fontsize=14, weight="bold")
    sensors = ", ".join(f"{c}: {s}" for c, s in data.sensors.items())
    lines = [
        f"session: {data.path.name}",
        f"target: {data.target}    sensors: {sensors}",
        (
            f"recording {data.recording_seconds:.1f} s, replayed in {data.replay_seconds:.1f} s"
            if data.replay_seconds is not None
            else f"live session of {data.recording_seconds:.1f} s, as measured (not replayed)"
        )
        + f"; {len({r.stop for r in data.flight.rows})} stops",
        "SNR = (peak - mean(BG)) / std(BG) per frame (Eq. 4), mean and sample std over the "
        "first 100 consecutive valid frames of each stop.",
        "BG (column bg): rim = the 7x7 box's rim; ext = outside the segmented drone and a 2 px",
        "guard (a drone wider than the box); rect = the operator's clear-sky rectangle.",
        "small, large, ... corr: the model's four curves at the stop's range (rangefinder, else "
        "GPS); ratio = measured mean / model.",
        "exp rim / exp ext: the expected Eq. (4) reading with the paper's 7x7 rim / the console's "
        "rule (ext where the drone is wider",
        "than the box's 5x5 guard); rule: the one the stop's bg makes applicable; ratio exp = "
        "measured mean / that reading.",
    ]
    for i, line in enumerate(lines):
        fig.text(0.06, 0.925 - 0.022 * i, line, fontsize=8)
    head = ["stop", "camera", "LRF m", "GPS m", "n", "SNR", "std", "bg"]
    # short headers: the table's columns are narrow (the lines above spell out what they are)
    head += [c.replace("_corrected", " corr") for c in CURVES] + ["ratio s.corr"]
    head += ["exp rim", "exp ext", "rule", "ratio exp"]
    cells = []
    for r in data.csv_rows:
        cells.append(
            [
                str(r["stop"]),
                str(r["camera"]),
                _fmt(r["lrf_range_m"], ".1f"),
                _fmt(r["gps_range_m"], ".1f"),
                str(r["n_frames"]),
                _fmt(r["snr_mean"], ".2f"),
                _fmt(r["snr_std"], ".2f"),
                _background(r["background"]),
            ]
            + [_fmt(r[f"model_{c}"], ".1f") for c in CURVES]
            + [_fmt(r["ratio_small_corrected"], ".3f")]
            + [
                _fmt(r["model_expected_eq4_rim"], ".1f"),
                _fmt(r["model_expected_eq4_extent"], ".1f"),
            ]
            + [str(r["expected_eq4_rule"] or "-"), _fmt(r["ratio_expected_eq4"], ".3f")]
        )
    empty = "no range stop was found in this session"
    draw_table(
        fig,
        (0.04, 0.05, 0.92, 0.70),
        head,
        cells,
        max_rows=40,
        fontsize=6.5,
        more="more rows in the CSV",
        empty=empty,
    )
    return fig


NOISE_3D = ("t", "v", "h", "tv", "th", "vh", "tvh", "total")


def noise_page(data: ReportData):
    """The 3D noise table (module docstring, page 2)."""
    from snrmon.acquisition.report.data import camera_noise

    fig = _figure()
    fig.text(0.06, 0.96, "3D noise of the background (DN)", fontsize=14, weight="bold")
    if data.measured_noise:
        source = ["the model's noise is the MEASURED one (each camera's, all stops):"] + [
            f"    {c}: sigma_tvh {m.temporal_dn:.3f} DN, sigma_vh {m.spatial_dn:.3f} DN, "
            f"together {m.total_dn:.3f} DN"
            for c, m in data.measured_noise.items()
        ]
    else:
        source = ["the model's noise is its own (Eq. 1 and its spatial term), not these"]
    lines = [
        "D'Agostino and Webb's seven components of each stop's background, bias-corrected for "
        "the finite cube (Haefner",
        "and Burks): the stop's summary frames (its SNR's), the largest region clear of every "
        "peak by 20 px, raw pixels.",
        "pix = sqrt(tvh^2 + vh^2): a pixel's noise against its frame once row, column and frame "
        "offsets are gone (Eq. 4's rim).",
        "all stops: the root mean square over the camera's stops. docs/measurement.md gives the "
        "formulas.",
        *source,
    ]
    for i, line in enumerate(lines):
        fig.text(0.06, 0.925 - 0.022 * i, line, fontsize=8)
    head = ["stop", "camera", "range m", "frames", "region", *NOISE_3D, "tvh 95 %", "pix"]
    cells = []
    for s in data.flight.noise_3d:
        n = s.noise
        lo, hi = n.ci95["tvh"]
        cells.append(
            [
                str(s.stop),
                s.camera,
                _fmt(s.range_m, ".1f"),
                str(n.frames),
                f"{n.cols}x{n.rows}",
                *(_fmt(n.sigma_corrected[k], ".3f") for k in NOISE_3D),
                f"{lo:.3f}-{hi:.3f}",
                _fmt(n.peak_pixel_noise, ".3f"),
            ]
        )
    for cam, figures in camera_noise(data.flight.noise_3d).items():
        pix = math.hypot(figures["tvh"], figures["vh"])
        stops = sum(1 for s in data.flight.noise_3d if s.camera == cam)
        cells.append(
            ["all", cam, "-", f"{stops} stops", "-"]
            + [_fmt(figures[k], ".3f") for k in NOISE_3D]
            + ["-", _fmt(pix, ".3f")]
        )
    empty = (
        "no stop with a background clear of the target"
        if data.replay_seconds is not None
        else "a live report holds no frames: the 3D noise is in the report of the recording"
    )
    draw_table(
        fig,
        (0.02, 0.05, 0.96, 0.9 - 0.022 * len(lines)),
        head,
        cells,
        max_rows=44,
        fontsize=5.5,
        more="more rows",
        empty=empty,
    )
    return fig


def draw_table(fig, rect, head, cells, *, max_rows: int, fontsize: float, more: str, empty: str):
    """A table of text cells on its own axes (at most ``max_rows``; the rest counted)."""
    ax = fig.add_axes(rect)
    ax.axis("off")
    if not cells:
        ax.text(0.5, 0.9, empty, ha="center", fontsize=11)
        return
    table = ax.table(cellText=cells[:max_rows], colLabels=head, loc="upper center", cellLoc="right")
    table.auto_set_font_size(False)
    table.set_fontsize(fontsize)
    table.scale(1.0, 1.25)
    if len(cells) > max_rows:
        ax.text(0.5, 0.0, f"... {len(cells) - max_rows} {more}", ha="center")


def _snr_axes(ax, data: ReportData, camera: str, paper_curves: bool = True) -> None:
    m = data.model.curves[camera]
    for curve, (color, ls, label) in _STYLE.items():
        if curve not in m.snr:
            continue
        ax.plot(m.ranges_m, m.snr[curve], color=color, ls=ls, lw=1.2, label=f"{label} {m.target}")
        if curve in m.lower:
            ax.fill_between(m.ranges_m, m.lower[curve], m.upper[curve], color=color, alpha=0.12)
    if paper_curves:
        for curve, (color, label) in _PAPER_STYLE.items():
            if curve in m.snr:
                ax.plot(m.ranges_m, m.snr[curve], color=color, ls=":", lw=0.9, label=label)
    for rt, name in ((m.transition_small_m, "small"), (m.transition_large_m, "large")):
        if m.ranges_m[0] <= rt <= m.ranges_m[-1]:
            ax.axvline(rt, color="grey", ls=":", lw=1)
            ax.text(
                rt,
                0.98,
                f" {name} D = 1 px at {rt:.0f} m",
                rotation=90,
                va="top",
                fontsize=6.5,
                color="grey",
                transform=ax.get_xaxis_transform(),
            )
    p = data.flight.points[camera]
    if len(p.range_m):
        ax.errorbar(
            p.range_m,
            p.snr_mean,
            yerr=np.nan_to_num(p.snr_sem),
            fmt="ko",
            ms=4,
            capsize=3,
            label="measured (mean, error of the mean)",
        )
        partial = ~p.complete
        if partial.any():
            ax.plot(
                p.range_m[partial],
                p.snr_mean[partial],
                "o",
                mfc="none",
                mec="red",
                ms=9,
                label="fewer than 100 valid frames",
            )
    fits = [f for f in data.fits if f.camera == camera]
    if fits:
        text = "chi2/dof of the unresolved stops\n" + "\n".join(
            f"{f.curve}: {f.chi2_per_dof:.2f} (n={f.n_stops})" for f in fits
        )
        ax.text(
            0.99,
            0.99,
            text,
            transform=ax.transAxes,
            ha="right",
            va="top",
            fontsize=6,
            family="monospace",
            bbox={"fc": "white", "alpha": 0.8, "lw": 0.3},
        )
    ax.set_yscale("log")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("peak SNR")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, loc="lower left")
    ax.set_title(
        f"{camera} ({m.sensor}) - target {m.target}; atmosphere {m.atmosphere}, "
        f"background {m.background_temp_k:.1f} K\ncorrected curves' PSF: {m.psf_label}",
        fontsize=8.5,
    )


def reference_page(data: ReportData):
    """The paper's reference numbers beside ours, and Pd versus range (beyond the paper)."""
    fig = _figure()
    fig.suptitle("The paper's numbers beside ours; probability of detection", fontsize=11)
    ax = fig.add_axes((0.04, 0.55, 0.92, 0.38))
    ax.axis("off")
    cells = [[r.quantity, r.paper, r.ours, r.reason] for r in data.model.references]
    if cells:
        table = ax.table(
            cellText=cells,
            colLabels=["quantity", "paper", "ours", "why they differ"],
            loc="upper center",
            cellLoc="left",
            colWidths=[0.22, 0.1, 0.14, 0.54],
        )
        table.auto_set_font_size(False)
        table.set_fontsize(5.5)
        table.scale(1.0, 2.6)
        for (row, col), cell in table.get_celld().items():
            if col == 3 and row > 0:
                cell.get_text().set_wrap(True)
    ax2 = fig.add_axes((0.1, 0.07, 0.85, 0.38))
    for cam, d in data.model.detections.items():
        line = ax2.plot(d.ranges_m, d.pd, label=cam)[0]
        ax2.fill_between(d.ranges_m, d.pd_lower, d.pd_upper, color=line.get_color(), alpha=0.15)
        if d.range_m is not None:
            lo = "-" if d.range_lower_m is None else f"{d.range_lower_m:.0f}"
            hi = "-" if d.range_upper_m is None else f"{d.range_upper_m:.0f}"
            ax2.axvline(d.range_m, color=line.get_color(), ls=":", lw=1)
            line.set_label(f"{cam}: Pd 50 % at {d.range_m:.0f} m ({lo}-{hi} m)")
    ax2.set_xscale("log")
    ax2.set_xlabel("range (m)")
    ax2.set_ylabel("probability of detection")
    ax2.grid(True, which="both", alpha=0.3)
    if data.model.detections:
        k = next(iter(data.model.detections.values()))
        ax2.set_title(
            f"one false alarm per {1 / k.false_alarms_per_hour:g} h over the frame: "
            f"threshold {k.threshold_sigma:.2f} sigma; band: the model's inputs",
            fontsize=8,
        )
    ax2.legend(fontsize=7)
    return fig


def snr_range_pages(data: ReportData, paper_curves: bool = True) -> Iterator:
    cams = list(data.model.curves)
    for i in range(0, len(cams), 2):
        fig = _figure()
        fig.suptitle("Measured peak SNR vs model (paper Figs. 7-10)", fontsize=11)
        axes = fig.subplots(2, 1)
        for ax, cam in zip(axes, cams[i : i + 2], strict=False):
            _snr_axes(ax, data, cam, paper_curves)
        for ax in axes[len(cams[i : i + 2]) :]:
            ax.axis("off")
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        yield fig


def budget_page(data: ReportData):
    fig = _figure()
    fig.suptitle("Uncertainty budget, small dimension (paper Fig. 12)", fontsize=11)
    cams = list(data.model.budgets) or ["-"]
    axes = np.atleast_1d(fig.subplots(len(cams), 1))
    labels = [*BUDGET_TERMS, "total"]
    for ax, cam in zip(axes, cams, strict=True):
        budgets = data.model.budgets.get(cam, [])
        if not budgets:
            ax.axis("off")
            ax.text(0.5, 0.5, f"{cam}: no stop with a range", ha="center")
            continue
        width = 0.8 / len(budgets)
        y = np.arange(len(labels))
        for k, b in enumerate(budgets):
            values = [100 * b.terms[t] for t in BUDGET_TERMS] + [100 * b.total]
            state = "resolved" if b.resolved else "unresolved"
            ax.barh(y + k * width, values, height=width, label=f"{b.range_m:.0f} m ({state})")
        ax.set_yticks(y + 0.4 - width / 2, [t.replace("_", " ") for t in labels], fontsize=7)
        ax.invert_yaxis()
        ax.set_xlabel(f"relative SNR uncertainty (%), combined by {budgets[0].combine}")
        ax.set_title(f"{cam} ({data.sensors.get(cam, cam)}), target {data.target}", fontsize=8.5)
        ax.legend(fontsize=6.5, loc="lower right")
        ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def _series_column(axes, s: StopSeries) -> None:
    n = np.arange(1, len(s.snr) + 1)
    rows = (
        ("peak", s.peak, "peak (DN)"),
        ("bg_mean", s.bg_mean, "background mean (DN)"),
        ("bg_std", s.bg_std, "background std (DN)"),
        ("snr", s.snr, "peak SNR"),
    )
    rng = "-" if s.range_m is None else f"{s.range_m:.1f} m"
    for ax, (_, values, label) in zip(axes, rows, strict=True):
        ax.plot(n, values, "-", lw=0.9, marker=".", ms=3)
        ax.set_ylabel(label, fontsize=7)
        ax.tick_params(labelsize=6.5)
        ax.grid(True, alpha=0.3)
    if len(s.snr):
        mean = float(np.mean(s.snr))
        std = float(np.std(s.snr, ddof=1)) if len(s.snr) > 1 else math.nan
        axes[3].axhline(mean, color="k", lw=0.8, ls="--")
        stats = f"SNR {mean:.2f} +/- {std:.2f}"
    else:
        stats = "no valid frame"
    note = "" if s.complete else " (incomplete)"
    axes[0].set_title(f"{s.camera}, {rng}: {len(s.snr)} frames{note}\n{stats}", fontsize=8)
    axes[3].set_xlabel("frame", fontsize=7)


def series_pages(data: ReportData) -> Iterator:
    by_stop: dict[int, list[StopSeries]] = {}
    for s in data.flight.series:
        by_stop.setdefault(s.stop, []).append(s)
    for stop, series in by_stop.items():
        fig = _figure()
        fig.suptitle(f"Stop {stop}: the 100 frames behind the SNR (paper Fig. 6)", fontsize=11)
        grid = fig.subplots(4, len(series), squeeze=False, sharex="col")
        for k, s in enumerate(series):
            _series_column(grid[:, k], s)
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        yield fig


def report_pages(data: ReportData, paper_curves: bool = True) -> Iterator:
    """Every page of the report as a matplotlib Figure, in order."""
    yield summary_page(data)
    yield noise_page(data)
    yield from snr_range_pages(data, paper_curves)
    yield reference_page(data)
    yield budget_page(data)
    yield from series_pages(data)


def _rgb(fig) -> np.ndarray:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def render_report(data: ReportData, path: str | Path, *, paper_curves: bool = True) -> Path:
    """Write the report to ``path`` (.pdf: one page per figure; .png: one tall image)."""
    return write_pages(report_pages(data, paper_curves), path)


def write_pages(pages, path: str | Path) -> Path:
    """Figures to ``path``: .pdf one page each, .png one tall image of them stacked."""
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"report file {out} must end in .pdf or .png, got {out.suffix!r}")
    if suffix == ".pdf":
        from matplotlib.backends.backend_pdf import PdfPages

        with PdfPages(out) as pdf:
            for fig in pages:
                pdf.savefig(fig)
        return out
    from matplotlib.image import imsave

    images = [_rgb(fig) for fig in pages]
    width = max(p.shape[1] for p in images)
    padded = [
        np.pad(p, ((0, 0), (0, width - p.shape[1]), (0, 0)), constant_values=255) for p in images
    ]
    imsave(out, np.concatenate(padded, axis=0))
    return out
