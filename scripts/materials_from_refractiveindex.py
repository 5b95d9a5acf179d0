#!/usr/bin/env python3
"""Write the measured n, k tables of scenes/materials/ from the refractiveindex.info database.

    materials_from_refractiveindex.py DATABASE_CHECKOUT [--out scenes/materials]

DATABASE_CHECKOUT is a git checkout (or bare repository) of
https://github.com/polyanskiy/refractiveindex.info-database (public domain, CC0 1.0).
Each table is copied exactly: the numbers are the database's text, row by row,
over the full published range; nothing is resampled or reformatted. The
header is `wavelength_um,n,k` (the refractiveindex.info CSV layout), preceded
by `#` comment lines that cite the publication and the database file and commit.

Only the standard library is used (the YAML files are read line by line: a
single `tabulated nk` block each).
"""

import argparse
import math
import pathlib
import subprocess
import sys

# (output file, database path, citation lines, note lines)
TABLES = [
    (
        "gold.csv",
        "database/data/main/Au/nk/Johnson.yml",
        [
            "P. B. Johnson and R. W. Christy,",
            "\"Optical constants of the noble metals\",",
            "Phys. Rev. B 6, 4370-4379 (1972), doi:10.1103/PhysRevB.6.4370.",
        ],
        ["Gold (Au), evaporated films, room temperature."],
    ),
    (
        "silver.csv",
        "database/data/main/Ag/nk/Johnson.yml",
        [
            "P. B. Johnson and R. W. Christy,",
            "\"Optical constants of the noble metals\",",
            "Phys. Rev. B 6, 4370-4379 (1972), doi:10.1103/PhysRevB.6.4370.",
        ],
        ["Silver (Ag), evaporated films, room temperature."],
    ),
    (
        "copper.csv",
        "database/data/main/Cu/nk/Johnson.yml",
        [
            "P. B. Johnson and R. W. Christy,",
            "\"Optical constants of the noble metals\",",
            "Phys. Rev. B 6, 4370-4379 (1972), doi:10.1103/PhysRevB.6.4370.",
        ],
        ["Copper (Cu), evaporated films, room temperature."],
    ),
    (
        "aluminium.csv",
        "database/data/main/Al/nk/Rakic.yml",
        [
            "A. D. Rakic,",
            "\"Algorithm for the determination of intrinsic optical constants of",
            "metal films: application to aluminum\",",
            "Appl. Opt. 34, 4755-4767 (1995), doi:10.1364/AO.34.004755.",
        ],
        [
            "Aluminium (Al), evaporated films: critically analysed optical and",
            "electron-energy-loss data (Kramers-Kronig analysis combined with a",
            "semiquantum model). Use for the visible; aluminium-ir.csv holds the",
            "direct infrared measurements of Ordal et al.",
        ],
    ),
    (
        "aluminium-ir.csv",
        "database/data/main/Al/nk/Ordal.yml",
        [
            "M. A. Ordal, R. J. Bell, R. W. Alexander, L. A. Newquist, M. R. Querry,",
            "\"Optical properties of Al, Fe, Ti, Ta, W, and Mo at submillimeter",
            "wavelengths\",",
            "Appl. Opt. 27, 1203-1209 (1988), doi:10.1364/AO.27.001203.",
        ],
        [
            "Aluminium (Al), room temperature: for the thermal infrared (3-14 um)",
            "of a blackbody radiator cavity.",
        ],
    ),
    (
        "pmma.csv",
        "database/data/organic/(C5H8O2)n - poly(methyl methacrylate)/nk/Zhang-Tomson.yml",
        [
            "X. Zhang, J. Qiu, X. Li, J. Zhao, L. Liu,",
            "\"Complex refractive indices measurements of polymers in visible and",
            "near-infrared bands\",",
            "Appl. Opt. 59, 2337-2344 (2020), doi:10.1364/AO.383831 (0.4-2 um);",
            "X. Zhang, J. Qiu, J. Zhao, X. Li, L. Liu,",
            "\"Complex refractive indices measurements of polymers in infrared bands\",",
            "J. Quant. Spectrosc. Radiat. Transf. 252, 107063 (2020),",
            "doi:10.1016/j.jqsrt.2020.107063 (2-20 um).",
        ],
        [
            "Poly(methyl methacrylate) (PMMA, acrylic), manufacturer Tomson (China),",
            "normal temperature and pressure.",
            "Stands in for a paint-like infrared absorber: acrylic polymers are the",
            "binder of acrylic paints, and a black paint's thermal-infrared",
            "emissivity comes mostly from its binder. As a smooth half-space (how",
            "roks uses n + ik) PMMA reflects 1.4-7.3% at normal incidence over",
            "3-14 um (n 1.24-1.71, k at most 0.36, in the C=O band at 5.8 um),",
            "so it absorbs 93-99%, like a matt black paint (emissivity about",
            "0.90-0.97). The table is not a paint: pigment scattering and",
            "surface texture are not in it.",
        ],
    ),
]


