//! The interactive report of a result folder (`report.html`, `roks
//! report`, `--report` of `roks brdf`, `trace` and `merge`): one HTML file
//! that holds its data and its code (the vendored Plotly.js, embedded at
//! build time) and opens offline in a current browser. Its data come from
//! the typed result of the library API ([`BrdfResult`], [`TraceResult`]):
//! the summary, the tables as columns ([`crate::api::Table`]), the fits
//! and exports the folder holds. See docs/src/report.md.
//!
//! The report leaves out what differs between two runs of the same
//! result: the times (`seconds`, `segments_per_second`) and the files a
//! merge adds (`tallies.json`), so that the report of `roks merge`'s folder
//! equals, byte for byte, the report of the whole run; and it never reads
//! an earlier `report.html`.

use std::path::Path;

use serde_json::{Map, Value, json};

use crate::api::{BrdfResult, Error, Table, TraceResult};
use crate::outdir::file::{Kind, ResultFile, ResultPattern};

/// The vendored Plotly.js (assets/vendor/plotly: version, source, licence).
const PLOTLY: &str = include_str!("../../assets/vendor/plotly/plotly.min.js");
/// The page: markers `/*STYLE*/`, `/*PLOTLY*/`, `/*DATA*/`, `/*SCRIPT*/`.
const TEMPLATE: &str = include_str!("template.html");
/// The page's style sheet.
const STYLE: &str = include_str!("report.css");
/// The page's code: every view drawn from the data.
const SCRIPT: &str = include_str!("report.js");

/// How every report begins: what tells a `report.html` roks wrote
/// ([`crate::outdir::kind::FileKind::Report`]).
pub use crate::outdir::kind::REPORT_MARK as MARK;

/// Keys of `summary.json` left out of a report: times, which differ between
/// two runs of the same result (a merge's are the sums of its shards').
const TIMES: [&str; 2] = ["seconds", "segments_per_second"];

/// The report of the result folder `dir` (micro when it holds `brdf.csv`,
/// else an object folder), as read by [`BrdfResult::read`] or
/// [`TraceResult::read`].
///
/// # Errors
/// The reader's: [`Error::Input`] for a folder that is not a result.
pub fn of_dir(dir: &Path) -> Result<String, Error> {
    if ResultFile::Brdf.path_in(dir).is_file() {
        brdf(&BrdfResult::read(dir)?)
    } else {
        trace(&TraceResult::read(dir)?)
    }
}

/// Add `report.html` to `files`, the files of the micro result folder
/// `dir` about to be written (`roks brdf --report`, `roks merge
/// --report`): the report of those files read back as
/// [`BrdfResult::from_files`] reads them, so it equals what `roks report`
/// makes of the written folder.
///
/// # Errors
/// As [`brdf`].
pub fn add_brdf(dir: &Path, files: &mut Vec<(String, Vec<u8>)>) -> Result<(), Error> {
    let html = brdf(&BrdfResult::from_files(dir, files.clone())?)?;
    files.push((ResultFile::Report.name().into(), html.into_bytes()));
    Ok(())
}

/// Add `report.html` to `files`, the files of the object result folder
/// `dir` about to be written (`roks trace --report`, `roks merge
/// --report`), as [`add_brdf`] does for a micro folder.
///
/// # Errors
/// As [`trace`].
pub fn add_trace(dir: &Path, files: &mut Vec<(String, Vec<u8>)>) -> Result<(), Error> {
    let html = trace(&TraceResult::from_files(dir, files.clone())?)?;
    files.push((ResultFile::Report.name().into(), html.into_bytes()));
    Ok(())
}

