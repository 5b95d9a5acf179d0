#!/usr/bin/env python3
"""Regenerate the `tables-*` bad-input cases (tests/bad_inputs/tables-*.toml
and tests/bad_inputs/data/tables-*/): valid results of a tiny run (default
scene with 10 bumps, bands = 1, inplane_step_deg = 90, 5000 photons at 0 and
40 deg: whole, as two shards, as one whole-run shard, and with a Mueller
tally), each tampered in one way. Run from the repository root after
`cargo build`:

    python3 tests/bad_inputs/data/make-tables-cases.py

Each case is one scene (or command) that roks must refuse with exit 2 and one
line naming the file and the key; see tests/bad_inputs.rs.
"""
import json, os, shutil, subprocess, tempfile

ROOT = os.getcwd()
ROKS = os.path.join(ROOT, "target/debug/roks")
CASES = os.path.join(ROOT, "tests/bad_inputs")
DATA = os.path.join(CASES, "data")

tmp = tempfile.mkdtemp()
scene = open(os.path.join(ROOT, "scenes/default.toml")).read()
scene = scene.replace("bands = 32", "bands = 1\ninplane_step_deg = 90").replace("count = 100", "count = 10")
open(os.path.join(tmp, "tiny.toml"), "w").write(scene)
def run(*args):
    subprocess.run([ROKS, "brdf", "tiny.toml", "--photons", "5000", "--theta", "0,40", "-q", *args], cwd=tmp, check=True)
run("--out", "full")
run("--out", "s0", "--shard", "0/2")
run("--out", "s1", "--shard", "1/2")
run("--out", "whole", "--shard", "0/1")
run("--out", "pol", "--polarisation", "mueller")

for d in os.listdir(DATA):
    if d.startswith("tables-") and os.path.isdir(os.path.join(DATA, d)):
        shutil.rmtree(os.path.join(DATA, d))
for f in os.listdir(CASES):
    if f.startswith("tables-") and f.endswith(".toml"):
        os.remove(os.path.join(CASES, f))

def read(run_dir, name):
    return open(os.path.join(tmp, run_dir, name)).read()

PLATE = """
seed = 11

[quadrics]
top = {{ plane = [0.0, 0.0, 1.0, 0.0] }}
bottom = {{ plane = [0.0, 0.0, 1.0, -1.0] }}
xp = {{ plane = [1.0, 0.0, 0.0, 5.0] }}
xm = {{ plane = [1.0, 0.0, 0.0, -5.0] }}
yp = {{ plane = [0.0, 1.0, 0.0, 5.0] }}
ym = {{ plane = [0.0, 1.0, 0.0, -5.0] }}

[[cells]]
name = "plate"
region = "-top +bottom -xp +xm -yp +ym"
fill = "solid"

[walls]
top = "rough"

[models.rough]
brdf = "{table}"

[[sources]]
beam = {{ direction = [0.0, 0.0, -1.0], diameter = 2.0 }}
position = [0.0, 0.0, 3.0]
photons = 100

[tally]
bands = 4
"""

def case(name, comment, expect, args=None, file=None, body=""):
    lines = [f"# {comment}"]
    if args:
        lines.append(f"# args: {args}")
    for e in expect:
        lines.append(f"# expect: {e}")
    if file:
        lines.append(f"# file: {file}")
    open(os.path.join(CASES, f"tables-{name}.toml"), "w").write("\n".join(lines) + "\n" + body)

def table_case(name, comment, expect, brdf=None, summary=None, mueller=None, with_summary=False):
    """A plate whose wall samples data/tables-<name>/brdf.csv."""
    d = os.path.join(DATA, f"tables-{name}")
    os.makedirs(d)
    src = "pol" if mueller is not None else "full"
    text = read(src, "brdf.csv")
    open(os.path.join(d, "brdf.csv"), "w").write(brdf(text) if brdf else text)
    if summary is not None or with_summary:
        s = json.loads(read(src, "summary.json"))
        if summary:
            summary(s)
        open(os.path.join(d, "summary.json"), "w").write(json.dumps(s))
    if mueller is not None:
        open(os.path.join(d, "mueller.csv"), "w").write(mueller(read(src, "mueller.csv")))
    args = "trace {scene} --out {out} -q"
    case(name, comment, expect, args=args, body=PLATE.format(table=f"data/tables-{name}/brdf.csv"))

