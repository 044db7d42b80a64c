"""``snrmon bench`` reports figures in the documented JSON shape (never asserts a speed)."""

from __future__ import annotations

import json

from snrmon.cli import main


def test_bench_json_has_the_sections_asked_for(capsys):
    assert main(["bench", "--only", "measurement,model", "--duration", "0.2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"machine", "measurement", "model"}
    assert out["measurement"]["per_frame_us_1280x720"] > 0
    assert out["model"]["mwir_four_curves_500_ranges_ms"] > 0


def test_bench_duration_must_be_positive(capsys):
    assert main(["bench", "--duration", "0"]) == 1
    assert "--duration must be positive" in capsys.readouterr().err
