//! What is drawn: motions loaded as world joint positions over time (from BVH, exp-map text or
//! `.npy`), their bones, and a fixed orthographic camera (a 3/4 view from the front right,
//! slightly from above; y up).
use std::path::Path;

use motion_core::any_format::read_positions;
use motion_core::grounding::find_body_parts;
use motion_core::skeleton::Skeleton;
use ndarray::Array3;

/// Which side of the body a bone is on (drawn in different shades).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The character's left.
    Left,
    /// The character's right.
    Right,
    /// Spine, head, or unnamed joints.
    Centre,
}

/// A bone: parent joint, child joint, side.
#[derive(Debug, Clone, Copy)]
pub struct Bone {
    /// Parent joint index.
    pub from: usize,
    /// Child joint index.
    pub to: usize,
    /// Side of the body.
    pub side: Side,
}

/// One motion to draw.
#[derive(Debug, Clone)]
pub struct Track {
    /// The file name, for legends.
    pub name: String,
    /// World joint positions, `frames x joints x 3` (mm, y up).
    pub positions: Array3<f64>,
    /// Bones of non-zero length.
    pub bones: Vec<Bone>,
    /// Frames per second.
    pub fps: f64,
    /// The foot points (`motion_core::grounding::legs`), empty when the rig has no two legs.
    pub feet: Vec<usize>,
    /// The body's size at frame 0 (largest joint distance from the root), in the file's units.
    pub extent: f64,
}

impl Track {
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.positions.dim().0
    }

    /// Duration in seconds (frames / fps).
    pub fn duration(&self) -> f64 {
        self.len() as f64 / self.fps
    }

    /// The frame shown at time `t` (s): the nearest one, the last after the end.
    pub fn frame_at(&self, t: f64) -> usize {
        ((t * self.fps).round().max(0.0) as usize).min(self.len().saturating_sub(1))
    }

    /// The root's position at frame `f`.
    pub fn root(&self, f: usize) -> [f64; 3] {
        [0, 1, 2].map(|a| self.positions[[f, 0, a]])
    }
}

