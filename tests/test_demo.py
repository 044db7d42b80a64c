"""``snrmon demo`` headless: the README's main command on a machine with no display."""

from __future__ import annotations

import cv2
import pytest

from snrmon.cli import main


@pytest.mark.slow
def test_demo_headless_flies_a_stop_prints_the_table_saves_a_screenshot_and_report(
    tmp_path, capsys
):
    shot, report = tmp_path / "demo.png", tmp_path / "report.png"
    code = main(
        ["demo", "--headless", "--stops", "126", "--screenshot", str(shot), "--report", str(report)]
    )
    out, err = capsys.readouterr()
    assert code == 0
    rows = [line.split() for line in out.splitlines() if line.startswith(("mwir", "lwir"))]
    # Each camera's row appears once as it completes, and again in the final table.
    done = {(r[0], r[1]) for r in rows if r[1] == "126" and r[4] == "100"}
    assert done == {("mwir", "126"), ("lwir", "126")}
    image = cv2.imread(str(shot))
    assert image is not None and image.shape[0] > 400 and image.shape[1] > 600
    assert image.std() > 10  # not a blank window
    # The report, from the live stop table (no recording): its pages stacked in one PNG.
    assert f"report: {report}" in err
    pages = cv2.imread(str(report))
    assert pages is not None and pages.shape[0] > 2 * pages.shape[1]


def test_demo_refuses_a_report_it_cannot_write_before_flying(capsys):
    assert main(["demo", "--headless", "--report", "r.docx"]) != 0
    assert "--report r.docx: must end in .pdf or .png" in capsys.readouterr().err
