//! Reflectance models of a micro-facet material: a constant, the Fresnel
//! equations for a complex refractive index, or a measured table of
//! reflectance against incidence angle.

use super::fresnel::{FresnelLanes, fresnel_unpolarised};
use thiserror::Error;

/// How much of the light striking a micro facet is reflected, as a function
/// of the local incidence angle.
#[derive(Debug, Clone, PartialEq)]
pub enum Reflectance {
    /// The same reflectance (dimensionless, in `[0, 1]`) at every angle.
    Constant(f64),
    /// Unpolarised Fresnel reflectance of a smooth interface from index 1
    /// into a medium of complex refractive index `n + i k` (both
    /// dimensionless; `n > 0`, `k ≥ 0`).
    Fresnel {
        /// Real part of the refractive index (dimensionless, `> 0`).
        n: f64,
        /// Extinction coefficient (dimensionless, `≥ 0`).
        k: f64,
    },
    /// Measured reflectance against incidence angle, linearly interpolated.
    Table(AngleTable),
    /// One model per wavelength of a spectral run, in the order of the
    /// run's wavelengths (none of them `Spectral`). A spectral carrier
    /// ([`crate::transport::carrier::Spectral`]) reflects wavelength `l`
    /// with model `l`; any other model applies to every wavelength alike.
    /// As a single model (monochrome code: renders, statistics) it is its
    /// first wavelength's.
    Spectral(std::sync::Arc<SpectralModel>),
}

/// The models of a [`Reflectance::Spectral`], one per wavelength, and, when
/// all are Fresnel, their indices laid out for reflecting every wavelength
/// at once ([`FresnelLanes`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralModel {
    lanes: Vec<Reflectance>,
    fresnel: Option<FresnelLanes>,
}

impl SpectralModel {
    /// The models per wavelength (none of them `Spectral`).
    #[must_use]
    pub fn new(lanes: Vec<Reflectance>) -> Self {
        let nk: Option<Vec<(f64, f64)>> = lanes
            .iter()
            .map(|m| match m {
                Reflectance::Fresnel { n, k } => Some((*n, *k)),
                _ => None,
            })
            .collect();
        Self {
            fresnel: nk.map(|nk| FresnelLanes::new(&nk)),
            lanes,
        }
    }

    /// The model of each wavelength.
    #[must_use]
    pub fn lanes(&self) -> &[Reflectance] {
        &self.lanes
    }

    /// All Fresnel: their indices by component.
    #[must_use]
    pub fn fresnel(&self) -> Option<&FresnelLanes> {
        self.fresnel.as_ref()
    }
}

impl Reflectance {
    /// Reflectance (dimensionless, in `[0, 1]`) for light arriving at
    /// incidence cosine `cos_i` (dimensionless) on the micro facet, i.e. the
    /// cosine of the angle between the incoming ray and the facet normal.
    ///
    /// `cos_i` is clamped to `[0, 1]`. Never panics: a NaN `cos_i`, or
    /// parameters that fail [`Reflectance::validate`], may give NaN.
    #[must_use]
    pub fn reflectance(&self, cos_i: f64) -> f64 {
        match self {
            Self::Constant(r) => r.clamp(0.0, 1.0),
            Self::Fresnel { n, k } => fresnel_unpolarised(cos_i, *n, *k),
            Self::Table(table) => table.reflectance(cos_i),
            Self::Spectral(m) => m.lanes.first().map_or(f64::NAN, |m| m.reflectance(cos_i)),
        }
    }

    /// The model at wavelength `l` of a spectral run: model `l` of
    /// [`Reflectance::Spectral`], or `self` for a model that does not vary.
    #[inline]
    #[must_use]
    pub fn lane(&self, l: usize) -> &Self {
        match self {
            Self::Spectral(m) => &m.lanes[l],
            other => other,
        }
    }

