//! The `roks` command line: parse the arguments, run the command, and end
//! with its exit status: 0 success; 2 bad input (scene file or arguments:
//! one line on stderr naming the file and key, nothing written); 1 other
//! failures (I/O). The commands live in [`roks::cli`].
#![forbid(unsafe_code)]

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use serde_json::json;

use roks::cli::Failure;
use roks::cli::args::{Cli, Command};
use roks::cli::brdf::{BrdfArgs, parse_formats};
use roks::cli::common::{
    check_out_dir, load_scene, progress_bar, result_dir, set_threads, stats_grid,
};
use roks::cli::export_brdf::export_table;
use roks::cli::merge::MergeArgs;
use roks::micro::surface_stats::surface_stats;
use roks::optics::brdf_table::BrdfTable;
use roks::output;
use roks::shard::{self, Shard};

fn main() -> ExitCode {
    let cli = match roks::cli::messages::parse_args::<Cli>() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if let Err(e) = roks::limits::max_memory() {
        eprintln!("roks: {e}");
        return ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Brdf(a) => brdf(a),
        Command::Stats(a) => roks::cli::stats::run(a),
        Command::Trace(a) => roks::cli::trace::run(a),
        Command::Fit(a) => roks::cli::fit::run(a),
        Command::ExportMesh(a) => roks::cli::export_mesh::run(a),
        Command::ExportHeightfield(a) => roks::cli::export_heightfield::run(a),
        Command::Render(a) => roks::cli::render::run(a),
        Command::Merge(a) => merge(a),
        Command::ExportBrdf(a) => roks::cli::export_brdf::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            eprintln!("roks: {failure}");
            failure.exit_code()
        }
    }
}

