"""Statistics of the cross-checks: z-scores over pooled standard errors,
chi-square deviates and multiple-comparison limits (no scipy).

Two independent Monte Carlo estimates a +- se_a and b +- se_b differ by
z = (a - b) / sqrt(se_a^2 + se_b^2) standard deviations (`z_score`,
`pooled_stderr`); over n cells the sum of z^2 is chi-square with n degrees
of freedom, judged by its Wilson-Hilferty normal deviate; the largest |z|
of n cells is judged against a Bonferroni limit (`cell_z_limit`).
"""

from __future__ import annotations

import math

import numpy as np


def pooled_stderr(*stderrs):
    """sqrt of the sum of squares of independent standard errors (arrays broadcast)."""
    return np.sqrt(sum(np.square(np.asarray(s, dtype=float)) for s in stderrs))


def z_score(a, se_a, b, se_b):
    """(a - b) / pooled standard error, elementwise; 0 where both agree with zero error, inf where
    they differ with zero error."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    s = pooled_stderr(se_a, se_b)
    d = a - b
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(s > 0, d / np.where(s > 0, s, 1.0), np.where(d == 0, 0.0, np.inf * np.sign(d)))
    return z if z.ndim else float(z)


def normal_two_sided(q: float) -> float:
    """z with P(|Z| > z) = q for a standard normal Z (erfc inverted by bisection)."""
    lo, hi = 0.0, 40.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.erfc(mid / math.sqrt(2.0)) > q:
            lo = mid
        else:
            hi = mid
    return hi


def cell_z_limit(n: int, p: float = 1e-3) -> float:
    """|z| that n independent standard normals all stay below with probability 1 - p (at least 4)."""
    return max(4.0, normal_two_sided(p / max(n, 1)))


def wilson_hilferty(chi2_per_dof: float, dof: int) -> float:
    """Normal deviate of a chi-square per degree of freedom (Wilson-Hilferty); 0 without dof."""
    if dof <= 0:
        return 0.0
    v = 2.0 / (9.0 * dof)
    return (chi2_per_dof ** (1.0 / 3.0) - (1.0 - v)) / math.sqrt(v)


def chi2_critical(dof: float, z: float = 3.719) -> float:
    """Wilson-Hilferty upper quantile of chi-square with `dof` degrees of freedom at the normal
    deviate z (3.719: p = 1e-4)."""
    return dof * (1 - 2 / (9 * dof) + z * math.sqrt(2 / (9 * dof))) ** 3


def gap(ra: float, lost_a: float, rb: float, lost_b: float) -> float:
    """Signed distance between the intervals [ra, ra + lost_a] and [rb, rb + lost_b] (0 if they
    overlap): the reflectance difference of two runs that each lost weight of unknown fate."""
    if ra > rb + lost_b:
        return ra - (rb + lost_b)
    if rb > ra + lost_a:
        return ra + lost_a - rb
    return 0.0
