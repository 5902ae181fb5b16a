//! Sets of motion files named on a command line: folders expanded to the motion files in them
//! (sorted by name), and two folders paired file by file by name — never by sort order alone,
//! which would pair `a.npy` with `b.npy` silently when one folder lacks a file.
use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::formats::FileFormat;

/// Why a set of files could not be formed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileSetError {
    /// A folder could not be listed.
    #[error("{}: cannot list the folder: {source}", path.display())]
    List {
        /// The folder.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A folder holds no motion file.
    #[error("{}: no .npy, .txt, .txt.gz or .bvh files in the folder", path.display())]
    Empty {
        /// The folder.
        path: PathBuf,
    },
    /// Two folders to be paired by file name do not hold the same names.
    #[error("{}: no file named {} to pair with {}'s (folders are paired by file name)", lacking.display(), name.to_string_lossy(), holding.display())]
    Unpaired {
        /// The folder without the file.
        lacking: PathBuf,
        /// The file name found only in `holding`.
        name: OsString,
        /// The folder with it.
        holding: PathBuf,
    },
}

/// The motion files (by extension: `.npy`, `.txt`, `.txt.gz`, `.bvh`) directly in `dir`, sorted
/// by name; possibly none.
pub fn motion_files_in(dir: &Path) -> Result<Vec<PathBuf>, FileSetError> {
    let entries = std::fs::read_dir(dir).map_err(|source| FileSetError::List {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && FileFormat::from_path(p).is_ok())
        .collect();
    files.sort();
    Ok(files)
}

/// `paths` with every folder replaced by its motion files ([`motion_files_in`]); a folder
/// without any is an error. Files are kept as given.
pub fn expand(paths: &[PathBuf]) -> Result<Vec<PathBuf>, FileSetError> {
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            let inside = motion_files_in(path)?;
            if inside.is_empty() {
                return Err(FileSetError::Empty { path: path.clone() });
            }
            files.extend(inside);
        } else {
            files.push(path.clone());
        }
    }
    Ok(files)
}

/// When `a` and `b` are each one folder, checks that both hold motion files of the same names
/// (then [`expand`] pairs them in the same order); any other shape of arguments is paired by
/// position and passes.
pub fn check_paired_by_name(a: &[PathBuf], b: &[PathBuf]) -> Result<(), FileSetError> {
    let ([a_dir], [b_dir]) = (a, b) else {
        return Ok(());
    };
    if !(a_dir.is_dir() && b_dir.is_dir()) {
        return Ok(());
    }
    let names = |dir: &PathBuf| -> Result<Vec<OsString>, FileSetError> {
        Ok(motion_files_in(dir)?
            .into_iter()
            .filter_map(|p| p.file_name().map(|n| n.to_os_string()))
            .collect())
    };
    let (an, bn) = (names(a_dir)?, names(b_dir)?);
    for (names, lacking_names, holding, lacking) in
        [(&an, &bn, a_dir, b_dir), (&bn, &an, b_dir, a_dir)]
    {
        if let Some(name) = names.iter().find(|n| !lacking_names.contains(n)) {
            return Err(FileSetError::Unpaired {
                lacking: lacking.clone(),
                name: name.clone(),
                holding: holding.clone(),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_expand_sorted_and_pair_only_by_name() {
        let root = std::env::temp_dir().join(format!("motion-file-sets-{}", std::process::id()));
        let (a, b) = (root.join("a"), root.join("b"));
        for d in [&a, &b] {
            std::fs::create_dir_all(d).unwrap();
        }
        for name in ["2.npy", "1.bvh", "notes.md"] {
            std::fs::write(a.join(name), "").unwrap();
        }
        for name in ["1.bvh", "2.npy"] {
            std::fs::write(b.join(name), "").unwrap();
        }
        let files = expand(std::slice::from_ref(&a)).unwrap();
        assert_eq!(files, vec![a.join("1.bvh"), a.join("2.npy")]);
        check_paired_by_name(std::slice::from_ref(&a), std::slice::from_ref(&b)).unwrap();
        std::fs::rename(b.join("2.npy"), b.join("3.npy")).unwrap();
        let e =
            check_paired_by_name(std::slice::from_ref(&a), std::slice::from_ref(&b)).unwrap_err();
        assert!(
            matches!(&e, FileSetError::Unpaired { lacking, name, .. } if lacking == &b && name == "2.npy"),
            "{e}"
        );
        let empty = root.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        assert!(matches!(expand(&[empty]), Err(FileSetError::Empty { .. })));
        assert!(matches!(
            motion_files_in(&root.join("none")),
            Err(FileSetError::List { .. })
        ));
        std::fs::remove_dir_all(&root).unwrap();
    }
}