    /// Whether the model polarises (Fresnel, at some wavelength): only
    /// then does a polarised carrier differ from the scalar weight.
    #[must_use]
    pub fn polarises(&self) -> bool {
        match self {
            Self::Fresnel { .. } => true,
            Self::Spectral(m) => m.lanes.iter().any(Self::polarises),
            _ => false,
        }
    }

    /// Checks the parameters: a constant must be finite and in `[0, 1]`; a
    /// Fresnel index must have finite `n > 0` and finite `k ≥ 0`. Tables are
    /// validated when they are built, so they always pass.
    ///
    /// # Errors
    /// The first offending parameter, as a [`ReflectanceError`].
    pub fn validate(&self) -> Result<(), ReflectanceError> {
        match self {
            Self::Constant(r) => {
                if r.is_finite() && (0.0..=1.0).contains(r) {
                    Ok(())
                } else {
                    Err(ReflectanceError::ConstantOutOfRange(*r))
                }
            }
            Self::Fresnel { n, k } => {
                if !(n.is_finite() && *n > 0.0) {
                    Err(ReflectanceError::InvalidN(*n))
                } else if !(k.is_finite() && *k >= 0.0) {
                    Err(ReflectanceError::InvalidK(*k))
                } else {
                    Ok(())
                }
            }
            Self::Table(_) => Ok(()),
            Self::Spectral(m) => m.lanes.iter().try_for_each(Self::validate),
        }
    }
}

/// A parameter of a [`Reflectance`] is out of its physical range.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ReflectanceError {
    /// A constant reflectance that is not a finite number in `[0, 1]`.
    #[error("constant reflectance {0} is not a finite number in [0, 1]")]
    ConstantOutOfRange(f64),
    /// A refractive index real part that is not finite and `> 0`.
    #[error("refractive index n = {0} must be finite and > 0")]
    InvalidN(f64),
    /// An extinction coefficient that is not finite and `≥ 0`.
    #[error("extinction coefficient k = {0} must be finite and >= 0")]
    InvalidK(f64),
}

/// Reflectance (dimensionless, `[0, 1]`) tabulated against incidence angle
/// (degrees, `[0, 90]`), linearly interpolated in angle and held constant at
/// the end values outside the tabulated range.
///
/// Invariants (enforced by the constructors): at least one point, angles
/// finite, strictly increasing and within `[0, 90]`, reflectances finite and
/// within `[0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleTable {
    /// `(angle_deg, reflectance)` points, strictly increasing in angle.
    points: Vec<(f64, f64)>,
}

/// Why an [`AngleTable`] (reflectance against incidence angle) was
/// rejected. Every message is one line; `line`
/// is the 1-based line number in the CSV text (or, for
/// [`AngleTable::new`], the 1-based index of the point).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AngleTableError {
    /// The table holds no data rows.
    #[error("reflectance table has no data rows")]
    Empty,
    /// A field is not a number.
    #[error("line {line}: field {field} `{text}` is not a number")]
    NotANumber {
        /// 1-based line number.
        line: usize,
        /// 1-based field number within the line.
        field: usize,
        /// The offending field text.
        text: String,
    },
    /// A row does not have exactly two fields.
    #[error("line {line}: expected 2 fields (angle_deg, reflectance), found {found}")]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// Number of fields found.
        found: usize,
    },
    /// An angle is not greater than the one on the previous data row.
    #[error("line {line}: angle {angle} deg is not greater than the previous angle {previous} deg")]
    NotIncreasing {
        /// 1-based line number.
        line: usize,
        /// The angle on this row (degrees).
        angle: f64,
        /// The angle on the previous data row (degrees).
        previous: f64,
    },
    /// An angle outside `[0, 90]` degrees (including infinities).
    #[error("line {line}: angle {angle} deg is outside [0, 90]")]
    AngleOutOfRange {
        /// 1-based line number.
        line: usize,
        /// The offending angle (degrees).
        angle: f64,
    },
    /// A reflectance outside `[0, 1]` (including infinities).
    #[error("line {line}: reflectance {value} is outside [0, 1]")]
    ReflectanceOutOfRange {
        /// 1-based line number.
        line: usize,
        /// The offending reflectance (dimensionless).
        value: f64,
    },
    /// A field is NaN.
    #[error("line {line}: field {field} is NaN")]
    NaN {
        /// 1-based line number.
        line: usize,
        /// 1-based field number within the line.
        field: usize,
    },
}

