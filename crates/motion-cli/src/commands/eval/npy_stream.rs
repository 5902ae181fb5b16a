//! A `.npy` (float64, C order) written piece by piece, so that `--save-predictions` of many
//! actions and samples never holds the whole array in memory. The data go to a temporary file
//! in the destination's directory that is renamed over the destination only when every value
//! has been written; a writer dropped before [`NpyStream::finish`] removes its temporary file.
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

/// An `.npy` file of a fixed shape being filled in C order.
#[derive(Debug)]
pub struct NpyStream {
    destination: PathBuf,
    temporary: PathBuf,
    file: Option<BufWriter<File>>,
    expected: usize,
    written: usize,
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
    /// Starts `destination` with `shape`: creates the temporary file next to it and writes the header.
    pub fn create(destination: &Path, shape: &[usize]) -> Result<Self> {
        let name = destination
            .file_name()
            .with_context(|| format!("{}: not a file name", destination.display()))?;
        let mut temporary_name = std::ffi::OsString::from(".");
        temporary_name.push(name);
        temporary_name.push(format!(".{}.tmp", std::process::id()));
        let temporary = destination.with_file_name(temporary_name);
        let file = File::create(&temporary).with_context(|| {
            format!(
                "{}: cannot create its temporary file {}",
                destination.display(),
                temporary.display()
            )
        })?;
        let mut stream = Self {
            destination: destination.to_path_buf(),
            temporary,
            file: Some(BufWriter::new(file)),
            expected: shape.iter().product(),
            written: 0,
        };
        let bytes = header(shape);
        stream.write_bytes(&bytes)?;
        Ok(stream)
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> Result<()> {
        let file = self.file.as_mut().expect("open until finish");
        file.write_all(bytes)
            .with_context(|| format!("{}: write failed", self.temporary.display()))
    }

    /// Appends values in C order.
    pub fn write(&mut self, values: impl IntoIterator<Item = f64>) -> Result<()> {
        let mut buffer = Vec::with_capacity(8 * 1024);
        for v in values {
            buffer.extend_from_slice(&v.to_le_bytes());
            self.written += 1;
            if buffer.len() >= 8 * 1024 {
                self.write_bytes(&buffer)?;
                buffer.clear();
            }
        }
        self.write_bytes(&buffer)
    }

    /// Checks that every value was written, flushes and renames the file into place.
    pub fn finish(mut self) -> Result<()> {
        if self.written != self.expected {
            bail!(
                "{}: {} values written, the shape needs {}",
                self.destination.display(),
                self.written,
                self.expected
            );
        }
        let file = self.file.take().expect("open until finish");
        let file = file
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("{}: write failed", self.temporary.display()))?;
        file.sync_all()
            .with_context(|| format!("{}: write failed", self.temporary.display()))?;
        std::fs::rename(&self.temporary, &self.destination)
            .with_context(|| format!("{}: cannot rename into place", self.destination.display()))
    }
}

impl Drop for NpyStream {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            // Not finished: leave nothing half-written behind.
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use motion_core::formats::npy::read_npy_dyn;

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
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
