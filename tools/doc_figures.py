"""The model's figures that docs/model.md and model/contrast.py quote, computed afresh.

    python tools/doc_figures.py           # print each figure and the sentence that holds it
    python tools/doc_figures.py --check   # exit 1 naming any file that no longer holds it

``tests/model/test_doc_figures.py`` runs the check, so a change of the model that moves one
of these numbers fails until the text is regenerated from this output. The figures (MWIR and
UAV1 presets, the default atmosphere, ``predict(..., expected=False, band=False)``):

* at 37 m, the diffraction-limited and the corrected small-dimension SNR against the paper's
  resolved (pixel-filling) formula (paper section 2, ``geometry="paper"``);
* how much one temperature for sky and air (280 K both) understates the contrast against a
  280 K sky seen through 288.15 K air (paper sections 8-9), over the paper's stops 37-508 m;
* the default atmosphere's rural aerosol (23 km) against a clear path at 500 m and 1.5 km, and
  its MWIR contrast-weighted band transmission against the flat one at 199 and 508 m;
* the paper's switched curve at the MWIR transition (314 m) against the continuous square;
* the expected Eq. (4) readings of the two background rules at the paper's stops.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)  # the paper's surveyed stops
FAST = {"expected": False, "band": False}


def figures() -> list[tuple[str, str]]:
    """(file relative to the repository, the sentence fragment that must be in it)."""
    return [
        *_resolved_formula_figures(),
        *_shared_temperature_figures(),
        *_aerosol_figures(),
        *_switch_figures(),
        *_two_rules_figures(),
    ]


def _resolved_formula_figures() -> list[tuple[str, str]]:
    """At 37 m, the square's curves against the paper's pixel-filling formula (section 2)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    mw, uav1 = load_sensor("mwir"), load_target("uav1")
    p = predict(mw, uav1, [37.0], **FAST)
    paper = predict(mw, uav1, [37.0], geometry="paper", **FAST)
    airy, real = float(p.snr_small[0]), float(p.snr_small_corrected[0])
    resolved = float(paper.snr_small_corrected[0])
    below_airy, below_real = 100 * (1 - airy / resolved), 100 * (1 - real / resolved)
    return [
        (
            "docs/model.md",
            f"at MWIR 37 m the diffraction-limited curve is {below_airy:.1f} % below",
        ),
        (
            "docs/model.md",
            f"{below_real:.1f} % below it ({real:.1f} against the diffraction limit's {airy:.1f})",
        ),
    ]


def _shared_temperature_figures() -> list[tuple[str, str]]:
    """One temperature for sky and air (280 K both) against a 280 K sky through 288.15 K air
    (sections 8-9), over the paper's stops."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    mw, uav1 = load_sensor("mwir"), load_target("uav1")
    sky = {**FAST, "background_temp_k": 280.0}
    same = predict(mw, uav1, list(STOPS_M), air_temp_k=280.0, **sky).snr_small
    warm = predict(mw, uav1, list(STOPS_M), air_temp_k=288.15, **sky).snr_small
    under = 100 * (1 - np.asarray(same) / np.asarray(warm))
    lo, hi = round(float(under.min())), round(float(under.max()))
    return [
        ("docs/model.md", f"understated the MWIR contrast by {lo}-{hi} % at the paper's stops"),
        ("model/contrast.py", f"({lo}-{hi} % at 37-508 m with a 280 K sky and 288 K air in the"),
    ]


def _aerosol_figures() -> list[tuple[str, str]]:
    """The default atmosphere's rural 23 km aerosol against a clear path, and its MWIR
    contrast-weighted against its flat band transmission."""
    from snrmon.model.atmosphere import default_atmosphere, resolve_atmosphere
    from snrmon.model.atmosphere_table import Weather

    lost = []
    for band in ((3.45, 5.25), (8.0, 12.0)):
        hazy = default_atmosphere(band).contrast_transmission([500.0, 1500.0])
        clear = resolve_atmosphere(Weather(aerosol="none"), band)
        lost += list(100 * (1 - hazy / clear.contrast_transmission([500.0, 1500.0])))
    mw = default_atmosphere((3.45, 5.25))
    c199, c508 = mw.contrast_transmission([199.0, 508.0])
    f199, f508 = mw.transmission([199.0, 508.0])
    return [
        (
            "docs/model.md",
            f"transmission {lost[0]:.1f} % lower at 500 m and {lost[1]:.1f} % at 1.5 km than "
            f"a path without aerosol (LWIR {lost[2]:.1f} % / {lost[3]:.1f} %)",
        ),
        (
            "docs/model.md",
            f"US Standard {c508:.3f} against {f508:.3f} ({c199:.3f} against {f199:.3f} at 199 m)",
        ),
    ]


def _switch_figures() -> list[tuple[str, str]]:
    """The paper's switched curve at the MWIR UAV1 transition (D = 1 px at 314 m)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    mw, uav1 = load_sensor("mwir"), load_target("uav1")
    paper = predict(mw, uav1, [314.0, 314.1], geometry="paper", **FAST)
    resolved, point = (float(v) for v in paper.snr_small)
    square = float(predict(mw, uav1, [314.0], **FAST).snr_small[0])
    return [
        (
            "docs/model.md",
            f"MWIR UAV1 small at 314 m: {resolved:.0f} -> {point:.0f} at the switch, where the "
            f"square gives {square:.0f}",
        ),
        ("model/snr.py", f"(MWIR UAV1 small, 314 m: {resolved:.0f} -> {point:.0f} uncorrected)"),
    ]


def _two_rules_figures() -> list[tuple[str, str]]:
    """The expected Eq. (4) readings of the paper's 7x7 rim and the console's extent rule
    (MWIR UAV1, the default sky and air, the preset's PSF)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    mw, uav1 = load_sensor("mwir"), load_target("uav1")
    p = predict(mw, uav1, [37.0, 126.0, 199.0, 393.0, 508.0], band=False)
    rim = [f"{v:.1f}" for v in p.expected_eq4_rim]
    ext = [f"{v:.1f}" if v < 100 else f"{v:.0f}" for v in p.expected_eq4_extent]
    return [
        (
            "docs/model.md",
            f"the preset's PSF: {rim[4]} / {ext[4]} at 508 m, {rim[3]} / {ext[3]} at 393 m); at "
            f"close range they part: {rim[0]} / {ext[0]} at 37 m, {rim[1]} / {ext[1]} at 126 m, "
            f"{rim[2]} / {ext[2]} at 199 m",
        ),
    ]


def missing(root: Path = ROOT) -> list[str]:
    """The figures a file does not hold, as 'file: fragment' lines."""
    out = []
    for name, text in figures():
        held = " ".join((root / name).read_text().split())
        if " ".join(text.split()) not in held:
            out.append(f"{name}: {text}")
    return out


def main(argv: list[str]) -> int:
    if argv[1:] == ["--check"]:
        gone = missing()
        for line in gone:
            print(f"not in {line}", file=sys.stderr)
        return 1 if gone else 0
    for name, text in figures():
        print(f"{name}: {text}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