/// Loads a motion file as a track ([`motion_core::any_format::read_positions`]: BVH, exp-map
/// text or `.npy` frames, a `samples x frames x dims` `.npy` (sample `sample` drawn) or positions
/// `frames x joints x 3`).
pub fn load_track(path: &Path, input_fps: f64, sample: usize) -> anyhow::Result<Track> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let track = read_positions(path, input_fps, sample)?;
    let p = &track.positions;
    let extent = (0..p.dim().1)
        .map(|j| {
            (0..3)
                .map(|a| (p[[0, j, a]] - p[[0, 0, a]]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    let bones = bones(&track.skeleton, p, extent);
    if bones.is_empty() {
        anyhow::bail!(
            "{}: no bones of non-zero length at the first frame: nothing to draw",
            path.display()
        );
    }
    let feet = find_body_parts(&track.skeleton)
        .map(|parts| {
            parts
                .legs
                .iter()
                .flat_map(|l| l.foot_points.clone())
                .collect()
        })
        .unwrap_or_default();
    Ok(Track {
        name,
        bones,
        positions: track.positions,
        fps: track.fps,
        feet,
        extent,
    })
}

/// Bones of the skeleton whose length (at frame 0) is over 1/2000 of the body's extent (about
/// 1 mm of a person, in any units); sides from the joint names.
fn bones(skeleton: &Skeleton, positions: &Array3<f64>, extent: f64) -> Vec<Bone> {
    let side = |j: usize| {
        let name = skeleton.joint(j).name.to_ascii_lowercase();
        if name.starts_with("left") || name.starts_with("l_") {
            Side::Left
        } else if name.starts_with("right") || name.starts_with("r_") {
            Side::Right
        } else {
            Side::Centre
        }
    };
    let joints = positions.dim().1.min(skeleton.len());
    (1..joints)
        .filter_map(|j| {
            let p = skeleton.parent(j)?;
            let d: f64 = (0..3)
                .map(|a| (positions[[0, j, a]] - positions[[0, p, a]]).powi(2))
                .sum::<f64>()
                .sqrt();
            (d > extent / 2000.0).then_some(Bone {
                from: p,
                to: j,
                side: side(j),
            })
        })
        .collect()
}

/// Which frames set the upright reference of a drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Upright {
    /// No rotation.
    Off,
    /// The first frame alone (the seed's first frame): later lean stays visible. The default.
    FirstFrame,
    /// The average over every frame: straightens the whole motion (opt-in).
    WholeMotion,
}

impl Upright {
    /// The rotation that turns `track` upright under this choice ([`upright_rotation`]).
    pub fn rotation(self, track: &Track) -> Option<([[f64; 3]; 3], f64)> {
        match self {
            Upright::Off => None,
            Upright::FirstFrame => upright_rotation(track, 1),
            Upright::WholeMotion => upright_rotation(track, track.len()),
        }
    }
}

/// Leans below this are a posture, not a tilted recording: left as they are.
pub const UPRIGHT_MIN_DEGREES: f64 = 8.0;

/// The rotation (column convention) that turns the average "up" of the track's first `frames`
/// frames (from the root to the joint highest above it on average) onto +y, and its angle in degrees; `None` for a motion
/// that is upright already (under [`UPRIGHT_MIN_DEGREES`]: people lean a little) or lies (over
/// 60°: crawling or lying motions stay as they are). H3.6M takes start from an unknown root orientation, so some lean as a whole.
pub fn upright_rotation(track: &Track, frames: usize) -> Option<([[f64; 3]; 3], f64)> {
    let (all, joints, _) = track.positions.dim();
    let frames = frames.clamp(1, all);
    let mean_offset = |j: usize, a: usize| {
        (0..frames)
            .map(|f| track.positions[[f, j, a]] - track.positions[[f, 0, a]])
            .sum::<f64>()
            / frames as f64
    };
    let top = (1..joints).max_by(|&a, &b| mean_offset(a, 1).total_cmp(&mean_offset(b, 1)))?;
    let v = [0, 1, 2].map(|a| mean_offset(top, a));
    let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if norm < 1e-9 {
        return None;
    }
    let v = v.map(|x| x / norm);
    let angle = v[1].clamp(-1.0, 1.0).acos();
    let degrees = angle.to_degrees();
    if !(UPRIGHT_MIN_DEGREES..=60.0).contains(&degrees) {
        return None;
    }
    // Axis v x y, normalized; Rodrigues' formula.
    let axis = [-v[2], 0.0, v[0]];
    let n = (axis[0] * axis[0] + axis[2] * axis[2]).sqrt();
    let k = axis.map(|x| x / n);
    let (s, c) = angle.sin_cos();
    let mut r = [[0.0; 3]; 3];
    let skew = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            let kk = k[i] * k[j] - if i == j { 1.0 } else { 0.0 };
            r[i][j] = if i == j { 1.0 } else { 0.0 } + s * skew[i][j] + (1.0 - c) * kk;
        }
    }
    Some((r, degrees))
}

/// Rotates every position of `track` by `r` about the point `centre`.
pub fn rotate_track(track: &mut Track, r: &[[f64; 3]; 3], centre: [f64; 3]) {
    for mut p in track.positions.rows_mut() {
        let d = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
        for i in 0..3 {
            p[i] = centre[i] + r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2];
        }
    }
}

/// An orthographic camera: world point -> (right, up, depth) in mm.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    right: [f64; 3],
    up: [f64; 3],
    forward: [f64; 3],
}