def yaml_text(checkout, path):
    """The file's text at HEAD of a git checkout or bare repository, or from a work tree."""
    work = pathlib.Path(checkout) / path
    if work.is_file():
        return work.read_text(encoding="utf-8")
    out = subprocess.run(
        ["git", "-C", str(checkout), "show", f"HEAD:{path}"],
        check=True,
        capture_output=True,
        text=True,
    )
    return out.stdout


def last_commit(checkout, path):
    """The commit that last changed `path`."""
    out = subprocess.run(
        ["git", "-C", str(checkout), "log", "-1", "--format=%H", "--", path],
        check=True,
        capture_output=True,
        text=True,
    )
    return out.stdout.strip()


def rows(text, path):
    """The rows of the one `tabulated nk` block, as the database's strings."""
    lines = text.splitlines()
    types = [line.strip() for line in lines if line.strip().startswith("- type:")]
    if types != ["- type: tabulated nk"]:
        sys.exit(f"{path}: expected one 'tabulated nk' block, found {types}")
    start = next(i for i, line in enumerate(lines) if line.strip() == "data: |") + 1
    out = []
    for line in lines[start:]:
        fields = line.split()
        if not fields:
            continue
        if len(fields) != 3:
            break
        try:
            values = [float(f) for f in fields]
        except ValueError:
            break
        if not all(math.isfinite(v) for v in values):
            sys.exit(f"{path}: non-finite value in {line!r}")
        out.append(fields)
    wavelengths = [float(r[0]) for r in out]
    if any(b <= a for a, b in zip(wavelengths, wavelengths[1:])):
        sys.exit(f"{path}: wavelengths are not strictly increasing")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkout")
    parser.add_argument("--out", default="scenes/materials")
    args = parser.parse_args()
    out_dir = pathlib.Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, path, citation, note in TABLES:
        data = rows(yaml_text(args.checkout, path), path)
        commit = last_commit(args.checkout, path)
        lo, hi = data[0][0], data[-1][0]
        header = ["Source: " + citation[0], *["        " + c for c in citation[1:]]]
        header += [
            "Numbers copied exactly, full published range, from the refractiveindex.info",
            "database (public domain, CC0 1.0), https://github.com/polyanskiy/refractiveindex.info-database,",
            f"file {path},",
            f"version of commit {commit}",
            "(written by scripts/materials_from_refractiveindex.py).",
            *note,
            f"Columns: vacuum wavelength in um, n, k of n + ik; {len(data)} rows, {lo}-{hi} um.",
        ]
        text = "".join(f"# {line}\n" for line in header)
        text += "wavelength_um,n,k\n"
        text += "".join(",".join(r) + "\n" for r in data)
        (out_dir / name).write_text(text, encoding="utf-8")
        print(f"{out_dir / name}: {len(data)} rows, {lo}-{hi} um")


if __name__ == "__main__":
    main()
