//! The standard errors of the normalised Mueller elements `m_ij / m00` that
//! `mueller.csv` carries (`mij_m00_stderr`), against the spread of
//! independent runs: 24 seeds of a rough aluminium surface.

mod cli_common;

use cli_common::roks;

/// Per run: per cell (rows of the file), `m_ij / m00` and its reported
/// error for the 15 elements; `None` where `m00 = 0`.
type Run = Vec<Option<[(f64, f64); 15]>>;

fn read_run(text: &str) -> Run {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let names: Vec<String> = (1..16).map(|k| format!("m{}{}", k / 4, k % 4)).collect();
    let (m00, cols, errs): (usize, Vec<usize>, Vec<usize>) = (
        col("m00"),
        names.iter().map(|n| col(n)).collect(),
        names
            .iter()
            .map(|n| col(&format!("{n}_m00_stderr")))
            .collect(),
    );
    lines
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (f[m00] > 0.0).then(|| std::array::from_fn(|k| (f[cols[k]] / f[m00], f[errs[k]])))
        })
        .collect()
}

/// Pooled over the cells lit in every run and the 15 elements, the spread
/// of `m_ij / m00` over 24 runs (sample variance) matches the mean squared
/// reported error: their ratio is within 4 of its standard deviations of 1.
/// That standard deviation is at most sqrt(2 / 23) / sqrt(cells) (pooling
/// over the cells, taken as independent; the elements of one cell are not,
/// so they count once).
#[test]
fn normalised_errors_match_the_spread_of_runs() {
    let dir = std::env::temp_dir().join(format!("roks-mueller-errors-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("rough.toml");
    let text = std::fs::read_to_string("scenes/gaussian-rough.toml").unwrap();
    std::fs::write(&scene, format!("{text}\n[tally]\nbands = 4\n")).unwrap();
    let runs: Vec<Run> = (1..=24)
        .map(|seed| {
            let out = dir.join(format!("s{seed}"));
            let o = roks(&[
                "brdf",
                scene.to_str().unwrap(),
                "--polarisation",
                "mueller",
                "--theta",
                "40",
                "--photons",
                "4000",
                "--seed",
                &seed.to_string(),
                "--stats-resolution",
                "16",
                "--out",
                out.to_str().unwrap(),
                "-q",
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            read_run(&std::fs::read_to_string(out.join("mueller.csv")).unwrap())
        })
        .collect();
    let cells = runs[0].len();
    let (mut ratio_sum, mut used) = (0.0, 0);
    for c in 0..cells {
        let Some(vals): Option<Vec<[(f64, f64); 15]>> = runs.iter().map(|r| r[c]).collect() else {
            continue;
        };
        let (mut cell_ratio, mut elements) = (0.0, 0);
        for k in 0..15 {
            let n = vals.len() as f64;
            let mean = vals.iter().map(|v| v[k].0).sum::<f64>() / n;
            let var = vals.iter().map(|v| (v[k].0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let reported = vals.iter().map(|v| v[k].1 * v[k].1).sum::<f64>() / n;
            if reported > 0.0 {
                cell_ratio += var / reported;
                elements += 1;
            }
        }
        if elements > 0 {
            ratio_sum += cell_ratio / f64::from(elements);
            used += 1;
        }
    }
    assert!(used >= 30, "{used} cells lit in every run");
    let ratio = ratio_sum / f64::from(used);
    let tol = 4.0 * (2.0 / 23.0_f64).sqrt() / f64::from(used).sqrt();
    assert!(
        (ratio - 1.0).abs() < tol,
        "spread / reported variance {ratio} over {used} cells (tolerance {tol})"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
