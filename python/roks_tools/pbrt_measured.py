"""pbrt-v4's measured BRDF (`Material "measured"`) in numpy: how pbrt-v4 loads
and evaluates an RGL `.bsdf` file, so that "pbrt-v4 reads roks's file and
gets the same BRDF" is tested without building pbrt (it is in no package
registry and needs its git submodules).

Our own code, following pbrt-v4's sources (github.com/mmp/pbrt-v4):

* `read_tensor`: the tensor-file container as pbrt's `Tensor::Tensor`
  reads it (`src/pbrt/bxdfs.cpp`, "Tensor file I/O"; the same layout as
  Mitsuba 3's `src/core/tensor.cpp`): the header `tensor_file\\0`, version
  1.0, then per field its name, rank, type code, data offset and shape.
  pbrt's errors: a file shorter than 18 bytes, another header or version,
  an unknown type code, data past the end of the file. A name given twice
  keeps its last field (`m_fields[name] = ...`). `write_tensor` writes the
  same layout (fields in the order given, data 8-byte aligned), for tests
  that alter a file.
* `MeasuredData.load`: `MeasuredBxDFData::Create` (`src/pbrt/bxdfs.cpp`).
  It fetches, in this order, `theta_i`, `phi_i`, `ndf`, `sigma`, `vndf`,
  `spectra`, `luminance`, `wavelengths`, `description`, `jacobian`; a
  missing one stops pbrt at `CHECK(it != m_fields.end())` in
  `Tensor::field` (so an RGB file, `rgb` instead of `spectra` and
  `wavelengths`, is refused). Then the structure: `description` uint8 of
  rank 1; `theta_i`, `phi_i`, `wavelengths` float32 of rank 1; `ndf`,
  `sigma` float32 of rank 2; `vndf` float32 `[n_phi, n_theta, ., .]`;
  `luminance` float32 `[n_phi, n_theta, n, n]`; `spectra` float32
  `[n_phi, n_theta, n_wavelengths, n, n]` with the same `n` as
  `luminance`; `jacobian` uint8 of shape `[1]`. pbrt prints "invalid BRDF
  file structure" and goes on without the data (the render then fails at
  its first evaluation); here `PbrtError` says which condition failed. A
  file with more than two `phi_i` is anisotropic and must cover the whole
  circle: `rint(2 pi / (phi_i[-1] - phi_i[0])) == 1`, else pbrt exits with
  "reduction N (!= 1) not supported" (Mitsuba 3 accepts 2 and 4). The
  `jacobian` flag is read and ignored: pbrt always applies the factor.
* `PiecewiseLinear2D`: `src/pbrt/util/sampling.h` `PiecewiseLinear2D<D>`,
  its constructor (per slice: conditional CDFs along x, a marginal CDF
  along y, the data divided by the total when `normalize`; else divided by
  `(nx - 1)(ny - 1)` and multiplied back in `Evaluate`), `Invert` (the
  inverse of its sample warp: `vndf`) and `Evaluate` (bilinear in the
  square, multilinear in the D parameters: `ndf`, `sigma`, `spectra`).
  The parameter interval is `FindInterval(n, values[i] <= p)` and the
  weight `clamp((p - p0) / (p1 - p0), 0, 1)`: a parameter outside the grid
  takes the nearest slice (a wavelength outside the file's range its
  nearest wavelength).
* `MeasuredBxDF.f`: `MeasuredBxDF::f` (`src/pbrt/bxdfs.cpp`, with
  `theta2u`, `phi2u` of `src/pbrt/bxdfs.h`). pbrt's `wo` is the direction
  towards the camera and `wi` towards the light; the file's *incident*
  direction is pbrt's `wo` (the one the `vndf`, `sigma` and `spectra`
  grids are parameterised by). With `m = (wo + wi)/|wo + wi|`,
  `u(w) = (sqrt(2 theta / pi), phi / 2 pi + 1/2)` and, for an isotropic
  file, the azimuth of `m` taken relative to that of `wo`:

      f = max(0, spectra(vndf.Invert(u_m; phi_o, theta_o); phi_o, theta_o, lambda))
          * ndf(u_m) / (4 sigma(u_wo) cos(theta_wi))

  0 when `wo` and `wi` are not in the same hemisphere (both flipped when
  below), at every wavelength of `lambda` (pbrt samples 4 per camera ray:
  `sample_visible_wavelengths`, `SampledWavelengths::SampleVisible` of
  `src/pbrt/util/spectrum.h`). So `f cos(theta_wi)` is what Mitsuba 3's
  `measured` `eval` returns (its `si.wi` is pbrt's `wo`) for a file with
  `jacobian = 1`; pbrt clamps at 0 where Mitsuba does not.

pbrt computes in float32 (its default `Float`) and stores the tables as
float32; here the tables are stored as float32 as in pbrt and the
arithmetic is float64, so results differ from pbrt's by float rounding
only. Every function takes arrays of directions (N x 3, unit vectors in
the surface frame, z up) and returns arrays.
"""

