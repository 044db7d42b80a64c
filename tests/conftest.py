"""Shared fixtures. GUI tests run offscreen; every random generator is seeded by the test."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO = Path(__file__).resolve().parent.parent
# A checkout elsewhere (a clone in /tmp) points at the data with SNRMON_SHARED_DATA.
SHARED_DATA = Path(os.environ.get("SNRMON_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the checkout, or ``$SNRMON_SHARED_DATA`` (real data with
    provenance; never edited)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data not found at {SHARED_DATA} (set SNRMON_SHARED_DATA)")
    return SHARED_DATA
