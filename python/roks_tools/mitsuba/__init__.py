"""The Mitsuba 3 side of the cross-checks (needs mitsuba and drjit).

* `setup`: choose the variant (LLVM if a libLLVM >= 19 is found, else scalar).
* `tracer`: the independent multiple-reflection BRDF tracer writing roks's
  formats, with its own Carlson binning on purpose.
* `render`, `object_render`: renders of exported meshes with Mitsuba's `path`.
* `roks_table`: the BSDF plugin rendering a brdf.csv; `render_table` a demo.
"""
