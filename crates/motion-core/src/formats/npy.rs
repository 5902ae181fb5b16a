//! `.npy` arrays of motion data (ndarray-npy): frames x channels (2-D), positions T x J x 3 or
//! N x T x D (3-D), and 4-D/5-D stacks. Always `f64` in memory; `float32` files are accepted and
//! widened, so are Fortran-ordered ones. Writes `float64`, C order, atomically.
use std::io::Cursor;
use std::path::Path;

use ndarray::{Array, ArrayBase, ArrayD, Data, Dimension, IxDyn};
use ndarray_npy::npy::header::Header;
use ndarray_npy::{ReadNpyExt, WriteNpyExt};

use crate::error::FormatError;
use crate::formats::atomic::write_atomically;

fn invalid(path: &Path, problem: String) -> FormatError {
    FormatError::Invalid {
        path: path.to_path_buf(),
        problem,
    }
}

/// Reads a `.npy` array of any rank as `f64` (from `float64` or `float32` data).
///
/// Errors: missing file ([`FormatError::Io`]); a bad header, another dtype, or data shorter or
/// longer than the header's shape ([`FormatError::Invalid`]). The declared shape is checked
/// against the file size before anything is allocated.
pub fn read_npy_dyn(path: impl AsRef<Path>) -> Result<ArrayD<f64>, FormatError> {
    let path = path.as_ref();
    let bytes = crate::input_file::read_regular(path).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_npy_dyn(&bytes, path)
}

/// [`read_npy_dyn`] of a `.npy` file's bytes already in memory; `path` names it in errors.
pub fn parse_npy_dyn(bytes: &[u8], path: &Path) -> Result<ArrayD<f64>, FormatError> {
    check_header_length(bytes, path)?;
    let mut cursor = Cursor::new(bytes);
    let header = Header::from_reader(&mut cursor).map_err(|e| {
        invalid(
            path,
            format!("not a valid .npy header: {}", one_line(&e.to_string())),
        )
    })?;
    let descr = header.type_descriptor.to_string();
    let elem = match descr.trim_matches(|c| c == '\'' || c == '"') {
        "<f8" | "=f8" | "f8" | "float64" => 8,
        "<f4" | "=f4" | "f4" | "float32" => 4,
        other => {
            return Err(invalid(
                path,
                format!(
                    "expected float64 or float32 little-endian data, found dtype {}",
                    one_line(other)
                ),
            ))
        }
    };
    // ndarray's own limit: the product of the non-zero axes must fit in isize, even when
    // another axis is 0 (a (0, 2^62, 4) header holds no data but no array can have its shape).
    let nonzero = header
        .shape
        .iter()
        .filter(|&&d| d != 0)
        .try_fold(elem, |acc: usize, &d| acc.checked_mul(d));
    if nonzero.is_none_or(|n| n > isize::MAX as usize) {
        return Err(invalid(
            path,
            format!("header shape {:?} is too large for any array", header.shape),
        ));
    }
    let data_len = bytes.len() - cursor.position() as usize;
    let needed = header
        .shape
        .iter()
        .try_fold(elem, |acc: usize, &d| acc.checked_mul(d));
    if needed != Some(data_len) {
        return Err(invalid(
            path,
            format!(
                "header shape {:?} needs {} bytes of data, file has {data_len}",
                header.shape,
                needed.map_or_else(|| "too many".to_string(), |n| n.to_string())
            ),
        ));
    }
    let parse_err = |e: ndarray_npy::ReadNpyError| {
        invalid(path, format!("bad .npy data: {}", one_line(&e.to_string())))
    };
    if elem == 8 {
        ArrayD::<f64>::read_npy(bytes).map_err(parse_err)
    } else {
        Ok(ArrayD::<f32>::read_npy(bytes)
            .map_err(parse_err)?
            .mapv(f64::from))
    }
}

/// Deepest bracket nesting accepted in a `.npy` header (real ones have 2).
const MAX_HEADER_NESTING: usize = 4;

