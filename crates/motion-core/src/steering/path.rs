//! Path files: where a character should go over time, for unattended steering (the CLI's
//! `predict --path`, tests, animators). One JSON object, one of two kinds:
//!
//! - **Waypoints**: `{"waypoints": [[x, z], ...], "speed": 1.2, "radius": 0.5, "loop": false}`:
//!   walk to each point in turn at `speed` (m/s, default [`DEFAULT_SPEED`]), moving on once
//!   within `radius` (m, default [`DEFAULT_RADIUS`]) of it; with `"loop": true` start again at
//!   the first point after the last (default `false`: stand still, facing where the character
//!   faces, after the last). Followed by [`Waypoints`].
//! - **Timed goals**: `{"goals": [{"t": 0.0, "velocity": [vx, vz], "facing": 1.57}, ...]}`: from
//!   time `t` (seconds after the seed's last frame, increasing) on, the goal is to move at
//!   `velocity` (m/s) facing `facing` (radians). Without `facing` a goal faces where its
//!   velocity goes; a goal slower than [`STOP_SPEED`] without one keeps the facing of the goal
//!   before it (or the character's own heading). Before the first goal's time the character
//!   moves as it will (no goal); after the last, the last goal stays in force.
//!
//! Units and axes (the crate's): metres and seconds; the floor is the `x`-`z` plane of the
//! world the character moves in (+y up); a facing is a yaw about +y, `0` facing +z and `π/2`
//! facing +x ([`facing_of`]). Unknown keys are refused (a misspelt `"raduis"` would otherwise be
//! silently ignored).
//!
//! ```
//! use motion_core::steering::path::{parse_path, PathFollower};
//! use motion_core::steering::Vec2;
//!
//! let square = r#"{"waypoints": [[0, 4], [4, 4], [4, 0], [0, 0]], "speed": 1.2}"#;
//! let path = parse_path(square, "square.json".as_ref())?;
//! let mut follower = PathFollower::new(&path);
//! let goal = follower.goal(0.0, Vec2::ZERO, 0.0).expect("waypoints always steer");
//! assert!((goal.velocity - Vec2::new(0.0, 1.2)).length() < 1e-6);
//! # Ok::<(), motion_core::steering::path::PathError>(())
//! ```
use std::path::{Path, PathBuf};

use glam::Vec2;
use serde::Deserialize;

use super::{facing_of, Goal, Waypoints, STOP_SPEED};

/// Walking speed of waypoints without `"speed"` (m/s).
pub const DEFAULT_SPEED: f32 = 1.2;
/// Radius within which a waypoint without `"radius"` counts as reached (m).
pub const DEFAULT_RADIUS: f32 = 0.5;
/// The most waypoints or goals one path may hold.
pub const MAX_PATH_ENTRIES: usize = 100_000;
/// The largest path file read (bytes).
pub const MAX_PATH_BYTES: u64 = 16 << 20;
/// The fastest speed a path may ask for (m/s): faster than any person runs.
pub const MAX_SPEED: f32 = 15.0;
/// The farthest a coordinate may be from the origin (m).
pub const MAX_COORDINATE: f64 = 1.0e6;
/// The latest time a goal may start at (s): a day.
pub const MAX_TIME: f64 = 86_400.0;
/// The largest waypoint radius (m).
pub const MAX_RADIUS: f32 = 100.0;
/// Seconds added to a waypoint path's walking time for starting and turning
/// ([`PathSpec::suggested_seconds`]).
pub const WAYPOINT_SLACK_S: f64 = 3.0;

/// Why a path could not be read: the file and the problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct PathError {
    /// The path file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub problem: String,
}

/// One timed goal of a path (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedGoal {
    /// When it comes into force (seconds after the seed's last frame).
    pub t: f64,
    /// Velocity on the floor (m/s, `(x, z)`).
    pub velocity: Vec2,
    /// The facing to hold (radians); `None`: the character's own heading.
    pub facing: Option<f32>,
}

