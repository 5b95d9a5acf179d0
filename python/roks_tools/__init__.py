"""Python tools of roks, the Monte Carlo tracer of light reflected from rough
surfaces and rough objects.

* `results`: one reader per result file (brdf.csv, inplane.csv, summary.json,
  stokes.csv, mueller.csv, reflectance.csv, farfield.csv, EXR renders) into
  typed objects; `BrdfResult.load(folder)`, `TraceResult.load(folder)`.
* `carlson`: the Carlson equal-solid-angle grid of brdf.csv.
* `stats`: z-scores over pooled standard errors, chi-square deviates,
  Bonferroni limits; `compare` and `images` compare two result folders or
  two renders with them.
* `microfacet`: Beckmann + Smith microfacet theory and the Heitz 2016 walk.
* `mitsuba`: the independent Mitsuba 3 tracer, renders and the `roks_table`
  BSDF plugin (needs mitsuba).
* `studies`: the studies behind results/ (entry points `roks-*-study`, ...).
* `runner`: running roks from Python (`run`, `roks_binary`).
"""