def rows(text):
    return text.split("\n")

def edit(text, line, col, value):
    """Field `col` (0-based) of physical line `line` (1-based) set to `value`."""
    ls = rows(text)
    f = ls[line - 1].split(",")
    f[col] = value
    ls[line - 1] = ",".join(f)
    return "\n".join(ls)

def scale(text, line, factor):
    """Fraction, its error and both BRDF columns of `line` times `factor` (consistent)."""
    ls = rows(text)
    f = ls[line - 1].split(",")
    for c in (12, 13, 14, 15):
        f[c] = f"{float(f[c]) * factor:.9e}"
    ls[line - 1] = ",".join(f)
    return "\n".join(ls)

# --- brdf.csv read by an object scene ---------------------------------------
table_case("fraction-nan", "a fraction that is not a number", ["models.rough.brdf", "line 3, column 13 (fraction)", "`NaN`"],
           brdf=lambda t: edit(t, 3, 12, "NaN"))
table_case("brdf-negative", "a negative BRDF", ["models.rough.brdf", "line 4, column 15 (brdf)", "must be >= 0"],
           brdf=lambda t: edit(t, 4, 14, "-2.5e-1"))
table_case("truncated-row", "the file cut in the middle of its last row", ["models.rough.brdf", "line 9", "expected 16 columns, found 9"],
           brdf=lambda t: "\n".join(rows(t)[:8] + [",".join(rows(t)[8].split(",")[:9])]))
table_case("truncated-number", "the file cut inside the last number of its last row", ["models.rough.brdf", "line 9, column 16 (brdf_stderr)", "truncated"],
           brdf=lambda t: t.rstrip("\n")[:-4])
table_case("truncated-block", "the table cut at a block boundary: its summary.json still lists 40 deg",
           ["models.rough.brdf", "summary.json", "incidence[1]", "theta_deg = 40.0", "not tabulated in", "brdf.csv"],
           brdf=lambda t: "\n".join(rows(t)[:5]) + "\n", with_summary=True)
table_case("creates-light", "the cells of 40 deg scaled up: a reflectance above 1, a wall that creates light",
           ["models.rough.brdf", "line 6, column 13 (fraction)", "theta_i_deg = 40", "more than 1"],
           brdf=lambda t: scale(scale(scale(scale(t, 6, 5.0), 7, 5.0), 8, 1.2), 9, 5.0))
table_case("fraction-above-one", "one cell's fraction 3.1 (columns consistent)",
           ["models.rough.brdf", "line 8, column 13 (fraction)", "must be <= 1"],
           brdf=lambda t: scale(t, 8, 5.0))
table_case("edited-fraction", "a fraction edited, its BRDF not",
           ["models.rough.brdf", "line 2, column 15 (brdf)", "fraction / projected_solid_angle_sr"],
           brdf=lambda t: edit(t, 2, 12, "9.0e-1"))
table_case("edited-stderr", "a standard error edited, its BRDF error not",
           ["models.rough.brdf", "line 5, column 16 (brdf_stderr)", "fraction_stderr / projected_solid_angle_sr"],
           brdf=lambda t: edit(t, 5, 13, "1.0e-1"))
table_case("grid-edge", "a cell edge off the Carlson grid", ["models.rough.brdf", "line 3, column 7 (phi_lo_deg)", "Carlson grid of 1 bands"],
           brdf=lambda t: edit(t, 3, 6, "50"))
table_case("grid-centre", "a cell centre off the Carlson grid", ["models.rough.brdf", "line 7, column 9 (theta_deg)", "Carlson grid"],
           brdf=lambda t: edit(t, 7, 8, "45"))