impl AngleTable {
    /// Builds a table from `(angle_deg, reflectance)` points: angles in
    /// degrees, strictly increasing, within `[0, 90]`; reflectances
    /// dimensionless within `[0, 1]`.
    ///
    /// # Errors
    /// [`AngleTableError`] naming the 1-based index of the first bad point as its
    /// `line`, or [`AngleTableError::Empty`] for no points.
    pub fn new(points: Vec<(f64, f64)>) -> Result<Self, AngleTableError> {
        for (i, &(angle, value)) in points.iter().enumerate() {
            let previous = if i == 0 { None } else { Some(points[i - 1].0) };
            check_point(i + 1, angle, value, previous)?;
        }
        if points.is_empty() {
            return Err(AngleTableError::Empty);
        }
        Ok(Self { points })
    }

    /// Parses CSV text with two columns, `angle_deg, reflectance`.
    ///
    /// * Fields are separated by commas (surrounding whitespace is trimmed)
    ///   or, on lines without a comma, by whitespace.
    /// * Blank lines and lines whose first non-blank character is `#` are
    ///   ignored.
    /// * The first remaining line is a header, and skipped, when none of its
    ///   fields parses as a number (e.g. `angle_deg,reflectance`).
    ///
    /// # Errors
    /// The first problem found, as a [`AngleTableError`] naming its line number:
    /// no data rows, a non-numeric or NaN field, a wrong number of fields,
    /// angles not strictly increasing or outside `[0, 90]`, a reflectance
    /// outside `[0, 1]`.
    pub fn parse_csv(text: &str) -> Result<Self, AngleTableError> {
        let mut points: Vec<(f64, f64)> = Vec::new();
        let mut seen_content = false;
        for (index, raw) in text.lines().enumerate() {
            let line = index + 1;
            let content = raw.trim_start_matches('\u{feff}').trim();
            if content.is_empty() || content.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = if content.contains(',') {
                content.split(',').map(str::trim).collect()
            } else {
                content.split_whitespace().collect()
            };
            let first_content = !seen_content;
            seen_content = true;
            if first_content && fields.iter().all(|f| f.parse::<f64>().is_err()) {
                continue; // header
            }
            if fields.len() != 2 {
                return Err(AngleTableError::FieldCount {
                    line,
                    found: fields.len(),
                });
            }
            let mut values = [0.0; 2];
            for (slot, (field_index, text)) in values.iter_mut().zip(fields.iter().enumerate()) {
                let field = field_index + 1;
                let value: f64 = text.parse().map_err(|_| AngleTableError::NotANumber {
                    line,
                    field,
                    text: (*text).to_owned(),
                })?;
                if value.is_nan() {
                    return Err(AngleTableError::NaN { line, field });
                }
                *slot = value;
            }
            let [angle, value] = values;
            check_point(line, angle, value, points.last().map(|p| p.0))?;
            points.push((angle, value));
        }
        if points.is_empty() {
            return Err(AngleTableError::Empty);
        }
        Ok(Self { points })
    }

