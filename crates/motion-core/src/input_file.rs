//! Opening the files users name: regular files only. A device (`/dev/zero`, a symlink to it), a
//! FIFO or a directory given as a motion, weights or joint-map file is refused before a byte is
//! read, instead of being read until memory runs out or blocking forever.
use std::fs::File;
use std::io::{Error, ErrorKind, Read};
use std::path::Path;

use crate::limits::MAX_INPUT_BYTES;

/// Opens `path` (following symlinks) if it is a regular file. The kind is checked before the
/// file is opened (opening a FIFO for reading blocks until a writer comes) and again on the open
/// file.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    check_kind(std::fs::metadata(path)?.file_type())?;
    let file = File::open(path)?;
    check_kind(file.metadata()?.file_type())?;
    Ok(file)
}

fn check_kind(kind: std::fs::FileType) -> std::io::Result<()> {
    if !kind.is_file() {
        let what = if kind.is_dir() {
            "a directory"
        } else {
            "a device, FIFO or socket"
        };
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("not a regular file ({what})"),
        ));
    }
    Ok(())
}

/// Reads all of `path` if it is a regular file ([`open_regular`]) of at most
/// [`MAX_INPUT_BYTES`] bytes (a larger file is refused before it is read; a file that grows
/// while read is cut off at the limit and refused).
pub fn read_regular(path: &Path) -> std::io::Result<Vec<u8>> {
    let file = open_regular(path)?;
    let size = file.metadata()?.len();
    if size > MAX_INPUT_BYTES {
        return Err(too_large(size));
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

fn too_large(size: u64) -> Error {
    Error::new(
        ErrorKind::InvalidData,
        format!(
            "{} MiB is over the {} MiB limit for a file read whole (MAX_INPUT_BYTES)",
            size >> 20,
            MAX_INPUT_BYTES >> 20
        ),
    )
}

/// Reads all of `path` as UTF-8 text if it is a regular file ([`open_regular`]).
pub fn read_regular_text(path: &Path) -> std::io::Result<String> {
    let bytes = read_regular(path)?;
    String::from_utf8(bytes).map_err(|e| Error::new(ErrorKind::InvalidData, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_regular_files_read() {
        for path in ["/dev/zero", "/dev/null", "/"] {
            let e = read_regular(Path::new(path)).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidInput, "{path}: {e}");
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let dir = std::env::temp_dir().join(format!("motion-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a.txt");
        std::fs::write(&file, "x").unwrap();
        assert_eq!(read_regular_text(&file).unwrap(), "x");
        #[cfg(unix)]
        {
            // A FIFO with no writer: refused at once instead of blocking in open().
            let fifo = dir.join("pipe.txt");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                let e = read_regular(&fifo).unwrap_err();
                assert!(e.to_string().contains("FIFO"), "{e}");
            }
            let link = dir.join("zero.bvh");
            std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
            assert_eq!(
                read_regular(&link).unwrap_err().kind(),
                ErrorKind::InvalidInput
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