table_case("header", "a renamed column", ["models.rough.brdf", "line 1", "header must be exactly"],
           brdf=lambda t: t.replace("fraction_stderr", "fraction_err", 1))
table_case("duplicate-incidence", "the 0 deg block twice", ["models.rough.brdf", "line 10", "already tabulated from line 2"],
           brdf=lambda t: t + "\n".join(rows(t)[1:5]) + "\n")
table_case("two-azimuths-wall", "a table of two light azimuths (0 and 90 deg) for a wall, which has no surface azimuth",
           ["models.rough.brdf", "column 2 (phi_i_deg)", "a table of 2 light azimuths", "a BRDF wall"],
           brdf=lambda t: t + "\n".join(",".join([r.split(",")[0], "90"] + r.split(",")[2:]) for r in rows(t)[1:9]) + "\n")
table_case("incomplete-block", "a block with its last cell missing", ["models.rough.brdf", "line 8", "incomplete incidence block theta_i_deg = 40"],
           brdf=lambda t: "\n".join(rows(t)[:8]) + "\n")
table_case("summary-reflectance", "summary.json of another run: reflectance differs",
           ["models.rough.brdf", "summary.json", "incidence[0].reflectance", "not the table's"],
           summary=lambda s: s["incidence"][0].__setitem__("reflectance", 0.5))
table_case("summary-stderr", "summary.json with an impossible standard error",
           ["models.rough.brdf", "summary.json", "incidence[1].reflectance_stderr: 0.5 exceeds"],
           summary=lambda s: s["incidence"][1].__setitem__("reflectance_stderr", 0.5))
table_case("summary-stderr-negative", "summary.json with a negative standard error",
           ["models.rough.brdf", "summary.json", "incidence[0].reflectance_stderr", "finite number >= 0"],
           summary=lambda s: s["incidence"][0].__setitem__("reflectance_stderr", -1e-3))
table_case("summary-photons", "summary.json with no photons at 40 deg",
           ["models.rough.brdf", "summary.json", "incidence[1].photons: must be an integer > 0"],
           summary=lambda s: s["incidence"][1].__setitem__("photons", 0))
table_case("summary-photons-differ", "summary.json: photons differ from photons_per_incidence",
           ["models.rough.brdf", "summary.json", "incidence[0].photons: 4000 is not photons_per_incidence = 5000"],
           summary=lambda s: s["incidence"][0].__setitem__("photons", 4000))
table_case("summary-bands", "summary.json of a run with other bands",
           ["models.rough.brdf", "summary.json", "bands: 8 is not the 1 bands of", "brdf.csv"],
           summary=lambda s: s["run"].__setitem__("bands", 8))
table_case("summary-json", "summary.json cut short", ["models.rough.brdf", "summary.json", "invalid JSON"],
           with_summary=True)
