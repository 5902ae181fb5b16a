//! The BVH writer: the standard layout (tab indentation up to [`MAX_INDENT`] levels, one frame
//! per line) with numbers in Rust's shortest round-trip representation, so that reading back
//! gives the same `f64`s. Output size is linear in joints and frames.
use std::fmt::Write as _;
use std::io::{self, Write};

use crate::skeleton::Skeleton;

use super::Bvh;

/// Writes `bvh` in BVH text form.
///
/// Fails with [`io::ErrorKind::InvalidInput`] if the frames do not have one column per channel of
/// the skeleton, if a value is not finite or if the frame time is not positive.
pub fn write_to<W: Write>(out: W, bvh: &Bvh) -> io::Result<()> {
    let skeleton = &bvh.skeleton;
    let channels = skeleton.channel_count();
    if bvh.frames.ncols() != channels {
        return Err(invalid(format!(
            "frames have {} columns but the skeleton has {channels} channels",
            bvh.frames.ncols()
        )));
    }
    if !(bvh.frame_time.is_finite() && bvh.frame_time > 0.0) {
        return Err(invalid(format!(
            "frame time must be positive, got {}",
            bvh.frame_time
        )));
    }
    if let Some(joint) = skeleton
        .joints()
        .iter()
        .find(|j| !is_writable_name(&j.name))
    {
        return Err(invalid(format!(
            "joint name {:?} cannot be written to BVH (empty, or with braces or line breaks)",
            joint.name
        )));
    }
    if bvh.frames.iter().any(|v| !v.is_finite()) {
        return Err(invalid("frames contain a non-finite value".to_string()));
    }
    let mut out = io::BufWriter::new(out);
    write_hierarchy(&mut out, skeleton)?;
    writeln!(out, "MOTION")?;
    writeln!(out, "Frames: {}", bvh.frames.nrows())?;
    writeln!(out, "Frame Time: {}", bvh.frame_time)?;
    let mut line = String::new();
    for frame in bvh.frames.rows() {
        line.clear();
        for (k, &value) in frame.iter().enumerate() {
            if k > 0 {
                line.push(' ');
            }
            // Writing to a String cannot fail.
            let _ = write!(line, "{value}");
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    out.flush()
}

/// A name that reads back as itself: not empty, no braces, no line breaks, no outer spaces.
fn is_writable_name(name: &str) -> bool {
    !name.is_empty()
        && name.trim() == name
        && !name.contains(['{', '}', '\n', '\r'])
        && name.split_whitespace().collect::<Vec<_>>().join(" ") == name
}

fn invalid(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

/// `HIERARCHY` and the joint tree, depth first, without recursion (a parsed file may nest deeply).
fn write_hierarchy<W: Write>(out: &mut W, skeleton: &Skeleton) -> io::Result<()> {
    writeln!(out, "HIERARCHY")?;
    // Each entry: a joint and how many of its children have been written.
    let mut stack: Vec<(usize, usize)> = Vec::new();
    open_joint(out, skeleton, 0, 0)?;
    stack.push((0, 0));
    while let Some(&(joint, next)) = stack.last() {
        let depth = stack.len();
        if let Some(&child) = skeleton.children(joint).get(next) {
            if let Some(top) = stack.last_mut() {
                top.1 += 1;
            }
            if skeleton.joint(child).is_end_site {
                write_end_site(out, skeleton, child, depth)?;
            } else {
                open_joint(out, skeleton, child, depth)?;
                stack.push((child, 0));
            }
        } else {
            stack.pop();
            writeln!(out, "{}}}", indent(depth - 1))?;
        }
    }
    Ok(())
}

/// Deepest indentation written: past it every line gets this many tabs, so the hierarchy's size
/// stays linear in the joint count (a 100,000-deep chain would otherwise take 5 * 10^9 tabs).
/// Readers ignore indentation.
pub const MAX_INDENT: usize = 32;

fn indent(depth: usize) -> &'static str {
    const TABS: &str = "\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t\t";
    &TABS[..depth.min(MAX_INDENT)]
}

fn open_joint<W: Write>(
    out: &mut W,
    skeleton: &Skeleton,
    j: usize,
    depth: usize,
) -> io::Result<()> {
    let joint = skeleton.joint(j);
    let tabs = indent(depth);
    let keyword = if joint.parent.is_none() {
        "ROOT"
    } else {
        "JOINT"
    };
    writeln!(out, "{tabs}{keyword} {}", joint.name)?;
    writeln!(out, "{tabs}{{")?;
    write_offset(out, &joint.offset, depth + 1)?;
    write!(out, "{tabs}\tCHANNELS {}", joint.channels.len())?;
    for channel in &joint.channels {
        write!(out, " {}", channel.bvh_name())?;
    }
    writeln!(out)
}

fn write_end_site<W: Write>(
    out: &mut W,
    skeleton: &Skeleton,
    j: usize,
    depth: usize,
) -> io::Result<()> {
    let tabs = indent(depth);
    writeln!(out, "{tabs}End Site")?;
    writeln!(out, "{tabs}{{")?;
    write_offset(out, &skeleton.joint(j).offset, depth + 1)?;
    writeln!(out, "{tabs}}}")
}

fn write_offset<W: Write>(out: &mut W, offset: &[f64; 3], depth: usize) -> io::Result<()> {
    writeln!(
        out,
        "{}OFFSET {} {} {}",
        indent(depth),
        offset[0],
        offset[1],
        offset[2]
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::bvh::parse_bvh;

    /// A chain of `n` joints, each the child of the one before, one frame of zeros.
    fn chain(n: usize) -> String {
        let mut text = String::from("HIERARCHY\n");
        for k in 0..n {
            let keyword = if k == 0 { "ROOT" } else { "JOINT" };
            text.push_str(&format!(
                "{keyword} j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
            ));
        }
        text.push_str("End Site\n{\nOFFSET 0 1 0\n}\n");
        text.push_str(&"}\n".repeat(n));
        text.push_str(&format!(
            "MOTION\nFrames: 1\nFrame Time: 0.04\n{}\n",
            vec!["0"; 3 * n].join(" ")
        ));
        text
    }

    #[test]
    fn a_deep_hierarchy_is_written_in_linear_size_and_reads_back() {
        assert_eq!(indent(MAX_INDENT + 5).len(), MAX_INDENT);
        assert_eq!(indent(3), "\t\t\t");
        let n = 20_000;
        let bvh = parse_bvh(&chain(n), "deep.bvh").unwrap();
        let mut written = Vec::new();
        write_to(&mut written, &bvh).unwrap();
        // ~240 bytes a joint (at most 32 tabs on its 4 lines); quadratic indentation would be
        // about n^2 / 2 * 4 lines = 8 * 10^8 bytes
        assert!(
            written.len() < 400 * n,
            "{} bytes for {n} joints",
            written.len()
        );
        let back = parse_bvh(std::str::from_utf8(&written).unwrap(), "back.bvh").unwrap();
        assert_eq!(back.skeleton.joints().len(), bvh.skeleton.joints().len());
        assert_eq!(back.frames, bvh.frames);
    }
}
