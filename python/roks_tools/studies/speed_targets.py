"""The speed targets, measured as ratios in one run: today's code against a baseline build.

    .venv/bin/python scripts/speed_targets.py [--base 6ce6b98] [--out speed] [--rounds 3]
        [--quick] [--no-mitsuba] [--callgrind] [--from-json SPEED_JSON]

Builds the baseline commit (default 6ce6b98, the main of before the speed
work) beside the working tree: `git archive BASE` into
target/speed-base/BASE/src, `cargo build --release` with its own target
folder there (kept, so a second run does not rebuild), and this tree's
`cargo build --release`. Then every case runs with both binaries, the
baseline and the new alternating, `--rounds` times, and the median of each
is kept (the machine is shared and noisy: only ratios measured in one run
mean something). Figures come from the runs' own summary.json (tracing time
only, start-up excluded), peak memory from GNU `/usr/bin/time -f %M` (`roks_tools.runner`).

Cases, each against its target:

* default scene, 60 deg, 2 threads, 2x10^6 photons: segments per second,
  new / base (target >= 3); and new / the Mitsuba 3 tracer of the
  cross-check (`roks_tools.mitsuba.tracer`) on the same surface exported as a
  1025^2-vertex mesh (`roks export-mesh --resolution 1024`), 2x10^5 photons,
  run once a round beside roks, the ratio taken within each round (target >= 15);
  for scale, the default surface's substrate alone (no bumps: two segments a
  photon), the fixed cost of a history against which 3x is to be read;
* scaling, one thread: 100 000 bumps against 100 at constant density (cell
  side 3 sqrt(N), `scripts/scaling.py`'s scenes), rate ratio (target >= 0.6);
  a 4096^2 Gaussian height field against 256^2 (target >= 0.5);
* macro level, one thread: the baffled tubes `scenes/baffled-tube-{10,100,1000}.toml`,
  time per macro segment, 1000 vanes / 10 vanes (target <= 2); the
  radiator with micro walls (`scenes/radiator.toml`), time per photon,
  base / new (target >= 2);
* polarised transport (the new code only; the baseline has none): the
  default geometry with aluminium walls, Stokes vector and Mueller columns
  against the scalar weight, time per segment (target <= 1.5).

--callgrind adds instructions per segment (valgrind --tool=callgrind, one
thread, the difference of two photon counts over the difference of their
segments, so start-up and output do not count) for the default scene and
the 100 000-bump scene, base and new, per photon for the radiator with micro
walls, base and new, and per segment for the three aluminium cases (new). Writes OUT/report.md and
OUT/speed.json. --quick: fewer photons and one round, for a smoke test. --from-json SPEED_JSON
writes the report again from a saved speed.json, without running anything.

Rates are the medians of the rounds; every ratio (new / base, big / small scene,
roks / Mitsuba, polarised / scalar) is the median of the ratios taken within each
round, since the shared machine's speed drifts between rounds more than between
two runs of one round.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from roks_tools.errors import RunError, command
from roks_tools.runner import add_out_argument, check_output, repo_root, run as run_cmd
from roks_tools.studies.scaling import bump_scene, field_scene
from roks_tools.summary import BrdfSummary, TraceSummary, read_summary

ROOT = repo_root()


def build_base(rev: str) -> Path:
    """Build commit `rev` under target/speed-base/REV; return its roks binary."""
    full = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=12", rev], check=True,
                          capture_output=True, text=True).stdout.strip()
    top = ROOT / "target" / "speed-base" / full
    exe = top / "target" / "release" / "roks"
    if exe.exists():
        return exe
    src = top / "src"
    src.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", full], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(src)], input=archive, check=True)
    subprocess.run(["cargo", "build", "--release", "--quiet", "--bin", "roks", "--manifest-path",
                    str(src / "Cargo.toml"), "--target-dir", str(top / "target")], check=True)
    return exe


def build_new() -> Path:
    subprocess.run(["cargo", "build", "--release", "--quiet", "--bin", "roks", "--manifest-path",
                    str(ROOT / "Cargo.toml")], check=True)
    return ROOT / "target" / "release" / "roks"


def measure(cmd: list) -> tuple[BrdfSummary | TraceSummary, float]:
    """Run `cmd` (whose --out folder follows `--out`); its summary and peak RSS (MB)."""
    done = run_cmd(cmd, "speed_targets", echo=False)
    out = Path(done.cmd[done.cmd.index("--out") + 1])
    return read_summary(out / "summary.json"), done.max_rss_mb


def brdf_rate(summary: BrdfSummary) -> dict:
    inc = summary.incidence[0]
    return {"per_segment_s": inc.seconds / inc.segments, "seconds": inc.seconds,
            "segments": inc.segments, "photons": inc.photons}


def trace_rate(summary: TraceSummary) -> dict:
    src = summary.sources
    sec = sum(s.seconds for s in src)
    seg = sum(s.segments for s in src)
    ph = sum(s.photons for s in src)
    return {"per_segment_s": sec / seg, "per_photon_s": sec / ph, "seconds": sec, "segments": seg, "photons": ph}


def alternate(cases: dict, rounds: int) -> dict:
    """cases: name -> (command builder(tmp folder) , rate function). Runs all cases round by round."""
    got: dict = {name: [] for name in cases}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(rounds):
            for name, (make, rate) in cases.items():
                out = Path(tmp) / f"{name.replace('/', '_')}_{r}"
                summary, rss = measure(make(out))
                row = rate(summary)
                row["max_rss_mb"] = rss
                got[name].append(row)
                print(f"  round {r + 1} {name}: {row['per_segment_s'] * 1e9:.1f} ns/segment, {rss:.0f} MB",
                      file=sys.stderr)
    med = {}
    for name, rows in got.items():
        m = {k: statistics.median(row[k] for row in rows) for k in rows[0]}
        m["runs"] = rows
        med[name] = m
    return med


def brdf_segments(summary: BrdfSummary) -> int:
    return summary.incidence[0].segments


def trace_photons(summary: TraceSummary) -> int:
    return sum(s.photons for s in summary.sources)


def callgrind_per_segment(cmd_for, photons: tuple[int, int], unit=brdf_segments) -> float:
    """Instructions per unit (default: per segment of a `roks brdf` run; `trace_photons`: per
    photon of a `roks trace` run): callgrind's total at two photon counts, differenced."""
    counts, segs = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in photons:
            out = Path(tmp) / f"cg_{n}"
            cmd = [str(c) for c in cmd_for(n, out)]
            p = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.out"] + cmd,
                               capture_output=True, text=True)
            if p.returncode != 0:
                sys.stderr.write(p.stderr)
                raise RunError("callgrind failed")
            counts.append(int(re.search(r"Collected : (\d+)", p.stderr).group(1)))
            summary = read_summary(out / "summary.json")
            segs.append(unit(summary))
    return (counts[1] - counts[0]) / (segs[1] - segs[0])