/// The report of a micro result (`roks brdf`, `roks merge` of its shards).
///
/// # Errors
/// [`Error::Input`] for a table of the result that cannot be read.
pub fn brdf(result: &BrdfResult) -> Result<String, Error> {
    let summary = serde_json::to_value(result.summary()).map_err(anyhow::Error::from)?;
    let brdf = result.brdf()?;
    let cells = result.cells();
    let cell = geometry(&brdf, cells)?;
    let inplane = result.inplane()?;
    let mut data = json!({
        "kind": "brdf",
        "material": material(result.summary()),
        "summary": without_times(summary),
        "shape": result.shape(),
        "theta": result.theta_deg(),
        "phi": result.phi_deg(),
        "wl": result.wavelengths_um(),
        "cell": cell,
        "brdf": column(&brdf, "brdf")?,
        "se": column(&brdf, "brdf_stderr")?,
        "inplane": {
            "theta_o": column(&inplane, "theta_o_deg")?,
            "brdf": column(&inplane, "brdf")?,
            "se": column(&inplane, "brdf_stderr")?,
        },
    });
    if let Some(p) = result.polarisation()? {
        let kind = if result.file(ResultFile::Mueller.name()).is_some() {
            "mueller"
        } else {
            "stokes"
        };
        data["polar"] = json!({ "kind": kind, "columns": values(&p, &["theta_i_deg", "phi_i_deg", "wavelength_um", "band", "cell", "theta_deg", "phi_deg"]) });
    }
    if let Some(bytes) = result.file(ResultFile::Colour.name()) {
        let t = Table::parse(&String::from_utf8_lossy(&bytes), ResultFile::Colour.name())
            .map_err(|e| Error::Input(e.to_string()))?;
        data["colour"] = json!(values(
            &t,
            &[
                "theta_i_deg",
                "phi_i_deg",
                "band",
                "cell",
                "theta_deg",
                "phi_deg"
            ]
        ));
    }
    let mut names = result.file_names();
    names.sort();
    data["products"] = products(&names, &|n| result.file(n));
    if let Some(fits) = data["products"]["fits"].as_array_mut() {
        for f in fits.iter_mut() {
            let name = f["name"].as_str().unwrap_or("");
            if name == ResultFile::FitRanking.name() || !ResultPattern::FitJson.matches(name) {
                continue;
            }
            match overlay(result, &brdf, &f["doc"]) {
                Ok(o) => f["overlay"] = o,
                Err(why) => f["not_drawn"] = json!(why),
            }
        }
    }
    if let Some(png) = result.file(ResultFile::SurfacePicture.name()) {
        data["surface_png"] = json!(base64(&png));
    }
    Ok(page(&title(&data), &data))
}

/// The report of an object result (`roks trace`, `roks merge` of its
/// shards).
///
/// # Errors
/// [`Error::Input`] for a table of the result that cannot be read.
pub fn trace(result: &TraceResult) -> Result<String, Error> {
    let summary = serde_json::to_value(result.summary()).map_err(anyhow::Error::from)?;
    let mut data = json!({
        "kind": "trace",
        "summary": without_times(summary),
        "reflectance": values(&result.reflectance()?, &[]),
    });
    if let Some(f) = result.farfield()? {
        // Every beam position's block is over the same cells.
        let source = column(&f, "source")?;
        let cells = source.iter().take_while(|&&s| s == source[0]).count();
        data["farfield"] = json!({
            "source": source,
            "cell": geometry(&f, cells)?,
            "brdf": column(&f, "brdf")?,
            "se": column(&f, "brdf_stderr")?,
        });
    }
    Ok(page(&title(&data), &data))
}

/// The substrate material of the run's scene, in words (`gold: measured
/// n, k at 21 wavelengths`), when the scene file its summary names still
/// loads and holds the run's content (the same hash); `None` otherwise.
fn material(summary: &crate::output::summary::BrdfSummary) -> Option<String> {
    use crate::optics::material::Reflectance;
    let source = crate::scene::source::SceneSource::from_recorded(&summary.scene);
    let scene = crate::api::load_micro(source.path(), &crate::api::Overrides::default()).ok()?;
    if scene.content != summary.content {
        return None;
    }
    let s = &scene.surface;
    let name = scene.material_names.get(s.substrate_material)?;
    let what = match s.materials.get(s.substrate_material)? {
        Reflectance::Constant(r) => format!("constant reflectance {r}"),
        Reflectance::Fresnel { n, k } => format!("Fresnel, n = {n}, k = {k}"),
        Reflectance::Table(_) => "reflectance against incidence, from a table".into(),
        Reflectance::Spectral(m) => format!(
            "one model per wavelength ({} in the scene)",
            m.lanes().len()
        ),
    };
    Some(format!("{name}: {what}"))
}

/// The exports and fits among `names`, with each fit's document (its
/// verdict, parameters and reflectance checks).
fn products(names: &[String], file: &dyn Fn(&str) -> Option<Vec<u8>>) -> Value {
    let mut exports = Vec::new();
    let mut fits = Vec::new();
    for n in names {
        let export = ResultFile::from_name(n).is_some_and(|f| f.kind() == Kind::Export)
            || ResultPattern::ZemaxAt.matches(n)
            || n == ResultFile::Export.name();
        if export {
            exports.push(json!(n));
        } else if ResultPattern::FitJson.matches(n) || n == ResultFile::FitRanking.name() {
            let doc = file(n)
                .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
                .unwrap_or(Value::Null);
            fits.push(json!({ "name": n, "doc": doc }));
        }
    }
    json!({ "exports": exports, "fits": fits })
}