fn brdf(a: BrdfArgs) -> Result<(), Failure> {
    let exports = parse_formats(&a.export, "--export")?;
    let scene = load_scene(a.scene.as_deref())?;
    let mut run = scene.brdf_run();
    if let Some(p) = a.photons {
        run.photons = p;
    }
    if let Some(s) = a.seed {
        run.seed = s;
    }
    if let Some(l) = &a.launch {
        run.launch = roks::transport::launch::Launch::from_name(l).expect("clap checked the name");
    }
    if let Some(s) = &a.symmetry {
        run.symmetry = roks::tally::Symmetry::from_name(s).expect("clap checked the name");
    }
    if a.polarisation.is_some() || a.no_polarisation || a.symmetry.is_some() {
        let tally = a
            .polarisation
            .as_deref()
            .map_or(scene.tally.polarisation, |p| {
                roks::tally::PolarTally::from_name(p).expect("clap checked the name")
            });
        let transport = if a.no_polarisation {
            Some(false)
        } else {
            scene.transport.polarisation
        };
        run.polarisation = roks::transport::brdf::Polarisation::resolve(
            scene.has_fresnel(),
            transport,
            run.polarisation.incident,
            tally,
            run.symmetry,
        )
        .map_err(|(key, e)| {
            let option = match key {
                "tally.symmetry" => "--symmetry",
                _ if a.no_polarisation => "--no-polarisation",
                _ => "--polarisation",
            };
            Failure::Input(format!("{option}: {e}"))
        })?;
    }
    roks::transport::launch::check_photons(run.launch, run.photons)
        .map_err(|e| Failure::Input(format!("--photons: {e}")))?;
    if let Some(t) = &a.theta {
        if t.is_empty() {
            return Err(Failure::Input("--theta: needs at least one angle".into()));
        }
        if let Some(bad) = t
            .iter()
            .find(|t| !(t.is_finite() && (0.0..90.0).contains(*t)))
        {
            return Err(Failure::Input(format!(
                "--theta: angles must be in [0, 90), got {bad}"
            )));
        }
        if let Some((_, t)) = roks::scene::micro::first_repeat(t) {
            return Err(Failure::Input(format!(
                "--theta: {t} is given twice (each incidence angle once)"
            )));
        }
        run.theta_deg.clone_from(t);
    }
    scene.check_run_memory(&run)?;
    let (rx, ry) = stats_grid(&scene, a.stats_resolution, 512, "--stats-resolution")?;
    let shard = a
        .shard
        .as_deref()
        .map(|s| {
            s.parse::<Shard>()
                .map_err(|e| Failure::Input(format!("--shard: {e}")))
        })
        .transpose()?;
    let range = shard
        .map(|s| s.photon_range(run.photons))
        .transpose()
        .map_err(|e| Failure::Input(format!("--shard: {e}")))?;
    set_threads(a.threads)?;
    let out = result_dir(a.out.as_deref(), &scene.source.file, &scene.name)?;

    let stats = surface_stats(&scene.surface.height_map(rx, ry));
    let edges = format!("{:?}", scene.surface.edges).to_lowercase();
    let settings = shard::settings_json(
        &scene.source.file,
        &scene.name,
        &edges,
        &run,
        &output::surface_json(&stats, rx),
    );
    let mut fields =
        shard::summary_fields(&settings).map_err(|e| anyhow::anyhow!(e.to_string()))?;

    let total_photons = run.photons;
    if let Some((first, last)) = range {
        run.first_photon = first;
        run.photons = last - first;
    }
    let bar = progress_bar(
        run.photons.saturating_mul(run.theta_deg.len() as u64),
        a.quiet,
        &scene.name,
    );
    let clock = Instant::now();
    let mut tallies_json = None;
    let results = if let (Some(sh), Some(range)) = (shard, range) {
        let mut results = Vec::new();
        let mut parts = Vec::new();
        for &theta in &run.theta_deg {
            let (nodes, secs) =
                run.run_shard_one(&scene.surface, theta, total_photons, &|n| bar.inc(n));
            // This shard's own sums, for its own files (left to right).
            let mut t = run.empty_tallies(&run.grid(), &run.inplane());
            for n in &nodes {
                t.merge(&n.value);
            }
            results.push(roks::transport::brdf::IncidenceResult {
                theta_i_deg: theta,
                phi_i_deg: run.phi_deg,
                tallies: t,
                seconds: secs,
            });
            parts.push((theta, secs, nodes));
        }
        let incidence: Vec<shard::ShardIncidence<'_>> = parts
            .iter()
            .map(|(theta, secs, nodes)| shard::ShardIncidence {
                theta_deg: *theta,
                seconds: *secs,
                nodes,
            })
            .collect();
        let v = shard::tallies_file(
            &settings,
            sh,
            range,
            &incidence,
            clock.elapsed().as_secs_f64(),
        );
        tallies_json = Some(v);
        fields.insert("photons_per_incidence".into(), json!(run.photons));
        fields.insert(
            "shard".into(),
            json!({"index": sh.index, "count": sh.count, "first_photon": range.0, "last_photon": range.1}),
        );
        results
    } else {
        run.run(&scene.surface, &|n| bar.inc(n))
    };
    bar.finish_and_clear();
    let seconds = clock.elapsed().as_secs_f64();

    let summary = output::brdf_summary(&fields, &results, seconds);
    let brdf_csv = output::brdf_csv(&run, &results);
    let inplane_csv = output::inplane_csv(&run, &results);
    let polar_csv = output::polar_csv(&run, &results);
    let mut text = serde_json::to_string_pretty(&summary).map_err(anyhow::Error::from)?;
    text.push('\n');
    let tallies_text = tallies_json
        .map(|v| serde_json::to_string(&v).map(|t| t + "\n"))
        .transpose()
        .map_err(anyhow::Error::from)?;
    let inplane_png = output::inplane_plot(&scene.name, &run, &results)
        .to_png(1000, 620)
        .map_err(Failure::Other)?;
    let maps: Vec<(String, Vec<u8>)> = {
        use rayon::prelude::*;
        let mut maps: Vec<(String, Vec<u8>)> = results
            .par_iter()
            .map(|r| {
                output::hemisphere_map(&scene.name, &run, r)
                    .to_png()
                    .map(|png| (output::hemisphere_file(r.theta_i_deg), png))
            })
            .collect::<anyhow::Result<_>>()
            .map_err(Failure::Other)?;
        let dop: Vec<(String, Vec<u8>)> = results
            .par_iter()
            .filter_map(|r| {
                output::dop_map(&scene.name, &run, r)
                    .map(|m| m.to_png().map(|png| (output::dop_file(r.theta_i_deg), png)))
            })
            .collect::<anyhow::Result<_>>()
            .map_err(Failure::Other)?;
        maps.extend(dop);
        maps
    };
    let mut exported = Vec::new();
    if !exports.is_empty() {
        let table = BrdfTable::parse(&brdf_csv, "brdf.csv")
            .map_err(|e| Failure::Other(anyhow::anyhow!("the run's own table: {e}")))?;
        for &f in &exports {
            let comment = format!("scene {}, {} photons per angle", scene.name, run.photons);
            exported.push((f.file_name(), export_table(&table, f, &comment, a.quiet)?));
        }
    }
    let mut files: Vec<(&str, &[u8])> = vec![
        ("brdf.csv", brdf_csv.as_bytes()),
        ("inplane.csv", inplane_csv.as_bytes()),
        ("inplane.png", &inplane_png),
    ];
    if let Some((name, text)) = &polar_csv {
        files.push((name, text.as_bytes()));
    }
    for (name, bytes) in &maps {
        files.push((name, bytes));
    }
    for (name, bytes) in &exported {
        files.push((name, bytes));
    }
    if let Some(t) = &tallies_text {
        files.push((shard::TALLIES_FILE, t.as_bytes()));
    }
    files.push(("summary.json", text.as_bytes()));
    write_outputs(&out, &files)?;

    if !a.quiet {
        print_brdf_table(&results);
        eprintln!("wrote {} ({seconds:.1} s)", out.display());
    }
    Ok(())
}

