//! The "tensor file" container of Mitsuba 3 (`mitsuba::TensorFile`, the
//! reader of its `measured` and `measured_polarized` plugins) and of the
//! RGL material database: named, typed, n-dimensional arrays in one
//! little-endian file.
//!
//! Layout (all integers little-endian):
//!
//! * 12 bytes `tensor_file\0`, then the version as two bytes `1, 0`;
//! * `u32` the number of fields, then per field: `u16` name length, the
//!   name (UTF-8), `u16` number of dimensions, `u8` data type (1 `u8`,
//!   2 `i8`, 3 `u16`, 4 `i16`, 5 `u32`, 6 `i32`, 7 `u64`, 8 `i64`, 9 `f16`,
//!   10 `f32`, 11 `f64`: the codes of Mitsuba's `Struct::Type`), `u64`
//!   offset of the data from the start of the file, and one `u64` per
//!   dimension (the shape, slowest-varying first);
//! * the data of each field, row-major (C order), at its offset. This writer
//!   aligns every field to 8 bytes, as Mitsuba's `tensor_io.write` does, so
//!   that the reader can use the memory-mapped `f32` data in place.
//!
//! Only the types the BRDF formats use are written and read here:
//! [`Data::U8`], [`Data::U16`] (the `wvls` of a pbsdf file) and
//! [`Data::F32`].

use std::collections::BTreeMap;

use super::super::resample::FormatError;

/// The first 12 bytes of a tensor file.
pub const MAGIC: &[u8; 12] = b"tensor_file\0";
/// Type code of `u8` data.
pub const U8: u8 = 1;
/// Type code of `u16` data.
pub const U16: u8 = 3;
/// Type code of `f32` data.
pub const F32: u8 = 10;

/// The values of a field.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// Bytes (type code 1): text, flags.
    U8(Vec<u8>),
    /// Unsigned 16-bit integers (type code 3): wavelengths in nm.
    U16(Vec<u16>),
    /// Single-precision floats (type code 10).
    F32(Vec<f32>),
}

impl Data {
    fn len(&self) -> usize {
        match self {
            Self::U8(v) => v.len(),
            Self::U16(v) => v.len(),
            Self::F32(v) => v.len(),
        }
    }
}

/// One named array.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Its name (`theta_i`, `spectra`, ...).
    pub name: String,
    /// Its shape, slowest-varying dimension first.
    pub shape: Vec<usize>,
    /// Its values, `shape.iter().product()` of them.
    pub data: Data,
}

impl Field {
    /// An `f32` field of `shape` from `f64` values (rounded to nearest).
    ///
    /// # Panics
    /// If the number of values is not the product of the shape.
    #[must_use]
    pub fn f32(name: &str, shape: &[usize], values: &[f64]) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            values.len(),
            "tensor field {name}: shape {shape:?}"
        );
        Self {
            name: name.into(),
            shape: shape.to_vec(),
            data: Data::F32(values.iter().map(|&v| v as f32).collect()),
        }
    }

    /// A one-dimensional `u8` field.
    #[must_use]
    pub fn bytes(name: &str, bytes: &[u8]) -> Self {
        Self {
            name: name.into(),
            shape: vec![bytes.len()],
            data: Data::U8(bytes.to_vec()),
        }
    }
}