from __future__ import annotations

import itertools
import struct
from pathlib import Path

import numpy as np

from roks_tools.errors import ResultError, show

TENSOR_TYPES = {
    1: np.uint8, 2: np.int8, 3: np.uint16, 4: np.int16, 5: np.uint32, 6: np.int32,
    7: np.uint64, 8: np.int64, 9: np.float16, 10: np.float32, 11: np.float64,
}
"""Type codes of the tensor file (`Tensor::Type`; 0 is invalid), little-endian."""

HEADER = b"tensor_file\0"

FIELDS = ("theta_i", "phi_i", "ndf", "sigma", "vndf", "spectra", "luminance", "wavelengths",
          "description", "jacobian")
"""The fields `MeasuredBxDFData::Create` fetches, in its order."""

N_SPECTRUM_SAMPLES = 4
"""pbrt-v4's `NSpectrumSamples`: wavelengths per camera ray."""


class PbrtError(ResultError):
    """A file pbrt-v4 would refuse; the message names the file and what pbrt
    checks (its own message where it has one)."""


def read_tensor(path: str | Path) -> dict[str, np.ndarray]:
    """The fields of a tensor file as pbrt-v4's `Tensor::Tensor` reads them:
    name -> array of the stored type and shape (little-endian, C order)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise PbrtError(f"{show(path)}: unable to open file ({e.strerror})") from None

    def fail(msg):
        return PbrtError(f"{show(path)}: Tensor: {msg}")

    if len(raw) < 12 + 2 + 4:
        raise fail("Invalid tensor file: too small, truncated?")
    if raw[:12] != HEADER:
        raise fail("Invalid tensor file: invalid header.")
    if raw[12:14] != b"\x01\x00":
        raise fail("Invalid tensor file: unknown file version.")
    (n_fields,) = struct.unpack_from("<I", raw, 14)
    pos, fields = 18, {}

    def take(fmt, what):
        nonlocal pos
        size = struct.calcsize(fmt)
        if pos + size > len(raw):
            raise fail(f"Unable to read {what}.")
        values = struct.unpack_from(fmt, raw, pos)
        pos += size
        return values

    for _ in range(n_fields):
        (name_length,) = take("<H", "&name_length")
        if pos + name_length > len(raw):
            raise fail("Unable to read (char *)name.data().")
        name = raw[pos:pos + name_length].decode("latin-1")
        pos += name_length
        ndim, dtype, offset = take("<HBQ", "&ndim, &dtype, &offset")
        if dtype not in TENSOR_TYPES:
            raise fail("Invalid tensor file: unknown type.")
        shape = take(f"<{ndim}Q", "&size_value") if ndim else ()
        t = np.dtype(TENSOR_TYPES[dtype]).newbyteorder("<")
        count = int(np.prod(shape, dtype=np.uint64))
        if offset + count * t.itemsize > len(raw):
            raise fail("Unable to read data.get().")
        fields[name] = np.frombuffer(raw, t, count, offset).reshape(shape)
    return fields


def write_tensor(path: str | Path, fields: dict[str, np.ndarray]) -> None:
    """Write `fields` (name -> array of a type of `TENSOR_TYPES`) as a tensor
    file that `read_tensor`, pbrt-v4 and Mitsuba 3 read."""
    codes = {np.dtype(t): code for code, t in TENSOR_TYPES.items()}
    arrays = {name: np.ascontiguousarray(a) for name, a in fields.items()}
    head = sum(2 + len(n.encode()) + 2 + 1 + 8 + 8 * a.ndim for n, a in arrays.items())
    offset = -(-(18 + head) // 8) * 8
    header, body = bytearray(HEADER + b"\x01\x00" + struct.pack("<I", len(arrays))), bytearray()
    for name, a in arrays.items():
        key = name.encode()
        header += struct.pack("<H", len(key)) + key
        header += struct.pack("<HBQ", a.ndim, codes[a.dtype.newbyteorder("=")], offset + len(body))
        header += struct.pack(f"<{a.ndim}Q", *a.shape)
        body += a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes()
        body += bytes(-len(body) % 8)
    Path(path).write_bytes(bytes(header) + bytes(offset - len(header)) + bytes(body))


def _interval(values: np.ndarray, p: np.ndarray) -> np.ndarray:
    """pbrt's `FindInterval(n, [&](i) { return values[i] <= p; })` for sorted
    values: the last i with values[i] <= p, clamped to [0, n - 2]."""
    count = (values[None, :] <= p[:, None]).sum(axis=1)
    return np.clip(count - 1, 0, len(values) - 2)


def _finite(pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points with a NaN or infinite coordinate (where pbrt's integer cast is
    undefined and it reads outside its table) moved to 0, and a mask of
    them: their results are NaN here."""
    bad = ~np.isfinite(pos).all(axis=1)
    return np.where(bad[:, None], 0.0, pos), bad