    /// The `(angle_deg, reflectance)` points, strictly increasing in angle.
    #[must_use]
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// Reflectance (dimensionless, `[0, 1]`) at incidence angle `angle_deg`
    /// (degrees): linear interpolation between the neighbouring points,
    /// the first / last reflectance below / above the tabulated range.
    /// Exact at the tabulated angles. NaN in gives NaN out.
    #[must_use]
    pub fn at_angle_deg(&self, angle_deg: f64) -> f64 {
        let pts = &self.points;
        let (Some(&(a_first, r_first)), Some(&(a_last, r_last))) = (pts.first(), pts.last()) else {
            return f64::NAN; // unreachable: constructors forbid empty tables
        };
        if angle_deg.is_nan() {
            return f64::NAN;
        }
        if angle_deg <= a_first {
            return r_first;
        }
        if angle_deg >= a_last {
            return r_last;
        }
        // a_first < angle < a_last, so 1 <= hi <= len - 1.
        let hi = pts.partition_point(|p| p.0 <= angle_deg);
        match (pts.get(hi.wrapping_sub(1)), pts.get(hi)) {
            (Some(&(a0, r0)), Some(&(a1, r1))) => {
                let t = (angle_deg - a0) / (a1 - a0);
                (r0 + (r1 - r0) * t).clamp(0.0, 1.0)
            }
            _ => f64::NAN, // unreachable by the bracketing above
        }
    }

    /// Reflectance (dimensionless, `[0, 1]`) at incidence cosine `cos_i`
    /// (clamped to `[0, 1]`), i.e. [`AngleTable::at_angle_deg`] of
    /// `acos(cos_i)` in degrees.
    #[must_use]
    pub fn reflectance(&self, cos_i: f64) -> f64 {
        self.at_angle_deg(cos_i.clamp(0.0, 1.0).acos().to_degrees())
    }
}