/// A path read from a file (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub enum PathSpec {
    /// Points to walk to in turn.
    Waypoints {
        /// The points, `(x, z)` metres.
        points: Vec<Vec2>,
        /// Walking speed (m/s).
        speed: f32,
        /// Reached within this distance (m).
        radius: f32,
        /// Start again at the first point after the last.
        looping: bool,
    },
    /// Goals in force from their times on, times increasing.
    Goals(Vec<TimedGoal>),
}

impl PathSpec {
    /// Waypoints or goals held.
    pub fn len(&self) -> usize {
        match self {
            PathSpec::Waypoints { points, .. } => points.len(),
            PathSpec::Goals(goals) => goals.len(),
        }
    }

    /// Whether it holds nothing (never so for a parsed path).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `"waypoints"` or `"goals"`.
    pub fn kind(&self) -> &'static str {
        match self {
            PathSpec::Waypoints { .. } => "waypoints",
            PathSpec::Goals(_) => "goals",
        }
    }

    /// How long following the path takes for a character starting at `start` (`(x, z)`), in
    /// seconds, when the path says: timed goals, the last goal's time (when after 0); a waypoint
    /// path that does not loop, its length from `start` at its speed plus
    /// [`WAYPOINT_SLACK_S`]. `None` for a loop (or a single goal at time 0).
    pub fn suggested_seconds(&self, start: Vec2) -> Option<f64> {
        match self {
            PathSpec::Goals(goals) => goals.last().map(|g| g.t).filter(|&t| t > 0.0),
            PathSpec::Waypoints { looping: true, .. } => None,
            PathSpec::Waypoints { points, speed, .. } => {
                let mut length = 0.0f64;
                let mut at = start;
                for &p in points {
                    length += f64::from((p - at).length());
                    at = p;
                }
                Some(length / f64::from(*speed) + WAYPOINT_SLACK_S)
            }
        }
    }
}

/// The JSON of a path file (both kinds' keys; which are given decides the kind).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPath {
    waypoints: Option<Vec<[f64; 2]>>,
    speed: Option<f64>,
    radius: Option<f64>,
    #[serde(rename = "loop")]
    looping: Option<bool>,
    goals: Option<Vec<RawGoal>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGoal {
    t: f64,
    velocity: [f64; 2],
    facing: Option<f64>,
}

