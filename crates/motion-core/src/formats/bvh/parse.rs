//! The BVH reader: a hand-written, non-recursive parser that never panics on bad input.
//!
//! Tokens are separated by any whitespace (spaces, tabs, `\r` of CRLF files); `{` and `}` are
//! tokens of their own even when glued to a word. The MOTION section is read line by line: one
//! frame per non-blank line. Nothing is allocated from a number read in the file (`Frames:` or
//! `CHANNELS`) without first bounding it by the size of the file.
use std::collections::HashMap;
use std::path::Path;

use ndarray::Array2;

use crate::error::FormatError;
use crate::limits::MAX_CLIP_VALUES;
use crate::skeleton::{Channel, Joint, Skeleton};

use super::Bvh;

/// At most this many channels per joint (3 positions + 3 rotations).
const MAX_CHANNELS_PER_JOINT: usize = 6;

/// Parses BVH text; `path` is only used in error messages.
pub(super) fn parse(text: &str, path: &Path) -> Result<Bvh, FormatError> {
    let mut cursor = Cursor::new(text, path);
    cursor.expect_keyword("HIERARCHY")?;
    let joints = parse_hierarchy(&mut cursor)?;
    let channel_count: usize = joints.iter().map(|j| j.channels.len()).sum();
    if channel_count == 0 {
        return Err(cursor.error_here("the hierarchy has no CHANNELS at all: nothing to animate"));
    }
    let (frames, frame_time) = parse_motion(&mut cursor, channel_count)?;
    let skeleton = Skeleton::new(joints).map_err(|e| FormatError::Invalid {
        path: path.to_path_buf(),
        problem: format!("invalid BVH hierarchy: {e}"),
    })?;
    Ok(Bvh {
        skeleton,
        frames,
        frame_time,
    })
}

/// A token and its 1-based line.
#[derive(Debug, Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    line: usize,
}

/// Walks the text token by token (hierarchy) or line by line (motion).
struct Cursor<'a> {
    path: &'a Path,
    lines: std::iter::Enumerate<std::str::Split<'a, char>>,
    /// The unread rest of the current line.
    rest: &'a str,
    /// 1-based number of the current line (0 before the first).
    line: usize,
    /// Length of the whole text, which bounds every allocation.
    text_len: usize,
}

impl<'a> Cursor<'a> {
    fn new(text: &'a str, path: &'a Path) -> Self {
        // A UTF-8 byte order mark is not part of the first keyword.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Cursor {
            path,
            lines: text.split('\n').enumerate(),
            rest: "",
            line: 0,
            text_len: text.len(),
        }
    }

    fn error(&self, line: usize, problem: impl Into<String>) -> FormatError {
        FormatError::Parse {
            path: self.path.to_path_buf(),
            line: line.max(1),
            problem: problem.into(),
        }
    }

    fn error_here(&self, problem: impl Into<String>) -> FormatError {
        self.error(self.line, problem)
    }

    /// Moves to the next line; false at the end of the text.
    fn advance_line(&mut self) -> bool {
        match self.lines.next() {
            Some((index, line)) => {
                self.line = index + 1;
                self.rest = line;
                true
            }
            None => false,
        }
    }

    /// The next token, or `None` at the end of the text.
    fn next(&mut self) -> Option<Token<'a>> {
        loop {
            let trimmed = self.rest.trim_start();
            if trimmed.is_empty() {
                if !self.advance_line() {
                    self.rest = "";
                    return None;
                }
                continue;
            }
            let end = if trimmed.starts_with(['{', '}']) {
                1
            } else {
                trimmed
                    .find(|c: char| c.is_whitespace() || c == '{' || c == '}')
                    .unwrap_or(trimmed.len())
            };
            let (text, rest) = trimmed.split_at(end);
            self.rest = rest;
            return Some(Token {
                text,
                line: self.line,
            });
        }
    }

    /// The next token, or an "unexpected end of file" error saying what was `expected`.
    fn require(&mut self, expected: &str) -> Result<Token<'a>, FormatError> {
        match self.next() {
            Some(token) => Ok(token),
            None => Err(self.error_here(format!("unexpected end of file: expected {expected}"))),
        }
    }

    fn expect_keyword(&mut self, keyword: &str) -> Result<Token<'a>, FormatError> {
        let token = self.require(keyword)?;
        if token.text.eq_ignore_ascii_case(keyword) {
            Ok(token)
        } else {
            Err(self.error(
                token.line,
                format!("expected {keyword}, found {:?}", shorten(token.text)),
            ))
        }
    }

    /// The rest of the current line (after the tokens read so far), trimmed; empties it.
    fn take_rest_of_line(&mut self) -> &'a str {
        let rest = self.rest.trim();
        self.rest = "";
        rest
    }

    /// Errors unless the current line has nothing left after the tokens read.
    fn expect_line_end(&mut self, after: &str) -> Result<(), FormatError> {
        let rest = self.take_rest_of_line();
        if rest.is_empty() {
            Ok(())
        } else {
            Err(self.error_here(format!(
                "expected the end of the line after {after}, found {:?}",
                shorten(rest)
            )))
        }
    }

    /// The next line that is not blank, with its 1-based number.
    fn next_nonblank_line(&mut self) -> Option<(usize, &'a str)> {
        loop {
            if !self.advance_line() {
                return None;
            }
            if !self.rest.trim().is_empty() {
                let line = self.rest;
                self.rest = "";
                return Some((self.line, line));
            }
        }
    }
}

