"""The model's figures that docs/model.md and model/contrast.py quote, computed afresh.

    python tools/doc_figures.py           # print each figure and the sentence that holds it
    python tools/doc_figures.py --check   # exit 1 naming any file that no longer holds it

``tests/model/test_doc_figures.py`` runs the check, so a change of the model that moves one
of these numbers fails until the text is regenerated from this output. The figures (MWIR and
UAV1 presets, the default atmosphere, ``predict(..., expected=False, band=False)``):

* at 37 m, the diffraction-limited and the corrected small-dimension SNR against the paper's
  resolved (pixel-filling) formula (paper section 2, ``geometry="paper"``);
* how much one temperature for sky and air (280 K both) understates the contrast against a
  280 K sky seen through 288.15 K air (paper sections 8-9), over the paper's stops 37-508 m.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)  # the paper's surveyed stops


def figures() -> list[tuple[str, str]]:
    """(file relative to the repository, the sentence fragment that must be in it)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    mw, uav1 = load_sensor("mwir"), load_target("uav1")
    kw = {"expected": False, "band": False}
    p = predict(mw, uav1, [37.0], **kw)
    paper = predict(mw, uav1, [37.0], geometry="paper", **kw)
    airy, real = float(p.snr_small[0]), float(p.snr_small_corrected[0])
    resolved = float(paper.snr_small_corrected[0])
    below_airy, below_real = 100 * (1 - airy / resolved), 100 * (1 - real / resolved)
    sky = {**kw, "background_temp_k": 280.0}
    same = predict(mw, uav1, list(STOPS_M), air_temp_k=280.0, **sky).snr_small
    warm = predict(mw, uav1, list(STOPS_M), air_temp_k=288.15, **sky).snr_small
    under = 100 * (1 - np.asarray(same) / np.asarray(warm))
    lo, hi = round(float(under.min())), round(float(under.max()))
    return [
        (
            "docs/model.md",
            f"at MWIR 37 m the diffraction-limited curve is {below_airy:.1f} % below",
        ),
        (
            "docs/model.md",
            f"{below_real:.1f} % below it ({real:.1f} against the diffraction limit's {airy:.1f})",
        ),
        ("docs/model.md", f"understated the MWIR contrast by {lo}-{hi} % at the paper's stops"),
        ("model/contrast.py", f"({lo}-{hi} % at 37-508 m with a 280 K sky and 288 K air in the"),
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
