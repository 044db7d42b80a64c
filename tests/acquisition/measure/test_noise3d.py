"""3D noise against independent truth: synthetic cubes with known components, an implementation
written here from the definitions (the directional operators applied to the whole cube, the bias
removed by solving the expectation equations), and the two real Cedip recordings."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from snrmon.acquisition.measure.noise3d import COMPONENTS, noise_3d
from snrmon.acquisition.replay.stack_io import load_stack

DATA = Path(__file__).parents[2] / "data" / "pyradi"
SEEDS = range(20)
AXES = {"t": 0, "v": 1, "h": 2}


# ----------------------------------------------------------------- reference (D'Agostino and Webb)
def _d(cube: np.ndarray, direction: str) -> np.ndarray:
    """D_x: the mean along direction x, kept as a length-1 axis."""
    return cube.mean(axis=AXES[direction], keepdims=True)


def reference_components(cube: np.ndarray) -> dict[str, np.ndarray]:
    """N_x = prod over x's directions of (1 - D) times prod over the others of D, applied to U."""
    u = np.asarray(cube, float)
    out = {}
    for name in COMPONENTS:
        n = u
        for d in "tvh":
            n = n - _d(n, d) if d in name else _d(n, d)
        out[name] = n
    return out


def reference_figures(cube: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    """(sample std with ddof 1 of each N_x over its own values, the bias-corrected sigma): the
    corrected variances solve E[s_x^2] = sum_y M_xy sigma_y^2 with, for y containing x,
    M_xy = [prod_{d in x}(n_d - 1) / (n_x - 1)] / prod_{d in y, not in x} n_d."""
    sizes = dict(zip("tvh", cube.shape, strict=True))
    comps = reference_components(cube)
    s2 = {k: float(np.var(v.ravel(), ddof=1)) for k, v in comps.items()}
    m = np.zeros((7, 7))
    for i, x in enumerate(COMPONENTS):
        n_x = math.prod(sizes[d] for d in x)
        scale = math.prod(sizes[d] - 1 for d in x) / (n_x - 1)
        for j, y in enumerate(COMPONENTS):
            if set(x) <= set(y):
                m[i, j] = scale / math.prod(sizes[d] for d in y if d not in x)
    var = np.linalg.solve(m, np.array([s2[k] for k in COMPONENTS]))
    sigma = {k: math.sqrt(v) for k, v in s2.items()}
    sigma["total"] = float(np.std(cube, ddof=1))
    corrected = {k: math.sqrt(max(v, 0.0)) for k, v in zip(COMPONENTS, var, strict=True)}
    corrected["total"] = math.sqrt(max(float(var.sum()), 0.0))
    return sigma, corrected


# ----------------------------------------------------------------- synthetic cubes
SHAPES = {"t": (1, 0, 0), "v": (0, 1, 0), "h": (0, 0, 1)}


def synthetic(rng, size: tuple[int, int, int], sigmas: dict[str, float]) -> np.ndarray:
    """A cube of independent Gaussian components, each white along its own directions."""
    t, v, h = size
    cube = np.full(size, 1000.0)
    for name, s in sigmas.items():
        shape = tuple(n if d in name else 1 for d, n in zip("tvh", (t, v, h), strict=True))
        cube = cube + s * rng.standard_normal(shape)
    return cube


def covered(result, truth: dict[str, float]) -> dict[str, bool]:
    return {k: result.ci95[k][0] <= truth.get(k, 0.0) <= result.ci95[k][1] for k in COMPONENTS}


def test_product_matches_the_reference_on_a_cube_with_every_component():
    cube = synthetic(
        np.random.default_rng(7),
        (30, 24, 20),
        {"t": 0.5, "v": 1.0, "h": 0.8, "tv": 0.6, "th": 0.4, "vh": 2.0, "tvh": 3.0},
    )
    r = noise_3d(cube)
    sigma, corrected = reference_figures(cube)
    for k in (*COMPONENTS, "total"):
        assert r.sigma[k] == pytest.approx(sigma[k], rel=1e-9), k
        assert r.sigma_corrected[k] == pytest.approx(corrected[k], rel=1e-9, abs=1e-12), k
    assert r.mean == pytest.approx(cube.mean(), rel=1e-12)
    assert (r.frames, r.rows, r.cols) == (30, 24, 20)


@pytest.mark.parametrize("name", ["PyradiSampleMWIR.ptw", "PyradiSampleLWIR.ptw"])
def test_real_recordings_match_the_reference(name):
    stack = load_stack(DATA / name)
    r = noise_3d(stack)
    sigma, corrected = reference_figures(np.asarray(stack, float))
    for k in (*COMPONENTS, "total"):
        assert r.sigma[k] == pytest.approx(sigma[k], rel=1e-9), k
        assert r.sigma_corrected[k] == pytest.approx(corrected[k], rel=1e-9, abs=1e-12), k
        lo, hi = r.ci95[k]
        assert 0.0 <= lo <= r.sigma_corrected[k] <= hi, k
    # the ANOVA identity: the total sum of squares is the sum of the seven components'
    comps = reference_components(np.asarray(stack, float))
    total = sum(np.sum(np.broadcast_to(v, stack.shape) ** 2) for v in comps.values())
    assert total == pytest.approx((stack.size - 1) * r.sigma["total"] ** 2, rel=1e-9)


@pytest.mark.parametrize("component", COMPONENTS)
def test_each_component_alone_is_recovered_within_its_interval(component):
    truth = {component: 2.0}
    hits = dict.fromkeys(COMPONENTS, 0)
    for seed in SEEDS:
        r = noise_3d(synthetic(np.random.default_rng(seed), (40, 32, 32), truth))
        for k, ok in covered(r, truth).items():
            hits[k] += ok
        others = [r.sigma_corrected[k] for k in COMPONENTS if k != component]
        assert max(others) < 0.2 * truth[component]  # nothing invented elsewhere
    assert all(h >= 19 for h in hits.values()), hits


def test_all_components_together_where_the_bias_matters():
    """A 64 x 64 frame: sigma_t small beside a large sigma_tvh, every other component present;
    each corrected component's interval holds the truth in 19 of 20 seeds or more. (An exact
    95 % interval does that in 74 % of 20-seed blocks; the coverage itself is the next test.)"""
    truth = {"t": 0.1, "v": 0.5, "h": 0.4, "tv": 0.3, "th": 0.25, "vh": 1.5, "tvh": 5.0}
    hits = dict.fromkeys(COMPONENTS, 0)
    for seed in SEEDS:
        r = noise_3d(synthetic(np.random.default_rng(seed), (50, 64, 64), truth))
        for k, ok in covered(r, truth).items():
            hits[k] += ok
    assert all(h >= 19 for h in hits.values()), hits


def test_interval_coverage_over_many_seeds():
    """On a small cube (every bias large) the 95 % intervals hold the truth 95 % of the time:
    over 400 seeds the binomial standard error is 1.1 %, the band below is -3.6 / +3.2 of it."""
    truth = {"t": 0.3, "v": 1.0, "h": 0.7, "tv": 0.5, "th": 0.4, "vh": 2.0, "tvh": 3.0}
    hits = dict.fromkeys(COMPONENTS, 0)
    n = 400
    for seed in range(n):
        r = noise_3d(synthetic(np.random.default_rng(1000 + seed), (20, 12, 12), truth))
        for k, ok in covered(r, truth).items():
            hits[k] += ok
    assert all(0.91 <= h / n <= 0.985 for h in hits.values()), hits


def test_bias_dominated_flicker_is_visible_uncorrected_and_gone_corrected():
    """sigma_t = 0.05 DN beside sigma_tvh = 5 DN on 100 x 64 x 64: the directional estimate of
    sigma_t^2 carries sigma_tvh^2 / (V H) = 0.0061 DN^2, 2.4 times the true 0.0025."""
    truth = {"t": 0.05, "tvh": 5.0}
    raw, var, inside = [], [], 0
    for seed in SEEDS:
        r = noise_3d(synthetic(np.random.default_rng(200 + seed), (100, 64, 64), truth))
        raw.append(r.sigma["t"])
        var.append(r.sigma_corrected["t"] ** 2)
        inside += r.ci95["t"][0] <= 0.05 <= r.ci95["t"][1]
    expected_raw = math.sqrt(0.05**2 + 5.0**2 / (64 * 64))  # 0.093: what D&W's estimate reads
    assert np.mean(raw) == pytest.approx(expected_raw, rel=0.05)
    assert min(raw) > 0.07  # every seed reads flicker 40 % or more above the truth
    # corrected: the mean variance estimate is the truth within its standard error
    # (sd of one estimate ~ sqrt(2 / 99) E[u_t] = 0.0012 DN^2; over 20 seeds 0.00027)
    assert np.mean(var) == pytest.approx(0.0025, abs=3 * 0.0012 / math.sqrt(len(SEEDS)))
    assert inside >= 19


def test_constant_and_too_small_cubes():
    r = noise_3d(np.full((5, 4, 3), 7, np.uint16))
    assert r.mean == 7.0
    assert all(r.sigma[k] == 0.0 and r.ci95[k] == (0.0, 0.0) for k in (*COMPONENTS, "total"))
    with pytest.raises(ValueError, match="at least 2 frames, got 1"):
        noise_3d(np.zeros((1, 4, 4)))
    with pytest.raises(ValueError, match=r"at least 2 rows and 2 columns, got 1 x 4"):
        noise_3d(np.zeros((3, 1, 4)))


def test_integer_and_float_pixels_agree_and_chunks_do_not_matter():
    rng = np.random.default_rng(3)
    cube = rng.integers(6000, 6400, (12, 10, 9)).astype(np.uint16)
    a, b = noise_3d(cube), noise_3d(cube.astype(np.float32))
    for k, (lo, hi) in a.ci95.items():
        assert b.sigma[k] == pytest.approx(a.sigma[k], rel=1e-9)
        assert b.ci95[k] == pytest.approx((lo, hi), rel=1e-9)
    from snrmon.acquisition.measure.noise3d import Noise3dSums

    sums = Noise3dSums(10, 9)
    for i in range(0, 12, 5):  # chunks of 5, 5 and 2 frames
        sums.add(cube[i : i + 5])
    c = sums.result()
    assert c.sigma_corrected == pytest.approx(a.sigma_corrected, rel=1e-12)
