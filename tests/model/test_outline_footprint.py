"""The "outline" footprint: the small target as the segmented pixels of a close stop, scaled by
range, in place of the paper's square of the small dimension (paper sections 3 and 10)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from snrmon.limits import FOOTPRINT_CHOICES
from snrmon.model.footprint import average_pvf_outline, average_pvf_square
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.snr import FOOTPRINTS, predict
from snrmon.model.target import Outline

MW, LW, UAV1 = load_sensor("mwir"), load_sensor("lwir"), load_target("uav1")
SIZES_PX = np.array([0.05, 1.0, 2.5, 8.0])
# a cross of 9 cells: a bar across and one down, each a cell thick
CROSS = Outline(("00100", "00100", "11111", "00100", "00100"), 0.02)


@pytest.mark.parametrize("sensor", [MW, LW], ids=["mwir", "lwir"])
def test_an_outline_of_one_cell_or_a_full_block_is_the_square(sensor):
    psf, ff = sensor.corrected_psf(), sensor.fill_factor
    square = average_pvf_square(psf, ff, SIZES_PX)
    one = average_pvf_outline(psf, ff, Outline(("1",), 0.01), SIZES_PX)
    block = average_pvf_outline(psf, ff, Outline(("111", "111", "111"), 0.01), SIZES_PX / 3)
    assert one == pytest.approx(square, rel=1e-4)  # the square's table: PCHIP within 1e-4
    assert block == pytest.approx(square, rel=1e-4)


@pytest.mark.parametrize("sensor", [MW, LW], ids=["mwir", "lwir"])
def test_a_cross_spreads_its_light_over_more_pixels_than_its_square(sensor):
    """The same area as a cross puts less on the centroid's pixel than as a square once the
    drone spans pixels (14 % less at MWIR with a 2.5-px equal-area square), and the same as
    a point when it is far below a pixel."""
    psf, ff = sensor.corrected_psf(), sensor.fill_factor
    square = average_pvf_square(psf, ff, SIZES_PX)
    cross = average_pvf_outline(psf, ff, CROSS, SIZES_PX / 3)
    assert np.all(cross < square)
    assert cross[0] == pytest.approx(square[0], rel=0.01)
    if sensor is MW:
        assert cross[2] / square[2] == pytest.approx(0.858, abs=0.005)


def test_predict_spreads_the_small_curves_over_the_outline_and_keeps_the_rest():
    """Only the small curves change; on a far drone they meet the square's; the outline
    interpolated over a 600-range grid is the outline computed at each range."""
    target = dataclasses.replace(UAV1, outline=Outline(CROSS.rows, UAV1.small_m / 3))
    kw = {"expected": False, "band": False}
    ranges = np.geomspace(20.0, 3000.0, 600)
    sq = predict(MW, target, ranges, **kw)
    out = predict(MW, target, ranges, footprint="outline", **kw)
    assert np.array_equal(out.snr_large_corrected, sq.snr_large_corrected)
    ratio = out.snr_small_corrected / sq.snr_small_corrected
    assert np.all(ratio < 1.0 + 1e-6) and ratio[-1] == pytest.approx(1.0, abs=0.01)
    at = [126.0, 199.0, 451.0]
    direct = predict(MW, target, at, footprint="outline", **kw).snr_small_corrected
    assert np.interp(at, ranges, out.snr_small_corrected) == pytest.approx(direct, rel=2e-3)


def test_an_outline_footprint_needs_an_outline():
    with pytest.raises(ValueError, match="target 'uav1' has no outline"):
        predict(MW, UAV1, [100.0], footprint="outline", expected=False, band=False)
    with pytest.raises(ValueError, match="footprint must be one of square, outline"):
        predict(MW, UAV1, [100.0], footprint="disc", expected=False, band=False)
    assert FOOTPRINTS == FOOTPRINT_CHOICES  # what the command line and the config offer


def test_bad_outlines_are_one_clear_error():
    with pytest.raises(ValueError, match="rows of equal length made of 0 and 1"):
        Outline(("101", "1"), 0.01)
    with pytest.raises(ValueError, match="at least one pixel inside"):
        Outline(("000",), 0.01)
    with pytest.raises(ValueError, match="pixel_m must be > 0"):
        Outline(("1",), 0.0)


def test_the_command_line_spreads_a_target_files_outline_and_refuses_a_preset(capsys, tmp_path):
    """``snrmon model snr --footprint outline`` with a target file holding an outline (as
    ``snrmon characterize --target-out`` writes it) lowers the small curves where the drone
    spans pixels; with a preset, which has none, it exits 2 naming the target (and ``hil``
    the same, before any device starts)."""
    from snrmon.cli import main
    from tests.helpers import strict_json

    path = tmp_path / "cross.toml"
    rows = ", ".join(f'"{r}"' for r in CROSS.rows)
    path.write_text(
        '[target]\nname = "cross"\nsmall_m = 0.157\nlarge_m = 0.238\n'
        f"temp_c = {{ mwir = 36.7 }}\noutline = [{rows}]\noutline_pixel_m = {0.157 / 3}\n"
    )
    base = ["model", "snr", "--sensor", "mwir", "--target", str(path), "--ranges", "126", "--json"]
    assert main(base) == 0
    (square,) = strict_json(capsys.readouterr().out)
    assert main([*base, "--footprint", "outline"]) == 0
    (outline,) = strict_json(capsys.readouterr().out)
    assert outline["snr_small_corrected"] < 0.95 * square["snr_small_corrected"]
    assert outline["snr_large_corrected"] == square["snr_large_corrected"]
    for argv in (
        ["model", "snr", "--sensor", "mwir", "--target", "uav1", "--footprint", "outline"],
        ["hil", "--footprint", "outline"],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "--footprint outline needs a target with an outline; 'uav1' has none" in err
