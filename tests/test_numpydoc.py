"""The public API's docstrings pass numpydoc's own validation (``numpydoc.validate``): every
public function and every public method of :class:`snrmon.RecordedSession` has its summary, its
Parameters section naming every parameter with a type and a description, and its Returns
section, as the numpydoc standard reads them."""

from __future__ import annotations

import inspect

import pytest
from numpydoc.validate import validate

from snrmon import api

# Not required of every docstring: an extended summary, a See Also section, an Examples
# section (the functions have them, and they run: test_api.py's doctest).
NOT_REQUIRED = {"ES01", "SA01", "EX01"}
PUBLIC = [f"snrmon.api.{name}" for name in api.__all__] + [
    f"snrmon.api.RecordedSession.{name}"
    for name, member in inspect.getmembers(api.RecordedSession)
    if not name.startswith("_") and callable(member)
]


@pytest.mark.parametrize("name", PUBLIC)
def test_the_public_api_passes_numpydoc_validation(name):
    errors = [(code, text) for code, text in validate(name)["errors"] if code not in NOT_REQUIRED]
    assert errors == [], f"{name}: {errors}"


def test_the_check_covers_the_session_methods_and_can_fail():
    assert {f"snrmon.api.RecordedSession.{m}" for m in ("frames", "stops", "close")} <= set(PUBLIC)

    def undocumented(camera: str) -> int:
        """Frames of a camera."""
        return 0

    api._undocumented_for_test = undocumented  # numpydoc imports by name
    try:
        codes = {code for code, _ in validate("snrmon.api._undocumented_for_test")["errors"]}
    finally:
        del api._undocumented_for_test
    assert {"PR01", "RT01"} <= codes
