"""The SNR-versus-range table of a HIL run as text: measured 100-frame SNR, truth and model."""

from __future__ import annotations

import math


def _f(v: float | None, width: int = 7, digits: int = 1) -> str:
    """A number, or '-' where there is none (not measured, no model): never 'nan'."""
    if v is None or not math.isfinite(v):
        return f"{'-':>{width}s}"
    return f"{v:{width}.{digits}f}"


def format_row(s: dict) -> str:
    """One stop of :meth:`HilRig.result` as a table line."""
    m = s["model_snr"]
    return (
        f"{s['camera']:6s} {s['planned_range_m']:7.0f} {_f(s['lrf_range_m'])} "
        f"{_f(s['gps_range_m'])} {s['n_frames']:4d} {_f(s['measured_snr_mean'], 7, 2)} "
        f"{_f(s['measured_snr_std'], 6, 2)} {_f(s.get('measured_snr_mean_raw'), 7, 2)} "
        f"{_f(s['truth_snr'], 7, 2)} {_f(m.get('small'), 8, 2)} "
        f"{_f(m.get('small_corrected'), 8, 2)} {_f(m.get('expected_eq4_rim'), 8, 2)} "
        f"{_f(m.get('expected_eq4_extent'), 8, 2)} {s.get('expected_eq4_rule') or '-':6s} "
        f"{_f(s.get('measured_over_model'), 6, 3)} {_f(s.get('truth_over_model'), 6, 3)} "
        f"{_f(s.get('live_over_model'), 6, 3)} {_psf_word(s):6s}  "
        f"{s.get('background') or '-':15s} {_target_note(s)}"
    )


def _psf_word(s: dict) -> str:
    """The PSF the row's live model values used, one word: "fitted", "preset" or "-"."""
    label = s.get("model_psf")
    return label.split()[0] if label else "-"


FRAMES_PER_STOP = 100  # the paper's consecutive frames per stop (the session's default)


def _target_note(s: dict) -> str:
    """``resolved`` where the model calls the small dimension resolved (wider than a pixel),
    else ``point``; ``short`` when the stop gave fewer than 100 consecutive valid frames."""
    notes = ["resolved" if s.get("resolved") else "point"]
    if s["n_frames"] < FRAMES_PER_STOP:
        notes.append("short")
    return ",".join(notes)


TABLE_HEADER = (
    f"{'camera':6s} {'plan_m':>7s} {'lrf_m':>7s} {'gps_m':>7s} {'n':>4s} "
    f"{'SNR':>7s} {'std':>6s} {'raw':>7s} {'truth':>7s} {'model_s':>8s} {'model_sc':>8s} "
    f"{'exp_rim':>8s} {'exp_ext':>8s} {'rule':6s} {'m/mod':>6s} {'t/mod':>6s} {'live':>6s} "
    f"{'psf':6s}  "
    f"{'background':15s} target"
)

TABLE_FOOTNOTE = (
    "raw: the SNR of the same track on frames without the fixed-pattern correction (with\n"
    "--fpn; '-': not measured). model_s / model_sc: the model's small dimension, uncorrected /\n"
    "corrected (real PSF, finite size); exp_rim / exp_ext: what Eq. (4) is expected to read\n"
    "with the paper's 7x7 rim / the console's target-aware background (the rim of the drone's\n"
    "extent once it is wider than the box's 5x5 guard); rule: the one the stop's background\n"
    "makes applicable. m/mod: measured / that expected reading, t/mod: truth / the noise-free\n"
    "peak SNR, both with the PSF fitted to the flight's frames and over the sub-pixel phases\n"
    "the stop's frames sampled (unresolved stops only). live: measured / the expected reading\n"
    "the console showed for the row, psf: the PSF it was computed with ('preset': the sensor\n"
    "preset's, before the first unresolved stop's fit; 'fitted': from this flight's stops).\n"
    "background: what Eq. (4)'s mean and std were taken over ('rim': the 7x7 box's rim;\n"
    "'extent_rim': outside the segmented drone and a 2 px guard, for a drone wider than the\n"
    "box's 5x5 guard; 'rect': the clear-sky rectangle), most used first. target: the model's\n"
    "verdict for the small dimension at the stop's range ('resolved': wider than a pixel; the\n"
    "paper's points are MWIR 199-508 m and LWIR 126-393 m). 'short': fewer than 100\n"
    "consecutive valid frames."
)


def format_result(result: dict) -> str:
    """The per-stop table of a HIL run: measured 100-frame SNR beside truth and model."""
    lines = [TABLE_HEADER, *(format_row(s) for s in result["stops"]), TABLE_FOOTNOTE]
    lines += [
        f"{cam}: {f['received']} frames received, {sum(f['dropped'].values())} dropped"
        + (f", {f['camera_gap']} never delivered by the camera" if f["camera_gap"] else "")
        for cam, f in result["frames"].items()
    ]
    return "\n".join(lines)