fn print_brdf_table(results: &[roks::transport::brdf::IncidenceResult]) {
    eprintln!(
        "{:>9} {:>12} {:>10} {:>8} {:>9} {:>12}",
        "theta_i", "reflectance", "stderr", "bounces", "lost", "Msegments/s"
    );
    for r in results {
        let (refl, se) = r.reflectance();
        eprintln!(
            "{:>9.2} {:>12.6} {:>10.2e} {:>8.3} {:>9.2e} {:>12.2}",
            r.theta_i_deg,
            refl,
            se,
            r.mean_bounces(),
            r.lost(),
            r.segments_per_second() / 1e6
        );
    }
}

fn merge(a: MergeArgs) -> Result<(), Failure> {
    use roks::transport::BATCH;
    use roks::transport::brdf::IncidenceResult;
    check_out_dir(&a.out, "--out")?;
    let parts = a
        .dirs
        .iter()
        .map(|d| shard::read_shard(d))
        .collect::<Result<Vec<_>, _>>()?;
    let n_parts = parts.len();
    let merged = shard::merge_shards(parts)?;
    let (run, settings) = (merged.run, merged.settings);
    roks::limits::check("the merged tallies and tables", run.memory_bytes()).map_err(|e| {
        Failure::Input(format!(
            "{}: {}: settings.bands: {e}",
            a.dirs[0].display(),
            shard::TALLIES_FILE
        ))
    })?;
    let total = run.photons;
    let batches = total.div_ceil(BATCH);
    let mut results = Vec::new();
    let mut roots = Vec::new();
    for inc in merged.incidence {
        let (theta, seconds, t) = (inc.theta_deg, inc.seconds, inc.tallies);
        roots.push((
            theta,
            seconds,
            vec![shard::Node {
                level: batches.next_power_of_two().trailing_zeros(),
                index: 0,
                value: t.clone(),
            }],
        ));
        results.push(IncidenceResult {
            theta_i_deg: theta,
            phi_i_deg: run.phi_deg,
            tallies: t,
            seconds,
        });
    }
    let seconds = merged.seconds;
    let d0 = a.dirs[0].join(shard::TALLIES_FILE).display().to_string();
    let fields = shard::summary_fields(&settings).map_err(|e| e.under("settings").in_file(&d0))?;
    let summary = output::brdf_summary(&fields, &results, seconds);
    let mut text = serde_json::to_string_pretty(&summary).map_err(anyhow::Error::from)?;
    text.push('\n');
    let incidence: Vec<shard::ShardIncidence<'_>> = roots
        .iter()
        .map(|(theta, secs, nodes)| shard::ShardIncidence {
            theta_deg: *theta,
            seconds: *secs,
            nodes,
        })
        .collect();
    let whole = Shard { index: 0, count: 1 };
    let mut tallies = serde_json::to_string(&shard::tallies_file(
        &settings,
        whole,
        (0, total),
        &incidence,
        seconds,
    ))
    .map_err(anyhow::Error::from)?;
    tallies.push('\n');
    let brdf_csv = output::brdf_csv(&run, &results);
    let inplane_csv = output::inplane_csv(&run, &results);
    let polar_csv = output::polar_csv(&run, &results);
    let mut files: Vec<(&str, &[u8])> = vec![
        ("brdf.csv", brdf_csv.as_bytes()),
        ("inplane.csv", inplane_csv.as_bytes()),
    ];
    if let Some((name, text)) = &polar_csv {
        files.push((name, text.as_bytes()));
    }
    files.push((shard::TALLIES_FILE, tallies.as_bytes()));
    files.push(("summary.json", text.as_bytes()));
    write_outputs(&a.out, &files)?;
    if !a.quiet {
        print_brdf_table(&results);
        eprintln!("merged {n_parts} shards into {}", a.out.display());
    }
    Ok(())
}

/// Write the result folder `out` whole: staged beside it, then swapped in
/// (see [`roks::outdir`]); a reader never sees old and new files mixed.
fn write_outputs(out: &Path, files: &[(&str, &[u8])]) -> Result<(), Failure> {
    roks::outdir::write_folder(out, files)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
    Ok(())
}
