"""The atmosphere table's rebuild check compares values, not bytes (tools/make_atmosphere_table.py).

Another processor or libm rounds the last bit of a computed value differently; the check must
pass such a table and refuse one whose physics moved. Runs on the shipped table itself, with no
LOWTRAN7 (the comparison is what is tested; ``make table-check`` runs it on a real rebuild).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))

import make_atmosphere_table as gen


@pytest.fixture(scope="module")
def shipped() -> dict[str, np.ndarray]:
    return gen.shipped_arrays()


def _nudged(arrays: dict[str, np.ndarray], name: str, index: int, value) -> dict:
    out = {k: v.copy() for k, v in arrays.items()}
    out[name].flat[index] = value
    return out


def test_the_shipped_table_agrees_with_itself(shipped):
    assert gen.table_differences(shipped, shipped) == []


@pytest.mark.parametrize("name", ["water_exponent", "wavenumber_cm1", "water_ln_k"])
def test_one_ulp_in_a_float64_or_float32_array_passes(shipped, name):
    a = shipped[name]
    assert a.dtype in (np.float64, np.float32)
    # 4 values 1 ulp up and down, as another machine's LOWTRAN7 build gave
    rebuilt = {k: v.copy() for k, v in shipped.items()}
    flat = rebuilt[name].reshape(-1)
    for i in range(0, 4 * max(1, flat.size // 4), max(1, flat.size // 4)):
        flat[i] = np.nextafter(flat[i], np.inf if i % 2 else -np.inf)
    assert not np.array_equal(rebuilt[name], a)
    assert gen.table_differences(shipped, rebuilt) == []


@pytest.mark.parametrize("name", ["water_exponent", "water_ln_k", "temp_k"])
def test_a_relative_change_of_1e_6_is_refused_and_named(shipped, name):
    i = shipped[name].size // 2
    value = shipped[name].flat[i]
    rebuilt = _nudged(shipped, name, i, value * (1 + 1e-6))
    lines = gen.table_differences(shipped, rebuilt)
    assert len(lines) == 1
    assert lines[0].startswith(f"{name}[")
    assert "1 of" in lines[0]


def test_a_float16_array_must_match_exactly(shipped):
    a = shipped["ln_od_dry"]
    assert a.dtype == np.float16
    i = a.size // 3
    one_ulp = np.nextafter(a.flat[i], np.float16(np.inf))
    lines = gen.table_differences(shipped, _nudged(shipped, "ln_od_dry", i, one_ulp))
    assert len(lines) == 1 and lines[0].startswith("ln_od_dry[")


def test_a_missing_or_reshaped_array_is_named(shipped):
    missing = {k: v for k, v in shipped.items() if k != "water_self"}
    assert gen.table_differences(shipped, missing) == ["water_self: only in the shipped table"]
    reshaped = dict(shipped, path_m=shipped["path_m"][:-1])
    (line,) = gen.table_differences(shipped, reshaped)
    assert line.startswith("path_m: shipped float64(12,), rebuilt float64(11,)")


def test_names_must_match_exactly(shipped):
    names = shipped["season_names"].copy()
    names[0] = "arctic"
    (line,) = gen.table_differences(shipped, dict(shipped, season_names=names))
    assert line == f"season_names: differs (1 of {names.size} values)"