/// The header length a `.npy` file declares must fit in the file: the header parser allocates
/// it before reading (a 4-byte length of 2.5 GB in a 20-byte file would abort the process).
fn check_header_length(bytes: &[u8], path: &Path) -> Result<(), FormatError> {
    const MAGIC: &[u8] = b"\x93NUMPY";
    if bytes.len() < MAGIC.len() + 2 || &bytes[..MAGIC.len()] != MAGIC {
        return Ok(()); // the header parser names what is wrong
    }
    let (length, start) = match bytes[MAGIC.len()] {
        1 if bytes.len() >= 10 => (u64::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u64::from(u32::from_le_bytes([
                bytes[8], bytes[9], bytes[10], bytes[11],
            ])),
            12,
        ),
        _ => return Ok(()),
    };
    let available = (bytes.len() - start) as u64;
    if length > available {
        return Err(invalid(
            path,
            format!("not a valid .npy header: it declares {length} bytes, the file has {available} after the preamble"),
        ));
    }
    // A real header nests two deep ({'shape': (2, 3)}); the header parser takes exponential
    // time on deeply nested brackets (found by fuzzing: 139 bytes took 10 minutes).
    let header = &bytes[start..start + length as usize];
    let mut depth = 0usize;
    for &b in header {
        match b {
            b'(' | b'[' | b'{' => {
                depth += 1;
                if depth > MAX_HEADER_NESTING {
                    return Err(invalid(
                        path,
                        format!("not a valid .npy header: brackets nested over {MAX_HEADER_NESTING} deep"),
                    ));
                }
            }
            b')' | b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    Ok(())
}

/// A library's multi-line message as one line, at most 200 characters.
fn one_line(message: &str) -> String {
    let flat: String = message.split_whitespace().collect::<Vec<_>>().join(" ");
    if flat.chars().count() > 200 {
        let cut: String = flat.chars().take(200).collect();
        format!("{cut}...")
    } else {
        flat
    }
}

/// Reads a `.npy` array that must have rank `D` (e.g. `Ix2` for frames x channels, `Ix3` for
/// positions); the error names the expected and found shapes.
pub fn read_npy_as<D: Dimension>(path: impl AsRef<Path>) -> Result<Array<f64, D>, FormatError> {
    let path = path.as_ref();
    let array = read_npy_dyn(path)?;
    let found = array.shape().to_vec();
    array.into_dimensionality::<D>().map_err(|_| {
        invalid(
            path,
            format!(
                "expected a {}-D array, found shape {found:?}",
                D::NDIM.map_or_else(|| "n".to_string(), |n| n.to_string())
            ),
        )
    })
}

/// Reads `frames x channels` (2-D).
pub fn read_npy_frames(path: impl AsRef<Path>) -> Result<ndarray::Array2<f64>, FormatError> {
    read_npy_as::<ndarray::Ix2>(path)
}

/// Reads joint positions `frames x joints x 3` (3-D whose last axis is 3).
pub fn read_npy_positions(path: impl AsRef<Path>) -> Result<ndarray::Array3<f64>, FormatError> {
    let path = path.as_ref();
    let array = read_npy_as::<ndarray::Ix3>(path)?;
    if array.shape()[2] != 3 {
        return Err(invalid(
            path,
            format!(
                "expected positions of shape [frames, joints, 3], found {:?}",
                array.shape()
            ),
        ));
    }
    Ok(array)
}

/// Writes any `f64` array as a `float64`, C-order `.npy` (via a temporary file and rename).
pub fn write_npy<S, D>(path: impl AsRef<Path>, array: &ArrayBase<S, D>) -> Result<(), FormatError>
where
    S: Data<Elem = f64>,
    D: Dimension,
{
    let path = path.as_ref();
    let standard = array.as_standard_layout().into_dimensionality::<IxDyn>();
    let standard = standard.expect("any dimension converts to IxDyn");
    write_atomically(path, |w| {
        standard
            .write_npy(&mut *w)
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::h36m_text::tests::Scratch;
    use ndarray::{Array2, Array3, Array4, Array5, ShapeBuilder};

    #[test]
    fn arrays_of_rank_2_to_5_round_trip() {
        let dir = Scratch::new("npy");
        let a2 = Array2::from_shape_fn((4, 99), |(i, j)| (i * 99 + j) as f64 * 0.5);
        let a3 = Array3::from_shape_fn((3, 32, 3), |(i, j, k)| (i + j * k) as f64 - 7.25);
        let a4 = Array4::from_shape_fn((2, 3, 4, 5), |(a, b, c, d)| (a + b + c + d) as f64);
        let a5 = Array5::from_shape_fn((1, 2, 3, 2, 3), |(a, b, c, d, e)| {
            (a * b + c * d + e) as f64
        });
        write_npy(dir.0.join("a2.npy"), &a2).unwrap();
        write_npy(dir.0.join("a3.npy"), &a3).unwrap();
        write_npy(dir.0.join("a4.npy"), &a4).unwrap();
        write_npy(dir.0.join("a5.npy"), &a5).unwrap();
        assert_eq!(read_npy_frames(dir.0.join("a2.npy")).unwrap(), a2);
        assert_eq!(read_npy_positions(dir.0.join("a3.npy")).unwrap(), a3);
        assert_eq!(
            read_npy_as::<ndarray::Ix4>(dir.0.join("a4.npy")).unwrap(),
            a4
        );
        assert_eq!(
            read_npy_as::<ndarray::Ix5>(dir.0.join("a5.npy")).unwrap(),
            a5
        );
        // Fortran-ordered and transposed views are written in C order.
        let f = Array2::from_shape_vec((2, 3).f(), vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
        write_npy(dir.0.join("f.npy"), &f.t()).unwrap();
        assert_eq!(read_npy_frames(dir.0.join("f.npy")).unwrap(), f.t());
    }

    /// A `.npy` file's bytes with `header` (a Python dict literal) and `data`.
    fn npy_bytes(header: &str, data: &[u8]) -> Vec<u8> {
        let mut dict = header.to_string();
        while !(10 + dict.len() + 1).is_multiple_of(64) {
            dict.push(' ');
        }
        dict.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
        out.extend_from_slice(dict.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn impossible_shapes_are_errors_not_panics() {
        let path = Path::new("big.npy");
        for shape in [
            "(0, 4611686018427387904, 4)",
            "(4611686018427387904, 0)",
            "(0, 18446744073709551615)",
        ] {
            let bytes = npy_bytes(
                &format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}"),
                &[],
            );
            let e = parse_npy_dyn(&bytes, path).unwrap_err().to_string();
            assert!(e.contains("too large"), "{shape}: {e}");
        }
        // Zero-sized arrays of sane shapes still read.
        let bytes = npy_bytes(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (0, 99), }",
            &[],
        );
        assert_eq!(parse_npy_dyn(&bytes, path).unwrap().shape(), &[0, 99]);
        // A declared header length beyond the file is refused before anything is allocated
        // (found by fuzzing: version 2, length 0x93000000, in a 20-byte file).
        let mut lying = b"\x93NUMPY\x02\x00\x00\x00\x00\x93".to_vec();
        lying.extend_from_slice(b"NUMPY\x02\x00\x00");
        let e = parse_npy_dyn(&lying, path).unwrap_err().to_string();
        assert!(e.contains("declares 2466250752 bytes"), "{e}");
        // Deeply nested brackets are refused at once (the parser is exponential in them).
        let nested = npy_bytes(&format!("{{{}", "[(".repeat(40)), &[]);
        let e = parse_npy_dyn(&nested, path).unwrap_err().to_string();
        assert!(e.contains("nested"), "{e}");
        // A header that does not parse gives one short line.
        let bytes = npy_bytes(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2, ",
            &[0; 16],
        );
        let e = parse_npy_dyn(&bytes, path).unwrap_err().to_string();
        assert!(!e.contains('\n') && e.len() < 300, "{e}");
    }

    #[test]
    fn float32_files_are_widened() {
        let dir = Scratch::new("npy32");
        let a = Array2::from_shape_fn((3, 4), |(i, j)| (i as f32) * 0.1 + j as f32);
        let path = dir.0.join("f32.npy");
        ndarray_npy::write_npy(&path, &a).unwrap();
        let b = read_npy_frames(&path).unwrap();
        assert_eq!(b, a.mapv(f64::from));
    }

    #[test]
    fn wrong_rank_dtype_and_truncation_are_named_errors() {
        let dir = Scratch::new("npybad");
        let a3 = Array3::<f64>::zeros((2, 3, 4));
        let path = dir.0.join("pos.npy");
        write_npy(&path, &a3).unwrap();
        let e = read_npy_frames(&path).unwrap_err();
        assert!(
            e.to_string()
                .contains("expected a 2-D array, found shape [2, 3, 4]"),
            "{e}"
        );
        let e = read_npy_positions(&path).unwrap_err();
        assert!(e.to_string().contains("[frames, joints, 3]"), "{e}");
        assert!(e.to_string().contains("pos.npy"));

        let ints = dir.0.join("ints.npy");
        ndarray_npy::write_npy(&ints, &Array2::<i64>::zeros((2, 2))).unwrap();
        let e = read_npy_frames(&ints).unwrap_err();
        assert!(e.to_string().contains("expected float64 or float32"), "{e}");

        let bytes = std::fs::read(&path).unwrap();
        let cut = dir.0.join("cut.npy");
        std::fs::write(&cut, &bytes[..bytes.len() - 8]).unwrap();
        let e = read_npy_dyn(&cut).unwrap_err();
        assert!(e.to_string().contains("needs 192 bytes"), "{e}");

        let junk = dir.0.join("junk.npy");
        std::fs::write(&junk, b"\x93NUMPY garbage").unwrap();
        assert!(read_npy_dyn(&junk).is_err());
        assert!(matches!(
            read_npy_dyn(dir.0.join("missing.npy")),
            Err(FormatError::Io { .. })
        ));
    }

    #[test]
    fn huge_declared_shapes_do_not_allocate() {
        let dir = Scratch::new("npyhuge");
        let path = dir.0.join("huge.npy");
        for (shape, says) in [
            ("(4000000000, 4000000000)", "too large"),
            ("(400000, 400000)", "needs"),
        ] {
            let header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
            std::fs::write(&path, npy_bytes(&header, &[0u8; 16])).unwrap();
            let e = read_npy_dyn(&path).unwrap_err();
            assert!(e.to_string().contains(says), "{e}");
        }
    }
}