impl Camera {
    /// Looking from the character's front right (H3.6M characters walk along +z, face +z, and
    /// have their left at +x), `azimuth` rad off the pure side view, `elevation` rad from above.
    pub fn three_quarter(azimuth: f64, elevation: f64) -> Camera {
        let (sa, ca) = azimuth.sin_cos();
        let (se, ce) = elevation.sin_cos();
        let forward = [ce * ca, -se, -ce * sa];
        let right = [sa, 0.0, ca];
        // up = right x forward
        let up = [
            right[1] * forward[2] - right[2] * forward[1],
            right[2] * forward[0] - right[0] * forward[2],
            right[0] * forward[1] - right[1] * forward[0],
        ];
        Camera { right, up, forward }
    }

    /// The view coordinates of a world point: (right, up, depth; larger depth is farther).
    pub fn project(&self, p: [f64; 3]) -> (f64, f64, f64) {
        let dot = |v: [f64; 3]| v[0] * p[0] + v[1] * p[1] + v[2] * p[2];
        (dot(self.right), dot(self.up), dot(self.forward))
    }
}

/// A view-space rectangle mapped onto a pixel rectangle, uniformly scaled.
#[derive(Debug, Clone, Copy)]
pub struct Viewport {
    /// Pixels per mm.
    pub scale: f64,
    /// View coordinates at the pixel rectangle's centre.
    pub centre: (f64, f64),
    /// The pixel rectangle's centre.
    pub pixel_centre: (f64, f64),
}

impl Viewport {
    /// Fits the view-space box `min..max` into a `width x height` pixel box at `(x, y)` with
    /// `margin` pixels on each side.
    pub fn fit(
        min: (f64, f64),
        max: (f64, f64),
        x: f64,
        y: f64,
        width: f64,
        height: f64,
        margin: f64,
    ) -> Viewport {
        let w = (max.0 - min.0).max(1.0);
        let h = (max.1 - min.1).max(1.0);
        let scale = ((width - 2.0 * margin) / w)
            .min((height - 2.0 * margin) / h)
            .max(1e-6);
        Viewport {
            scale,
            centre: ((min.0 + max.0) / 2.0, (min.1 + max.1) / 2.0),
            pixel_centre: (x + width / 2.0, y + height / 2.0),
        }
    }

    /// Pixel coordinates of view coordinates (y down).
    pub fn to_pixels(self, v: (f64, f64)) -> (f64, f64) {
        (
            self.pixel_centre.0 + (v.0 - self.centre.0) * self.scale,
            self.pixel_centre.1 - (v.1 - self.centre.1) * self.scale,
        )
    }
}

/// The view-space bounding box of every joint of every frame of `tracks`.
pub fn bounds(camera: &Camera, tracks: &[&Track]) -> ((f64, f64), (f64, f64)) {
    let mut min = (f64::INFINITY, f64::INFINITY);
    let mut max = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for track in tracks {
        for p in track.positions.rows() {
            let (u, v, _) = camera.project([p[0], p[1], p[2]]);
            min = (min.0.min(u), min.1.min(v));
            max = (max.0.max(u), max.1.max(v));
        }
    }
    (min, max)
}

/// Frames of the first track whose feet set the floor when no seed length is given (1 s at 25
/// Hz).
pub const FLOOR_FRAMES: usize = 25;

