"""Null scattering through heterogeneous media: ratio tracking's transmittance and delta tracking's free flights are
unbiased (their means are exp(-integral sigma_t) and its CDF), where the march's midpoints are not (issue 35)."""
import numpy as np

from core.volumes.tracking import delta_tracking, majorants, ratio_tracking

N = 200_000


def linear(a: float, b: float):
    """sigma_t(s) = a + b s."""
    return lambda s: a + b * np.asarray(s)


def cells(d: float, count: int, seed: int = 3):
    """A jumpy density: `count` equal cells over [0, d], each 0 or 100 at random; returns (sigma_t, integral)."""
    values = np.random.default_rng(seed).choice([0.0, 100.0], size=count)
    def sigma_t(s):
        return values[np.clip((np.asarray(s) / d * count).astype(np.int64), 0, count - 1)]
    return sigma_t, values.sum() * d / count


def within(estimates: np.ndarray, exact: float, sigmas: float = 4.0) -> bool:
    """Whether the estimates' mean is within `sigmas` standard errors of exact."""
    return abs(estimates.mean() - exact) <= sigmas * estimates.std() / np.sqrt(estimates.size) + 1e-12


def test_ratio_tracking_through_a_linear_density_keeps_exp_of_minus_its_integral():
    a, b, d = 0.5, 2.0, 1.0
    edges = np.linspace(0.0, d, 11)
    T_hat = ratio_tracking(linear(a, b), edges, majorants(linear(a, b), edges), np.random.default_rng(1), N)
    assert within(T_hat, np.exp(-(a * d + b * d * d / 2)))


def test_ratio_tracking_through_jumpy_cells_is_unbiased_where_the_march_is_not():
    # 0/100 cells finer than the march's pieces and not aligned to them; majorants sampled at 4 points can miss a
    # cell (then the null weight turns negative, and the mean stays exact).
    d = 0.1
    sigma_t, tau = cells(d, 37)
    edges = np.linspace(0.0, d, 8)
    exact = np.exp(-tau)
    T_hat = ratio_tracking(sigma_t, edges, majorants(sigma_t, edges), np.random.default_rng(2), N)
    assert within(T_hat, exact)
    # The march's estimate on the same pieces (each at its midpoint's density) fails the same check.
    mid = 0.5 * (edges[:-1] + edges[1:])
    march = np.full(N, np.exp(-(sigma_t(mid) * np.diff(edges)).sum()))
    assert not within(march, exact)
    assert abs(march[0] / exact - 1.0) > 0.05


def test_delta_tracking_free_flights_follow_the_closed_form_cdf_of_a_linear_density():
    a, b, d = 0.5, 2.0, 1.0
    edges = np.linspace(0.0, d, 11)
    s, w = delta_tracking(linear(a, b), edges, majorants(linear(a, b), edges), np.random.default_rng(4), N)
    assert np.all(w == 1.0)  # the majorant bounds a linear density: plain delta tracking
    cdf = lambda x: 1.0 - np.exp(-(a * x + b * x * x / 2))
    # Kolmogorov-Smirnov against the closed form, escapes (s = inf) at the mass 1 - cdf(d) beyond d.
    x = np.sort(s)
    empirical = np.arange(1, N + 1) / N
    inside = np.isfinite(x)
    ks = np.max(np.abs(empirical[inside] - cdf(x[inside])))
    assert ks < 1.63 / np.sqrt(N)  # 1 % level
    assert abs((~inside).mean() - (1.0 - cdf(d))) < 4 * np.sqrt(cdf(d) * (1 - cdf(d)) / N)


def test_weighted_delta_tracking_stays_unbiased_where_the_majorant_is_too_low():
    d = 0.1
    sigma_t, tau = cells(d, 37)
    edges = np.linspace(0.0, d, 8)
    s, w = delta_tracking(sigma_t, edges, 0.3 * majorants(sigma_t, edges), np.random.default_rng(5), N)
    assert np.any(w < 0.0)
    # E[w; s <= x] = 1 - T(x) at a few x, and the escapes' weights average to T(d).
    for x in (0.25 * d, 0.5 * d, d):
        tau_x = (sigma_t(np.linspace(0, x, 200_001)[:-1] + x / 400_000).mean()) * x
        assert within(np.where(s <= x, w, 0.0), 1.0 - np.exp(-tau_x))
    assert within(np.where(np.isinf(s), w, 0.0), np.exp(-tau))



def two_sample_ks(x: np.ndarray, y: np.ndarray) -> float:
    """The largest gap between the empirical CDFs of x and y (inf sorts last)."""
    grid = np.sort(np.concatenate([x, y]))
    return np.max(np.abs(np.searchsorted(np.sort(x), grid, side="right") / x.size
                         - np.searchsorted(np.sort(y), grid, side="right") / y.size))


def test_both_kernels_track_the_same_transmittance_and_free_flight_distribution():
    from core.volumes.tracking import compiled_rows, delta_tracking, ratio_tracking, table_density
    n = 100_000
    for values, length, linear in ((np.array([0.5, 2.5]), 1.0, True),
                                   (np.random.default_rng(3).choice([0.0, 100.0], size=37), 0.1, False)):
        sigma_t = table_density(values, length, linear)
        edges = np.linspace(0.0, length, 8)
        mu_bar = majorants(sigma_t, edges)
        T_c, s_c, w_c = compiled_rows(values, length, linear, edges, mu_bar, n, seed=7)
        T_py = ratio_tracking(sigma_t, edges, mu_bar, np.random.default_rng(8), n)
        s_py, w_py = delta_tracking(sigma_t, edges, mu_bar, np.random.default_rng(9), n)
        # linear: sigma_t = 0.5 + 2 s, T = exp(-(a d + b d^2 / 2)); cells: exp(-their sum x width)
        exact = np.exp(-(0.5 * length + 2.0 * length ** 2 / 2) if linear else -values.sum() * length / values.size)
        assert within(T_c, exact) and within(T_py, exact)
        standard_error = np.hypot(T_c.std(), T_py.std()) / np.sqrt(n)
        assert abs(T_c.mean() - T_py.mean()) <= 4 * standard_error
        if np.all(w_c == 1.0) and np.all(w_py == 1.0):
            assert two_sample_ks(s_c, s_py) < 1.95 * np.sqrt(2.0 / n)   # 0.1 % level
        assert within(np.where(np.isinf(s_c), w_c, 0.0), exact)
