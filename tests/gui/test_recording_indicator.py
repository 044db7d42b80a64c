"""The recording indicator: its words and colour at given write rates and free space, and the
rate and time left the session computes from a real recording's growing file."""

from __future__ import annotations

import math

import pytest

from snrmon.acquisition.engine.status import RecordingStatus
from snrmon.acquisition.record.recorder_status import WriteRate, disk_time_left_s
from snrmon.gui import theme as th
from snrmon.gui.recording_indicator import RecordingIndicator

MB = 1_000_000


def recording(rate_mb_s: float, free_gb: float, elapsed_s: float = 754.0) -> RecordingStatus:
    rate = rate_mb_s * MB
    free = int(free_gb * 1e9)
    return RecordingStatus(
        "recording",
        "/data/day.h5",
        bytes_written=int(rate * elapsed_s),
        free_bytes=free,
        dropped_frames=0,
        elapsed_s=elapsed_s,
        rate_bytes_s=rate,
        time_left_s=disk_time_left_s(free, rate),
    )


@pytest.mark.parametrize(
    ("rate_mb_s", "free_gb", "left", "level"),
    [
        (129.0, 25.0, "disk 3 min left", "amber"),  # the day: 129 MB/s on 25 GB free
        (129.0, 500.0, "disk 1 h 04 min left", ""),  # the red mark only
        (129.0, 10.0, "disk 1 min left", "red"),  # 77 s
        (129.0, 5.0, "disk 39 s left", "red"),
        (10.0, 6.1, "disk 10 min left", ""),  # 610 s: just over 10 minutes
        (10.0, 5.9, "disk 9 min left", "amber"),
    ],
)
def test_the_indicator_s_time_left_and_colour(qtbot, rate_mb_s, free_gb, left, level):
    colours = {  # (background, text): amber under 10 min, red under 2, else the red mark
        "amber": (th.current().verdicts["near"][0], "#000000"),
        "red": (th.ALARM, "#ffffff"),
        "": ("", th.ALARM),
    }[level]
    label = RecordingIndicator()
    qtbot.addWidget(label)
    rec = recording(rate_mb_s, free_gb)
    label.show_recording(rec)
    text = label.text()
    assert text.startswith("\u25cf REC  12:34  ")  # the mark, the elapsed time
    assert f"{rate_mb_s:.1f} MB/s" in text and left in text, text
    assert f"{rec.bytes_written / MB:.0f} MB" in text and "day.h5" in text
    expected_left = free_gb * 1e9 / (rate_mb_s * MB)
    assert rec.time_left_s == pytest.approx(expected_left)
    assert label.level == level and label.colours() == colours
    fill, ink = colours
    assert f"color: {ink}" in label.styleSheet()
    assert (f"background: {fill}" in label.styleSheet()) == bool(fill)


def test_after_the_recording_the_indicator_is_plain_again(qtbot):
    label = RecordingIndicator()
    qtbot.addWidget(label)
    label.show_recording(recording(129.0, 5.0))
    assert label.level == "red"
    label.show_recording(RecordingStatus("stopped", "/data/day.h5"))
    assert label.text() == "recording stopped" and label.level == "" and not label.recording


def test_the_write_rate_is_the_last_seconds_of_bytes():
    meter = WriteRate(t0_s=100.0)
    # The first 2 s: no rate (the file's layout written at once: 5 MB at its start)
    assert all(math.isnan(meter.add(100.0 + i * 0.5, 5 * MB + i * 10 * MB)) for i in range(4))
    assert math.isnan(meter.add(102.0, 5 * MB + 40 * MB))  # one sample: no rate yet
    for i in range(5, 21):  # 20 MB/s for 10 s, sampled twice a second
        rate = meter.add(100.0 + i * 0.5, 5 * MB + int(i * 0.5 * 20 * MB))
    assert rate == pytest.approx(20 * MB)
    t, b = 110.0, 200 * MB
    for _ in range(12):  # then 100 MB/s: within the window the rate follows
        t, b = t + 0.5, b + 50 * MB
        rate = meter.add(t, b)
    assert rate == pytest.approx(100 * MB)
    assert disk_time_left_s(None, rate) is None and disk_time_left_s(10, math.nan) is None
    assert disk_time_left_s(10 * MB, 0.0) == math.inf