/// Significant digits of the model values a report holds: far below any
/// table's standard error, and 3 to 4 bytes a value less than all 17 once
/// compressed (docs/src/report.md: Size).
const MODEL_DIGITS: usize = 6;

/// `x` to [`MODEL_DIGITS`] significant digits.
fn model_digits(x: f64) -> f64 {
    format!("{x:.prec$e}", prec = MODEL_DIGITS - 1)
        .parse()
        .unwrap_or(x)
}

/// The fitted model of the fit document `doc` (a `fit_<model>.json` of the
/// folder) over the table `brdf` of `result` it was fitted to: per fitted
/// incidence its cells' values and its in-plane bins' values
/// ([`SavedFit::cells`], [`SavedFit::inplane`], to [`MODEL_DIGITS`]
/// digits), with the wavelength's index (`lane`) and the incidences'
/// (`theta`) in the run's tree.
///
/// # Errors
/// Why the model is not drawn, in words: a document that is not a fit of
/// this table (another wavelength, incidences or reflectance), or a
/// material that cannot be rebuilt.
///
/// [`SavedFit::cells`]: crate::fit_model::saved::SavedFit::cells
/// [`SavedFit::inplane`]: crate::fit_model::saved::SavedFit::inplane
fn overlay(result: &BrdfResult, brdf: &Table, doc: &Value) -> Result<Value, String> {
    use crate::fit_model::saved::{SavedFit, material_again};
    let run = result.run();
    let summary = result.summary();
    let wl = result.wavelengths_um();
    let lane = match doc["wavelength_um"].as_f64() {
        None if wl.is_empty() => 0,
        None => return Err("fitted to a table of one wavelength; this run is spectral".into()),
        Some(w) => wl
            .iter()
            .position(|&x| x == w)
            .ok_or_else(|| format!("fitted at {w} µm, not one of this run's wavelengths"))?,
    };
    if run.phi_deg.len() != 1 {
        return Err("this run has several light azimuths; a fit has one".into());
    }
    let saved = SavedFit::from_doc(doc, &|words, kind| {
        if words.starts_with("scene ") && material(summary).is_none() {
            return Err(format!(
                "its material is the scene's, and {} is not found with the run's content",
                summary.scene
            ));
        }
        material_again(words, Path::new(""), kind, Some(&summary.scene), wl, lane)
    })?;
    let [_, np, nl, nc] = result.shape();
    let fraction = column(brdf, "fraction").map_err(|e| e.to_string())?;
    let mut theta = Vec::new();
    let (mut cells, mut inplane) = (Vec::new(), Vec::new());
    let grid = run.grid();
    let tally = run.inplane();
    for (k, (t, _)) in saved.sets.iter().enumerate() {
        let i = run
            .theta_deg
            .iter()
            .position(|x| x == t)
            .ok_or_else(|| format!("fitted at θi = {t}°, not one of this run's incidences"))?;
        // The table the fit read: its reflectance over the cells fitted
        // (every cell when none was left out) is this table's.
        let block = ((i * np) * nl + lane) * nc;
        let here: f64 = fraction[block..block + nc].iter().sum();
        let fitted = doc["fits"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|f| f["cells_left_out"].as_u64() == Some(0))
            .flat_map(|f| f["reflectance"].as_array().into_iter().flatten())
            .find(|r| r["theta_i_deg"].as_f64() == Some(*t))
            .and_then(|r| r["table"].as_f64());
        if let Some(r) = fitted.filter(|r| (r - here).abs() > 1e-8 * here.abs()) {
            return Err(format!(
                "fitted to a table of reflectance {r} at θi = {t}°; this one's is {here}: another table"
            ));
        }
        theta.push(i);
        cells.extend(
            saved
                .cells(k, &grid, run.phi_deg[0])
                .into_iter()
                .map(model_digits),
        );
        inplane.extend(saved.inplane(k, &tally).into_iter().map(model_digits));
    }
    Ok(json!({
        "model": saved.kind.name(),
        "lane": lane,
        "theta": theta,
        "cells": cells,
        "inplane": inplane,
    }))
}