/// A joint whose block is open: its index and the line of its keyword.
struct Open {
    joint: usize,
    line: usize,
}

/// Parses `ROOT ... }` into joints in depth-first order (parents before children).
fn parse_hierarchy(cursor: &mut Cursor<'_>) -> Result<Vec<Joint>, FormatError> {
    let mut joints: Vec<Joint> = Vec::new();
    let mut names: HashMap<String, usize> = HashMap::new();
    let mut stack: Vec<Open> = Vec::new();

    let root = cursor.expect_keyword("ROOT")?;
    let name = joint_name(cursor, "ROOT")?;
    open_joint(cursor, &mut joints, &mut names, name, None, root.line)?;
    stack.push(Open {
        joint: 0,
        line: root.line,
    });

    while let Some(top) = stack.last() {
        let parent = top.joint;
        let opened = top.line;
        let closing = || {
            format!(
                "JOINT, End Site or '}}' closing joint {:?} (opened at line {opened})",
                joints[parent].name
            )
        };
        let Some(token) = cursor.next() else {
            return Err(
                cursor.error_here(format!("unexpected end of file: expected {}", closing()))
            );
        };
        if token.text == "}" {
            stack.pop();
        } else if token.text.eq_ignore_ascii_case("JOINT") {
            let name = joint_name(cursor, "JOINT")?;
            let index = open_joint(
                cursor,
                &mut joints,
                &mut names,
                name,
                Some(parent),
                token.line,
            )?;
            stack.push(Open {
                joint: index,
                line: token.line,
            });
        } else if token.text.eq_ignore_ascii_case("End") {
            let site = cursor.require("Site after End")?;
            if !site.text.eq_ignore_ascii_case("Site") {
                return Err(cursor.error(
                    site.line,
                    format!("expected Site after End, found {:?}", shorten(site.text)),
                ));
            }
            // Some exporters name their end sites; such a name carries no information.
            if cursor.take_rest_of_line().ends_with('{') {
                cursor.rest = "{";
            }
            parse_end_site(cursor, &mut joints, &mut names, parent, token.line)?;
        } else {
            return Err(cursor.error(
                token.line,
                format!("expected {}, found {:?}", closing(), shorten(token.text)),
            ));
        }
    }
    Ok(joints)
}

