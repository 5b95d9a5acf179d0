"""Readers of the files roks exports for other programs: one per format,
returning typed objects of numpy arrays.

* `ZemaxBsdf` (`read_zemax`): the Zemax / Radiant tabular BSDF text of
  `roks export-brdf --format zemax` and `roks brdf --export zemax`
  (`brdf.bsdf`; a spectral run's `brdf_<wavelength>um.bsdf`),
  `PlaneSymmetrical` or `Asymmetrical4D` (src/export/zemax.rs);
* `Merl` (`read_merl`): the MERL binary BRDF (`brdf.binary`,
  src/export/merl.rs), its 90 x 90 x 180 x 3 table in sr^-1 and the
  reference reader's lookup;
* `TensorFile` (`read_tensor_file`): the tensor-file container of Mitsuba 3
  (src/export/rgl/tensor.rs), typed as `RglBsdf` (`read_rgl`: the RGL
  measured BRDF `brdf_rgl.bsdf`, src/export/rgl.rs) or `Pbsdf`
  (`read_pbsdf`: the polarised measured BRDF `brdf.pbsdf`,
  src/export/pbsdf.rs);
* `AbgRows` (`read_opticstudio_abg`): the ABg rows for OpticStudio's
  dialog that `roks fit-model --model abg` writes (`fit_abg_opticstudio.txt`);
* `PlyMesh` (`read_ply`): the binary little-endian PLY of
  `roks export-mesh` (src/export/mod.rs `write_ply`);
* `HeightMap` (`read_height_map`): the text height map of `roks
  export-heightfield --out FILE.txt` (an `.exr` one is read by
  `results.read_exr`).

`fit_<model>.json` and `export.json` are JSON: `roks_tools.summary`
(`read_fit_model`, `read_export_marker`) reads them.

Every reader checks the whole file against what roks writes (keywords,
counts, sizes, finite values) and raises `ResultError`, one line naming
the file (and the line or byte), for anything else: a cut file, garbage,
another format. Readers tolerate what the formats allow and roks may add
(comment lines, keywords in any letter case, more tensor fields).
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ResultError, show

__all__ = [
    "ZemaxBsdf", "read_zemax", "Merl", "read_merl", "MERL_SCALES", "TensorFile", "read_tensor_file",
    "RglBsdf", "read_rgl", "Pbsdf", "read_pbsdf", "AbgRows", "read_opticstudio_abg", "PlyMesh", "read_ply",
    "is_tensor_file", "HeightMap", "read_height_map",
]

MAX_EXPORT_BYTES = 4 << 30
"""Largest export file read (4 GiB)."""


def _bytes(path: Path) -> bytes:
    """The file's bytes, or ResultError naming it."""
    try:
        size = path.stat().st_size
        if size > MAX_EXPORT_BYTES:
            raise ResultError(f"{show(path)}: {size} bytes, larger than any roks export")
        return path.read_bytes()
    except FileNotFoundError:
        raise ResultError(f"{show(path)}: not found") from None
    except IsADirectoryError:
        raise ResultError(f"{show(path)}: a folder, not a file") from None
    except OSError as e:
        raise ResultError(f"{show(path)}: cannot read: {e.strerror or e}") from None


