"""The Carlson (1976) equal-solid-angle grid of roks's brdf.csv, in numpy.

The same grid as the Rust side's `CarlsonGrid` (src/tally/carlson.rs): with
M bands and K = M (M + 1), band j = 1..M (counted from the pole) spans
mu = cos(theta) in [1 - j (j + 1) / K, 1 - (j - 1) j / K], each edge an
integer ratio rounded once, and is split into 4 j azimuth cells; azimuth
cell c is centred on phi = c 2 pi / (4 j), so cell 0 straddles phi = 0 and
reports phi_lo < 0. Every cell has solid angle pi / K sr; the projected
solid angle of a cell of band j is pi (K - j^2) / K^2 sr. Flat indices run
band by band from the pole (band j starts at 2 j (j - 1)), 2 K cells in
all: the row order of every incidence block of brdf.csv.

This is the grid the readers, the `roks_table` plugin and the tests use.
The Mitsuba tracer (`roks_tools.mitsuba.tracer`) keeps its own Carlson
binning on purpose: it is an independent check of roks's binning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class CarlsonGrid:
    """The grid with `bands` polar bands; arrays are per flat cell."""

    bands: int

    def __post_init__(self):
        if self.bands < 1:
            raise ValueError(f"a Carlson grid needs at least one band, not {self.bands}")

    @classmethod
    def of_cells(cls, n_cells: int) -> "CarlsonGrid":
        """The grid with `n_cells` = 2 M (M + 1) cells; ValueError if there is none."""
        m = int(round((-1 + math.sqrt(1 + 2 * n_cells)) / 2))
        if m < 1 or 2 * m * (m + 1) != n_cells:
            raise ValueError(f"{n_cells} cells are not a complete Carlson grid")
        return cls(m)

    @property
    def k(self) -> int:
        """K = M (M + 1), the number of cells per steradian times pi."""
        return self.bands * (self.bands + 1)

    @property
    def n_cells(self) -> int:
        """2 M (M + 1)."""
        return 2 * self.k

    @property
    def solid_angle(self) -> float:
        """Solid angle of every cell, pi / K sr."""
        return math.pi / self.k

    @cached_property
    def band(self) -> np.ndarray:
        """Band (1-based) of every flat cell."""
        return np.concatenate([np.full(4 * j, j) for j in range(1, self.bands + 1)])

    @cached_property
    def cell(self) -> np.ndarray:
        """Azimuth cell (0-based, within its band) of every flat cell."""
        return np.concatenate([np.arange(4 * j) for j in range(1, self.bands + 1)])

    @cached_property
    def mu_bot(self) -> np.ndarray:
        """cos of the lower polar edge, (K - j (j + 1)) / K."""
        j = self.band
        return (self.k - j * (j + 1)) / self.k

    @cached_property
    def mu_top(self) -> np.ndarray:
        """cos of the upper polar edge, (K - (j - 1) j) / K."""
        j = self.band
        return (self.k - (j - 1) * j) / self.k

    @cached_property
    def dphi(self) -> np.ndarray:
        """Azimuth width of the cells, 2 pi / (4 j) (radians)."""
        return 2 * math.pi / (4 * self.band)

    @cached_property
    def phi_lo(self) -> np.ndarray:
        """(c - 1/2) 2 pi / (4 j), radians (negative for cell 0)."""
        return (self.cell - 0.5) * self.dphi

    @cached_property
    def phi_hi(self) -> np.ndarray:
        """(c + 1/2) 2 pi / (4 j), radians."""
        return (self.cell + 0.5) * self.dphi

    @cached_property
    def theta_centre(self) -> np.ndarray:
        """acos((mu_top + mu_bot) / 2): splits the cell's solid angle in half (radians)."""
        return np.arccos((self.mu_top + self.mu_bot) / 2)

    @cached_property
    def phi_centre(self) -> np.ndarray:
        """c 2 pi / (4 j), in [0, 2 pi) (radians)."""
        return self.cell * self.dphi

    @cached_property
    def projected_solid_angle(self) -> np.ndarray:
        """pi (K - j^2) / K^2 sr, the exact integral of cos(theta) over the cell."""
        return math.pi * (self.k - self.band * self.band) / (self.k * self.k)

    def start(self, band: int) -> int:
        """Flat index of the first cell of `band`, 2 j (j - 1)."""
        return 2 * band * (band - 1)

    def locate(self, d: np.ndarray) -> np.ndarray:
        """Flat cell of unit directions d (N, 3) with z > 0 (a band holds
        mu_bot <= mu < mu_top, band 1 also the pole; a cell phi_lo <= phi < phi_hi)."""
        d = np.asarray(d, dtype=float)
        mu = d[:, 2]
        m, k = self.bands, self.k
        x = (1.0 - mu) * k
        j = np.clip(np.ceil((-1.0 + np.sqrt(1.0 + 4.0 * x)) / 2.0).astype(np.int64), 1, m)
        for _ in range(2):  # correct the closed form against the exact edges
            bot = (k - j * (j + 1)) / k
            top = (k - (j - 1) * j) / k
            j = np.where((j < m) & (mu < bot), j + 1, j)
            j = np.where((j > 1) & (mu >= top), j - 1, j)
        n = 4 * j
        v = np.arctan2(d[:, 1], d[:, 0]) / (2 * math.pi / n) + 0.5 + n
        c = np.mod(np.floor(v).astype(np.int64), n)
        return 2 * j * (j - 1) + c
