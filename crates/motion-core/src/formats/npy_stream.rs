//! A `.npy` (float64, C order) written piece by piece, so that an output of many actions and
//! samples (`motion-cli eval --save-predictions`) never holds the whole array in memory. The data
//! go to a registered temporary file next to the destination ([`super::atomic::TempFile`]) that
//! is renamed over the destination only when every value has been written; a writer dropped
//! before [`NpyStream::finish`] (or a SIGINT / SIGTERM in `motion-cli`) removes it.
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::atomic::TempFile;
use crate::error::{FormatError, WriteFailure};

/// An `.npy` file of a fixed shape being filled in C order.
#[derive(Debug)]
pub struct NpyStream {
    destination: PathBuf,
    temporary: Option<TempFile>,
    file: Option<BufWriter<File>>,
    expected: usize,
    written: usize,
    buffer: Vec<u8>,
}

/// The `.npy` version 1.0 header of a little-endian float64, C-order array of `shape`.
fn header(shape: &[usize]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let tuple = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {tuple}, }}");
    // Magic (6) + version (2) + length (2) + dict + '\n' is padded to a multiple of 64.
    let unpadded = 10 + dict.len() + 1;
    dict.push_str(&" ".repeat((64 - unpadded % 64) % 64));
    dict.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out
}

impl NpyStream {
    /// Starts `destination` with `shape`: creates the temporary file next to it and writes the
    /// header. A shape over 2^60 values, or whose header would not fit a version-1.0 `.npy`, is
    /// refused ([`FormatError::Invalid`]).
    pub fn create(destination: &Path, shape: &[usize]) -> Result<Self, FormatError> {
        let expected = shape
            .iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d))
            .filter(|&n| n as u64 <= 1u64 << 60)
            .ok_or_else(|| FormatError::Invalid {
                path: destination.to_path_buf(),
                problem: format!("the shape {shape:?} holds too many values for one file"),
            })?;
        let bytes = header(shape);
        if bytes.len() > u16::MAX as usize {
            return Err(FormatError::Invalid {
                path: destination.to_path_buf(),
                problem: format!("the shape {shape:?} does not fit a .npy header"),
            });
        }
        let (temporary, file) =
            TempFile::create(destination).map_err(|e| write_error(destination, e))?;
        let mut stream = Self {
            destination: destination.to_path_buf(),
            temporary: Some(temporary),
            file: Some(BufWriter::new(file)),
            expected,
            written: 0,
            buffer: Vec::with_capacity(8 * 1024),
        };
        stream.write_bytes(&bytes)?;
        Ok(stream)
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> Result<(), FormatError> {
        let file = self.file.as_mut().expect("open until finish");
        file.write_all(bytes)
            .map_err(|e| write_error(&self.destination, e))
    }

    /// Appends values in C order.
    pub fn write(&mut self, values: impl IntoIterator<Item = f64>) -> Result<(), FormatError> {
        let mut buffer = std::mem::take(&mut self.buffer);
        buffer.clear();
        let mut result = Ok(());
        for v in values {
            buffer.extend_from_slice(&v.to_le_bytes());
            self.written += 1;
            if buffer.len() >= 8 * 1024 {
                result = self.write_bytes(&buffer);
                buffer.clear();
                if result.is_err() {
                    break;
                }
            }
        }
        if result.is_ok() {
            result = self.write_bytes(&buffer);
        }
        self.buffer = buffer;
        result
    }

    /// Checks that every value was written, syncs the file and renames it into place.
    pub fn finish(mut self) -> Result<(), FormatError> {
        if self.written != self.expected {
            return Err(FormatError::Invalid {
                path: self.destination.clone(),
                problem: format!(
                    "{} values written, the shape needs {}",
                    self.written, self.expected
                ),
            });
        }
        let file = self.file.take().expect("open until finish");
        let destination = self.destination.clone();
        let file = file
            .into_inner()
            .map_err(|e| write_error(&destination, e.into_error()))?;
        file.sync_all().map_err(|e| write_error(&destination, e))?;
        drop(file);
        let temporary = self.temporary.take().expect("open until finish");
        temporary
            .persist()
            .map_err(|e| write_error(&destination, e))
    }
}

fn write_error(path: &Path, source: std::io::Error) -> FormatError {
    FormatError::Write {
        path: path.to_path_buf(),
        source: WriteFailure(source),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::npy::read_npy_dyn;

    #[test]
    fn streamed_file_reads_back_and_unfinished_leaves_nothing() {
        let dir = std::env::temp_dir().join(format!("npy-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.npy");
        let mut s = NpyStream::create(&path, &[2, 3, 1, 2, 2]).unwrap();
        s.write((0..12).map(|v| v as f64 * 0.5)).unwrap();
        s.write((12..24).map(|v| v as f64 * 0.5)).unwrap();
        s.finish().unwrap();
        let a = read_npy_dyn(&path).unwrap();
        assert_eq!(a.shape(), &[2, 3, 1, 2, 2]);
        assert_eq!(a.iter().copied().collect::<Vec<_>>()[23], 11.5);
        for shape in [vec![5], vec![1, 8, 3, 100, 99]] {
            assert_eq!(header(&shape).len() % 64, 0);
        }
        let other = dir.join("b.npy");
        let mut s = NpyStream::create(&other, &[4]).unwrap();
        s.write([1.0]).unwrap();
        drop(s);
        assert!(!other.exists());
        let short = dir.join("c.npy");
        let mut s = NpyStream::create(&short, &[4]).unwrap();
        s.write([1.0]).unwrap();
        assert!(matches!(s.finish(), Err(FormatError::Invalid { .. })));
        assert!(!short.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        assert!(matches!(
            NpyStream::create(&dir.join("d.npy"), &[1 << 40, 1 << 40]),
            Err(FormatError::Invalid { .. })
        ));
        assert!(matches!(
            NpyStream::create(&dir.join("no/such/e.npy"), &[1]),
            Err(FormatError::Write { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