/// Validates one point against the table invariants.
fn check_point(
    line: usize,
    angle: f64,
    value: f64,
    previous: Option<f64>,
) -> Result<(), AngleTableError> {
    if angle.is_nan() {
        return Err(AngleTableError::NaN { line, field: 1 });
    }
    if value.is_nan() {
        return Err(AngleTableError::NaN { line, field: 2 });
    }
    if !(0.0..=90.0).contains(&angle) {
        return Err(AngleTableError::AngleOutOfRange { line, angle });
    }
    if !(0.0..=1.0).contains(&value) {
        return Err(AngleTableError::ReflectanceOutOfRange { line, value });
    }
    match previous {
        Some(previous) if angle <= previous => Err(AngleTableError::NotIncreasing {
            line,
            angle,
            previous,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> AngleTable {
        AngleTable::parse_csv(text).expect("valid table")
    }

    #[test]
    fn parses_header_comments_blank_and_separators() {
        let t = table(
            "\u{feff}angle_deg, reflectance\n\
             # measured 2024\n\
             \n\
             0, 0.5\n\
             \t30 0.25 \r\n\
             # mid comment\n\
             60.5,1\n",
        );
        assert_eq!(t.points(), &[(0.0, 0.5), (30.0, 0.25), (60.5, 1.0)]);
    }

    #[test]
    fn header_is_optional() {
        let t = table("10 0.1\n20 0.2");
        assert_eq!(t.points(), &[(10.0, 0.1), (20.0, 0.2)]);
    }

    #[test]
    fn interpolation_is_exact_linear() {
        let t = table("0,0.2\n40,0.6\n80,0.0");
        // At nodes: exactly the tabulated values.
        assert_eq!(t.at_angle_deg(0.0), 0.2);
        assert_eq!(t.at_angle_deg(40.0), 0.6);
        assert_eq!(t.at_angle_deg(80.0), 0.0);
        // Between nodes: r0 + (r1 - r0) (θ - θ0) / (θ1 - θ0).
        for theta in [1.0, 10.0, 20.0, 33.3, 39.999, 40.001, 55.0, 79.0] {
            let (a0, r0, a1, r1) = if theta < 40.0 {
                (0.0, 0.2, 40.0, 0.6)
            } else {
                (40.0, 0.6, 80.0, 0.0)
            };
            let expect = r0 + (r1 - r0) * (theta - a0) / (a1 - a0);
            assert!((t.at_angle_deg(theta) - expect).abs() < 1e-15, "{theta}");
        }
        assert!((t.at_angle_deg(20.0) - 0.4).abs() < 1e-15);
        assert!((t.at_angle_deg(60.0) - 0.3).abs() < 1e-15);
    }

    #[test]
    fn clamps_outside_range() {
        let t = table("10,0.3\n50,0.7");
        assert_eq!(t.at_angle_deg(0.0), 0.3);
        assert_eq!(t.at_angle_deg(-5.0), 0.3);
        assert_eq!(t.at_angle_deg(50.0), 0.7);
        assert_eq!(t.at_angle_deg(89.0), 0.7);
        assert_eq!(t.at_angle_deg(1e9), 0.7);
        assert!(t.at_angle_deg(f64::NAN).is_nan());
    }

    #[test]
    fn single_point_table_is_constant() {
        let t = table("45 0.42");
        for c in [0.0, 0.3, 1.0] {
            assert_eq!(t.reflectance(c), 0.42);
        }
    }

    #[test]
    fn reflectance_uses_incidence_angle_from_cosine() {
        let t = table("0,0\n90,1");
        // R(θ) = θ / 90, θ = acos(cos_i) in degrees.
        for c in [0.0f64, 0.1, 0.5, 0.9, 1.0] {
            let expect = c.acos().to_degrees() / 90.0;
            assert!((t.reflectance(c) - expect).abs() < 1e-14, "{c}");
        }
        assert_eq!(t.reflectance(2.0), 0.0);
        assert_eq!(t.reflectance(-1.0), 1.0);
        let r = Reflectance::Table(t);
        assert!((r.reflectance(0.5) - 60.0 / 90.0).abs() < 1e-14);
    }

    #[test]
    fn reflectance_variants() {
        assert_eq!(Reflectance::Constant(0.3).reflectance(0.7), 0.3);
        let f = Reflectance::Fresnel { n: 1.5, k: 0.0 };
        assert_eq!(f.reflectance(1.0), 0.04);
        assert_eq!(f.reflectance(0.0), 1.0);
        assert_eq!(f.reflectance(0.6), fresnel_unpolarised(0.6, 1.5, 0.0));
    }

    #[test]
    fn validate_checks_ranges() {
        assert_eq!(Reflectance::Constant(0.0).validate(), Ok(()));
        assert_eq!(Reflectance::Constant(1.0).validate(), Ok(()));
        assert_eq!(
            Reflectance::Constant(1.5).validate(),
            Err(ReflectanceError::ConstantOutOfRange(1.5))
        );
        assert!(Reflectance::Constant(f64::NAN).validate().is_err());
        assert!(Reflectance::Constant(-0.1).validate().is_err());
        assert_eq!(Reflectance::Fresnel { n: 1.0, k: 0.0 }.validate(), Ok(()));
        for n in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Reflectance::Fresnel { n, k: 1.0 }.validate(),
                Err(ReflectanceError::InvalidN(_))
            ));
        }
        for k in [-1e-9, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Reflectance::Fresnel { n: 1.0, k }.validate(),
                Err(ReflectanceError::InvalidK(_))
            ));
        }
        assert_eq!(Reflectance::Table(table("0 0")).validate(), Ok(()));
        assert_eq!(
            ReflectanceError::InvalidN(-1.0).to_string(),
            "refractive index n = -1 must be finite and > 0"
        );
    }

    fn err(text: &str) -> AngleTableError {
        AngleTable::parse_csv(text).expect_err("table must be rejected")
    }

    #[test]
    fn error_empty() {
        assert_eq!(err(""), AngleTableError::Empty);
        assert_eq!(err("# only comments\n\n"), AngleTableError::Empty);
        assert_eq!(err("angle_deg,reflectance\n"), AngleTableError::Empty);
        assert_eq!(err("").to_string(), "reflectance table has no data rows");
        assert_eq!(AngleTable::new(vec![]), Err(AngleTableError::Empty));
    }

    #[test]
    fn error_not_a_number() {
        let e = err("angle,r\n0,0.1\n10,abc\n");
        assert_eq!(
            e,
            AngleTableError::NotANumber {
                line: 3,
                field: 2,
                text: "abc".into()
            }
        );
        assert_eq!(e.to_string(), "line 3: field 2 `abc` is not a number");
        // A first line with one numeric field is data, not a header.
        assert!(matches!(
            err("0, x\n"),
            AngleTableError::NotANumber {
                line: 1,
                field: 2,
                ..
            }
        ));
        // Empty field between commas.
        assert!(matches!(
            err("0,,0.5\n"),
            AngleTableError::FieldCount { line: 1, found: 3 }
        ));
        assert!(matches!(
            err(",0.5\n"),
            AngleTableError::NotANumber {
                line: 1,
                field: 1,
                ..
            }
        ));
    }

    #[test]
    fn error_field_count() {
        let e = err("0 0.1\n10 0.2 0.3\n");
        assert_eq!(e, AngleTableError::FieldCount { line: 2, found: 3 });
        assert_eq!(
            e.to_string(),
            "line 2: expected 2 fields (angle_deg, reflectance), found 3"
        );
        assert_eq!(
            err("0\n"),
            AngleTableError::FieldCount { line: 1, found: 1 }
        );
    }

    #[test]
    fn error_not_increasing() {
        let e = err("0 0.1\n# c\n20 0.2\n20 0.3\n");
        assert_eq!(
            e,
            AngleTableError::NotIncreasing {
                line: 4,
                angle: 20.0,
                previous: 20.0
            }
        );
        assert_eq!(
            e.to_string(),
            "line 4: angle 20 deg is not greater than the previous angle 20 deg"
        );
        assert!(matches!(
            err("30 0\n10 0\n"),
            AngleTableError::NotIncreasing { line: 2, .. }
        ));
    }

    #[test]
    fn error_angle_out_of_range() {
        let e = err("0 0\n90.5 0\n");
        assert_eq!(
            e,
            AngleTableError::AngleOutOfRange {
                line: 2,
                angle: 90.5
            }
        );
        assert_eq!(e.to_string(), "line 2: angle 90.5 deg is outside [0, 90]");
        assert!(matches!(
            err("-1 0"),
            AngleTableError::AngleOutOfRange { line: 1, .. }
        ));
        assert!(matches!(
            err("inf 0"),
            AngleTableError::AngleOutOfRange { line: 1, .. }
        ));
    }

    #[test]
    fn error_reflectance_out_of_range() {
        let e = err("0 1.01\n");
        assert_eq!(
            e,
            AngleTableError::ReflectanceOutOfRange {
                line: 1,
                value: 1.01
            }
        );
        assert_eq!(e.to_string(), "line 1: reflectance 1.01 is outside [0, 1]");
        assert!(matches!(
            err("0 0\n5 -0.5"),
            AngleTableError::ReflectanceOutOfRange { line: 2, .. }
        ));
    }

    #[test]
    fn error_nan() {
        let e = err("0 0\n10 NaN\n");
        assert_eq!(e, AngleTableError::NaN { line: 2, field: 2 });
        assert_eq!(e.to_string(), "line 2: field 2 is NaN");
        assert_eq!(err("nan,0.5"), AngleTableError::NaN { line: 1, field: 1 });
    }

    #[test]
    fn new_validates_points() {
        assert!(AngleTable::new(vec![(0.0, 0.1), (90.0, 0.9)]).is_ok());
        assert_eq!(
            AngleTable::new(vec![(0.0, 0.1), (0.0, 0.9)]),
            Err(AngleTableError::NotIncreasing {
                line: 2,
                angle: 0.0,
                previous: 0.0
            })
        );
        assert_eq!(
            AngleTable::new(vec![(f64::NAN, 0.1)]),
            Err(AngleTableError::NaN { line: 1, field: 1 })
        );
        assert_eq!(
            AngleTable::new(vec![(1.0, 2.0)]),
            Err(AngleTableError::ReflectanceOutOfRange {
                line: 1,
                value: 2.0
            })
        );
    }

    #[test]
    fn all_error_messages_are_one_line() {
        for text in ["", "0,a", "0 1 2", "1 0\n0 0", "91 0", "0 2", "NaN 0"] {
            let msg = err(text).to_string();
            assert!(!msg.contains('\n'), "{msg}");
        }
    }
}