/// The name after ROOT/JOINT: the rest of the line (a trailing `{` is left for the caller).
fn joint_name(cursor: &mut Cursor<'_>, keyword: &str) -> Result<String, FormatError> {
    let line = cursor.line;
    let rest = cursor.rest.trim();
    let (name, brace) = match rest.strip_suffix('{') {
        Some(name) => (name.trim_end(), true),
        None => (rest, false),
    };
    if name.is_empty() {
        return Err(cursor.error(line, format!("expected a joint name after {keyword}")));
    }
    if name.contains(['{', '}']) {
        return Err(cursor.error(
            line,
            format!(
                "expected a joint name after {keyword}, found {:?}",
                shorten(name)
            ),
        ));
    }
    // Names with inner runs of whitespace are normalised to single spaces.
    let name = name.split_whitespace().collect::<Vec<_>>().join(" ");
    cursor.rest = if brace { "{" } else { "" };
    Ok(name)
}

/// Reads `{ OFFSET x y z CHANNELS n ...` of a ROOT/JOINT and appends the joint.
fn open_joint(
    cursor: &mut Cursor<'_>,
    joints: &mut Vec<Joint>,
    names: &mut HashMap<String, usize>,
    name: String,
    parent: Option<usize>,
    line: usize,
) -> Result<usize, FormatError> {
    if let Some(first) = names.get(&name) {
        return Err(cursor.error(
            line,
            format!("joint name {name:?} is used twice (first at line {first})"),
        ));
    }
    let what = format!("joint {name:?}");
    expect_open_brace(cursor, &what)?;
    let offset = parse_offset(cursor, &what)?;
    let channels = parse_channels(cursor, &what)?;
    names.insert(name.clone(), line);
    joints.push(Joint {
        name,
        parent,
        offset,
        channels,
        is_end_site: false,
    });
    Ok(joints.len() - 1)
}

/// Reads `{ OFFSET x y z }` of an End Site and appends it as a joint without channels.
fn parse_end_site(
    cursor: &mut Cursor<'_>,
    joints: &mut Vec<Joint>,
    names: &mut HashMap<String, usize>,
    parent: usize,
    line: usize,
) -> Result<(), FormatError> {
    let what = format!("the End Site of {:?}", joints[parent].name);
    expect_open_brace(cursor, &what)?;
    let offset = parse_offset(cursor, &what)?;
    let close = cursor.require(&format!("'}}' closing {what}"))?;
    if close.text != "}" {
        return Err(cursor.error(
            close.line,
            format!(
                "expected '}}' closing {what} (an End Site has only an OFFSET), found {:?}",
                shorten(close.text)
            ),
        ));
    }
    let name = end_site_name(&joints[parent].name, names);
    names.insert(name.clone(), line);
    joints.push(Joint {
        name,
        parent: Some(parent),
        offset,
        channels: Vec::new(),
        is_end_site: true,
    });
    Ok(())
}

/// `<parent>_End`, made unique with a number if needed (End Sites have no name in BVH).
fn end_site_name(parent: &str, names: &HashMap<String, usize>) -> String {
    let base = format!("{parent}_End");
    if !names.contains_key(&base) {
        return base;
    }
    (2..)
        .map(|k| format!("{base}{k}"))
        .find(|n| !names.contains_key(n))
        .unwrap_or(base)
}

fn expect_open_brace(cursor: &mut Cursor<'_>, what: &str) -> Result<(), FormatError> {
    let token = cursor.require(&format!("'{{' opening {what}"))?;
    if token.text == "{" {
        Ok(())
    } else {
        Err(cursor.error(
            token.line,
            format!(
                "expected '{{' opening {what}, found {:?}",
                shorten(token.text)
            ),
        ))
    }
}

fn parse_offset(cursor: &mut Cursor<'_>, what: &str) -> Result<[f64; 3], FormatError> {
    let token = cursor.require(&format!("OFFSET of {what}"))?;
    if !token.text.eq_ignore_ascii_case("OFFSET") {
        return Err(cursor.error(
            token.line,
            format!("expected OFFSET of {what}, found {:?}", shorten(token.text)),
        ));
    }
    let mut offset = [0.0; 3];
    for (axis, value) in ["x", "y", "z"].iter().zip(offset.iter_mut()) {
        let expected = format!("the OFFSET {axis} of {what}");
        let token = cursor.require(&expected)?;
        *value = parse_number(token.text)
            .ok_or_else(|| cursor.error(token.line, not_a_number(&expected, token.text)))?;
    }
    Ok(offset)
}