class PiecewiseLinear2D:
    """pbrt-v4's `PiecewiseLinear2D<D>` (`src/pbrt/util/sampling.h`): a
    bilinear density on the unit square, given at `ny x nx` nodes per slice,
    conditioned on D parameters with node values `param_values` (slices
    interpolated linearly). `data` has shape `(*param_res, ny, nx)` (x
    contiguous, the first parameter outermost), as pbrt's constructor takes
    it with `xSize = nx`, `ySize = ny`; points are (x, y)."""

    def __init__(self, data: np.ndarray, param_values=(), normalize: bool = True,
                 build_cdf: bool = True):
        if build_cdf and not normalize:
            raise ValueError("PiecewiseLinear2D: build_cdf implies normalize=true")
        data = np.asarray(data, np.float64)
        self.params = [np.asarray(v, np.float32).astype(np.float64) for v in param_values]
        self.ny, self.nx = data.shape[-2:]
        self.inv_patch = np.array([self.nx - 1, self.ny - 1], np.float64)
        slices = data.reshape(-1, self.ny, self.nx)
        self.cond = self.marg = None
        if build_cdf:
            # Conditional CDF along x per row (trapezoids), marginal along y
            # from the rows' totals; all divided by the slice's total.
            cond = np.concatenate([np.zeros((len(slices), self.ny, 1)),
                                   np.cumsum(0.5 * (slices[..., :-1] + slices[..., 1:]), axis=-1)],
                                  axis=-1).astype(np.float32).astype(np.float64)
            rows = cond[..., -1]
            marg = np.concatenate([np.zeros((len(slices), 1)),
                                   np.cumsum(0.5 * (rows[:, :-1] + rows[:, 1:]), axis=-1)],
                                  axis=-1).astype(np.float32).astype(np.float64)
            norm = (1.0 / marg[:, -1].astype(np.float32)).astype(np.float64)
            self.cond = (cond * norm[:, None, None]).astype(np.float32).reshape(data.shape)
            self.marg = (marg * norm[:, None]).astype(np.float32).reshape(data.shape[:-1])
            out = slices * norm[:, None, None]
        elif normalize:
            avg = 0.25 * (slices[:, :-1, :-1] + slices[:, :-1, 1:] + slices[:, 1:, :-1] + slices[:, 1:, 1:])
            out = slices / avg.sum(axis=(1, 2))[:, None, None]
        else:
            out = slices / np.prod(self.inv_patch)
        self.data = out.astype(np.float32).reshape(data.shape)

    def _corners(self, params):
        """The parameter interpolation: [(index tuple of the slice, weight)]
        over the 2^D corners, per point (pbrt's `param_weight`,
        `slice_offset` and `lookup<D>`; a parameter of one value has weight
        1 on it)."""
        n = len(params[0]) if params else 1
        per_dim = []
        for values, p in zip(self.params, params):
            p = np.asarray(p, np.float64)
            if len(values) == 1:
                per_dim.append([(np.zeros(n, int), np.ones(n)), (np.zeros(n, int), np.zeros(n))])
                continue
            i = _interval(values, p)
            p0, p1 = values[i], values[i + 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                w1 = np.clip((p - p0) / (p1 - p0), 0.0, 1.0)
            per_dim.append([(i, 1.0 - w1), (i + 1, w1)])
        corners = []
        for choice in itertools.product(*per_dim):
            index = tuple(c[0] for c in choice)
            weight = np.prod([c[1] for c in choice], axis=0) if choice else np.ones(n)
            corners.append((index, weight))
        return corners

    def _lookup(self, table, corners, *tail):
        return sum(w * table[(*index, *tail)].astype(np.float64) for index, w in corners)

    def _patch(self, corners, x, y):
        """The density at the four nodes of the patch at (x, y): v00, v10,
        v01, v11 (first index x, second y)."""
        return (self._lookup(self.data, corners, y, x), self._lookup(self.data, corners, y, x + 1),
                self._lookup(self.data, corners, y + 1, x), self._lookup(self.data, corners, y + 1, x + 1))

    def evaluate(self, pos: np.ndarray, *params) -> np.ndarray:
        """`Evaluate(pos, params...)`: the density at points `pos` (N x 2)."""
        pos, bad = _finite(np.asarray(pos, np.float64) * self.inv_patch)
        off = np.minimum(np.trunc(pos).astype(int), [self.nx - 2, self.ny - 2])
        w1 = pos - off
        w0 = 1.0 - w1
        corners = self._corners(params)
        v00, v10, v01, v11 = self._patch(corners, off[:, 0], off[:, 1])
        value = (w0[:, 1] * (w0[:, 0] * v00 + w1[:, 0] * v10)
                 + w1[:, 1] * (w0[:, 0] * v01 + w1[:, 0] * v11)) * np.prod(self.inv_patch)
        return np.where(bad, np.nan, value)

    def invert(self, sample: np.ndarray, *params) -> tuple[np.ndarray, np.ndarray]:
        """`Invert(sample, params...)`: the uniform square point that the
        sample warp maps to `sample` (N x 2), and the density there."""
        s, bad = _finite(np.asarray(sample, np.float64) * self.inv_patch)
        pos = np.minimum(np.trunc(s).astype(int), [self.nx - 2, self.ny - 2])
        s = s - pos
        corners = self._corners(params)
        x, y = pos[:, 0], pos[:, 1]
        v00, v10, v01, v11 = self._patch(corners, x, y)
        w1 = s
        w0 = 1.0 - w1
        c0 = w0[:, 1] * v00 + w1[:, 1] * v01
        c1 = w0[:, 1] * v10 + w1[:, 1] * v11
        pdf = w0[:, 0] * c0 + w1[:, 0] * c1
        sx = s[:, 0] * (c0 + 0.5 * s[:, 0] * (c1 - c0))
        sy = s[:, 1]
        v0 = self._lookup(self.cond, corners, y, x)
        v1 = self._lookup(self.cond, corners, y + 1, x)
        sx = sx + (1.0 - sy) * v0 + sy * v1
        r0 = self._lookup(self.cond, corners, y, self.nx - 1)
        r1 = self._lookup(self.cond, corners, y + 1, self.nx - 1)
        sx = sx / ((1.0 - sy) * r0 + sy * r1)
        sy = sy * (r0 + 0.5 * sy * (r1 - r0))
        sy = sy + self._lookup(self.marg, corners, y)
        sx, sy = np.where(bad, np.nan, sx), np.where(bad, np.nan, sy)
        return np.stack([sx, sy], axis=1), np.where(bad, np.nan, pdf * np.prod(self.inv_patch))


def theta2u(theta):
    """`MeasuredBxDF::theta2u`: sqrt(2 theta / pi)."""
    return np.sqrt(theta * (2 / np.pi))


def phi2u(phi):
    """`MeasuredBxDF::phi2u`: phi / 2 pi + 1/2."""
    return phi * (1 / (2 * np.pi)) + 0.5


def sample_visible_wavelengths(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """pbrt-v4's `SampledWavelengths::SampleVisible(u)` for each `u` in [0, 1):
    the 4 wavelengths (nm) of a camera ray, `u + i/4` (wrapped) through
    `SampleVisibleWavelengths`, and their densities
    `VisibleWavelengthsPDF` (`src/pbrt/util/sampling.h`). Shapes (N, 4)."""
    up = np.asarray(u, np.float64)[:, None] + np.arange(N_SPECTRUM_SAMPLES) / N_SPECTRUM_SAMPLES
    up = np.where(up > 1, up - 1, up)
    lam = 538 - 138.888889 * np.arctanh(0.85691062 - 1.82750197 * up)
    pdf = np.where((lam < 360) | (lam > 830), 0.0, 0.0039398042 / np.cosh(0.0072 * (lam - 538)) ** 2)
    return lam, pdf


def _check_structure(path: Path, t: dict[str, np.ndarray]) -> None:
    """The structure test of `MeasuredBxDFData::Create`, naming the first
    condition that fails."""
    f32, u8 = np.dtype(np.float32), np.dtype(np.uint8)
    n_phi, n_theta = t["phi_i"].shape[:1], t["theta_i"].shape[:1]
    conditions = [
        ("description uint8 of rank 1", t["description"].ndim == 1 and t["description"].dtype == u8),
        ("theta_i float32 of rank 1", t["theta_i"].ndim == 1 and t["theta_i"].dtype == f32),
        ("phi_i float32 of rank 1", t["phi_i"].ndim == 1 and t["phi_i"].dtype == f32),
        ("wavelengths float32 of rank 1", t["wavelengths"].ndim == 1 and t["wavelengths"].dtype == f32),
        ("ndf float32 of rank 2", t["ndf"].ndim == 2 and t["ndf"].dtype == f32),
        ("sigma float32 of rank 2", t["sigma"].ndim == 2 and t["sigma"].dtype == f32),
        ("vndf float32 [n_phi, n_theta, ., .]",
         t["vndf"].ndim == 4 and t["vndf"].dtype == f32 and t["vndf"].shape[:2] == n_phi + n_theta),
        ("luminance float32 [n_phi, n_theta, n, n]",
         t["luminance"].ndim == 4 and t["luminance"].dtype == f32
         and t["luminance"].shape[:2] == n_phi + n_theta
         and t["luminance"].shape[2] == t["luminance"].shape[3]),
        ("spectra float32 [n_phi, n_theta, n_wavelengths, n, n]",
         t["spectra"].dtype == f32 and t["spectra"].ndim == 5
         and t["spectra"].shape[:3] == n_phi + n_theta + t["wavelengths"].shape[:1]
         and t["spectra"].shape[3] == t["spectra"].shape[4]),
        ("luminance and spectra of the same n",
         t["luminance"].shape[2:] == t["spectra"].shape[3:]),
        ("jacobian uint8 of shape [1]", t["jacobian"].shape == (1,) and t["jacobian"].dtype == u8),
    ]
    for what, ok in conditions:
        if not ok:
            raise PbrtError(f"{show(path)}: invalid BRDF file structure (pbrt-v4 needs {what})")


class MeasuredData:
    """pbrt-v4's `MeasuredBxDFData`: the interpolants of a `.bsdf` file.

    Attributes: `wavelengths` (nm), `isotropic` (at most two `phi_i`),
    `jacobian` (the file's flag, which pbrt ignores), and the
    `PiecewiseLinear2D` tables `ndf`, `sigma` (no normalisation), `vndf`,
    `luminance` (normalised, with CDFs) and `spectra` (no normalisation),
    built as `MeasuredBxDFData::Create` builds them."""

    @classmethod
    def load(cls, path: str | Path) -> "MeasuredData":
        """Read and check a file as pbrt-v4 does (`PbrtError` where pbrt
        stops or refuses the file)."""
        path = Path(path)
        t = read_tensor(path)
        for name in FIELDS:
            if name not in t:
                raise PbrtError(f"{show(path)}: no field '{name}' (pbrt-v4 stops: "
                                "Check failed: it != m_fields.end(), Tensor::field)")
        _check_structure(path, t)
        self = cls()
        self.path = path
        phi_i, theta_i = t["phi_i"], t["theta_i"]
        self.isotropic = phi_i.shape[0] <= 2
        if not self.isotropic:
            reduction = int(np.rint(2 * np.pi / float(np.float32(phi_i[-1] - phi_i[0]))))
            if reduction != 1:
                raise PbrtError(f"{show(path)}: reduction {reduction} (!= 1) not supported")
        self.jacobian = int(t["jacobian"][0])
        self.wavelengths = np.asarray(t["wavelengths"], np.float32)
        self.ndf = PiecewiseLinear2D(t["ndf"], normalize=False, build_cdf=False)
        self.sigma = PiecewiseLinear2D(t["sigma"], normalize=False, build_cdf=False)
        self.vndf = PiecewiseLinear2D(t["vndf"], (phi_i, theta_i))
        self.luminance = PiecewiseLinear2D(t["luminance"], (phi_i, theta_i))
        self.spectra = PiecewiseLinear2D(t["spectra"], (phi_i, theta_i, self.wavelengths),
                                         normalize=False, build_cdf=False)
        return self

    def f(self, wo: np.ndarray, wi: np.ndarray, lam) -> np.ndarray:
        """`MeasuredBxDF::f(wo, wi)` at the wavelengths `lam` (nm; shape (4,)
        for all pairs or (N, 4)): the BRDF (1/sr), shape (N, len(lam)). `wo`
        towards the camera (the file's incident direction), `wi` towards the
        light, both (N, 3) unit vectors. NaN where pbrt's result is
        undefined: a point that the `vndf` warp maps to NaN (a slice or row
        without density, 0 / 0), where pbrt casts NaN to an integer and
        reads outside its table."""
        wo = np.array(wo, np.float64, ndmin=2)
        wi = np.array(wi, np.float64, ndmin=2)
        n = len(wo)
        lam = np.broadcast_to(np.asarray(lam, np.float64), (n, np.shape(lam)[-1]))
        with np.errstate(divide="ignore", invalid="ignore"):
            same = wo[:, 2] * wi[:, 2] > 0
            flip = np.where(wo[:, 2] < 0, -1.0, 1.0)[:, None]
            wo, wi = wo * flip, wi * flip
            wm = wi + wo
            length2 = (wm * wm).sum(axis=1)
            ok = same & (length2 > 0)
            wm = wm / np.sqrt(np.where(length2 > 0, length2, 1.0))[:, None]
            theta_o, phi_o = np.arccos(np.clip(wo[:, 2], -1, 1)), np.arctan2(wo[:, 1], wo[:, 0])
            theta_m, phi_m = np.arccos(np.clip(wm[:, 2], -1, 1)), np.arctan2(wm[:, 1], wm[:, 0])
            u_wo = np.stack([theta2u(theta_o), phi2u(phi_o)], axis=1)
            u_wm = np.stack([theta2u(theta_m), phi2u(phi_m - phi_o if self.isotropic else phi_m)], axis=1)
            u_wm[:, 1] -= np.floor(u_wm[:, 1])
            ui, _ = self.vndf.invert(u_wm, phi_o, theta_o)
            fr = np.stack([np.maximum(0.0, self.spectra.evaluate(ui, phi_o, theta_o, lam[:, k]))
                           for k in range(lam.shape[1])], axis=1)
            scale = self.ndf.evaluate(u_wm) / (4 * self.sigma.evaluate(u_wo) * wi[:, 2])
            return np.where(ok[:, None], fr * scale[:, None], 0.0)
