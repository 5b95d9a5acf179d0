"""Python tools of roks, the Monte Carlo tracer of light reflected from rough
surfaces and rough objects.

* `results`: one reader per file roks writes (monochrome and spectral
  brdf.csv, inplane.csv, stokes.csv, mueller.csv, colour.csv,
  reflectance.csv, farfield.csv, farfield_stokes.csv, fit files, PNG and
  EXR pictures) into typed objects; `load_result(folder)` (brdf, merge,
  shard, trace, fit folders), `read_file(path)`.
* `summary`: summary.json, tallies.json and fit.json as typed dataclasses.
* `errors`: the exceptions (`ResultError` names the file), and `cli` /
  `command`, which turn them into exit codes in the tools' `main`.
* `carlson`: the Carlson equal-solid-angle grid of brdf.csv.
* `stats`: z-scores over pooled standard errors, chi-square deviates,
  Bonferroni limits; `compare` and `images` compare two result folders or
  two renders with them.
* `microfacet`: Beckmann + Smith microfacet theory and the Heitz 2016 walk.
* `mitsuba`: the independent Mitsuba 3 tracer, renders and the `roks_table`
  BSDF plugin (needs mitsuba).
* `studies`: the studies behind results/, run from a checkout as
  `scripts/<name>.py` (not installed as commands).
* `runner`: running roks from Python (`run`, `roks_binary`: $ROKS_BIN, then
  PATH, then the repository's build).
"""