fn parse_channels(cursor: &mut Cursor<'_>, what: &str) -> Result<Vec<Channel>, FormatError> {
    let token = cursor.require(&format!("CHANNELS of {what}"))?;
    if !token.text.eq_ignore_ascii_case("CHANNELS") {
        return Err(cursor.error(
            token.line,
            format!(
                "expected CHANNELS of {what} after its OFFSET, found {:?}",
                shorten(token.text)
            ),
        ));
    }
    let expected = format!("the channel count of {what} (0 to {MAX_CHANNELS_PER_JOINT})");
    let count_token = cursor.require(&expected)?;
    let count = count_token
        .text
        .parse::<usize>()
        .ok()
        .filter(|&n| n <= MAX_CHANNELS_PER_JOINT)
        .ok_or_else(|| {
            cursor.error(
                count_token.line,
                format!("expected {expected}, found {:?}", shorten(count_token.text)),
            )
        })?;
    let mut channels = Vec::with_capacity(count);
    for _ in 0..count {
        let expected = format!(
            "a channel name of {what} (Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation)"
        );
        let token = cursor.require(&expected)?;
        let channel = channel_from_name(token.text).ok_or_else(|| {
            cursor.error(
                token.line,
                format!("expected {expected}, found {:?}", shorten(token.text)),
            )
        })?;
        if channels.contains(&channel) {
            return Err(cursor.error(
                token.line,
                format!("{what} lists channel {} twice", token.text),
            ));
        }
        channels.push(channel);
    }
    Ok(channels)
}

/// A BVH channel name, case-insensitively.
pub(super) fn channel_from_name(name: &str) -> Option<Channel> {
    const NAMES: [(&str, Channel); 6] = [
        ("Xposition", Channel::Xposition),
        ("Yposition", Channel::Yposition),
        ("Zposition", Channel::Zposition),
        ("Xrotation", Channel::Xrotation),
        ("Yrotation", Channel::Yrotation),
        ("Zrotation", Channel::Zrotation),
    ];
    NAMES
        .iter()
        .find(|(n, _)| n.eq_ignore_ascii_case(name))
        .map(|&(_, c)| c)
}

