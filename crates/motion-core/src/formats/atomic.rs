//! Writing outputs atomically: the bytes go to a temporary file next to the destination, synced,
//! then renamed over it, so that a failure (disk full, a killed process) never leaves a
//! half-written file, and the temporary file is removed on failure. Every writer of the crates
//! (motion files, pictures, plots) goes through here.
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{FormatError, WriteFailure};

/// Writes `path` with `body` through a temporary file and a rename.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), FormatError> {
    let tmp = temp_path(path);
    let result = (|| {
        let file = File::create(&tmp)?;
        let mut w = BufWriter::new(file);
        body(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        FormatError::Write {
            path: path.to_path_buf(),
            source: WriteFailure(source),
        }
    })
}

/// Writes `bytes` to `path` atomically ([`write_atomically`]).
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), FormatError> {
    write_atomically(path, |w| w.write_all(bytes))
}

/// The temporary file next to `path`: `.NAME.tmpPID`.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing_and_says_write() {
        let dir = std::env::temp_dir().join(format!("motion-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("out.bin");
        write_bytes_atomically(&out, b"first").unwrap();
        let e = write_atomically(&out, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "disk full",
            ))
        })
        .unwrap_err();
        assert!(matches!(e, FormatError::Write { .. }), "{e}");
        assert!(e.to_string().contains("cannot write"), "{e}");
        assert_eq!(std::fs::read(&out).unwrap(), b"first");
        assert!(!temp_path(&out).exists());
        let missing = dir.join("no/such/dir/out.bin");
        assert!(matches!(
            write_bytes_atomically(&missing, b"x"),
            Err(FormatError::Write { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
