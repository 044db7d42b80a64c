"""Strict JSON for the commands' ``--json`` output: never NaN (a number that was not measured
is null), dates as ISO strings, tuples as lists."""

from __future__ import annotations

import math
from datetime import date
from typing import Any


def json_ready(v: Any) -> Any:
    """``v`` with NaN and infinities as None, dates ISO, tuples lists (recursively)."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: json_ready(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [json_ready(x) for x in v]
    if isinstance(v, date):
        return v.isoformat()
    return v