/// Parses `MOTION`, `Frames:`, `Frame Time:` and the frame lines.
fn parse_motion(
    cursor: &mut Cursor<'_>,
    channel_count: usize,
) -> Result<(Array2<f64>, f64), FormatError> {
    match cursor.next() {
        None => {
            return Err(
                cursor.error_here("unexpected end of file: expected MOTION after the hierarchy")
            )
        }
        Some(t) if t.text.eq_ignore_ascii_case("MOTION") => {}
        Some(t) if t.text.eq_ignore_ascii_case("ROOT") => {
            return Err(cursor.error(
                t.line,
                "a second ROOT: only files with one skeleton are supported",
            ))
        }
        Some(t) => {
            return Err(cursor.error(
                t.line,
                format!(
                    "expected MOTION after the hierarchy (is there one '}}' too many?), found {:?}",
                    shorten(t.text)
                ),
            ))
        }
    }
    cursor.expect_line_end("MOTION")?;

    let (frames_line, text) = cursor
        .next_nonblank_line()
        .ok_or_else(|| cursor.error_here("unexpected end of file: expected 'Frames: <count>'"))?;
    let declared = labelled_value(text, "frames")
        .and_then(|v| v.parse::<usize>().ok())
        .ok_or_else(|| {
            cursor.error(
                frames_line,
                format!(
                    "expected 'Frames: <count>', found {:?}",
                    shorten(text.trim())
                ),
            )
        })?;

    let (time_line, text) = cursor.next_nonblank_line().ok_or_else(|| {
        cursor.error_here("unexpected end of file: expected 'Frame Time: <seconds>'")
    })?;
    let frame_time = labelled_value(text, "frame time")
        .and_then(parse_number)
        .filter(|&t| t > 0.0)
        .ok_or_else(|| {
            cursor.error(
                time_line,
                format!(
                    "expected 'Frame Time: <seconds>' with a positive number, found {:?}",
                    shorten(text.trim())
                ),
            )
        })?;

    // Each number takes at least two bytes (a digit and a separator), so the size of the text
    // bounds what can be stored, whatever `Frames:` claims.
    let remaining_bytes = cursor.text_len;
    let mut values: Vec<f64> = Vec::with_capacity(
        declared
            .saturating_mul(channel_count)
            .min(remaining_bytes / 2 + channel_count)
            .min(MAX_CLIP_VALUES),
    );
    let mut found = 0usize;
    let mut last_line = time_line;
    while let Some((line_no, line)) = cursor.next_nonblank_line() {
        last_line = line_no;
        let start = values.len();
        for (column, token) in line.split_whitespace().enumerate() {
            if column >= channel_count {
                let n = line.split_whitespace().count();
                return Err(cursor.error(
                    line_no,
                    format!(
                        "expected {channel_count} numbers per frame (one per channel of the hierarchy), found {n}"
                    ),
                ));
            }
            let value = parse_number(token).ok_or_else(|| {
                cursor.error(
                    line_no,
                    not_a_number(
                        &format!("channel {} of frame {}", column + 1, found + 1),
                        token,
                    ),
                )
            })?;
            if value.abs() > MAX_CHANNEL_MAGNITUDE {
                return Err(cursor.error(
                    line_no,
                    format!(
                        "channel {} of frame {}: {} is out of range (a channel value is a finite number of at most {} in magnitude: degrees or the file's length unit)",
                        column + 1,
                        found + 1,
                        crate::motion::compact_number(value),
                        crate::motion::compact_number(MAX_CHANNEL_MAGNITUDE)
                    ),
                ));
            }
            values.push(value);
        }
        let n = values.len() - start;
        if n != channel_count {
            return Err(cursor.error(
                line_no,
                format!(
                    "expected {channel_count} numbers per frame (one per channel of the hierarchy), found {n}"
                ),
            ));
        }
        found += 1;
        if values.len() > MAX_CLIP_VALUES {
            let hint = "cut the file into shorter clips";
            let problem = crate::limits::check_clip(found, channel_count, hint)
                .err()
                .map_or_else(String::new, |e| e.to_string());
            return Err(cursor.error(line_no, format!("frame {found}: {problem}")));
        }
    }
    if found != declared {
        return Err(cursor.error(
            frames_line,
            format!(
                "'Frames: {declared}' but the file has {found} frame lines (last at line {last_line})"
            ),
        ));
    }
    let frames = Array2::from_shape_vec((found, channel_count), values).map_err(|e| {
        FormatError::Invalid {
            path: cursor.path.to_path_buf(),
            problem: format!("frame data has an inconsistent shape: {e}"),
        }
    })?;
    Ok((frames, frame_time))
}

/// `value` of a line `Label: value` whose label equals `label` (case-insensitive, any whitespace).
fn labelled_value<'a>(line: &'a str, label: &str) -> Option<&'a str> {
    let (head, value) = line.split_once(':')?;
    let words = head.split_whitespace();
    let mut expected = label.split_whitespace();
    for word in words {
        if !expected.next()?.eq_ignore_ascii_case(word) {
            return None;
        }
    }
    if expected.next().is_some() {
        return None;
    }
    let value = value.trim();
    (!value.is_empty() && !value.contains(char::is_whitespace)).then_some(value)
}

/// The largest magnitude of a channel value (degrees, or the file's length unit): beyond it a
/// rotation means nothing and forward kinematics overflows.
pub const MAX_CHANNEL_MAGNITUDE: f64 = 1e9;

/// A finite f64, or `None` (NaN and infinities are not valid BVH numbers).
fn parse_number(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|v| v.is_finite())
}

fn not_a_number(expected: &str, found: &str) -> String {
    format!(
        "expected a finite number for {expected}, found {:?}",
        shorten(found)
    )
}

/// At most 40 characters of what was found, for error messages about arbitrary input.
fn shorten(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}...", &text[..cut]),
        None => text.to_string(),
    }
}
