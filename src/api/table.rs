//! A result table (`brdf.csv`, `inplane.csv`, `reflectance.csv`, ...) as
//! named columns of numbers: what a numpy consumer takes as arrays.

use std::fmt;

/// A CSV table of a result folder, column by column: the header's names
/// and, per name, its values in row order (`f64`, exactly as written:
/// the files hold shortest round-trip or 10-significant-digit decimals).
///
/// The row order is the file's. In `brdf.csv` that is the result tree's:
/// incidence angle, then light azimuth, then wavelength, then Carlson cell
/// ([`super::BrdfResult::theta_deg`] and the other axes give the shape).
///
/// ```
/// let t = roks::api::Table::parse("a,b\n1,2.5\n3,4\n", "t.csv").unwrap();
/// assert_eq!(t.column("b"), Some(&[2.5, 4.0][..]));
/// assert_eq!((t.rows(), t.names().len()), (2, 2));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

/// Why a text is not a table of numbers: the file, the 1-based line and
/// what is wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}: line {line}: {problem}")]
pub struct TableError {
    /// The file's name as given.
    pub file: String,
    /// The line (1 is the header).
    pub line: usize,
    /// What is wrong.
    pub problem: String,
}

impl Table {
    /// The table of the CSV `text` (named `file` in errors): a header of
    /// names, then rows of as many numbers.
    ///
    /// # Errors
    /// An empty text, a row of another width, or a field that is not a
    /// number.
    pub fn parse(text: &str, file: &str) -> Result<Self, TableError> {
        let err = |line: usize, problem: String| TableError {
            file: file.to_owned(),
            line,
            problem,
        };
        let mut lines = text.lines();
        let names: Vec<String> = lines
            .next()
            .ok_or_else(|| err(1, "no header".into()))?
            .split(',')
            .map(str::to_owned)
            .collect();
        let mut columns = vec![Vec::new(); names.len()];
        for (k, row) in lines.enumerate().filter(|(_, r)| !r.is_empty()) {
            let fields: Vec<&str> = row.split(',').collect();
            if fields.len() != names.len() {
                let p = format!("expected {} columns, found {}", names.len(), fields.len());
                return Err(err(k + 2, p));
            }
            for (c, f) in fields.iter().enumerate() {
                let x = f
                    .parse::<f64>()
                    .map_err(|_| err(k + 2, format!("column {}: `{f}` is not a number", c + 1)))?;
                columns[c].push(x);
            }
        }
        Ok(Self { names, columns })
    }

    /// The column names, in the file's order.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The values of the column `name`, in row order; `None` when the
    /// table has no such column.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[k])
    }

    /// The number of rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
}

impl fmt::Display for Table {
    /// The header and the row count, e.g. `3 rows of a,b`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} rows of {}", self.rows(), self.names.join(","))
    }
}