/// Reads a path file (see the module docs).
///
/// # Errors
/// The file cannot be read or is over [`MAX_PATH_BYTES`], or [`parse_path`] refuses it.
pub fn read_path(path: &Path) -> Result<PathSpec, PathError> {
    let error = |problem: String| PathError {
        path: path.to_path_buf(),
        problem,
    };
    let size = std::fs::metadata(path)
        .map_err(|e| error(e.to_string()))?
        .len();
    if size > MAX_PATH_BYTES {
        return Err(error(format!(
            "{size} bytes, over the {MAX_PATH_BYTES} bytes a path file may have (MAX_PATH_BYTES)"
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    parse_path(&text, path)
}

/// Parses a path's JSON text; `label` names it in errors.
///
/// # Errors
/// Bad JSON, unknown keys, both kinds or neither, no entries or more than
/// [`MAX_PATH_ENTRIES`], non-finite or out-of-range numbers, goal times not increasing.
pub fn parse_path(text: &str, label: &Path) -> Result<PathSpec, PathError> {
    let error = |problem: String| PathError {
        path: label.to_path_buf(),
        problem,
    };
    if text.len() as u64 > MAX_PATH_BYTES {
        return Err(error(format!(
            "{} bytes, over the {MAX_PATH_BYTES} bytes a path may have (MAX_PATH_BYTES)",
            text.len()
        )));
    }
    let raw: RawPath = serde_json::from_str(text).map_err(|e| {
        error(format!(
            "not a path ({e}); expected {{\"waypoints\": [[x, z], ...], \"speed\": 1.2}} or {{\"goals\": [{{\"t\": 0, \"velocity\": [vx, vz]}}, ...]}}"
        ))
    })?;
    let count = |n: usize, what: &str| {
        if n == 0 {
            Err(error(format!(
                "`{what}` is empty: a path needs at least one entry"
            )))
        } else if n > MAX_PATH_ENTRIES {
            Err(error(format!(
                "{n} {what}, over the {MAX_PATH_ENTRIES} a path may hold (MAX_PATH_ENTRIES)"
            )))
        } else {
            Ok(())
        }
    };
    let coordinate = |v: f64, what: &dyn Fn() -> String| {
        if v.is_finite() && v.abs() <= MAX_COORDINATE {
            Ok(v as f32)
        } else {
            Err(error(format!(
                "{} is {v}: it must be a finite number of metres within ±{MAX_COORDINATE}",
                what()
            )))
        }
    };
    match (raw.waypoints, raw.goals) {
        (Some(_), Some(_)) => Err(error(
            "holds both `waypoints` and `goals`: a path is one or the other".into(),
        )),
        (None, None) => Err(error(
            "holds neither `waypoints` nor `goals` (see `motion-cli predict --help`)".into(),
        )),
        (Some(points), None) => {
            count(points.len(), "waypoints")?;
            let points = points
                .iter()
                .enumerate()
                .map(|(i, [x, z])| {
                    Ok(Vec2::new(
                        coordinate(*x, &|| format!("waypoint {i}'s x"))?,
                        coordinate(*z, &|| format!("waypoint {i}'s z"))?,
                    ))
                })
                .collect::<Result<Vec<_>, PathError>>()?;
            let speed = raw.speed.unwrap_or(f64::from(DEFAULT_SPEED));
            if !(speed.is_finite() && speed > 0.0 && speed <= f64::from(MAX_SPEED)) {
                return Err(error(format!(
                    "speed {speed} m/s: it must be above 0 and at most {MAX_SPEED}"
                )));
            }
            let radius = raw.radius.unwrap_or(f64::from(DEFAULT_RADIUS));
            if !(radius.is_finite() && radius > 0.0 && radius <= f64::from(MAX_RADIUS)) {
                return Err(error(format!(
                    "radius {radius} m: it must be above 0 and at most {MAX_RADIUS}"
                )));
            }
            Ok(PathSpec::Waypoints {
                points,
                speed: speed as f32,
                radius: radius as f32,
                looping: raw.looping.unwrap_or(false),
            })
        }
        (None, Some(goals)) => {
            if let Some(key) = [
                ("speed", raw.speed.is_some()),
                ("radius", raw.radius.is_some()),
                ("loop", raw.looping.is_some()),
            ]
            .iter()
            .find_map(|(k, given)| given.then_some(k))
            {
                return Err(error(format!(
                    "`{key}` belongs to waypoints; timed goals give a velocity each"
                )));
            }
            count(goals.len(), "goals")?;
            let mut out: Vec<TimedGoal> = Vec::with_capacity(goals.len());
            let mut facing_before: Option<f32> = None;
            for (i, goal) in goals.iter().enumerate() {
                if !(goal.t.is_finite() && (0.0..=MAX_TIME).contains(&goal.t)) {
                    return Err(error(format!(
                        "goal {i}'s time t = {} s: it must be between 0 and {MAX_TIME}",
                        goal.t
                    )));
                }
                if let Some(before) = out.last() {
                    if goal.t <= before.t {
                        return Err(error(format!(
                            "goal {i}'s time t = {} s is not after goal {}'s ({} s): times must increase",
                            goal.t,
                            i - 1,
                            before.t
                        )));
                    }
                }
                let [vx, vz] = goal.velocity;
                if !(vx.is_finite() && vz.is_finite()) {
                    return Err(error(format!("goal {i}'s velocity is not finite")));
                }
                let velocity = Vec2::new(vx as f32, vz as f32);
                if velocity.length() > MAX_SPEED {
                    return Err(error(format!(
                        "goal {i}'s velocity is {:.2} m/s, over the {MAX_SPEED} m/s a path may ask for",
                        velocity.length()
                    )));
                }
                let facing = match goal.facing {
                    Some(f) if f.is_finite() && f.abs() <= 1.0e3 => Some(f as f32),
                    Some(f) => {
                        return Err(error(format!(
                            "goal {i}'s facing {f}: it must be a finite angle in radians"
                        )))
                    }
                    None if velocity.length() > STOP_SPEED => Some(facing_of(velocity)),
                    None => facing_before,
                };
                facing_before = facing;
                out.push(TimedGoal {
                    t: goal.t,
                    velocity,
                    facing,
                });
            }
            Ok(PathSpec::Goals(out))
        }
    }
}

/// Follows a [`PathSpec`]: the goal in force for a character at a time, place and heading
/// (see the module docs). No allocation per call.
#[derive(Debug, Clone)]
pub struct PathFollower {
    kind: Follow,
}

#[derive(Debug, Clone)]
enum Follow {
    Waypoints(Waypoints),
    Goals(Vec<TimedGoal>),
}

impl PathFollower {
    /// A follower at the start of `path`.
    pub fn new(path: &PathSpec) -> PathFollower {
        let kind = match path {
            PathSpec::Waypoints {
                points,
                speed,
                radius,
                looping,
            } => Follow::Waypoints(Waypoints::new(points.clone(), *speed, *radius, *looping)),
            PathSpec::Goals(goals) => Follow::Goals(goals.clone()),
        };
        PathFollower { kind }
    }

    /// The goal in force at `time` (seconds after the seed's last frame) for a character at
    /// `here` (`(x, z)`, metres) heading `heading` (radians): waypoints always give one (to
    /// stand, facing `heading`, once done); timed goals none before the first goal's time.
    pub fn goal(&mut self, time: f64, here: Vec2, heading: f32) -> Option<Goal> {
        match &mut self.kind {
            Follow::Waypoints(waypoints) => Some(waypoints.goal(here, heading)),
            Follow::Goals(goals) => {
                let after = goals.partition_point(|g| g.t <= time);
                let goal = goals.get(after.checked_sub(1)?)?;
                Some(Goal {
                    velocity: goal.velocity,
                    facing: goal.facing.unwrap_or(heading),
                })
            }
        }
    }

    /// For waypoints, the index of the point being walked to (`None` for timed goals).
    pub fn next_waypoint(&self) -> Option<usize> {
        match &self.kind {
            Follow::Waypoints(w) => Some(w.next_index()),
            Follow::Goals(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<PathSpec, PathError> {
        parse_path(text, Path::new("p.json"))
    }

    fn problem(text: &str) -> String {
        let e = parse(text).unwrap_err();
        assert_eq!(e.path, Path::new("p.json"));
        assert!(e.to_string().starts_with("p.json: "), "{e}");
        e.problem
    }

    #[test]
    fn waypoints_parse_with_defaults_and_are_followed() {
        let path = parse(r#"{"waypoints": [[0, 4], [4, 4]]}"#).unwrap();
        assert_eq!(
            path,
            PathSpec::Waypoints {
                points: vec![Vec2::new(0.0, 4.0), Vec2::new(4.0, 4.0)],
                speed: DEFAULT_SPEED,
                radius: DEFAULT_RADIUS,
                looping: false,
            }
        );
        assert_eq!((path.len(), path.kind()), (2, "waypoints"));
        // 4 m + 4 m at 1.2 m/s, plus the slack.
        let s = path.suggested_seconds(Vec2::ZERO).unwrap();
        assert!((s - (8.0 / 1.2 + WAYPOINT_SLACK_S)).abs() < 1e-5, "{s}");
        let mut f = PathFollower::new(&path);
        let g = f.goal(0.0, Vec2::ZERO, 0.3).unwrap();
        assert!((g.velocity - Vec2::new(0.0, 1.2)).length() < 1e-6);
        assert!(g.facing.abs() < 1e-6);
        let g = f.goal(1.0, Vec2::new(0.0, 3.8), 0.0).unwrap();
        assert_eq!(f.next_waypoint(), Some(1));
        assert!(g.velocity.x > 1.1, "{g:?}");
        // Done: stand facing where the character faces.
        let g = f.goal(2.0, Vec2::new(4.0, 4.0), 1.0).unwrap();
        assert_eq!((g.velocity, g.facing), (Vec2::ZERO, 1.0));
        let looped =
            parse(r#"{"waypoints": [[0, 4]], "speed": 0.5, "radius": 0.2, "loop": true}"#).unwrap();
        assert_eq!(looped.suggested_seconds(Vec2::ZERO), None);
    }

    #[test]
    fn timed_goals_hold_from_their_time_and_face_their_velocity() {
        let path = parse(
            r#"{"goals": [
                {"t": 0.5, "velocity": [1.0, 0.0]},
                {"t": 2.0, "velocity": [0.0, 0.0]},
                {"t": 3.0, "velocity": [0.0, 0.0], "facing": -1.0}
            ]}"#,
        )
        .unwrap();
        assert_eq!(path.suggested_seconds(Vec2::ZERO), Some(3.0));
        let mut f = PathFollower::new(&path);
        assert_eq!(f.goal(0.0, Vec2::ZERO, 0.2), None);
        let g = f.goal(0.5, Vec2::ZERO, 0.2).unwrap();
        assert_eq!(g.velocity, Vec2::new(1.0, 0.0));
        assert!((g.facing - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        // A stop keeps the facing before it.
        let g = f.goal(2.5, Vec2::ZERO, 0.2).unwrap();
        assert_eq!(g.velocity, Vec2::ZERO);
        assert!((g.facing - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        // The last goal stays in force; time may also go back.
        assert_eq!(f.goal(100.0, Vec2::ZERO, 0.2).unwrap().facing, -1.0);
        assert_eq!(f.goal(1.0, Vec2::ZERO, 0.2).unwrap().velocity, Vec2::X);
        // A first stop without facing: the character's own heading.
        let path = parse(r#"{"goals": [{"t": 0, "velocity": [0, 0]}]}"#).unwrap();
        let mut f = PathFollower::new(&path);
        assert_eq!(f.goal(0.0, Vec2::ZERO, 0.7).unwrap().facing, 0.7);
        assert_eq!(path.suggested_seconds(Vec2::ZERO), None);
    }

    #[test]
    fn bad_paths_are_refused_with_the_file_and_the_problem() {
        assert!(problem("{\"waypoints\": [[0, 1]").contains("not a path"));
        assert!(problem("[1, 2]").contains("not a path"));
        assert!(problem(r#"{"waypoints": [[0, 1]], "raduis": 1}"#).contains("raduis"));
        assert!(problem(r#"{"waypoints": []}"#).contains("empty"));
        assert!(problem(r#"{"goals": []}"#).contains("empty"));
        assert!(problem("{}").contains("neither"));
        assert!(
            problem(r#"{"waypoints": [[0, 1]], "goals": [{"t": 0, "velocity": [0, 0]}]}"#)
                .contains("both")
        );
        assert!(problem(r#"{"waypoints": [[0, 1e300]]}"#).contains("waypoint 0's z"));
        assert!(problem(r#"{"waypoints": [[0, 1e999]]}"#).contains("not a path"));
        assert!(problem(r#"{"waypoints": [[0, 1]], "speed": 0}"#).contains("speed"));
        assert!(problem(r#"{"waypoints": [[0, 1]], "speed": 100}"#).contains("speed"));
        assert!(problem(r#"{"waypoints": [[0, 1]], "radius": -1}"#).contains("radius"));
        assert!(problem(
            r#"{"goals": [{"t": 1, "velocity": [0, 0]}, {"t": 1, "velocity": [1, 0]}]}"#
        )
        .contains("times must increase"));
        assert!(problem(r#"{"goals": [{"t": -1, "velocity": [0, 0]}]}"#).contains("time"));
        assert!(problem(r#"{"goals": [{"t": 0, "velocity": [40, 0]}]}"#).contains("m/s"));
        assert!(
            problem(r#"{"goals": [{"t": 0, "velocity": [0, 0]}], "speed": 1}"#)
                .contains("belongs to waypoints")
        );
        let many = format!(
            "{{\"waypoints\": [{}]}}",
            vec!["[0,0]"; MAX_PATH_ENTRIES + 1].join(",")
        );
        assert!(problem(&many).contains("MAX_PATH_ENTRIES"));
    }

    #[test]
    fn a_missing_file_names_itself() {
        let e = read_path(Path::new("/no/such/path.json")).unwrap_err();
        assert_eq!(e.path, Path::new("/no/such/path.json"));
    }
}