with open(os.path.join(DATA, "tables-summary-json", "summary.json"), "r+") as f:
    t = f.read(); f.seek(0); f.truncate(); f.write(t[: len(t) // 2])
table_case("mueller-stderr", "mueller.csv with a negative standard error",
           ["models.rough.brdf", "mueller.csv", "line 3", "column 10 (a standard error)", "must be >= 0"],
           mueller=lambda t: edit(t, 3, 9, "-1e-3"))
table_case("mueller-m00", "mueller.csv of another run: m00 is not the table's brdf",
           ["models.rough.brdf", "mueller.csv", "line 4", "m00 = 0.5 is not the brdf"],
           mueller=lambda t: edit(t, 4, 6, "0.5"))
table_case("mueller-extra-block", "mueller.csv with an incidence the table lacks",
           ["models.rough.brdf", "mueller.csv", "3 incidence blocks, but", "brdf.csv has 2"],
           mueller=lambda t: t + "\n".join(l.replace("40,0,", "60,0,", 1) for l in rows(t)[5:9]) + "\n")

# --- export-brdf ------------------------------------------------------------
d = os.path.join(DATA, "tables-export-truncated")
os.makedirs(d)
open(os.path.join(d, "brdf.csv"), "w").write("\n".join(rows(read("full", "brdf.csv"))[:5]) + "\n")
open(os.path.join(d, "summary.json"), "w").write(read("full", "summary.json"))
case("export-truncated", "export-brdf of a table cut at a block boundary (summary.json lists 40 deg)",
     ["incidence[1]", "not tabulated in"], args="export-brdf {data}/tables-export-truncated --format zemax --out {out} -q",
     file="{data}/tables-export-truncated/summary.json")
d = os.path.join(DATA, "tables-export-creates-light")
os.makedirs(d)
t = read("full", "brdf.csv")
open(os.path.join(d, "brdf.csv"), "w").write(scale(scale(scale(scale(t, 2, 2.0), 3, 2.0), 4, 2.0), 5, 2.0))
case("export-creates-light", "export-brdf of a table whose 0 deg fractions sum to 1.56",
     ["line 2, column 13 (fraction)", "more than 1"], args="export-brdf {data}/tables-export-creates-light --format merl --out {out} -q",
     file="{data}/tables-export-creates-light/brdf.csv")

# --- merge ------------------------------------------------------------------
shards = os.path.join(DATA, "tables-shards")
for s in ("s0", "s1"):
    os.makedirs(os.path.join(shards, s))
    shutil.copy(os.path.join(tmp, s, "tallies.json"), os.path.join(shards, s, "tallies.json"))

def merge_case(name, comment, expect, tamper, which="s1", whole=False):
    """Merge of the two shards with `tamper` applied to `which`; `whole`:
    of the one shard of the whole run, tampered."""
    d = os.path.join(DATA, f"tables-{name}")
    if whole:
        os.makedirs(os.path.join(d, "whole"))
        v = json.loads(read("whole", "tallies.json"))
        tamper(v)
        open(os.path.join(d, "whole", "tallies.json"), "w").write(json.dumps(v))
        case(name, comment, expect, args=f"merge {{data}}/tables-{name}/whole --out {{out}} -q",
             file=f"{{data}}/tables-{name}/whole/tallies.json")
        return
    dirs = {}
    for s in ("s0", "s1"):
        if s == which:
            os.makedirs(os.path.join(d, s))
            v = json.loads(read(s, "tallies.json"))
            tamper(v)
            open(os.path.join(d, s, "tallies.json"), "w").write(json.dumps(v))
            dirs[s] = f"{{data}}/tables-{name}/{s}"
        else:
            dirs[s] = f"{{data}}/tables-shards/{s}"
    case(name, comment, expect, args=f"merge {dirs['s0']} {dirs['s1']} --out {{out}} -q",
         file=f"{dirs[which]}/tallies.json")

def node(v, i=0, k=0):
    return v["incidence"][i]["nodes"][k]["tallies"]

merge_case("merge-nan", "a sum of \"NaN\" in the second shard", ["incidence[0].nodes[0].tallies.carlson.sum[2]", "not a finite number"],
           lambda v: node(v)["carlson"]["sum"].__setitem__(2, "NaN"))
merge_case("merge-negative-sumsq", "a negative sum of squares in the first shard", ["incidence[1].nodes[0].tallies.reflected.sum_sq[0]", "must be >= 0"],
           lambda v: node(v, 1)["reflected"].__setitem__("sum_sq", ["-1.0"]), which="s0")
merge_case("merge-sum-above-photons", "a sum far above the photon count", ["incidence[0].nodes[0].tallies.inplane.sum[1]", "exceeds the 904 photons"],
           lambda v: node(v)["inplane"]["sum"].__setitem__(1, "1e6"))
merge_case("merge-cauchy-schwarz", "a sum of squares too small for its sum", ["incidence[1].nodes[0].tallies.carlson.sum_sq[0]", "sum² <= photons × sum_sq"],
           lambda v: node(v, 1)["carlson"]["sum_sq"].__setitem__(0, "1e-6"))
merge_case("merge-sumsq-above-sum", "a sum of squares above its sum (scores are at most 1)", ["incidence[0].nodes[0].tallies.carlson.sum_sq[3]", "exceeds the sum"],
           lambda v: node(v)["carlson"]["sum_sq"].__setitem__(3, "800.0"))
def bands0(v): v["description"]["run"]["bands"] = 0
merge_case("merge-bands-zero", "the run edited to bands = 0 (alike in all shards: here the one of the whole run)", ["description.run.bands", "must be in 1..=1000, got 0"],
           bands0, whole=True)
def theta95(v): v["description"]["run"]["theta_deg"][1] = 95.0
merge_case("merge-theta-settings", "the run edited alike in all shards: an incidence of 95 deg", ["description.run.theta_deg[1]", "must be in [0, 90)"],
           theta95, whole=True)
def step(v): v["description"]["run"]["inplane_step_deg"] = 7.0
merge_case("merge-inplane-step", "the run edited alike in all shards: in-plane step 7 deg", ["description.run.inplane_step_deg", "must divide 180"],
           step, whole=True)
def roulette(v): v["description"]["run"]["controls"]["roulette_weight"] = "NaN"
merge_case("merge-roulette-nan", "the run edited alike in all shards: roulette weight NaN", ["description.run.controls.roulette_weight", "invalid type"],
           roulette, whole=True)
merge_case("merge-node-photons", "a node with more photons than its batches", ["incidence[0].nodes[0].tallies.photons", "is not the 904 photons of its batches"],
           lambda v: node(v).__setitem__("photons", 5000))
merge_case("merge-node-level", "a node above the tree's root", ["incidence[1].nodes[0].level", "above the root level 1"],
           lambda v: v["incidence"][1]["nodes"][0].__setitem__("level", 40))
merge_case("merge-node-index", "the first shard holding the second's node", ["incidence[0].nodes[0]", "not the next of this shard's batches"],
           lambda v: v["incidence"][0].__setitem__("nodes", json.loads(read("s1", "tallies.json"))["incidence"][0]["nodes"]), which="s0")
merge_case("merge-node-batch", "a node moved to another batch", ["incidence[0].nodes[0].tallies.photons", "4096 is not the 904 photons of its batches"],
           lambda v: v["incidence"][0]["nodes"][0].__setitem__("index", 1), which="s0")
merge_case("merge-lost-negative", "negative lost weight", ["incidence[0].nodes[0].tallies.lost_walls", "must be >= 0"],
           lambda v: node(v).__setitem__("lost_walls", "-3.0"))
merge_case("merge-capped", "more capped histories than photons", ["incidence[1].nodes[0].tallies.capped_histories", "histories of 904 photons"],
           lambda v: node(v, 1).__setitem__("capped_histories", 100000))
merge_case("merge-incidence-missing", "an incidence dropped from the second shard", ["incidence", "must list the run's 2 incidence angles, found 1"],
           lambda v: v["incidence"].pop())
merge_case("merge-seconds-nan", "a total time of NaN", ["seconds", "not a finite number"],
           lambda v: v.__setitem__("seconds", "NaN"))
merge_case("merge-seed-differs", "a shard of another run (seed)", ["description.run.seed", "`description.run.seed` differs"],
           lambda v: v["description"]["run"].__setitem__("seed", 2))
merge_case("merge-replicates", "lattice replicates in a random-launch shard", ["incidence[0].nodes[0].tallies.replicates", "must be null for a random launch"],
           lambda v: node(v).__setitem__("replicates", {"count": 16, "reflected": [], "carlson": [], "inplane": []}))
merge_case("merge-format", "not a tallies file", ["format", "not a roks tallies file"],
           lambda v: v.__setitem__("format_version", 7))
case("merge-one-shard", "one shard alone: the second half of the photons is missing",
     ["description.run.shard.last_photon", "photons [4096, 5000) are missing after this shard"],
     args="merge {data}/tables-shards/s0 --out {out} -q", file="{data}/tables-shards/s0/tallies.json")
shutil.rmtree(tmp)