def mitsuba_case(work: Path, photons: int):
    """The Mitsuba tracer on the default scene's 1025² mesh as a case of `alternate` (None without
    Mitsuba): the mesh is exported once, the tracer runs once a round beside roks."""
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        print("speed_targets: mitsuba not importable, skipping its case", file=sys.stderr)
        return None
    mesh = work / "default_1024.ply"
    subprocess.run([str(ROOT / "target" / "release" / "roks"), "export-mesh", "--resolution", "1024",
                    "--out", str(mesh)], check=True, capture_output=True)
    make = lambda out: [sys.executable, "-m", "roks_tools.mitsuba.tracer", mesh, "--size", "30,30",  # noqa: E731
                        "--theta", 60, "--rho", 0.8, "--photons", photons, "--out", out, "-q"]
    return make, brdf_rate


def paired_ratio(res: dict, a: str, b: str) -> float:
    """Median over the rounds of the rate of case `a` over that of case `b` in the same round (the
    machine's speed drifts between rounds; a ratio within one round is steadier)."""
    return statistics.median(rb["per_segment_s"] / ra["per_segment_s"]
                             for ra, rb in zip(res[a]["runs"], res[b]["runs"]))


@command("speed_targets")
def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="6ce6b98", help="baseline commit")
    add_out_argument(ap, "speed")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--callgrind", action="store_true")
    ap.add_argument("--from-json", type=Path, metavar="SPEED_JSON",
                    help="write the report again from a saved speed.json (no runs)")
    a = ap.parse_args()
    check_output(a.out, a.overwrite_committed)
    if a.from_json:
        saved = json.loads(a.from_json.read_text())
        a.base = saved["base"]
        write_report(a, saved["cases"], saved["mitsuba"], saved["callgrind"], saved.get("rounds", 3))
        return 0
    rounds = 1 if a.quick else a.rounds
    scale = 10 if a.quick else 1
    print("building ...", file=sys.stderr)
    base, new = build_base(a.base), build_new()
    bins = {"base": base, "new": new}

    work = Path(tempfile.mkdtemp(prefix="speed_targets_"))
    scenes = {"bumps100": bump_scene(100), "bumps100000": bump_scene(100_000),
              "field256": field_scene(256), "field4096": field_scene(4096),
              "al": (ROOT / "scenes" / "default.toml").read_text()
              .replace("reflectance = 0.8", "n = 1.015\nk = 6.627")}
    # The default surface without its bumps.
    scenes["flat"] = ("name = \"flat\"\n[surface]\nsize = [30.0, 30.0]\nedges = \"periodic\"\n"
                      "material = \"paint\"\n[materials.paint]\nreflectance = 0.8\n"
                      "[light]\ntheta_deg = [60]\nphi_deg = 0.0\n[tally]\nbands = 32\n")
    paths = {}
    for name, text in scenes.items():
        paths[name] = work / f"{name}.toml"
        paths[name].write_text(text)
    al_scalar = work / "al_scalar.toml"
    al_scalar.write_text(scenes["al"] + "\n[transport]\npolarisation = false\n")
    al_mueller = work / "al_mueller.toml"
    al_mueller.write_text(scenes["al"].replace("[tally]", "[tally]\npolarisation = \"mueller\""))

    def brdf(exe, scene, photons, threads, theta=60):
        def make(out):
            cmd = [exe, "brdf"] + ([scene] if scene else []) + [
                "--theta", theta, "--photons", photons // scale, "--threads", threads,
                "--stats-resolution", 64, "-q", "--out", out]
            return cmd
        return make, brdf_rate

    def trace(exe, scene, photons):
        return (lambda out: [exe, "trace", scene, "--photons", photons // scale, "--threads", 1, "-q",
                             "--out", out]), trace_rate

    cases = {}
    for who, exe in bins.items():
        cases[f"default_2t/{who}"] = brdf(exe, None, 2_000_000, 2)
        cases[f"bumps100_1t/{who}"] = brdf(exe, paths["bumps100"], 1_000_000, 1)
        cases[f"bumps100000_1t/{who}"] = brdf(exe, paths["bumps100000"], 200_000, 1)
        cases[f"field256_1t/{who}"] = brdf(exe, paths["field256"], 1_000_000, 1)
        cases[f"field4096_1t/{who}"] = brdf(exe, paths["field4096"], 200_000, 1)
        for vanes in (10, 100, 1000):
            scene = ROOT / "scenes" / f"baffled-tube-{vanes}.toml"
            if scene.exists():
                cases[f"tube{vanes}/{who}"] = trace(exe, scene, 20_000 if vanes < 1000 else 5_000)
        cases[f"radiator_micro/{who}"] = trace(exe, ROOT / "scenes" / "radiator.toml", 5_000)
    # The fixed cost of a history: the default scene's substrate alone (two
    # segments a photon, no bump to test), the yardstick of the 3x target.
    cases["flat_2t/new"] = brdf(new, paths["flat"], 2_000_000, 2)
    mi_case = None if a.no_mitsuba else mitsuba_case(work, 200_000 // scale)
    if mi_case:
        cases["mitsuba/tracer"] = mi_case
    cases["al_scalar/new"] = brdf(new, al_scalar, 1_000_000, 1)
    cases["al_stokes/new"] = brdf(new, paths["al"], 1_000_000, 1)
    cases["al_mueller/new"] = brdf(new, al_mueller, 1_000_000, 1)
    # Alternate base and new within each round.
    order = sorted(cases, key=lambda k: (k.split("/")[0], k.split("/")[1]))
    res = alternate({k: cases[k] for k in order}, rounds)

    mi = None
    if "mitsuba/tracer" in res:
        m = res["mitsuba/tracer"]
        mi = {"segments_per_second": 1.0 / m["per_segment_s"], "segments": m["segments"],
              "photons": m["photons"], "roks_over_mitsuba": paired_ratio(res, "default_2t/new", "mitsuba/tracer"),
              "base_over_mitsuba": paired_ratio(res, "default_2t/base", "mitsuba/tracer")}
    cg = {}
    if a.callgrind:
        for who, exe in bins.items():
            for label, scene in (("default", None), ("bumps100000", paths["bumps100000"])):
                make = lambda n, out, exe=exe, scene=scene: [exe, "brdf"] + ([scene] if scene else []) + [
                    "--theta", 60, "--photons", n, "--threads", 1, "--stats-resolution", 16, "-q",
                    "--out", out]
                cg[f"{label}/{who}"] = callgrind_per_segment(make, (20_000 // scale, 100_000 // scale))
                print(f"  callgrind {label}/{who}: {cg[f'{label}/{who}']:.0f} instructions/segment",
                      file=sys.stderr)
            make = lambda n, out, exe=exe: [exe, "trace", ROOT / "scenes" / "radiator.toml", "--photons", n,
                                            "--threads", 1, "-q", "--out", out]
            cg[f"radiator_per_photon/{who}"] = callgrind_per_segment(make, (100, 300), trace_photons)
            print(f"  callgrind radiator/{who}: {cg[f'radiator_per_photon/{who}']:.0f} instructions/photon",
                  file=sys.stderr)
        for label, scene in (("al_scalar", al_scalar), ("al_stokes", paths["al"]), ("al_mueller", al_mueller)):
            make = lambda n, out, scene=scene: [new, "brdf", scene, "--theta", 60, "--photons", n,
                                                "--threads", 1, "--stats-resolution", 16, "-q", "--out", out]
            cg[f"{label}/new"] = callgrind_per_segment(make, (20_000 // scale, 100_000 // scale))
            print(f"  callgrind {label}/new: {cg[f'{label}/new']:.0f} instructions/segment", file=sys.stderr)

    write_report(a, res, mi, cg, rounds)
    return 0


def rate(res: dict, name: str) -> float:
    """Segments per second (M) of a case."""
    return 1e-6 / res[name]["per_segment_s"]


def write_report(a, res: dict, mi: dict | None, cg: dict, rounds: int) -> None:
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "speed.json").write_text(json.dumps({"base": a.base, "rounds": rounds, "cases": res, "mitsuba": mi,
                                                  "callgrind": cg}, indent=1))
    L = ["# Speed targets", "",
         f"`scripts/speed_targets.py`: baseline commit {a.base} and this tree built side by side, "
         f"every case alternated base/new, {rounds} rounds; tracing time "
         "from summary.json (start-up excluded), peak memory of the roks process from "
         "`/usr/bin/time -f %M`. Rates are medians over the rounds; every ratio is the median of the "
         "ratios taken within each round (the machine's speed drifts between rounds).", "",
         "| case | base | new | new / base | target | met |", "|---|---:|---:|---:|---:|---|"]

    def row(label, b, n, ratio, target, ok, unit=""):
        L.append(f"| {label} | {b}{unit} | {n}{unit} | {ratio:.2f} | {target} | {'yes' if ok else 'no'} |")

    b, n = rate(res, "default_2t/base"), rate(res, "default_2t/new")
    r = paired_ratio(res, "default_2t/new", "default_2t/base")
    row("default scene 60°, 2 threads, M segments/s", f"{b:.2f}", f"{n:.2f}", r, ">= 3", r >= 3)
    if mi:
        m, r = mi["segments_per_second"] / 1e6, mi["roks_over_mitsuba"]
        L.append(f"| Mitsuba tracer, 1025² mesh, M segments/s | | {m:.2f} | roks / Mitsuba {r:.1f} "
                 f"(base {mi['base_over_mitsuba']:.1f}; ratios within a round, median) | >= 15 | "
                 f"{'yes' if r >= 15 else 'no'} |")
    f = rate(res, "flat_2t/new")
    L.append(f"| for scale: flat substrate alone (2 segments a photon, no bump), 2 threads, M segments/s | | "
             f"{f:.2f} | 3x the base default = {3 * b:.2f} | | |")
    for big, small, label, target in (("bumps100000_1t", "bumps100_1t", "100 000 / 100 bumps, rate per thread", 0.6),
                                      ("field4096_1t", "field256_1t", "4096² / 256² field, rate per thread", 0.5)):
        rb = paired_ratio(res, f"{big}/base", f"{small}/base")
        rn = paired_ratio(res, f"{big}/new", f"{small}/new")
        L.append(f"| {label} | {rb:.2f} | {rn:.2f} | {rn / rb:.2f} | >= {target} | {'yes' if rn >= target else 'no'} |")
    if all(f"tube{v}/new" in res for v in (10, 1000)):
        tb = paired_ratio(res, "tube10/base", "tube1000/base")
        tn = paired_ratio(res, "tube10/new", "tube1000/new")
        L.append(f"| baffled tube, time per macro segment 1000 / 10 vanes | {tb:.1f} | {tn:.2f} | | <= 2 | "
                 f"{'yes' if tn <= 2 else 'no'} |")
    rb, rn = res["radiator_micro/base"]["per_photon_s"], res["radiator_micro/new"]["per_photon_s"]
    # The same histories (same segments a photon), so the ratio of rates is that of times per photon.
    up = paired_ratio(res, "radiator_micro/new", "radiator_micro/base")
    L.append(f"| radiator, micro walls, µs per photon | {rb * 1e6:.1f} | {rn * 1e6:.1f} | speed-up {up:.2f} "
             f"| >= 2 | {'yes' if up >= 2 else 'no'} |")
    for mode in ("stokes", "mueller"):
        r = paired_ratio(res, "al_scalar/new", f"al_{mode}/new")
        L.append(f"| Al scene, {mode} / scalar, time per segment | | {r:.2f} | | <= 1.5 | {'yes' if r <= 1.5 else 'no'} |")
    L += ["", "## Every case", "",
          "| case | ns per segment | M segments/s | µs per photon | peak memory (MB) |", "|---|---:|---:|---:|---:|"]
    for name, r in res.items():
        L.append(f"| {name} | {r['per_segment_s'] * 1e9:.1f} | {1e-6 / r['per_segment_s']:.2f} | "
                 f"{r['seconds'] / r['photons'] * 1e6:.3f} | {r['max_rss_mb']:.0f} |")
    if cg:
        L += ["", "## Instructions (callgrind, 1 thread)", "", "| scene | unit | base | new | new / base |",
              "|---|---|---:|---:|---:|"]
        for label, unit in (("default", "segment"), ("bumps100000", "segment"),
                            ("radiator_per_photon", "photon")):
            cb, cn = cg[f"{label}/base"], cg[f"{label}/new"]
            L.append(f"| {label} | {unit} | {cb:.0f} | {cn:.0f} | {cn / cb:.2f} |")
        scalar = cg["al_scalar/new"]
        for label in ("al_scalar", "al_stokes", "al_mueller"):
            L.append(f"| {label} | segment | | {cg[label + '/new']:.0f} | vs scalar {cg[label + '/new'] / scalar:.2f} |")
    text = "\n".join(L) + "\n"
    (a.out / "report.md").write_text(text)
    print(text)


if __name__ == "__main__":
    sys.exit(main())
