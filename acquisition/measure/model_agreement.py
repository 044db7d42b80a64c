"""A measured peak SNR (Eq. 4, the mean of its frames) against the model's expected Eq. (4)
reading at the same range: their ratio and whether the measurement lies inside the model's
uncertainty band (paper section 9, Fig. 12).

The model's prediction at a range is a mapping of curve names to SNR
(:class:`snrmon.acquisition.prediction.Predictor`): the expected reading under ``rule`` (the
curve the comparison is made against, e.g. ``expected_eq4``) and, where the model states one, its
band as ``<rule>_lower`` / ``<rule>_upper``. The verdict:

* ``inside``: lower <= measured <= upper;
* ``near``: outside the band, but within two errors of the mean of its nearer edge (the band and
  the measurement's own 2-sigma interval overlap);
* ``outside``: farther than that;
* ``""``: not decided (no measurement, no expected reading, or no band and no error of the mean).

Without a band the band is the expected reading itself (a point), so only ``near`` or
``outside`` can be said, by the error of the mean.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

NAN = math.nan
NEAR_SEMS = 2.0  # "near": within this many errors of the mean of the band's nearer edge


@dataclass(frozen=True, slots=True)
class ModelAgreement:
    """A measurement and the model's expected reading at its range (module docstring).

    ``ratio`` is measured / expected; ``ratio_lower`` and ``ratio_upper`` are the band's edges
    over the expected reading (the band as a ratio); NaN where undefined."""

    rule: str
    expected: float
    lower: float
    upper: float
    measured: float
    measured_sem: float
    ratio: float
    ratio_lower: float
    ratio_upper: float
    verdict: str


def _finite(v: float | None) -> float:
    return float(v) if v is not None and math.isfinite(v) else NAN


def _over(a: float, b: float) -> float:
    return a / b if math.isfinite(a) and math.isfinite(b) and b > 0 else NAN


def verdict(measured: float, sem: float, lower: float, upper: float) -> str:
    """``inside``, ``near``, ``outside`` or ``""`` (module docstring)."""
    if not (math.isfinite(measured) and math.isfinite(lower) and math.isfinite(upper)):
        return ""
    if lower <= measured <= upper:
        return "inside"
    if not (math.isfinite(sem) and sem > 0):
        return "" if lower == upper else "outside"
    gap = lower - measured if measured < lower else measured - upper
    return "near" if gap <= NEAR_SEMS * sem else "outside"


def model_agreement(
    measured: float, sem: float, model: Mapping[str, float], rule: str
) -> ModelAgreement | None:
    """``measured`` (with its error of the mean ``sem``) against ``model[rule]`` and its band;
    None when the model has no reading under ``rule``."""
    expected = _finite(model.get(rule))
    if not math.isfinite(expected):
        return None
    lower = _finite(model.get(f"{rule}_lower"))
    upper = _finite(model.get(f"{rule}_upper"))
    if not (math.isfinite(lower) and math.isfinite(upper)):
        lower = upper = expected  # no band stated: the reading itself
    measured, sem = _finite(measured), _finite(sem)
    return ModelAgreement(
        rule=rule,
        expected=expected,
        lower=lower,
        upper=upper,
        measured=measured,
        measured_sem=sem,
        ratio=_over(measured, expected),
        ratio_lower=_over(lower, expected),
        ratio_upper=_over(upper, expected),
        verdict=verdict(measured, sem, lower, upper),
    )