/// The bytes of a tensor file holding `fields` in this order.
#[must_use]
pub fn write(fields: &[Field]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(fields.len() as u32).to_le_bytes());
    // The header's size decides the first offset.
    let header: usize = out.len()
        + fields
            .iter()
            .map(|f| 2 + f.name.len() + 2 + 1 + 8 + 8 * f.shape.len())
            .sum::<usize>();
    let align = |at: usize| at.div_ceil(8) * 8;
    let mut at = align(header);
    let mut offsets = Vec::with_capacity(fields.len());
    for f in fields {
        offsets.push(at);
        let bytes = match &f.data {
            Data::U8(v) => v.len(),
            Data::U16(v) => 2 * v.len(),
            Data::F32(v) => 4 * v.len(),
        };
        at = align(at + bytes);
    }
    for (f, &offset) in fields.iter().zip(&offsets) {
        out.extend_from_slice(&(f.name.len() as u16).to_le_bytes());
        out.extend_from_slice(f.name.as_bytes());
        out.extend_from_slice(&(f.shape.len() as u16).to_le_bytes());
        out.push(match f.data {
            Data::U8(_) => U8,
            Data::U16(_) => U16,
            Data::F32(_) => F32,
        });
        out.extend_from_slice(&(offset as u64).to_le_bytes());
        for &n in &f.shape {
            out.extend_from_slice(&(n as u64).to_le_bytes());
        }
    }
    debug_assert_eq!(out.len(), header);
    for (f, &offset) in fields.iter().zip(&offsets) {
        out.resize(offset, 0);
        match &f.data {
            Data::U8(v) => out.extend_from_slice(v),
            Data::U16(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
            Data::F32(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes())),
        }
    }
    out
}

/// A tensor file read back: its fields by name.
#[derive(Debug, Clone, PartialEq)]
pub struct TensorFile {
    /// The fields by name.
    pub fields: BTreeMap<String, Field>,
    /// The file's name, for messages.
    pub file: String,
}

