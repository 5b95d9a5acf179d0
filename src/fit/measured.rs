//! The measured in-plane BRDF a scene is fitted to ([`Measured`]).

use super::FitError;

// ---------------------------------------------------------------- measured

/// A measured in-plane BRDF.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// `(theta_i_deg, theta_o_deg, brdf, brdf_stderr)`, in file order.
    pub points: Vec<(f64, f64, f64, Option<f64>)>,
    /// The light azimuth of every point (degrees, in `[0, 360)`, in file
    /// order) when the file has the column `phi_i_deg`; `None`: the
    /// points are at the scene's one light azimuth.
    pub phi_i_deg: Option<Vec<f64>>,
}

impl Measured {
    /// Parse a CSV with header `theta_i_deg,theta_o_deg,brdf[,brdf_stderr]`,
    /// or with `phi_i_deg` after `theta_i_deg` (the header of `inplane.csv`
    /// of a run of several light azimuths) (blank lines and `#` comments
    /// allowed). `name` is used in messages.
    pub fn parse(text: &str, name: &str) -> Result<Self, FitError> {
        let err = |line: usize, message: String| FitError::Measured {
            file: name.to_string(),
            line,
            message,
        };
        // (columns, whether column 2 is phi_i_deg)
        let mut ncols: Option<(usize, bool)> = None;
        let mut points = Vec::new();
        let mut azimuths = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let content = raw.trim_start_matches('\u{feff}').trim();
            if content.is_empty() || content.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = content.split(',').map(str::trim).collect();
            let Some((n, with_phi)) = ncols else {
                ncols = Some(header(&fields, content).map_err(|m| err(line, m))?);
                continue;
            };
            let (point, phi) = row(&fields, n, with_phi).map_err(|m| err(line, m))?;
            azimuths.extend(phi);
            points.push(point);
        }
        let Some((_, with_phi)) = ncols else {
            return Err(err(0, "empty file (no header)".into()));
        };
        if points.is_empty() {
            return Err(err(0, "no data rows".into()));
        }
        if points.iter().all(|p| p.2 == 0.0) {
            return Err(err(0, "every brdf is 0".into()));
        }
        Ok(Self {
            points,
            phi_i_deg: with_phi.then_some(azimuths),
        })
    }

    /// The distinct light azimuths (degrees) of a file with `phi_i_deg`, in
    /// order of first appearance; `None` without the column.
    #[must_use]
    pub fn azimuths(&self) -> Option<Vec<f64>> {
        let phi = self.phi_i_deg.as_ref()?;
        let mut out: Vec<f64> = Vec::new();
        for &p in phi {
            if !out.contains(&p) {
                out.push(p);
            }
        }
        Some(out)
    }

    /// The distinct incidence angles, in order of first appearance.
    #[must_use]
    pub fn incidence_angles(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for p in &self.points {
            if !out.contains(&p.0) {
                out.push(p.0);
            }
        }
        out
    }
}

/// The columns of the header `fields` (the line `content`), and whether
/// the second is `phi_i_deg`.
fn header(fields: &[&str], content: &str) -> Result<(usize, bool), String> {
    let three = ["theta_i_deg", "theta_o_deg", "brdf"];
    let with_phi = fields.get(1) == Some(&"phi_i_deg");
    let rest: Vec<&str> = if with_phi {
        std::iter::once(fields[0])
            .chain(fields[2..].iter().copied())
            .collect()
    } else {
        fields.to_vec()
    };
    let ok =
        rest[..] == three || (rest.len() == 4 && rest[..3] == three && rest[3] == "brdf_stderr");
    if !ok {
        return Err(format!(
            "header must be `theta_i_deg,theta_o_deg,brdf` or `theta_i_deg,theta_o_deg,brdf,brdf_stderr` (with `phi_i_deg` after `theta_i_deg` for several light azimuths), got `{content}`"
        ));
    }
    Ok((fields.len(), with_phi))
}

