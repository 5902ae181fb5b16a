//! Writing outputs atomically: the bytes go to a temporary file next to the destination, synced,
//! then renamed over it, so that a failure (disk full, a killed process) never leaves a
//! half-written file, and the temporary file is removed on failure. Every writer of the crates
//! (motion files, pictures, plots, streamed `.npy`) goes through here.
//!
//! Every temporary file alive is listed in a process-wide registry, so that a signal handler can
//! remove them on SIGINT / SIGTERM ([`remove_live_temp_files`]; `motion-cli` installs one).
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{FormatError, WriteFailure};

/// The temporary files being written now (see the module doc).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A temporary file next to its destination, listed in the registry while it exists: dropped
/// without [`persist`](Self::persist), it is removed.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    destination: PathBuf,
    done: bool,
}

impl TempFile {
    /// Creates `.NAME.tmpPID` next to `destination` ([`temp_path`]) and registers it.
    pub fn create(destination: &Path) -> std::io::Result<(Self, File)> {
        let path = temp_path(destination);
        let mut list = live();
        let file = File::create(&path)?;
        list.push(path.clone());
        Ok((
            Self {
                path,
                destination: destination.to_path_buf(),
                done: false,
            },
            file,
        ))
    }

    /// The temporary file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the temporary file over its destination (after the caller synced it).
    pub fn persist(mut self) -> std::io::Result<()> {
        let result = std::fs::rename(&self.path, &self.destination);
        self.done = result.is_ok();
        result
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let mut list = live();
        if !self.done {
            let _ = std::fs::remove_file(&self.path);
        }
        list.retain(|p| p != &self.path);
    }
}

/// Removes every temporary file being written now and returns how many there were: for a
/// SIGINT / SIGTERM handler, after which the process must exit (the writers' files are gone).
pub fn remove_live_temp_files() -> usize {
    remove_live_temp_files_under(Path::new(""))
}

/// [`remove_live_temp_files`] for the temporary files under `dir` only (every file for "").
fn remove_live_temp_files_under(dir: &Path) -> usize {
    let mut list = live();
    let before = list.len();
    list.retain(|path| {
        let listed = path.starts_with(dir);
        if listed {
            let _ = std::fs::remove_file(path);
        }
        !listed
    });
    before - list.len()
}

/// Writes `path` with `body` through a temporary file and a rename.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), FormatError> {
    let result = (|| {
        let (tmp, file) = TempFile::create(path)?;
        let mut w = BufWriter::new(file);
        body(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        tmp.persist()
    })();
    result.map_err(|source| FormatError::Write {
        path: path.to_path_buf(),
        source: WriteFailure(source),
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

    #[test]
    fn live_temp_files_are_listed_until_done_and_removed_on_request() {
        let dir = std::env::temp_dir().join(format!("motion-atomic-live-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, _fa) = TempFile::create(&dir.join("a.bin")).unwrap();
        let (b, _fb) = TempFile::create(&dir.join("b.bin")).unwrap();
        let (pa, pb) = (a.path().to_path_buf(), b.path().to_path_buf());
        assert!(live().contains(&pa) && live().contains(&pb));
        b.persist().unwrap();
        assert!(dir.join("b.bin").exists() && !live().contains(&pb));
        // what a signal handler does (here limited to this test's folder: other tests write
        // files at the same time): the unfinished file goes, the registry forgets it
        assert_eq!(remove_live_temp_files_under(&dir), 1);
        assert!(!pa.exists() && !live().contains(&pa));
        drop(a); // dropping after removal is harmless
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