impl TensorFile {
    /// Parse `bytes`; `file` names the file in errors.
    ///
    /// # Errors
    /// A wrong magic or version, a truncated header or field, a type other
    /// than `u8` or `f32`, or a field whose data lies outside the file.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Self, FormatError> {
        let err = |message: String| FormatError {
            file: file.into(),
            message,
        };
        let mut at = 0usize;
        let mut take = |n: usize| -> Result<&[u8], FormatError> {
            let s = bytes
                .get(at..at + n)
                .ok_or_else(|| err(format!("truncated header at byte {at}")))?;
            at += n;
            Ok(s)
        };
        if take(12)? != MAGIC {
            return Err(err("not a tensor file (no `tensor_file` header)".into()));
        }
        let version = take(2)?;
        if version != [1, 0] {
            return Err(err(format!(
                "tensor file version {version:?}, expected [1, 0]"
            )));
        }
        let u16_at = |s: &[u8]| u16::from_le_bytes([s[0], s[1]]);
        let u64_at = |s: &[u8]| u64::from_le_bytes(s.try_into().expect("8 bytes"));
        let n = u32::from_le_bytes(take(4)?.try_into().expect("4 bytes"));
        let mut fields = BTreeMap::new();
        for _ in 0..n {
            let len = usize::from(u16_at(take(2)?));
            let name = String::from_utf8(take(len)?.to_vec())
                .map_err(|_| err("a field name is not UTF-8".into()))?;
            let ndim = usize::from(u16_at(take(2)?));
            let dtype = take(1)?[0];
            let offset = u64_at(take(8)?);
            let shape = (0..ndim)
                .map(|_| take(8).map(|s| u64_at(s) as usize))
                .collect::<Result<Vec<_>, _>>()?;
            let count = shape
                .iter()
                .try_fold(1usize, |a, &b| a.checked_mul(b))
                .ok_or_else(|| err(format!("field {name}: shape {shape:?} overflows")))?;
            let size = match dtype {
                U8 => 1,
                U16 => 2,
                F32 => 4,
                t => {
                    return Err(err(format!(
                        "field {name}: data type {t} (only u8, u16 and f32 are read)"
                    )));
                }
            };
            let data = usize::try_from(offset)
                .ok()
                .and_then(|o| Some(o..o.checked_add(count.checked_mul(size)?)?))
                .and_then(|r| bytes.get(r))
                .ok_or_else(|| err(format!("field {name}: data past the end of the file")))?;
            let data = if dtype == U8 {
                Data::U8(data.to_vec())
            } else if dtype == U16 {
                Data::U16(
                    data.chunks_exact(2)
                        .map(|c| u16::from_le_bytes([c[0], c[1]]))
                        .collect(),
                )
            } else {
                Data::F32(
                    data.chunks_exact(4)
                        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                        .collect(),
                )
            };
            debug_assert_eq!(data.len(), count);
            fields.insert(name.clone(), Field { name, shape, data });
        }
        Ok(Self {
            fields,
            file: file.into(),
        })
    }

    /// The `f32` field `name` with its shape, which must have `ndim`
    /// dimensions.
    ///
    /// # Errors
    /// If there is no such field, or it is not `f32` of `ndim` dimensions.
    pub fn f32(&self, name: &str, ndim: usize) -> Result<(&[usize], &[f32]), FormatError> {
        match self.fields.get(name) {
            Some(Field {
                shape,
                data: Data::F32(v),
                ..
            }) if shape.len() == ndim => Ok((shape, v)),
            Some(f) => Err(self.error(format!(
                "field {name}: expected {ndim}-dimensional f32, found shape {:?} of {}",
                f.shape,
                match f.data {
                    Data::U8(_) => "u8",
                    Data::U16(_) => "u16",
                    Data::F32(_) => "f32",
                }
            ))),
            None => Err(self.error(format!("no field {name}"))),
        }
    }

    /// The `u8` field `name`.
    ///
    /// # Errors
    /// If there is no such field, or it is not `u8`.
    pub fn bytes(&self, name: &str) -> Result<&[u8], FormatError> {
        match self.fields.get(name) {
            Some(Field {
                data: Data::U8(v), ..
            }) => Ok(v),
            Some(_) => Err(self.error(format!("field {name}: expected u8"))),
            None => Err(self.error(format!("no field {name}"))),
        }
    }

    fn error(&self, message: String) -> FormatError {
        FormatError {
            file: self.file.clone(),
            message,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes of a small file, laid out by hand from the format above
    /// (and Mitsuba's `tensor_io.write`): header, field table, data at
    /// offsets rounded up to 8.
    #[test]
    fn layout_is_the_documented_one() {
        let bytes = write(&[
            Field::bytes("j", &[1]),
            Field::f32("xy", &[2], &[0.5, -2.0]),
        ]);
        let mut want = b"tensor_file\0".to_vec();
        want.extend_from_slice(&[1, 0, 2, 0, 0, 0]);
        // Header: 18 + (2+1+2+1+8+8) + (2+2+2+1+8+8) = 63 bytes -> data at 64.
        want.extend_from_slice(&[1, 0, b'j', 1, 0, 1]);
        want.extend_from_slice(&64u64.to_le_bytes());
        want.extend_from_slice(&1u64.to_le_bytes());
        want.extend_from_slice(&[2, 0, b'x', b'y', 1, 0, 10]);
        want.extend_from_slice(&72u64.to_le_bytes());
        want.extend_from_slice(&2u64.to_le_bytes());
        want.push(0);
        want.push(1);
        want.extend_from_slice(&[0; 7]);
        want.extend_from_slice(&0.5f32.to_le_bytes());
        want.extend_from_slice(&(-2.0f32).to_le_bytes());
        assert_eq!(bytes, want);
        let t = TensorFile::parse(&bytes, "t").unwrap();
        assert_eq!(t.bytes("j").unwrap(), [1]);
        assert_eq!(t.f32("xy", 1).unwrap().1, [0.5, -2.0]);
        assert!(t.f32("xy", 2).is_err() && t.f32("j", 1).is_err());
    }

    #[test]
    fn truncated_and_foreign_files_are_refused() {
        let bytes = write(&[Field::f32("a", &[3], &[1.0, 2.0, 3.0])]);
        for cut in [5, 20, bytes.len() - 1] {
            let e = TensorFile::parse(&bytes[..cut], "a.bsdf").unwrap_err();
            assert!(e.to_string().starts_with("a.bsdf: "), "{e}");
        }
        assert!(TensorFile::parse(b"tensor_filx\0\x01\x00\0\0\0\0", "x").is_err());
    }
}
