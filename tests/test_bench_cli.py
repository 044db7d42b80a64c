"""``snrmon bench`` reports figures in the documented JSON shape (never asserts a speed)."""

from __future__ import annotations

from snrmon.cli import main
from tests.helpers import strict_json


def test_bench_json_has_the_sections_asked_for(capsys):
    assert main(["bench", "--only", "measurement,model", "--duration", "0.2", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert set(out) == {"machine", "measurement", "model"}
    assert out["measurement"]["per_frame_us_1280x720"] > 0
    assert out["model"]["mwir_four_curves_500_ranges_ms"] > 0


def test_bench_duration_must_be_positive(capsys):
    assert main(["bench", "--duration", "0"]) == 2
    assert "--duration must be positive" in capsys.readouterr().err


def test_acquisition_soak_rolls_its_recording_and_samples_memory(monkeypatch):
    """A run longer than a segment records in segments (an hour raw would fill the disk) and
    samples the resident memory along the way; the last segment replays."""
    from benchmarks import bench_acquisition

    monkeypatch.setattr(bench_acquisition, "SEGMENT_S", 1.0)
    monkeypatch.setattr(bench_acquisition, "RSS_EVERY_S", 0.5)
    out = bench_acquisition.run(2.6)
    acq = out["acquisition"]
    assert acq["recording_segments"] == 3  # rolled at 1 s and 2 s
    assert len(acq["rss_mb_samples"]) >= 4
    assert all(rss > 50 for _, rss in acq["rss_mb_samples"])
    assert acq["recording_mb"] > 0
    assert out["replay"]["fps"] > 0  # the last segment is a complete, readable session