/// The floor: the median over the first track's seed frames (its first `seed_frames`, else its
/// first [`FLOOR_FRAMES`]) of the lowest foot point (the lowest joint for a rig without two
/// legs). Fixed for the whole drawing, so a float or a sink after the seed shows in every frame.
pub fn floor_height(tracks: &[&Track], seed_frames: Option<usize>) -> f64 {
    let Some(first) = tracks.first() else {
        return 0.0;
    };
    let frames = first.len();
    let k = seed_frames.unwrap_or(FLOOR_FRAMES).clamp(1, frames.max(1));
    let mut lows: Vec<f64> = (0..k.min(frames))
        .map(|t| {
            let joints: Box<dyn Iterator<Item = usize>> = if first.feet.is_empty() {
                Box::new(0..first.positions.dim().1)
            } else {
                Box::new(first.feet.iter().copied())
            };
            joints
                .map(|j| first.positions[[t, j, 1]])
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    if lows.is_empty() {
        return 0.0;
    }
    lows.sort_by(f64::total_cmp);
    lows[lows.len() / 2]
}

/// Floor grid lines (world segments on `y = floor`), every `spacing` mm, covering the roots'
/// floor positions plus `reach` mm around them.
pub fn floor_grid(
    tracks: &[&Track],
    floor: f64,
    spacing: f64,
    reach: f64,
) -> Vec<([f64; 3], [f64; 3])> {
    let (mut x0, mut x1, mut z0, mut z1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for track in tracks {
        for f in 0..track.len() {
            let r = track.root(f);
            x0 = x0.min(r[0]);
            x1 = x1.max(r[0]);
            z0 = z0.min(r[2]);
            z1 = z1.max(r[2]);
        }
    }
    let snap_down = |v: f64| ((v - reach) / spacing).floor() * spacing;
    let snap_up = |v: f64| ((v + reach) / spacing).ceil() * spacing;
    let (x0, x1, z0, z1) = (snap_down(x0), snap_up(x1), snap_down(z0), snap_up(z1));
    let mut lines = Vec::new();
    let mut x = x0;
    while x <= x1 + 1e-9 && lines.len() < 400 {
        lines.push(([x, floor, z0], [x, floor, z1]));
        x += spacing;
    }
    let mut z = z0;
    while z <= z1 + 1e-9 && lines.len() < 800 {
        lines.push(([x0, floor, z], [x1, floor, z]));
        z += spacing;
    }
    lines
}

/// Frame times of an animation of `tracks`: every frame of the first track, extended to the
/// longest track at the same rate.
///
/// `Err(frames)` when that is more than `max_frames` frames (nothing is allocated then).
pub fn timeline(tracks: &[&Track], max_frames: usize) -> Result<Vec<f64>, f64> {
    let fps = tracks[0].fps;
    let duration = tracks.iter().map(|t| t.duration()).fold(0.0, f64::max);
    let frames = (duration * fps).round().max(1.0);
    if frames.is_nan() || frames > max_frames as f64 {
        return Err(frames);
    }
    Ok((0..frames as usize).map(|k| k as f64 / fps).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_shows_up_as_up_and_forward_walking_to_the_right() {
        let cam = Camera::three_quarter(0.6, 0.25);
        let (_, up, _) = cam.project([0.0, 1.0, 0.0]);
        assert!(up > 0.9);
        let (right, _, _) = cam.project([0.0, 0.0, 1.0]);
        assert!(right > 0.5);
        // The basis is orthonormal.
        let (a, b, c) = cam.project([0.3, -0.4, 0.5]);
        assert!(((a * a + b * b + c * c) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_leaning_figure_is_turned_upright() {
        // A two-joint "figure": root and a head 1 m away, leaning 20° towards +x.
        let lean = 20f64.to_radians();
        let positions = Array3::from_shape_fn((3, 2, 3), |(f, j, a)| {
            let base = [f as f64 * 100.0, 900.0, 0.0][a];
            let head = [1000.0 * lean.sin(), 1000.0 * lean.cos(), 0.0][a];
            base + if j == 1 { head } else { 0.0 }
        });
        let mut track = Track {
            name: "t".into(),
            bones: Vec::new(),
            positions,
            fps: 25.0,
            feet: Vec::new(),
            extent: 1000.0,
        };
        let (r, degrees) = upright_rotation(&track, 3).unwrap();
        assert!((degrees - 20.0).abs() < 1e-9);
        let centre = track.root(0);
        rotate_track(&mut track, &r, centre);
        for f in 0..3 {
            let dx = track.positions[[f, 1, 0]] - track.positions[[f, 0, 0]];
            let dy = track.positions[[f, 1, 1]] - track.positions[[f, 0, 1]];
            assert!(dx.abs() < 1e-9 && (dy - 1000.0).abs() < 1e-9);
        }
        assert!(upright_rotation(&track, 3).is_none());
    }

    /// A two-joint figure (root, head 1 m above) whose lean about z goes from `from` to `to`
    /// degrees over `frames` frames.
    fn leaning(frames: usize, from: f64, to: f64) -> Track {
        let positions = Array3::from_shape_fn((frames, 2, 3), |(f, j, a)| {
            let lean = (from + (to - from) * f as f64 / (frames - 1) as f64).to_radians();
            let head = [1000.0 * lean.sin(), 1000.0 * lean.cos(), 0.0][a];
            [0.0, 900.0, 0.0][a] + if j == 1 { head } else { 0.0 }
        });
        Track {
            name: "t".into(),
            bones: Vec::new(),
            positions,
            fps: 25.0,
            feet: Vec::new(),
            extent: 1000.0,
        }
    }

    fn lean_of(track: &Track, f: usize) -> f64 {
        let dx = track.positions[[f, 1, 0]] - track.positions[[f, 0, 0]];
        let dy = track.positions[[f, 1, 1]] - track.positions[[f, 0, 1]];
        dx.atan2(dy).to_degrees()
    }

    #[test]
    fn by_default_only_the_first_frame_sets_upright_so_a_growing_lean_stays_visible() {
        // Upright at first, tipping over to 40° later: the default leaves it alone.
        let track = leaning(50, 0.0, 40.0);
        assert!(Upright::FirstFrame.rotation(&track).is_none());
        assert!(Upright::Off.rotation(&track).is_none());
        // The opt-in straightening of the whole motion turns it by the average (~20°).
        let (_, degrees) = Upright::WholeMotion.rotation(&track).unwrap();
        assert!((degrees - 20.0).abs() < 1.0, "{degrees}");
        // Starting tilted by 20° and tipping to 45°: turned by the first frame's 20° only, so
        // the last frame still leans 25°.
        let mut track = leaning(50, 20.0, 45.0);
        let (r, degrees) = Upright::FirstFrame.rotation(&track).unwrap();
        assert!((degrees - 20.0).abs() < 1e-9);
        let centre = track.root(0);
        rotate_track(&mut track, &r, centre);
        assert!(lean_of(&track, 0).abs() < 1e-9);
        assert!(
            (lean_of(&track, 49) - 25.0).abs() < 1e-9,
            "{}",
            lean_of(&track, 49)
        );
    }

    #[test]
    fn viewport_fits_the_box() {
        let v = Viewport::fit((-100.0, 0.0), (100.0, 1800.0), 0.0, 0.0, 200.0, 400.0, 10.0);
        let top = v.to_pixels((0.0, 1800.0));
        let bottom = v.to_pixels((0.0, 0.0));
        assert!((top.1 - 10.0).abs() < 1e-9 && (bottom.1 - 390.0).abs() < 1e-9);
    }

    #[test]
    fn a_rig_in_metres_has_bones_and_the_floor_is_the_seed_feet() {
        let skeleton = Skeleton::h36m();
        let rest = motion_core::grounding::legs::rest_positions(&skeleton);
        // Two frames in metres: standing, then floating 0.5 m up.
        let positions = Array3::from_shape_fn((2, rest.len(), 3), |(f, j, a)| {
            rest[j][a] * 1e-3 + if a == 1 { 1.0 + 0.5 * f as f64 } else { 0.0 }
        });
        let bones = bones(&skeleton, &positions, 0.9);
        assert!(bones.len() > 20, "{}", bones.len());
        let parts = find_body_parts(&skeleton).unwrap();
        let track = Track {
            name: "m".into(),
            bones,
            positions,
            fps: 25.0,
            feet: parts
                .legs
                .iter()
                .flat_map(|l| l.foot_points.clone())
                .collect(),
            extent: 0.9,
        };
        // The seed (frame 0) stands with its toes at 1 - 0.897 m: the floor stays there.
        let floor = floor_height(&[&track], Some(1));
        assert!((floor - (1.0 - 0.8971)).abs() < 1e-3, "{floor}");
    }
}