/// The point `(theta_i_deg, theta_o_deg, brdf, brdf_stderr)` of the data
/// row `fields` of a file of `n` columns, and its light azimuth (with
/// `phi_i_deg`), checked.
fn row(
    fields: &[&str],
    n: usize,
    with_phi: bool,
) -> Result<((f64, f64, f64, Option<f64>), Option<f64>), String> {
    if fields.len() != n {
        return Err(format!("expected {n} fields, found {}", fields.len()));
    }
    let mut all = [0.0; 5];
    for (j, f) in fields.iter().enumerate() {
        all[j] = f
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("field {} `{f}` is not a finite number", j + 1))?;
    }
    // `v`: theta_i, theta_o, brdf, brdf_stderr, without phi_i.
    let mut v = [0.0; 4];
    if with_phi {
        let phi = all[1];
        if !(0.0..360.0).contains(&phi) {
            return Err(format!("phi_i_deg must be in [0, 360), got {phi}"));
        }
        v[0] = all[0];
        v[1..n - 1].copy_from_slice(&all[2..n]);
    } else {
        v[..n].copy_from_slice(&all[..n]);
    }
    let n = if with_phi { n - 1 } else { n };
    if !(0.0..90.0).contains(&v[0]) {
        return Err(format!("theta_i_deg must be in [0, 90), got {}", v[0]));
    }
    if !(-90.0..=90.0).contains(&v[1]) {
        return Err(format!("theta_o_deg must be in [-90, 90], got {}", v[1]));
    }
    if v[2] < 0.0 {
        return Err(format!("brdf must be >= 0, got {}", v[2]));
    }
    if n == 4 && v[3] < 0.0 {
        return Err(format!("brdf_stderr must be >= 0, got {}", v[3]));
    }
    Ok((
        (v[0], v[1], v[2], (n == 4).then_some(v[3])),
        with_phi.then_some(all[1]),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    // ------------------------------------------------------------ measured file

    #[test]
    fn measured_parse() {
        let m = Measured::parse(
            "# Z-302 at 10.6 um\ntheta_i_deg,theta_o_deg,brdf\n30,-10,0.5\n\n30, 25.5 ,1e-2\n60,80,0\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(
            m.points,
            vec![
                (30.0, -10.0, 0.5, None),
                (30.0, 25.5, 0.01, None),
                (60.0, 80.0, 0.0, None)
            ]
        );
        assert_eq!(m.incidence_angles(), vec![30.0, 60.0]);
        let m = Measured::parse(
            "theta_i_deg,theta_o_deg,brdf,brdf_stderr\n0,0,1,0.1\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(m.points, vec![(0.0, 0.0, 1.0, Some(0.1))]);
        assert_eq!(m.phi_i_deg, None);
        // The columns of inplane.csv of a run of several light azimuths.
        let m = Measured::parse(
            "theta_i_deg,phi_i_deg,theta_o_deg,brdf,brdf_stderr\n30,0,5,1,0.1\n30,90,5,2,0.2\n60,90,-5,3,0.3\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(
            m.points,
            vec![
                (30.0, 5.0, 1.0, Some(0.1)),
                (30.0, 5.0, 2.0, Some(0.2)),
                (60.0, -5.0, 3.0, Some(0.3))
            ]
        );
        assert_eq!(m.phi_i_deg, Some(vec![0.0, 90.0, 90.0]));
        assert_eq!(m.azimuths(), Some(vec![0.0, 90.0]));
        let m = Measured::parse(
            "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n0,45,0,1\n",
            "z.csv",
        )
        .unwrap();
        assert_eq!(m.points, vec![(0.0, 0.0, 1.0, None)]);
        assert_eq!(m.phi_i_deg, Some(vec![45.0]));

        let h = "theta_i_deg,theta_o_deg,brdf\n";
        for (text, msg) in [
            ("", "z.csv: line 0: empty file (no header)"),
            (
                "theta_i,theta_o,brdf\n30,0,1\n",
                "z.csv: line 1: header must be",
            ),
            ("30,0,1\n", "z.csv: line 1: header must be"),
            (h, "z.csv: line 0: no data rows"),
            (
                &format!("{h}30,0,abc\n"),
                "z.csv: line 2: field 3 `abc` is not a finite number",
            ),
            (
                &format!("{h}30,0,NaN\n"),
                "z.csv: line 2: field 3 `NaN` is not a finite number",
            ),
            (
                &format!("{h}30,0\n"),
                "z.csv: line 2: expected 3 fields, found 2",
            ),
            (
                &format!("{h}30,0,1,0.1\n"),
                "z.csv: line 2: expected 3 fields, found 4",
            ),
            (
                &format!("{h}90,0,1\n"),
                "z.csv: line 2: theta_i_deg must be in [0, 90), got 90",
            ),
            (
                &format!("{h}-5,0,1\n"),
                "z.csv: line 2: theta_i_deg must be in [0, 90), got -5",
            ),
            (
                &format!("{h}30,95,1\n"),
                "z.csv: line 2: theta_o_deg must be in [-90, 90], got 95",
            ),
            (
                &format!("{h}30,0,1\n30,5,-0.1\n"),
                "z.csv: line 3: brdf must be >= 0, got -0.1",
            ),
            (&format!("{h}30,0,0\n"), "z.csv: line 0: every brdf is 0"),
            (
                "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n30,360,0,1\n",
                "z.csv: line 2: phi_i_deg must be in [0, 360), got 360",
            ),
            (
                "theta_i_deg,phi_i_deg,theta_o_deg,brdf\n30,0,1\n",
                "z.csv: line 2: expected 4 fields, found 3",
            ),
            (
                "theta_i_deg,theta_o_deg,phi_i_deg,brdf\n30,0,0,1\n",
                "z.csv: line 1: header must be",
            ),
            (
                "theta_i_deg,theta_o_deg,brdf,brdf_stderr\n30,0,1,-1\n",
                "z.csv: line 2: brdf_stderr must be >= 0, got -1",
            ),
        ] {
            let e = Measured::parse(text, "z.csv").unwrap_err().to_string();
            assert!(e.starts_with(msg), "`{text}`: got `{e}`, want `{msg}...`");
            assert!(!e.contains('\n'), "one line: {e}");
        }
    }
}
