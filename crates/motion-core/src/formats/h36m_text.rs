//! H3.6M / CMU exp-map text: one frame per line, comma-separated floats, any column count
//! (99 for H3.6M, 117 for CMU), plain (`.txt`) or gzip (`.txt.gz`); plus the protocol's 25 Hz
//! downsampling.
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;

use ndarray::{Array2, ArrayView2, Axis};

use crate::error::FormatError;
use crate::formats::atomic::write_atomically;

/// True if the path ends in `.gz` (case-insensitive).
fn is_gzip(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

fn io_error(path: &Path, source: std::io::Error) -> FormatError {
    FormatError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The most text (decompressed) one exp-map file may hold: 256 MiB (the H3.6M files are a
/// few MiB).
pub const MAX_TEXT_BYTES: u64 = 256 << 20;
/// The longest line: 1 MiB (a frame of 99 values is about 2 KiB).
pub const MAX_LINE_BYTES: u64 = 1 << 20;
/// The most values one file may give (512 MiB of f64).
pub const MAX_VALUES: usize = 1 << 26;

/// A field as an error shows it: at most 24 characters (a long run of digits cut short).
fn shown(field: &str) -> String {
    match field.char_indices().nth(24) {
        Some((cut, _)) => format!("{}...", &field[..cut]),
        None => field.to_string(),
    }
}

/// The largest magnitude a value may have (radians or millimetres): beyond it the forward
/// kinematics of the frame overflows or means nothing.
pub const MAX_MAGNITUDE: f64 = 1e9;

/// Reads an exp-map text file (`.txt` or `.txt.gz`) into `frames x columns`.
///
/// Errors: missing/unreadable file ([`FormatError::Io`]); a non-number, NaN/infinite value or a
/// value beyond [`MAX_MAGNITUDE`], a row whose column count differs from the first row
/// ([`FormatError::Parse`] with the 1-based
/// line); no frames at all ([`FormatError::Invalid`]). Blank lines (e.g. a trailing newline) and
/// surrounding whitespace are ignored.
pub fn read_expmap_text(path: impl AsRef<Path>) -> Result<Array2<f64>, FormatError> {
    let path = path.as_ref();
    let file = crate::input_file::open_regular(path).map_err(|e| io_error(path, e))?;
    let reader: Box<dyn Read> = if is_gzip(path) {
        Box::new(flate2::read::MultiGzDecoder::new(file))
    } else {
        Box::new(file)
    };
    parse_expmap_text(BufReader::new(reader), path)
}

/// Parses exp-map text from any reader; `path` only names the source in errors.
pub fn parse_expmap_text(reader: impl BufRead, path: &Path) -> Result<Array2<f64>, FormatError> {
    let mut values: Vec<f64> = Vec::new();
    let mut columns: Option<(usize, usize)> = None; // (count, line where it was set)
    let mut rows = 0usize;
    let parse_err = |line: usize, problem: String| FormatError::Parse {
        path: path.to_path_buf(),
        line,
        problem,
    };
    // Bounded before it is read: the whole text (a gzip bomb expands without end) and each line.
    let mut reader = reader.take(MAX_TEXT_BYTES + 1);
    let mut bytes = Vec::new();
    let mut line_no = 0usize;
    loop {
        bytes.clear();
        let read = (&mut reader)
            .take(MAX_LINE_BYTES + 1)
            .read_until(b'\n', &mut bytes)
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::InvalidData => {
                    parse_err(line_no + 1, format!("not a valid gzip stream ({e})"))
                }
                _ => io_error(path, e),
            })?;
        if read == 0 {
            break;
        }
        line_no += 1;
        if reader.limit() == 0 {
            return Err(FormatError::Invalid {
                path: path.to_path_buf(),
                problem: format!(
                    "more than {} MiB of text (decompressed): over the limit of this reader; split the file",
                    MAX_TEXT_BYTES >> 20
                ),
            });
        }
        if bytes.len() as u64 > MAX_LINE_BYTES {
            return Err(parse_err(
                line_no,
                format!(
                    "a line longer than {} KiB (a frame is a few KiB): not exp-map text",
                    MAX_LINE_BYTES >> 10
                ),
            ));
        }
        let line = std::str::from_utf8(&bytes)
            .map_err(|_| parse_err(line_no, "not UTF-8 text".to_string()))?;
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if values.len() >= MAX_VALUES {
            return Err(FormatError::Invalid {
                path: path.to_path_buf(),
                problem: format!(
                    "more than {MAX_VALUES} values: over the limit of this reader; split the file"
                ),
            });
        }
        let mut count = 0usize;
        for (col, field) in trimmed.split(',').enumerate() {
            let field = field.trim();
            let v: f64 = field.parse().map_err(|_| {
                parse_err(
                    line_no,
                    format!(
                        "column {}: expected a number, found {:?}",
                        col + 1,
                        shown(field)
                    ),
                )
            })?;
            if !v.is_finite() {
                return Err(parse_err(
                    line_no,
                    format!(
                        "column {}: expected a finite number, found {}",
                        col + 1,
                        crate::motion::compact_number(v)
                    ),
                ));
            }
            if v.abs() > MAX_MAGNITUDE {
                return Err(parse_err(
                    line_no,
                    format!(
                        "column {}: {} is out of range (an exp-map angle in radians or a position in millimetres is at most {} in magnitude)",
                        col + 1,
                        crate::motion::compact_number(v),
                        crate::motion::compact_number(MAX_MAGNITUDE)
                    ),
                ));
            }
            values.push(v);
            count += 1;
        }
        match columns {
            None => columns = Some((count, line_no)),
            Some((expected, first_line)) if expected != count => {
                return Err(parse_err(
                    line_no,
                    format!(
                        "expected {expected} comma-separated values (as on line {first_line}), found {count}"
                    ),
                ))
            }
            Some(_) => {}
        }
        rows += 1;
    }
    let Some((cols, _)) = columns else {
        return Err(FormatError::Invalid {
            path: path.to_path_buf(),
            problem: "no frames (the file is empty)".to_string(),
        });
    };
    Array2::from_shape_vec((rows, cols), values).map_err(|e| FormatError::Invalid {
        path: path.to_path_buf(),
        problem: format!("inconsistent shape: {e}"),
    })
}

/// Writes frames as exp-map text (`.txt`, or gzip if the path ends in `.gz`), one frame per line,
/// comma-separated, with Rust's shortest round-trip representation of every `f64`.
///
/// The file is written to a temporary file in the same directory and renamed into place, so a
/// failure never leaves a half-written output.
pub fn write_expmap_text(
    path: impl AsRef<Path>,
    frames: ArrayView2<f64>,
) -> Result<(), FormatError> {
    let path = path.as_ref();
    write_atomically(path, |w| {
        if is_gzip(path) {
            let mut gz = flate2::write::GzEncoder::new(w, flate2::Compression::default());
            format_expmap_text(&mut gz, frames)?;
            gz.finish()?.flush()
        } else {
            format_expmap_text(&mut *w, frames)?;
            w.flush()
        }
    })
}

/// Formats frames as exp-map text into any writer (shortest round-trip `f64` representation).
pub fn format_expmap_text(mut w: impl Write, frames: ArrayView2<f64>) -> std::io::Result<()> {
    for row in frames.axis_iter(Axis(0)) {
        for (k, v) in row.iter().enumerate() {
            if k > 0 {
                w.write_all(b",")?;
            }
            write!(w, "{v:?}")?;
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

/// The protocol's downsampling of 50 Hz frames to 25 Hz: keeps frames 0, 2, 4, ...
pub fn downsample_protocol(frames: ArrayView2<f64>) -> Array2<f64> {
    frames.slice(ndarray::s![..;2, ..]).to_owned()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use ndarray::Array2;
    use std::path::PathBuf;

    /// A scratch directory removed on drop.
    pub(crate) struct Scratch(pub PathBuf);

    impl Scratch {
        pub(crate) fn new(tag: &str) -> Scratch {
            let dir = std::env::temp_dir().join(format!(
                "motion-core-{tag}-{}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ));
            std::fs::create_dir_all(&dir).unwrap();
            Scratch(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn sample(frames: usize, cols: usize) -> Array2<f64> {
        Array2::from_shape_fn((frames, cols), |(t, k)| {
            ((t * 31 + k * 7) as f64 * 0.1234567).sin() * 10f64.powi((k % 5) as i32 - 2)
        })
    }

    fn parse(text: &str) -> Result<Array2<f64>, FormatError> {
        parse_expmap_text(text.as_bytes(), Path::new("clip.txt"))
    }

    #[test]
    fn text_and_gzip_round_trip_bit_exactly() {
        let dir = Scratch::new("text");
        for (name, cols) in [("a.txt", 99), ("b.txt.gz", 117), ("c.txt", 1)] {
            let x = sample(13, cols);
            let path = dir.0.join(name);
            write_expmap_text(&path, x.view()).unwrap();
            let y = read_expmap_text(&path).unwrap();
            assert_eq!(x, y, "{name}");
        }
        // The gzip file really is gzip.
        let bytes = std::fs::read(dir.0.join("b.txt.gz")).unwrap();
        assert_eq!(&bytes[..2], &[0x1f, 0x8b]);
        // No temporary files are left behind.
        assert_eq!(std::fs::read_dir(&dir.0).unwrap().count(), 3);
    }

    #[test]
    fn tolerant_of_spacing_crlf_and_blank_lines() {
        let x = parse("1, 2,3\r\n\n  -4.5e-3,5,6  \n\n").unwrap();
        assert_eq!(x, ndarray::array![[1.0, 2.0, 3.0], [-4.5e-3, 5.0, 6.0]]);
    }

    #[test]
    fn errors_name_file_line_and_problem() {
        let msg = |e: FormatError| e.to_string();
        let e = parse("1,2,3\n4,5\n").unwrap_err();
        assert!(matches!(e, FormatError::Parse { line: 2, .. }));
        assert!(msg(e).contains("clip.txt:2: expected 3 comma-separated values"));
        let e = parse("1,2,3\n4,x,6\n").unwrap_err();
        assert!(msg(e).contains("clip.txt:2: column 2: expected a number, found \"x\""));
        let e = parse("\n1,nan,3\n").unwrap_err();
        assert!(matches!(e, FormatError::Parse { line: 2, .. }));
        let e = parse("1,inf,3\n").unwrap_err();
        assert!(msg(e).contains("finite"));
        let e = parse("1,,3\n").unwrap_err();
        assert!(matches!(e, FormatError::Parse { line: 1, .. }));
        let e = parse("\n \n").unwrap_err();
        assert!(matches!(e, FormatError::Invalid { .. }));
        assert!(msg(e).contains("empty"));
    }

    #[test]
    fn missing_and_corrupt_files_are_clear_errors() {
        let dir = Scratch::new("missing");
        let e = read_expmap_text(dir.0.join("nope.txt.gz")).unwrap_err();
        assert!(matches!(e, FormatError::Io { .. }));
        assert!(e.to_string().contains("nope.txt.gz"));
        let bad = dir.0.join("bad.txt.gz");
        std::fs::write(&bad, b"this is not gzip").unwrap();
        let e = read_expmap_text(&bad).unwrap_err();
        assert!(e.to_string().contains("bad.txt.gz"), "{e}");
        let binary = dir.0.join("bin.txt");
        std::fs::write(&binary, [0xff, 0xfe, 0x00, 0x31]).unwrap();
        assert!(read_expmap_text(&binary).is_err());
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = Scratch::new("failwrite");
        let path = dir.0.join("no_such_dir").join("x.txt");
        assert!(write_expmap_text(&path, sample(2, 3).view()).is_err());
        assert!(!path.exists());
    }

    #[test]
    fn downsampling_keeps_even_frames() {
        let x = Array2::from_shape_fn((7, 2), |(t, k)| (10 * t + k) as f64);
        let y = downsample_protocol(x.view());
        assert_eq!(y.nrows(), 4);
        for (i, t) in [0, 2, 4, 6].into_iter().enumerate() {
            assert_eq!(y.row(i), x.row(t));
        }
        assert_eq!(
            downsample_protocol(x.slice(ndarray::s![..6, ..])).nrows(),
            3
        );
    }

    /// An endless stream of one byte pattern.
    struct Endless(&'static [u8], usize);

    impl std::io::Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            for b in buf.iter_mut() {
                *b = self.0[self.1 % self.0.len()];
                self.1 += 1;
            }
            Ok(buf.len())
        }
    }

    #[test]
    fn endless_text_is_cut_at_the_limits_not_read_until_memory_runs_out() {
        let path = Path::new("bomb.txt.gz");
        let read = |pattern: &'static [u8]| {
            parse_expmap_text(BufReader::new(Endless(pattern, 0)), path)
                .unwrap_err()
                .to_string()
        };
        // One line without end.
        let e = read(b"0.1,");
        assert!(
            e.contains("bomb.txt.gz:1") && e.contains("line longer"),
            "{e}"
        );
        // Blank lines without end: the whole text's limit.
        let e = read(b"\n");
        assert!(e.contains("MiB of text"), "{e}");
        // Values without end: the values' limit.
        let e = read(b"0\n");
        assert!(e.contains("values"), "{e}");
    }
}
