"""SNR-versus-range figures like the paper's Figs. 7-10: the four curves, the Fig. 12 band around
the corrected ones, and the resolved/unresolved transitions (matplotlib, Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from snrmon.model.snr import SnrPrediction

_STYLE = {
    "small": ("tab:blue", "-", "Model SNR small"),
    "large": ("tab:orange", "-", "Model SNR large"),
    "small_corrected": ("tab:blue", "--", "Corrected small"),
    "large_corrected": ("tab:orange", "--", "Corrected large"),
}


def plot_prediction(
    pred: SnrPrediction,
    path: str | Path,
    *,
    measured: tuple[np.ndarray, np.ndarray] | None = None,
    title: str | None = None,
) -> Path:
    """Write the figure to ``path`` (format from the suffix) and return the path."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 5.0), dpi=120)
    ax = fig.add_subplot()
    r = pred.ranges_m
    for curve, (color, ls, label) in _STYLE.items():
        ax.plot(r, pred.snr(curve), color=color, ls=ls, label=f"{label} {pred.target_name}")
        if curve in pred.lower:
            ax.fill_between(r, pred.lower[curve], pred.upper[curve], color=color, alpha=0.15)
    for rt, name in (
        (pred.transition_range_small_m, "small"),
        (pred.transition_range_large_m, "large"),
    ):
        if r.min() <= rt <= r.max():
            ax.axvline(rt, color="grey", ls=":", lw=1)
            ax.text(
                rt,
                0.98,
                f" {name} unresolved",
                transform=ax.get_xaxis_transform(),
                rotation=90,
                va="top",
                fontsize=7,
                color="grey",
            )
    if measured is not None:
        ax.plot(measured[0], measured[1], "ko-", label="Measured")
    ax.set_yscale("log")
    ax.set_xlabel("Range (m)")
    ax.set_ylabel("Peak SNR")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(
        title
        or f"{pred.sensor_name.upper()} {pred.target_name.upper()} "
        f"(atmosphere: {pred.atmosphere_name}, background {pred.background_temp_k:.1f} K)",
        fontsize=9,
    )
    out = Path(path)
    fig.savefig(out)
    return out
