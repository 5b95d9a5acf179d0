#!/usr/bin/env python3
"""Reference numbers for src/optics/colour.rs, computed with colour-science (independent implementation).

    python3 -m venv /tmp/cvenv && /tmp/cvenv/bin/pip install colour-science==0.4.7
    /tmp/cvenv/bin/python scripts/colour_reference.py tables   # the Rust const tables
    /tmp/cvenv/bin/python scripts/colour_reference.py expected # the numbers the tests assert

`tables` prints the CIE 1931 2-degree colour-matching functions and the CIE D65
relative spectral power at 5 nm from 380 to 780 nm, as colour-science 0.4.7 holds
them (the literals of colour.colorimetry.datasets: the CIE 1931 table from CVRL,
D65 from the CIE 15:2004 table data; the values of CIE 015:2018), each decimal
written so that it parses to the same f64.

`expected` computes, with colour-science's `sd_to_XYZ_integration` (k = 100 / sum S ybar dw,
rescaled here to Y = 1 for the perfect white reflector) and its sRGB colourspace
(`XYZ_to_RGB` with the IEC 61966-2-1 matrix, `eotf_inverse_sRGB`):
* the ColorChecker "red" patch (No. 15) as measured by Ohta (1997), 380-780 nm at
  5 nm (colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]);
* a flat gold mirror at normal incidence, R = ((n-1)^2 + k^2) / ((n+1)^2 + k^2),
  n and k of scenes/materials/gold.csv interpolated linearly (numpy.interp) onto
  380-780 nm at 5 nm.
The 8-bit value is round(255 * clip(v, 0, 1)) of the encoded value v.
"""

import pathlib
import sys

import numpy as np
import colour

GRID_NM = np.arange(380, 781, 5)
SHAPE = colour.SpectralShape(380, 780, 5)
ROOT = pathlib.Path(__file__).resolve().parent.parent


def cmfs_d65():
    # The table values at 380, 385, ..., 780 nm (tabulated points: nothing is interpolated).
    cmfs_1nm = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65_5nm = colour.SDS_ILLUMINANTS["D65"]
    assert all(w in cmfs_1nm.wavelengths for w in GRID_NM)
    assert all(w in d65_5nm.wavelengths for w in GRID_NM)
    cmfs = colour.MultiSpectralDistributions(
        dict(zip(GRID_NM, cmfs_1nm[GRID_NM])), labels=cmfs_1nm.labels
    )
    d65 = colour.SpectralDistribution(dict(zip(GRID_NM, d65_5nm[GRID_NM])))
    assert np.array_equal(cmfs.wavelengths, GRID_NM) and np.array_equal(d65.wavelengths, GRID_NM)
    return cmfs, d65


def clean(v):
    """The table's decimal: at most 10 significant digits, dropping float noise such as 0.0013680000000000003."""
    text = f"{float(v):.10g}"
    assert float(text) == v, (v, text)
    return text if ("." in text or "e" in text) else text + ".0"


def rust_array(name, doc, values):
    body = "".join(f"    {clean(v)},\n" for v in values)
    return f"/// {doc}\npub const {name}: [f64; {len(values)}] = [\n{body}];\n"


def tables():
    # The dataset literals themselves (the spectral-distribution objects add float noise).
    from colour.colorimetry.datasets.cmfs import DATA_CMFS_STANDARD_OBSERVER
    from colour.colorimetry.datasets.illuminants.sds import DATA_ILLUMINANTS_CIE

    raw_cmfs = DATA_CMFS_STANDARD_OBSERVER["CIE 1931 2 Degree Standard Observer"]
    raw_d65 = DATA_ILLUMINANTS_CIE["D65"]
    cmfs, d65 = cmfs_d65()
    for i, w in enumerate(GRID_NM):
        assert np.allclose(raw_cmfs[int(w)], cmfs.values[i], rtol=1e-12, atol=1e-15)
        assert np.isclose(raw_d65[int(w)], d65.values[i], rtol=1e-12)
    for column, bar in enumerate("XYZ"):
        values = [raw_cmfs[int(w)][column] for w in GRID_NM]
        doc = f"CIE 1931 2-degree {bar.lower()}-bar at [`CMF_WAVELENGTH_NM`] (dimensionless)."
        print(rust_array(f"CIE_{bar}_BAR", doc, values))
    values = [raw_d65[int(w)] for w in GRID_NM]
    doc = "CIE D65 relative spectral power at [`CMF_WAVELENGTH_NM`] (100 at 560 nm)."
    print(rust_array("D65_SPD", doc, values))


def colour_of(reflectance):
    cmfs, d65 = cmfs_d65()
    sd = colour.SpectralDistribution(dict(zip(GRID_NM, reflectance)))
    xyz = colour.colorimetry.sd_to_XYZ_integration(sd, cmfs, d65) / 100.0
    srgb = colour.RGB_COLOURSPACES["sRGB"]
    rgb = colour.XYZ_to_RGB(xyz, srgb, apply_cctf_encoding=False)
    encoded = colour.models.eotf_inverse_sRGB(np.clip(rgb, 0.0, 1.0))
    eight = np.round(255.0 * encoded).astype(int)
    return xyz, rgb, eight


def gold_reflectance():
    rows = [
        line.split(",")
        for line in (ROOT / "scenes/materials/gold.csv").read_text().splitlines()
        if line and line[0].isdigit()
    ]
    table = np.array([[float(v) for v in r] for r in rows])
    lam_um = GRID_NM / 1000.0
    n = np.interp(lam_um, table[:, 0], table[:, 1])
    k = np.interp(lam_um, table[:, 0], table[:, 2])
    return ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)


def expected():
    ohta = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]["red"].copy().trim(SHAPE)
    assert np.array_equal(ohta.wavelengths, GRID_NM)
    print("Ohta red reflectance 380-780/5:", ", ".join(repr(float(v)) for v in ohta.values))
    for name, refl in [("ohta red", ohta.values), ("gold", gold_reflectance())]:
        xyz, rgb, eight = colour_of(refl)
        print(f"{name}: XYZ {xyz.tolist()} linear sRGB {rgb.tolist()} sRGB8 {eight.tolist()}")
    cmfs, d65 = cmfs_d65()
    white = (d65.values[:, None] * cmfs.values).sum(0)
    print("D65 white xy:", (white[:2] / white.sum()).tolist())
    e = cmfs.values.sum(0)
    print("E xy:", (e[:2] / e.sum()).tolist())


if __name__ == "__main__":
    {"tables": tables, "expected": expected}[sys.argv[1] if len(sys.argv) > 1 else "expected"]()
