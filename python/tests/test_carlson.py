"""The Carlson grid of `roks_tools.carlson` against the cell bounds the Rust
side documents (src/tally/carlson.rs) and against the Mitsuba tracer's own,
independent binning."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roks_tools.carlson import CarlsonGrid


def direction(mu, phi):
    s = np.sqrt(np.maximum(0.0, 1.0 - mu * mu))
    return np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=-1)


def test_four_bands_edges_correctly_rounded():
    # src/tally/carlson.rs: "M = 4 gives edges 1, 0.9, 0.7, 0.4, 0 correctly rounded".
    g = CarlsonGrid(4)
    tops = [g.mu_top[g.start(j)] for j in range(1, 5)]
    bots = [g.mu_bot[g.start(j)] for j in range(1, 5)]
    assert tops == [1.0, 0.9, 0.7, 0.4]
    assert bots == [0.9, 0.7, 0.4, 0.0]


@pytest.mark.parametrize("m", [1, 2, 6, 32])
def test_counts_order_and_solid_angles(m):
    g = CarlsonGrid(m)
    k = m * (m + 1)
    assert g.k == k and g.n_cells == 2 * k == len(g.band) == len(g.cell)
    for j in range(1, m + 1):
        s = g.start(j)
        assert s == 2 * j * (j - 1)
        assert g.band[s] == j and g.cell[s] == 0 and g.cell[s + 4 * j - 1] == 4 * j - 1
    assert g.mu_top[0] == 1.0 and g.mu_bot[-1] == 0.0
    # every cell has solid angle pi / K; projected solid angles add up to pi
    omega = g.dphi * (g.mu_top - g.mu_bot)
    assert np.allclose(omega, math.pi / k, rtol=1e-12, atol=0)
    assert g.solid_angle == math.pi / k
    assert abs(g.projected_solid_angle.sum() - math.pi) < 1e-12
    exact = g.dphi * (g.mu_top ** 2 - g.mu_bot ** 2) / 2
    assert np.allclose(g.projected_solid_angle, exact, rtol=1e-9, atol=0)
    # cell 0 straddles phi = 0; centres at c 2 pi / (4 j)
    first = g.cell == 0
    assert np.all(g.phi_lo[first] < 0) and np.allclose(g.phi_lo[first], -g.phi_hi[first])
    assert np.allclose(g.phi_centre, g.cell * 2 * math.pi / (4 * g.band))
    assert np.allclose(np.cos(g.theta_centre), (g.mu_top + g.mu_bot) / 2, rtol=1e-15)


def test_locate_boundaries():
    g = CarlsonGrid(4)
    # a band holds mu_bot <= mu < mu_top, band 1 also the pole
    mu = np.array([1.0, 0.9, 0.9 - 1e-12, 0.7, 0.4, 1e-9])
    cells = g.locate(direction(mu, np.zeros_like(mu) + 0.01))
    assert list(g.band[cells]) == [1, 1, 2, 2, 3, 4]
    # a cell holds phi_lo <= phi < phi_hi: band 2 has 8 cells of 45 deg, cell 1 from 22.5 deg
    d = direction(np.array([0.8, 0.8, 0.8]), np.radians([22.5, 22.5 - 1e-9, -22.5]))
    assert list(g.cell[g.locate(d)]) == [1, 0, 0]


@pytest.mark.parametrize("m", [3, 16])
def test_locate_cell_centres(m):
    g = CarlsonGrid(m)
    d = direction(np.cos(g.theta_centre), g.phi_centre)
    assert np.array_equal(g.locate(d), np.arange(g.n_cells))


def test_of_cells():
    assert CarlsonGrid.of_cells(2 * 32 * 33).bands == 32
    with pytest.raises(ValueError):
        CarlsonGrid.of_cells(100)
    with pytest.raises(ValueError):
        CarlsonGrid(0)


def test_independent_tracer_binning_agrees():
    """The Mitsuba tracer bins with its own code on purpose; both must agree."""
    from roks_tools.mitsuba.tracer import Carlson

    rng = np.random.default_rng(3)
    for m in (4, 32):
        g, theirs = CarlsonGrid(m), Carlson(m)
        mu = rng.random(100_000)
        d = direction(mu, rng.random(100_000) * 2 * math.pi)
        assert np.array_equal(g.locate(d), theirs.locate(d))
        rows = list(theirs.rows())
        assert np.array_equal([r[0] for r in rows], g.band)
        assert np.allclose([r[2] for r in rows], np.degrees(np.arccos(g.mu_top)), rtol=0, atol=1e-12)
        assert np.array_equal([r[9] for r in rows], g.projected_solid_angle)