def _text(path: Path, what: str) -> str:
    data = _bytes(path)
    nul = data.find(b"\0")
    if nul >= 0:
        raise ResultError(f"{show(path)}: byte {nul}: a NUL byte, not {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ResultError(f"{show(path)}: byte {e.start}: not UTF-8 text, not {what}") from None


# ----------------------------------------------------------------------------
# Zemax tabular BSDF
# ----------------------------------------------------------------------------

ZEMAX_SYMMETRIES = {"planesymmetrical": "PlaneSymmetrical", "asymmetrical4d": "Asymmetrical4D"}
"""The `Symmetry` values read (any letter case: the format's documents spell
`Asymmetrical4D` and `ASymmetrical4D`), by their lower-case form."""


@dataclass(frozen=True)
class ZemaxBsdf:
    """A Zemax tabular BSDF file (BRDF, monochrome) as roks writes it.

    Angles in degrees: `sample_rotation_deg` (`SampleRotation`: `[0]` for
    PlaneSymmetrical, the run's light azimuths phi_i_deg for
    Asymmetrical4D), `aoi_deg` (`AngleOfIncidence`), `azimuth_deg` and
    `radial_deg` (`ScatterAzimuth`, `ScatterRadial`: measured from the
    specular direction). `tis[r, a]` is the TIS (the table's reflectance)
    and `data[r, a, psi, radial]` the BRDF (sr^-1) of sample rotation `r`
    and angle of incidence `a`. `wavelength_um`: of a spectral run's
    per-wavelength file, from its name (`brdf_0.55um.bsdf`), else None."""

    path: Path
    symmetry: str
    source: str
    sample_rotation_deg: np.ndarray
    aoi_deg: np.ndarray
    azimuth_deg: np.ndarray
    radial_deg: np.ndarray
    tis: np.ndarray
    data: np.ndarray
    comments: list[str] = field(default_factory=list)
    wavelength_um: float | None = None

    def block(self, aoi_deg: float, rotation_deg: float | None = None) -> tuple[float, np.ndarray]:
        """(TIS, BRDF[azimuth, radial]) of one angle of incidence (and,
        for several sample rotations, the rotation, which must be named)."""
        a = np.flatnonzero(np.abs(self.aoi_deg - aoi_deg) <= 1e-9)
        if not len(a):
            raise ResultError(f"{show(self.path)}: no AngleOfIncidence {aoi_deg:g}")
        if rotation_deg is None:
            if len(self.sample_rotation_deg) > 1:
                rots = ", ".join(f"{r:g}" for r in self.sample_rotation_deg)
                raise ResultError(f"{show(self.path)}: {len(self.sample_rotation_deg)} sample rotations ({rots} "
                                  f"deg): name one, e.g. block({aoi_deg:g}, {self.sample_rotation_deg[0]:g})")
            r = 0
        else:
            rr = np.flatnonzero(np.abs(self.sample_rotation_deg - rotation_deg) <= 1e-9)
            if not len(rr):
                raise ResultError(f"{show(self.path)}: no SampleRotation {rotation_deg:g}")
            r = int(rr[0])
        return float(self.tis[r, a[0]]), self.data[r, a[0]]


class _Tokens:
    """Whitespace-separated tokens with their line numbers, `#` lines skipped."""

    def __init__(self, text: str, path: Path):
        self.path = path
        self.items: list[tuple[int, str]] = []
        self.comments: list[str] = []
        lines = text.split("\n")
        self.last_line = len(lines)
        for i, line in enumerate(lines):
            line = line.lstrip("\ufeff").rstrip("\r")
            if line.lstrip().startswith("#"):
                self.comments.append(line.lstrip()[1:].strip())
                continue
            self.items.extend((i + 1, t) for t in line.split())
        self.pos = 0

    def error(self, line: int, message: str) -> ResultError:
        return ResultError(f"{show(self.path)}: line {line}: {message}")

    def next(self, key: str) -> tuple[int, str]:
        if self.pos >= len(self.items):
            raise self.error(self.last_line, f"{key}: unexpected end of file (cut?)")
        t = self.items[self.pos]
        self.pos += 1
        return t

    def keyword(self, key: str) -> int:
        line, t = self.next(key)
        if t.lower() != key.lower():
            raise self.error(line, f"expected keyword {key}, found {t[:30]!r}")
        return line

    def count(self, key: str) -> tuple[int, int]:
        line, t = self.next(key)
        if not re.fullmatch(r"[0-9]{1,9}", t):
            raise self.error(line, f"{key}: {t[:30]!r} is not a count")
        return line, int(t)

    def numbers(self, key: str, n: int) -> np.ndarray:
        if self.pos + n > len(self.items):
            raise self.error(self.last_line, f"{key}: unexpected end of file (cut?)")
        chunk = self.items[self.pos:self.pos + n]
        try:
            v = np.array([t for _, t in chunk], dtype=float)
        except ValueError:
            v = None
        if v is None or not np.all(np.isfinite(v)) or any(_not_decimal(t) for _, t in chunk):
            for i, (line, t) in enumerate(chunk):
                if _not_decimal(t) or not math.isfinite(float(t)):
                    raise self.error(line, f"{key}: value {i + 1} of {n}: {t[:30]!r} is not a finite number")
            raise self.error(chunk[0][0], f"{key}: not {n} finite numbers")
        self.pos += n
        return v


_DECIMAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def _not_decimal(t: str) -> bool:
    """A token that is not a decimal number (Python's float takes 'nan',
    'inf', '1_0' too)."""
    return _DECIMAL.fullmatch(t) is None


_WAVELENGTH_NAME = re.compile(r"^brdf_([0-9]+(?:\.[0-9]+)?)um\.bsdf$")


def read_zemax(path: str | Path) -> ZemaxBsdf:
    """A Zemax tabular BSDF file roks writes (see `ZemaxBsdf`): the header
    keywords in roks's order (Source, Symmetry, SpectralContent Monochrome,
    ScatterType BRDF, SampleRotation, AngleOfIncidence, ScatterAzimuth,
    ScatterRadial), then Monochrome, DataBegin, per block `TIS` and the
    azimuth x radial values, DataEnd. Angles ascending, within the format's
    ranges; values finite and not negative."""
    path = Path(path)
    text = _text(path, "a Zemax BSDF text file")
    tok = _Tokens(text, path)
    values: dict[str, str] = {}
    for key, want in (("Source", None), ("Symmetry", None), ("SpectralContent", "monochrome"),
                      ("ScatterType", "brdf")):
        tok.keyword(key)
        line, v = tok.next(key)
        if want is not None and v.lower() != want:
            raise tok.error(line, f"{key}: {v[:30]!r} is not supported (roks writes {want})")
        if key == "Symmetry" and v.lower() not in ZEMAX_SYMMETRIES:
            raise tok.error(line, f"Symmetry: {v[:30]!r} is not PlaneSymmetrical or Asymmetrical4D")
        values[key] = v
    symmetry = ZEMAX_SYMMETRIES[values["Symmetry"].lower()]
    tok.keyword("SampleRotation")
    line, n = tok.count("SampleRotation")
    if n < 1 or (n != 1 and symmetry == "PlaneSymmetrical"):
        raise tok.error(line, f"SampleRotation: {n} rotations, {symmetry} has "
                              f"{'1' if symmetry == 'PlaneSymmetrical' else 'at least 1'}")
    rotations = tok.numbers("SampleRotation", n)
    if np.any(np.diff(rotations) <= 0):
        raise tok.error(line, "SampleRotation: the rotations are not ascending")
    lists = []
    for key, hi in (("AngleOfIncidence", 90.0), ("ScatterAzimuth", 360.0 if symmetry == "Asymmetrical4D" else 180.0),
                    ("ScatterRadial", 180.0)):
        tok.keyword(key)
        line, n = tok.count(key)
        v = tok.numbers(key, n)
        if n == 0 or np.any(np.diff(v) <= 0) or np.any(v < 0) or np.any(v > hi):
            raise tok.error(line, f"{key}: the {n} angles must be ascending and in [0, {hi:g}] degrees")
        lists.append(v)
    aoi, azimuth, radial = lists
    tok.keyword("Monochrome")
    tok.keyword("DataBegin")
    per = len(azimuth) * len(radial)
    tis = np.empty((len(rotations), len(aoi)))
    data = np.empty((len(rotations), len(aoi), len(azimuth), len(radial)))
    for r, rho in enumerate(rotations):
        for a, theta in enumerate(aoi):
            where = f"AngleOfIncidence {theta:g}" + (f", SampleRotation {rho:g}" if symmetry == "Asymmetrical4D"
                                                     else "")
            tok.keyword("TIS")
            t = tok.numbers(f"TIS ({where})", 1)[0]
            block = tok.numbers(f"data ({where})", per)
            if t < 0 or np.any(block < 0):
                raise tok.error(tok.items[tok.pos - 1][0], f"{where}: a negative value")
            tis[r, a] = t
            data[r, a] = block.reshape(len(azimuth), len(radial))
    tok.keyword("DataEnd")
    if tok.pos != len(tok.items):
        line, t = tok.items[tok.pos]
        raise tok.error(line, f"{t[:30]!r} after DataEnd")
    m = _WAVELENGTH_NAME.match(path.name)
    return ZemaxBsdf(path=path, symmetry=symmetry, source=values["Source"], sample_rotation_deg=rotations,
                     aoi_deg=aoi, azimuth_deg=azimuth, radial_deg=radial, tis=tis, data=data,
                     comments=tok.comments, wavelength_um=float(m.group(1)) if m else None)


def zemax_direction(aoi_deg: float, psi_deg, r_deg) -> np.ndarray:
    """The unit direction (the table's frame: light on the +x side) at
    ScatterAzimuth `psi_deg` and ScatterRadial `r_deg` about the specular
    direction of incidence `aoi_deg`: `cos r s + sin r (cos psi e0 + sin
    psi e1)`, `s = (-sin t, 0, cos t)`, `e0 = (cos t, 0, sin t)`, `e1 = y`
    (the module documentation of src/export/zemax.rs)."""
    t = math.radians(aoi_deg)
    psi, r = np.radians(np.asarray(psi_deg, float)), np.radians(np.asarray(r_deg, float))
    s, e0, e1 = np.array([-math.sin(t), 0, math.cos(t)]), np.array([math.cos(t), 0, math.sin(t)]), np.array([0, 1, 0.])
    return (np.cos(r)[..., None] * s + np.sin(r)[..., None] * (np.cos(psi)[..., None] * e0
                                                                + np.sin(psi)[..., None] * e1))


# ----------------------------------------------------------------------------
# MERL binary
# ----------------------------------------------------------------------------

MERL_DIMS = (90, 90, 180)
"""Bins in theta_half, theta_diff, phi_diff."""
MERL_SCALES = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
"""Stored value times scale = BRDF (sr^-1), red, green, blue (BRDFRead.cpp)."""


@dataclass(frozen=True)
class Merl:
    """A MERL BRDF: `brdf[i, j, k, c]` in sr^-1 (the stored value times
    `MERL_SCALES[c]`), `i` the theta_half bin, `j` theta_diff, `k` phi_diff,
    `c` red, green, blue; `stored` the file's own numbers (channel-major,
    shape (3, 90, 90, 180))."""

    path: Path
    brdf: np.ndarray
    stored: np.ndarray

    def lookup(self, wi, wo) -> np.ndarray:
        """The BRDF (sr^-1; (N, 3): red, green, blue) for light from `wi`
        seen from `wo` ((N, 3) unit vectors, z the normal), found as the
        reference reader BRDFRead.cpp does: half and difference angles,
        bins by truncation (theta_half's bin sqrt(theta_half / 90 deg) 90),
        phi_diff < 0 folded by +180 deg."""
        wi, wo = np.atleast_2d(np.asarray(wi, float)), np.atleast_2d(np.asarray(wo, float))
        h = wi + wo
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        th = np.arccos(np.clip(h[:, 2], -1, 1))
        ph = np.arctan2(h[:, 1], h[:, 0])
        d = _rotate(_rotate(wi, np.array([0, 0, 1.0]), -ph), np.array([0, 1.0, 0]), -th)
        td = np.arccos(np.clip(d[:, 2], -1, 1))
        pd = np.arctan2(d[:, 1], d[:, 0])
        pd = np.where(pd < 0, pd + math.pi, pd)
        i = np.where(th <= 0, 0, np.minimum(np.sqrt(th / (math.pi / 2) * 90 * 90).astype(int), 89))
        j = np.clip((td / (math.pi / 2) * 90).astype(int), 0, 89)
        k = np.clip((pd / math.pi * 180).astype(int), 0, 179)
        return self.brdf[i, j, k]


def _rotate(v: np.ndarray, axis: np.ndarray, angle) -> np.ndarray:
    """`v` (N, 3) turned by `angle` (N,) about the unit `axis` (Rodrigues)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return v * c + axis * (v @ axis)[:, None] * (1 - c) + np.cross(axis, v) * s


def read_merl(path: str | Path) -> Merl:
    """A MERL binary file: three little-endian int32 dimensions 90, 90,
    180, then 3 x 90 x 90 x 180 little-endian float64 (exactly), finite."""
    path = Path(path)
    raw = _bytes(path)
    if len(raw) < 12:
        raise ResultError(f"{show(path)}: {len(raw)} bytes, too short for MERL's three int32 dimensions")
    dims = struct.unpack_from("<3i", raw)
    if dims != MERL_DIMS:
        raise ResultError(f"{show(path)}: dimensions {dims[0]} x {dims[1]} x {dims[2]}, not MERL's 90 x 90 x 180")
    n = 3 * 90 * 90 * 180
    if len(raw) != 12 + 8 * n:
        raise ResultError(f"{show(path)}: {len(raw)} bytes, a MERL file has {12 + 8 * n} (cut?)")
    stored = np.frombuffer(raw, "<f8", n, 12).reshape(3, 90, 90, 180)
    bad = ~np.isfinite(stored)
    if bad.any():
        c, i, j, k = (int(x) for x in np.argwhere(bad)[0])
        raise ResultError(f"{show(path)}: channel {c} bin ({i}, {j}, {k}): not a finite number")
    brdf = np.moveaxis(stored * np.array(MERL_SCALES)[:, None, None, None], 0, -1)
    return Merl(path=path, brdf=brdf, stored=stored)


# ----------------------------------------------------------------------------
# Tensor files: RGL and pbsdf
# ----------------------------------------------------------------------------

TENSOR_MAGIC = b"tensor_file\0"
TENSOR_TYPES = {
    1: np.uint8, 2: np.int8, 3: np.uint16, 4: np.int16, 5: np.uint32, 6: np.int32,
    7: np.uint64, 8: np.int64, 9: np.float16, 10: np.float32, 11: np.float64,
}
"""Type codes of the tensor file (Mitsuba's `Struct::Type`), little-endian."""


def is_tensor_file(path: str | Path) -> bool:
    """Whether the file begins as a tensor file (RGL, pbsdf), not a Zemax text."""
    try:
        with open(path, "rb") as f:
            return f.read(len(TENSOR_MAGIC)) == TENSOR_MAGIC
    except OSError:
        return False


@dataclass(frozen=True)
class TensorFile:
    """A tensor file: `fields` name -> array of its stored type and shape."""

    path: Path
    fields: dict[str, np.ndarray]


def read_tensor_file(path: str | Path) -> TensorFile:
    """The tensor-file container (src/export/rgl/tensor.rs): magic
    `tensor_file\\0`, version 1.0, u32 field count, per field u16 name
    length, name, u16 rank, u8 type, u64 offset, u64 per dimension; each
    field's data within the file, after the header, fields not overlapping;
    names distinct."""
    path = Path(path)
    raw = _bytes(path)

    def fail(msg: str) -> ResultError:
        return ResultError(f"{show(path)}: {msg}")

    if len(raw) < 18:
        raise fail(f"{len(raw)} bytes, too short for a tensor file")
    if raw[:12] != TENSOR_MAGIC:
        raise fail("not a tensor file (no 'tensor_file' header)")
    if raw[12:14] != b"\x01\x00":
        raise fail(f"tensor file version {raw[12]}.{raw[13]}, this reader knows 1.0")
    (count,) = struct.unpack_from("<I", raw, 14)
    pos = 18
    fields: dict[str, np.ndarray] = {}
    spans = []

    def take(fmt: str, what: str):
        nonlocal pos
        size = struct.calcsize(fmt)
        if pos + size > len(raw):
            raise fail(f"byte {pos}: the header ends inside {what} (cut?)")
        v = struct.unpack_from(fmt, raw, pos)
        pos += size
        return v

    if count > (len(raw) - 18) // 13:
        raise fail(f"{count} fields cannot fit in {len(raw)} bytes")
    for f in range(count):
        (length,) = take("<H", f"the name length of field {f}")
        if pos + length > len(raw):
            raise fail(f"byte {pos}: the header ends inside the name of field {f} (cut?)")
        try:
            name = raw[pos:pos + length].decode("utf-8")
        except UnicodeDecodeError:
            raise fail(f"byte {pos}: the name of field {f} is not UTF-8") from None
        if not name.isprintable() or not name:
            raise fail(f"byte {pos}: field {f} has no printable name")
        pos += length
        ndim, code, offset = take("<HBQ", f"field {name!r}")
        if code not in TENSOR_TYPES:
            raise fail(f"field {name!r}: unknown type code {code}")
        if ndim > 16:
            raise fail(f"field {name!r}: {ndim} dimensions")
        shape = take(f"<{ndim}Q", f"the shape of field {name!r}") if ndim else ()
        t = np.dtype(TENSOR_TYPES[code]).newbyteorder("<")
        n = math.prod(shape)
        if name in fields:
            raise fail(f"field {name!r} given twice")
        if offset > len(raw) or n * t.itemsize > len(raw) - offset:
            raise fail(f"field {name!r}: its data ({n} x {t.itemsize} bytes at byte {offset}) run past the end "
                       f"of the file ({len(raw)} bytes; cut?)")
        fields[name] = np.frombuffer(raw, t, n, offset).reshape(shape)
        spans.append((offset, offset + n * t.itemsize, name))
    for a, b, name in spans:
        if a < pos and b > a:
            raise fail(f"field {name!r}: its data at byte {a} lie inside the header (which ends at byte {pos})")
    spans.sort()
    for (a0, b0, n0), (a1, b1, n1) in zip(spans, spans[1:]):
        if a1 < b0 and b1 > a1 and b0 > a0:
            raise fail(f"fields {n0!r} and {n1!r} overlap")
    return TensorFile(path=path, fields=fields)


def _need(t: TensorFile, name: str, dtype, ndim: int | None = None) -> np.ndarray:
    a = t.fields.get(name)
    if a is None:
        raise ResultError(f"{show(t.path)}: no field {name!r}")
    if a.dtype != np.dtype(dtype).newbyteorder("<") and a.dtype != np.dtype(dtype):
        raise ResultError(f"{show(t.path)}: field {name!r} is {a.dtype}, not {np.dtype(dtype)}")
    if ndim is not None and a.ndim != ndim:
        raise ResultError(f"{show(t.path)}: field {name!r} has {a.ndim} dimensions, not {ndim}")
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ResultError(f"{show(t.path)}: field {name!r} holds a value that is not a finite number")
    return a


def _shape(t: TensorFile, name: str, a: np.ndarray, want: tuple) -> None:
    if tuple(a.shape) != tuple(want):
        raise ResultError(f"{show(t.path)}: field {name!r} has shape {list(a.shape)}, expected {list(want)}")


@dataclass(frozen=True)
class RglBsdf:
    """An RGL measured BRDF (`brdf_rgl.bsdf`, Mitsuba 3's `measured`): the
    incidences `theta_i` (radians) and light azimuths `phi_i`, the
    `wavelengths` (nm; None for an RGB file), `values` the `spectra` (or
    `rgb`) field [phi_i, theta_i, wavelength or channel, n, n], the
    `description` text; every field in `fields`."""

    path: Path
    fields: dict[str, np.ndarray]
    theta_i: np.ndarray
    phi_i: np.ndarray
    wavelengths: np.ndarray | None
    values: np.ndarray
    description: str

    @property
    def rgb(self) -> bool:
        return self.wavelengths is None


def read_rgl(path: str | Path) -> RglBsdf:
    """An RGL measured-BRDF tensor file as roks writes it: the fields
    theta_i, phi_i, ndf, sigma, vndf, luminance, description, jacobian and
    spectra with wavelengths (or rgb), of the shapes pbrt-v4 and Mitsuba 3
    check, float32 finite and spectra not negative."""
    t = read_tensor_file(path)
    f32 = np.float32
    theta_i, phi_i = _need(t, "theta_i", f32, 1), _need(t, "phi_i", f32, 1)
    for name in ("ndf", "sigma"):
        _need(t, name, f32, 2)
    vndf, lum = _need(t, "vndf", f32, 4), _need(t, "luminance", f32, 4)
    desc = _need(t, "description", np.uint8, 1)
    jac = _need(t, "jacobian", np.uint8, 1)
    _shape(t, "jacobian", jac, (1,))
    if "spectra" in t.fields:
        values, waves = _need(t, "spectra", f32, 5), _need(t, "wavelengths", f32, 1)
        _shape(t, "spectra", values, (len(phi_i), len(theta_i), len(waves)) + lum.shape[2:])
    elif "rgb" in t.fields:
        values, waves = _need(t, "rgb", f32, 5), None
        _shape(t, "rgb", values, (len(phi_i), len(theta_i), 3) + lum.shape[2:])
    else:
        raise ResultError(f"{show(t.path)}: no field 'spectra' (nor 'rgb')")
    _shape(t, "luminance", lum, (len(phi_i), len(theta_i)) + lum.shape[2:])
    if vndf.shape[:2] != (len(phi_i), len(theta_i)):
        raise ResultError(f"{show(t.path)}: field 'vndf' has shape {list(vndf.shape)}, not "
                          f"[{len(phi_i)}, {len(theta_i)}, ...]")
    if np.any(values < 0):
        raise ResultError(f"{show(t.path)}: a negative BRDF value in {'spectra' if waves is not None else 'rgb'}")
    if np.any(np.diff(theta_i) <= 0):
        raise ResultError(f"{show(t.path)}: field 'theta_i' is not ascending")
    try:
        text = bytes(desc).decode("utf-8")
    except UnicodeDecodeError:
        raise ResultError(f"{show(t.path)}: field 'description' is not UTF-8 text") from None
    return RglBsdf(path=t.path, fields=t.fields, theta_i=theta_i, phi_i=phi_i, wavelengths=waves, values=values,
                   description=text)


PBSDF_NODES = (46, 46, 73)
"""Nodes of theta_h, theta_d, phi_d of roks's pbsdf files."""


@dataclass(frozen=True)
class Pbsdf:
    """A polarised measured BRDF (`brdf.pbsdf`, Mitsuba 3's
    `measured_polarized`): the nodes `theta_h`, `theta_d`, `phi_d`
    (radians), the wavelengths `wvls` (nm) and `M[phi_d, theta_d, theta_h,
    wavelength, row, column]` the Mueller-matrix BRDF (sr^-1); every field
    in `fields`."""

    path: Path
    fields: dict[str, np.ndarray]
    theta_h: np.ndarray
    theta_d: np.ndarray
    phi_d: np.ndarray
    wvls: np.ndarray
    M: np.ndarray


def read_pbsdf(path: str | Path) -> Pbsdf:
    """A pbsdf tensor file as roks writes it: theta_h, theta_d, phi_d
    (float32, shape [1, n], ascending), wvls (uint16, [5]) and M (float32,
    [phi_d, theta_d, theta_h, 5, 4, 4], finite, m00 not negative)."""
    t = read_tensor_file(path)
    axes = []
    for name in ("theta_h", "theta_d", "phi_d"):
        a = _need(t, name, np.float32, 2)
        if a.shape[0] != 1 or a.shape[1] < 2 or np.any(np.diff(a[0]) <= 0):
            raise ResultError(f"{show(t.path)}: field {name!r} is not one ascending row of nodes "
                              f"(shape {list(a.shape)})")
        axes.append(a[0])
    wvls = _need(t, "wvls", np.uint16, 1)
    _shape(t, "wvls", wvls, (5,))
    m = _need(t, "M", np.float32, 6)
    _shape(t, "M", m, (len(axes[2]), len(axes[1]), len(axes[0]), len(wvls), 4, 4))
    if np.any(m[..., 0, 0] < 0):
        raise ResultError(f"{show(t.path)}: a negative m00 in field 'M'")
    return Pbsdf(path=t.path, fields=t.fields, theta_h=axes[0], theta_d=axes[1], phi_d=axes[2], wvls=wvls, M=m)


# ----------------------------------------------------------------------------
# ABg rows for OpticStudio
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class AbgRows:
    """fit_abg_opticstudio.txt of `roks fit-model --model abg`: the entry's
    `name` and `wave_um` (0: no scaling), one row per angle of incidence
    (`angle_deg`, `a` in sr^-1, `b`, `g`) and the TIS of the fit from each
    row's comment (NaN where a row has none); `comments`: every `!` line."""

    path: Path
    name: str | None
    wave_um: float | None
    angle_deg: np.ndarray
    a: np.ndarray
    b: np.ndarray
    g: np.ndarray
    tis: np.ndarray
    comments: list[str] = field(default_factory=list)


def read_opticstudio_abg(path: str | Path) -> AbgRows:
    """The ABg rows for OpticStudio's dialog: `!` comment lines (`! Name`,
    `! Wave`), then rows `Angle A B g` (finite numbers; A, B positive,
    angles ascending in [0, 90)), each with an optional `! TIS` comment."""
    path = Path(path)
    text = _text(path, "an ABg text file")
    if not text.endswith("\n"):
        raise ResultError(f"{show(path)}: line {text.count(chr(10)) + 1}: the file ends inside a line (cut?)")
    name = wave = None
    rows, tis, comments = [], [], []
    for n, line in enumerate(text.split("\n")[:-1], start=1):
        body, _, comment = line.rstrip("\r").partition("!")
        comment = comment.strip()
        if not body.strip():
            if comment:
                comments.append(comment)
                if comment.startswith("Name "):
                    name = comment[5:].strip()
                elif comment.startswith("Wave "):
                    try:
                        wave = float(comment[5:].split()[0])
                    except (ValueError, IndexError):
                        raise ResultError(f"{show(path)}: line {n}: Wave: not a number") from None
            elif line.strip():
                raise ResultError(f"{show(path)}: line {n}: not a row Angle A B g")
            continue
        cells = body.split()
        if len(cells) != 4 or any(_not_decimal(c) for c in cells):
            raise ResultError(f"{show(path)}: line {n}: {body.strip()[:40]!r} is not a row of four numbers "
                              f"Angle A B g")
        v = [float(c) for c in cells]
        if not all(math.isfinite(x) for x in v) or not (0 <= v[0] < 90) or v[1] <= 0 or v[2] <= 0:
            raise ResultError(f"{show(path)}: line {n}: Angle in [0, 90), A > 0 and B > 0 expected, got "
                              f"{body.strip()[:40]!r}")
        t = comment.split()[0] if comment else ""
        tis.append(float(t) if t and not _not_decimal(t) else math.nan)
        rows.append(v)
    if not rows:
        raise ResultError(f"{show(path)}: no row Angle A B g")
    r = np.array(rows)
    if np.any(np.diff(r[:, 0]) <= 0):
        raise ResultError(f"{show(path)}: the angles are not ascending")
    return AbgRows(path=path, name=name, wave_um=wave, angle_deg=r[:, 0], a=r[:, 1], b=r[:, 2], g=r[:, 3],
                   tis=np.array(tis), comments=comments)


# ----------------------------------------------------------------------------
# PLY meshes of export-mesh
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class PlyMesh:
    """A binary little-endian PLY triangle mesh as `roks export-mesh` writes
    it: `vertices` (N, 3) float32 (scene length units, z up), `faces`
    (M, 3) int32 indices into them (counter-clockwise seen from outside);
    `comments`: the header's comment lines."""

    path: Path
    vertices: np.ndarray
    faces: np.ndarray
    comments: list[str] = field(default_factory=list)


PLY_MAX_HEADER = 4096


def read_ply(path: str | Path) -> PlyMesh:
    """The PLY of `roks export-mesh`: header `ply`, `format
    binary_little_endian 1.0`, `element vertex N` with `property float`
    x, y, z, `element face M` with `property list uchar int
    vertex_indices`, `end_header` (comment lines allowed); then exactly N
    vertices (finite) and M triangles (count 3, indices below N)."""
    path = Path(path)
    raw = _bytes(path)
    end = raw.find(b"end_header\n", 0, PLY_MAX_HEADER)
    if not raw.startswith(b"ply\n") or end < 0:
        raise ResultError(f"{show(path)}: not a PLY file roks writes (no 'ply' ... 'end_header' header)")
    try:
        head = raw[:end].decode("ascii").split("\n")[:-1]
    except UnicodeDecodeError:
        raise ResultError(f"{show(path)}: the PLY header is not ASCII text") from None
    comments = [ln[8:] for ln in head if ln.startswith("comment ") or ln == "comment"]
    lines = [ln.rstrip("\r") for ln in head if not (ln.startswith("comment ") or ln == "comment")]
    want = ["ply", "format binary_little_endian 1.0", None, "property float x", "property float y",
            "property float z", None, "property list uchar int vertex_indices"]
    counts = []
    if len(lines) != len(want):
        raise ResultError(f"{show(path)}: the PLY header has {len(lines)} lines, roks writes {len(want)} "
                          f"(vertex x, y, z floats; faces as lists of int)")
    for i, (got, w) in enumerate(zip(lines, want)):
        if w is None:
            kind = "vertex" if i == 2 else "face"
            m = re.fullmatch(rf"element {kind} ([0-9]{{1,10}})", got)
            if not m:
                raise ResultError(f"{show(path)}: PLY header: expected 'element {kind} N', got {got[:40]!r}")
            counts.append(int(m.group(1)))
        elif got != w:
            raise ResultError(f"{show(path)}: PLY header: expected {w!r}, got {got[:40]!r}")
    nv, nf = counts
    body = end + len(b"end_header\n")
    size = body + 12 * nv + 13 * nf
    if len(raw) != size:
        raise ResultError(f"{show(path)}: {len(raw)} bytes, the header's {nv} vertices and {nf} triangles take "
                          f"{size} (cut?)")
    vertices = np.frombuffer(raw, "<f4", 3 * nv, body).reshape(nv, 3)
    if not np.all(np.isfinite(vertices)):
        raise ResultError(f"{show(path)}: vertex {int(np.argwhere(~np.isfinite(vertices))[0][0])}: "
                          f"not a finite coordinate")
    rec = np.frombuffer(raw, np.dtype([("n", "u1"), ("i", "<i4", (3,))]), nf, body + 12 * nv)
    if np.any(rec["n"] != 3):
        k = int(np.flatnonzero(rec["n"] != 3)[0])
        raise ResultError(f"{show(path)}: face {k}: {rec['n'][k]} vertices, roks writes triangles")
    faces = rec["i"]
    if nf and (faces.min() < 0 or faces.max() >= nv):
        k = int(np.flatnonzero((faces < 0).any(axis=1) | (faces >= nv).any(axis=1))[0])
        raise ResultError(f"{show(path)}: face {k}: a vertex index outside 0..{nv - 1}")
    return PlyMesh(path=path, vertices=vertices, faces=np.array(faces), comments=comments)


# ----------------------------------------------------------------------------
# Text height maps of export-heightfield
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class HeightMap:
    """A text height map (`roks export-heightfield --out FILE.txt`, or one a
    scene's `heightfield = { file = ... }` loads): `heights[j, i]` the
    height of vertex (i, j) at x = i pitch, y = j pitch (file units);
    `comments`: the `#` lines (roks's names the scene and the pitch)."""

    path: Path
    heights: np.ndarray
    comments: list[str] = field(default_factory=list)


def read_height_map(path: str | Path) -> HeightMap:
    """A text height map: one row of heights per line, separated by
    whitespace or commas; empty lines and lines starting with `#` ignored;
    every row as long as the first, every height a finite number (the
    format of src/micro/heightfield_io.rs)."""
    path = Path(path)
    text = _text(path, "a text height map")
    if text and not text.endswith("\n"):
        raise ResultError(f"{show(path)}: line {text.count(chr(10)) + 1}: the file ends inside a line (cut?)")
    rows, comments, width = [], [], None
    for n, line in enumerate(text.split("\n")[:-1], start=1):
        line = line.lstrip("\ufeff").strip()
        if not line:
            continue
        if line.startswith("#"):
            comments.append(line[1:].strip())
            continue
        cells = line.replace(",", " ").split()
        bad = next((c for c in cells if _not_decimal(c)), None)
        if bad is not None:
            raise ResultError(f"{show(path)}: line {n}: {bad[:30]!r} is not a number")
        if width is None:
            width = len(cells)
        elif len(cells) != width:
            raise ResultError(f"{show(path)}: line {n}: {len(cells)} heights, the first row has {width}")
        v = [float(c) for c in cells]
        if not all(math.isfinite(x) for x in v):
            raise ResultError(f"{show(path)}: line {n}: a height that is not a finite number")
        rows.append(v)
    if not rows:
        raise ResultError(f"{show(path)}: no heights")
    return HeightMap(path=path, heights=np.array(rows), comments=comments)