/// The page's title: the scene's name and the kind of result.
fn title(data: &Value) -> String {
    let name = data["summary"]["name"].as_str().unwrap_or("");
    let what = if data["kind"] == "brdf" {
        "BRDF"
    } else {
        "object trace"
    };
    format!("roks report: {name} ({what})")
}

/// The column `name` of `t`.
fn column<'t>(t: &'t Table, name: &str) -> Result<&'t [f64], Error> {
    t.column(name)
        .ok_or_else(|| Error::Input(format!("the table has no column {name}")))
}

/// The geometry of the first `cells` Carlson cells of the table `t`
/// (`brdf.csv`, `farfield.csv`): their bounds and centres (degrees).
fn geometry(t: &Table, cells: usize) -> Result<Map<String, Value>, Error> {
    let names = [
        "theta_lo_deg",
        "theta_hi_deg",
        "phi_lo_deg",
        "phi_hi_deg",
        "theta_deg",
        "phi_deg",
    ];
    let mut cell = Map::new();
    for g in names {
        cell.insert(g.into(), json!(head(column(t, g)?, cells)));
    }
    Ok(cell)
}

/// The first `n` values of `c`.
fn head(c: &[f64], n: usize) -> &[f64] {
    &c[..n.min(c.len())]
}

/// Every column of `t` but `skip`, by name.
fn values(t: &Table, skip: &[&str]) -> Map<String, Value> {
    t.names()
        .iter()
        .filter(|n| !skip.contains(&n.as_str()))
        .map(|n| (n.clone(), json!(t.column(n).unwrap_or(&[]))))
        .collect()
}

/// `v` without the keys of [`TIMES`], at any depth.
fn without_times(v: Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.into_iter()
                .filter(|(k, _)| !TIMES.contains(&k.as_str()))
                .map(|(k, v)| (k, without_times(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.into_iter().map(without_times).collect()),
        v => v,
    }
}

/// The vendored library, gzip-compressed and in base64, made once.
fn plotly_packed() -> &'static str {
    static PACKED: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PACKED.get_or_init(|| pack(PLOTLY.as_bytes()))
}

/// `bytes` gzip-compressed (the best level; no name, no time: the same
/// bytes give the same text) and in base64, as the page unpacks it.
fn pack(bytes: &[u8]) -> String {
    use std::io::Write as _;
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    gz.write_all(bytes).expect("compressing in memory");
    base64(&gz.finish().expect("compressing in memory"))
}

/// The page of `data` under `title`: the template with its style, the
/// library and the data (JSON), each packed ([`pack`]), and the code put
/// in.
fn page(title: &str, data: &Value) -> String {
    let json = pack(data.to_string().as_bytes());
    let title = title
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    let parts = [
        ("<!--TITLE-->", title.as_str()),
        ("/*STYLE*/", STYLE),
        ("/*PLOTLY*/", plotly_packed()),
        ("/*DATA*/", json.as_str()),
        ("/*SCRIPT*/", SCRIPT),
    ];
    let mut out = String::with_capacity(plotly_packed().len() + json.len() + 65536);
    out.push_str(MARK);
    let mut rest = TEMPLATE;
    for (marker, content) in parts {
        let (before, after) = rest
            .split_once(marker)
            .expect("the report template holds every marker once, in order");
        out.push_str(before);
        out.push_str(content);
        rest = after;
    }
    out.push_str(rest);
    out
}

/// `bytes` in base64 (RFC 4648, with padding), for a picture inline.
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(char::from(ABC[(n >> (18 - 6 * k)) as usize & 63]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_is_rfc_4648() {
        // RFC 4648 section 10's test vectors.
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (text, code) in cases {
            assert_eq!(base64(text.as_bytes()), code);
        }
    }

    #[test]
    fn times_are_left_out_and_the_data_cannot_end_the_script() {
        let v = json!({"seconds": 1.0, "a": [{"seconds": 2.0, "b": 3}], "segments_per_second": 4});
        assert_eq!(without_times(v), json!({"a": [{"b": 3}]}));
        let html = page("x</title>", &json!({"s": "</script><!--"}));
        assert!(html.starts_with(MARK));
        // The library's, the data's and the code's: the data are packed.
        assert_eq!(html.matches("</script>").count(), 3);
        assert!(html.contains("<title>x&lt;/title&gt;</title>"));
        // Packing is deterministic, and gzip: its magic bytes first.
        let packed = pack(b"roks");
        assert_eq!(packed, pack(b"roks"));
        assert!(packed.starts_with("H4sI"), "{packed}");
    }
}
