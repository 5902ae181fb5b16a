//! Foot locking, stepping and the hip-height hold: each foot's lock and the [`Grounder`] steps
//! that take, release and move it (steps 3-4 of the [module docs](super)).

use glam::{Quat, Vec3};

use super::{ik, soft_limit, Grounder, HIP_SOFTNESS};

/// How high a foot let go while away from the model's foot is lifted mid-step (metres).
const STEP_HEIGHT_M: f32 = 0.08;
/// A foot let go farther than this (horizontally) from the model's foot steps (metres).
const STEP_MIN_M: f32 = 0.05;
/// A foot that lands within this (horizontally) of where it was drawn on the previous frame is
/// held there, with the rotation it was drawn with (metres).
const LANDING_M: f32 = STEP_MIN_M;
/// The fastest the hip-height hold moves the body over a lone held foot, and back (m/s).
const BALANCE_SPEED_M_S: f32 = 1.5;
/// The time constant over which that balance offset returns to zero once the body no longer
/// stands on one held foot (s).
const BALANCE_RETURN_S: f32 = 1.0;
/// The balance offset is kept (not returned) once the body has stood on one held foot this
/// long (s): longer than a walking step's single support.
const BALANCE_HOLD_S: f32 = 0.5;
/// The body is moved over a lone held foot only while the model's root travels slower than
/// this (m/s): a walking body passes over its stance foot by itself, and pulling it back over
/// the foot would slow its walk.
const BALANCE_MAX_TRAVEL_M_S: f32 = 0.6;
/// A foot stepping in towards under its hip stops at this share of the horizontal distance a
/// straight leg allows.
const STANCE_REACH: f32 = 0.9;
/// Seconds a free foot takes to rise to the swing clearance.
const SWING_RISE_S: f32 = 0.06;
/// A held foot farther than this (horizontally) from where a source that gives its own contacts
/// ([`Grounder::set_source_contacts`]) has it is let go (metres).
const SOURCE_UNLOCK_M: f32 = 0.2;
/// A held foot farther than this times its leg's reach from the hip is let go.
const RELEASE_REACH: f32 = 1.3;
/// The body is held back so that a held foot is at most this times its leg's reach away.
const REACH_USED: f32 = 0.995;
/// The most a planted foot that its straight leg cannot reach rises onto its toes (radians of
/// heel rise about the toe tip; people roll 30-40 degrees onto the toes before a foot leaves
/// the floor).
const MAX_HEEL_RISE_RAD: f32 = 0.7;

/// One foot's lock.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct FootState {
    /// Where the ankle is held.
    pub(super) lock: Option<Vec3>,
    /// The foot's world rotation held with it.
    pub(super) lock_rotation: Quat,
    /// 1 while held, falling to 0 while released.
    pub(super) weight: f32,
    /// The model's ankle on the previous frame (floor frame, after the height correction,
    /// without the horizontal offsets grounding adds: its speed is the model's).
    pub(super) previous: Option<Vec3>,
    /// Whether the model's foot is in contact on the last frame.
    pub(super) contact: bool,
    /// Whether the foot being let go steps (lifted) to the model's foot instead of sliding.
    pub(super) stepping: bool,
    /// Where the ankle was drawn on the previous frame, with the foot's world rotation.
    pub(super) drawn: Option<(Vec3, Quat)>,
    /// The share of the swing clearance a free foot has risen to (0 to 1).
    pub(super) lifted: f32,
    /// Where a held foot stepping to a new lock (`lock`) left from.
    pub(super) from: Option<Vec3>,
    /// How far through that step it is (0 to 1).
    pub(super) travel: f32,
}

impl FootState {
    /// Starts letting the lock go: the first `fraction` of the release done.
    pub(super) fn let_go(&mut self, fraction: f32, stepping: bool) {
        self.weight = 1.0 - fraction;
        self.stepping = stepping;
    }

    /// Starts stepping the held foot to `to` (held there once it lands): the first `fraction`
    /// of the step done.
    pub(super) fn step_to(&mut self, to: Vec3, fraction: f32) {
        self.from = self.lock;
        self.lock = Some(to);
        self.travel = fraction;
    }

    /// Whether the foot is held (fully, not stepping anywhere).
    pub(super) fn held(&self) -> bool {
        self.lock.is_some() && self.weight >= 1.0 && self.from.is_none()
    }

    /// Whether the foot is stepping (to the model's foot or to a new lock).
    pub(super) fn moving(&self) -> bool {
        self.stepping || self.from.is_some()
    }
}

impl Grounder {
    /// The horizontal offset grounding adds to the model's root this frame: where held feet
    /// have held the body back so far, and the balance offset, first returned towards zero by
    /// a frame of `dt` seconds.
    pub(super) fn carried(&mut self, dt: f32) -> Vec3 {
        let standing = self.one_foot.is_some_and(|(_, s)| s >= BALANCE_HOLD_S);
        if !standing {
            let back = self.balance * (dt / BALANCE_RETURN_S).min(1.0);
            self.balance -= back.clamp_length_max(BALANCE_SPEED_M_S * dt);
        }
        self.held_offset + self.balance
    }

    /// Contact detection and the lock of one leg (positions are this frame's, before any IK;
    /// `height` of its lowest point over the floor, `speed` of the model's ankle horizontally,
    /// `carried` the horizontal offset grounding added to the root).
    pub(super) fn update_lock(
        &mut self,
        side: usize,
        dt: f32,
        height: f32,
        speed: f32,
        carried: Vec3,
    ) {
        let fraction = self.release_fraction(dt);
        let source_known = self.source_contacts.is_some();
        let leg = &self.parts.legs[side];
        let ankle = self.positions[leg.ankle];
        let state = &mut self.feet[side];
        state.previous = Some(ankle - carried);
        state.contact = match self.source_contacts {
            Some(contacts) => contacts[side],
            None => height < self.config.contact_height_m && speed < self.config.contact_speed_m_s,
        };
        if !self.config.foot_locking {
            return;
        }
        if state.from.is_some() {
            state.travel += fraction;
            if state.travel >= 1.0 {
                state.from = None;
            }
            return;
        }
        let hip = self.positions[leg.hip];
        let reach =
            (self.positions[leg.knee] - hip).length() + (ankle - self.positions[leg.knee]).length();
        match state.lock {
            Some(lock)
                if state.weight >= 1.0
                    && (!state.contact
                        || (lock - hip).length() > reach * RELEASE_REACH
                        || source_known
                            && (lock.x - ankle.x).hypot(lock.z - ankle.z) > SOURCE_UNLOCK_M) =>
            {
                // A foot held away from where the model has it steps there rather than slides.
                let (dx, dz) = (ankle.x - lock.x, ankle.z - lock.z);
                state.let_go(fraction, dx * dx + dz * dz > STEP_MIN_M * STEP_MIN_M);
            }
            Some(_) if state.weight >= 1.0 => {}
            Some(_) => {
                state.weight -= fraction;
            }
            None => {}
        }
        if state.lock.is_some() && state.weight <= 0.0 {
            state.lock = None;
            state.stepping = false;
        }
        if state.lock.is_none() && state.contact {
            // A landing foot is held where it was drawn (it does not slide the last bit of the
            // model's swing along the floor).
            let (lock, rotation) = match state.drawn {
                Some((p, q)) if (p.x - ankle.x).hypot(p.z - ankle.z) < LANDING_M => {
                    (Vec3::new(p.x, ankle.y, p.z), q)
                }
                _ => (ankle, self.rotations[leg.ankle]),
            };
            state.lock = Some(lock);
            state.lock_rotation = rotation;
            state.weight = 1.0;
            state.lifted = 0.0;
        }
    }

    /// How far the hip-height hold raises a root `root_y` over the floor: no higher than the
    /// feet still held reach (it never pulls the body towards them). A held foot that keeps the
    /// body down steps, one foot at a time, the one held lowest first, while the body has
    /// something to stand on ([`Self::stands_without`]): to where the model has it when that is
    /// near enough, else, while the other foot is held, in towards under its hip
    /// ([`Self::stance_point`]). `model_speed`: how fast the model's root moves over the floor
    /// (m/s; the balance over a lone held foot acts only below [`BALANCE_MAX_TRAVEL_M_S`]).
    pub(super) fn hip_raise(&mut self, root_y: f32, model_speed: f32, dt: f32) -> Vec3 {
        let limit = self.min_hip_height();
        let softness = HIP_SOFTNESS * self.standing_height;
        let wanted = (-soft_limit(-root_y, -limit, softness) - root_y).max(0.0);
        let rooms = [self.raise_room(0), self.raise_room(1)];
        let step = if self.feet.iter().any(FootState::moving) {
            None
        } else {
            (0..2)
                .filter_map(|side| rooms[side].map(|(held, _)| (side, held)))
                .filter(|&(side, held)| held < wanted && self.stands_without(side))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(side, _)| side)
        };
        let both_held = self.feet.iter().all(FootState::held);
        let fraction = self.release_fraction(dt);
        let mut room = f32::INFINITY;
        for (side, r) in rooms.iter().enumerate() {
            let Some((held, stepped)) = *r else { continue };
            if step != Some(side) {
                room = room.min(held);
            } else if stepped >= wanted {
                self.feet[side].let_go(fraction, true);
            } else if let Some(to) = self.stance_point(side, wanted).filter(|_| both_held) {
                self.feet[side].step_to(to, fraction);
            } else {
                room = room.min(held);
            }
        }
        // A lone held foot the body cannot rise over moves the body over it (balance), at most
        // `BALANCE_SPEED_M_S`.
        let lone = match [self.feet[0].held(), self.feet[1].held()] {
            [true, false] => Some(0),
            [false, true] => Some(1),
            _ => None,
        };
        self.one_foot = lone.map(|side| match self.one_foot {
            Some((held, s)) if held == side => (side, s + dt),
            _ => (side, dt),
        });
        if let Some((lock, hip, reach)) = lone.and_then(|side| self.held(side)) {
            let d = Vec3::new(lock.x - hip.x, 0.0, lock.z - hip.z);
            let h = d.length();
            let rise = wanted + hip.y - lock.y;
            let over = h - (reach * reach - rise * rise).max(0.0).sqrt();
            if room < wanted && over > 0.0 && h > 1e-6 && model_speed < BALANCE_MAX_TRAVEL_M_S {
                let shift = over.min(BALANCE_SPEED_M_S * dt);
                let h = h - shift;
                let room = lock.y + (reach * reach - h * h).max(0.0).sqrt() - hip.y;
                return d / (h + shift) * shift + Vec3::Y * wanted.min(room).max(0.0);
            }
        }
        Vec3::Y * wanted.min(room).max(0.0)
    }

    /// Whether the body has something to stand on while leg `side`'s foot steps: the other foot
    /// held, or clear of the floor by more than a step's height (the body is put on the lowest
    /// foot point: it would drop onto a free foot near the floor, which would slide).
    fn stands_without(&self, side: usize) -> bool {
        let other = 1 - side;
        self.feet[other].held()
            || self.parts.legs[other]
                .foot_points
                .iter()
                .map(|&j| self.positions[j].y)
                .fold(f32::INFINITY, f32::min)
                > STEP_HEIGHT_M
    }

    /// The share of a release one frame of `dt` seconds does.
    fn release_fraction(&self, dt: f32) -> f32 {
        dt / self.config.release_s.max(1e-3)
    }

    /// Leg `side`'s fully held foot: its lock, the hip and the leg's usable reach.
    fn held(&self, side: usize) -> Option<(Vec3, Vec3, f32)> {
        let (leg, state) = (&self.parts.legs[side], &self.feet[side]);
        let lock = state.lock.filter(|_| state.held())?;
        let hip = self.positions[leg.hip];
        let knee = self.positions[leg.knee];
        let ankle = self.positions[leg.ankle];
        let reach = ((knee - hip).length() + (ankle - knee).length()) * REACH_USED;
        Some((lock, hip, reach))
    }

    /// How far the root must move horizontally so that every fully held foot is within its
    /// leg's reach (the mean over the held feet that need it): flat, or, while the root leads
    /// ([`Grounder::set_root_leads`]), rolled onto its toes as far as [`Self::heel_rise`] allows.
    pub(super) fn held_back(&self) -> Vec3 {
        if self.source_contacts.is_some() {
            // The source's root is where it is steered; a foot it leaves behind lets go
            // (`SOURCE_UNLOCK_M`).
            return Vec3::ZERO;
        }
        let (mut sum, mut n) = (Vec3::ZERO, 0.0);
        for side in 0..2 {
            let Some((lock, hip, reach)) = self.held(side) else {
                continue;
            };
            let ankle = if self.root_leads {
                let state = &self.feet[side];
                let model = self.rotations[self.parts.legs[side].ankle];
                let turn = state.lock_rotation * model.inverse();
                self.heel_rise(side, lock, state.lock_rotation, turn).0
            } else {
                lock
            };
            let d = ankle - hip;
            let horizontal = Vec3::new(d.x, 0.0, d.z);
            let (h, v) = (horizontal.length(), d.y.abs());
            if d.length() > reach && v < reach && h > 1e-6 {
                let allowed = (reach * reach - v * v).sqrt();
                sum += horizontal / h * (h - allowed);
                n += 1.0;
            }
        }
        if n > 0.0 {
            sum / n
        } else {
            Vec3::ZERO
        }
    }

    /// How far the body can rise with leg `side`'s foot, when fully held, still within the leg's
    /// reach: held where it is, and stepped to under the model's ankle.
    fn raise_room(&self, side: usize) -> Option<(f32, f32)> {
        let (lock, hip, reach) = self.held(side)?;
        let ankle = self.positions[self.parts.legs[side].ankle];
        let room = |x: f32, z: f32| {
            let h2 = (x - hip.x).powi(2) + (z - hip.z).powi(2);
            lock.y + (reach * reach - h2).max(0.0).sqrt() - hip.y
        };
        Some((room(lock.x, lock.z), room(ankle.x, ankle.z)))
    }

    /// Where leg `side`'s fully held foot steps in to, towards under its hip, for the body to
    /// rise by `wanted` over the held feet (most of the way when a straight leg can't): `None`
    /// when that is a step under [`STEP_MIN_M`].
    fn stance_point(&self, side: usize, wanted: f32) -> Option<Vec3> {
        let (lock, hip, reach) = self.held(side)?;
        let rise = wanted + hip.y - lock.y;
        let h = (reach * reach - rise * rise).max(0.0).sqrt() * STANCE_REACH;
        let d = Vec3::new(lock.x - hip.x, 0.0, lock.z - hip.z);
        let length = d.length();
        (length - h > STEP_MIN_M).then(|| lock - d / length * (length - h))
    }

    /// The IK of one leg after its lock is updated (`support`: the foot that holds the body,
    /// which never gets the swing clearance).
    pub(super) fn place(
        &mut self,
        side: usize,
        rotations: &mut [Quat],
        height: f32,
        speed: f32,
        support: bool,
        dt: f32,
    ) {
        if !self.config.foot_locking {
            return;
        }
        let leg = &self.parts.legs[side];
        let ankle = self.positions[leg.ankle];
        let state = &self.feet[side];
        let Some(lock) = state.lock else {
            // A swinging foot: its lowest point at least at the swing clearance (wanted from
            // nothing at half the contact speed to all of it at the contact speed, risen to over
            // `SWING_RISE_S`), never under the floor.
            let contact_speed = self.config.contact_speed_m_s.max(1e-6);
            let over = (2.0 * speed / contact_speed - 1.0).clamp(0.0, 1.0);
            let rise = dt / SWING_RISE_S;
            let lifted = &mut self.feet[side].lifted;
            *lifted = over.min(*lifted + rise).max(*lifted - rise);
            // A source that gives its contacts swings its feet as it likes (only out of the
            // floor).
            let own = self.source_contacts.is_some();
            let wanted = if support || own {
                0.0
            } else {
                self.config.swing_clearance_m * *lifted
            };
            // The support foot goes back to the floor when the hip-height hold raised it.
            if height < wanted || (support && !own && height > wanted) {
                let target = ankle + Vec3::Y * (wanted - height);
                let rotation = self.rotations[leg.ankle];
                let (target, rotation) = if support {
                    self.heel_rise(side, target, rotation, Quat::IDENTITY)
                } else {
                    (target, rotation)
                };
                self.solve_leg(side, rotations, target, rotation);
            }
            return;
        };
        // Held: the ankle over its lock with the foot's world rotation of that moment (toes do
        // not slide round the ankle) and its lowest point on the floor; blended back to the
        // model's foot while released.
        let w = state.weight.clamp(0.0, 1.0);
        let model_rotation = self.rotations[leg.ankle];
        let foot_rotation = model_rotation.slerp(state.lock_rotation, w).normalize();
        let turn = foot_rotation * model_rotation.inverse();
        let below_ankle = leg
            .foot_points
            .iter()
            .map(|&j| (turn * (self.positions[j] - ankle)).y)
            .fold(0.0f32, f32::min);
        // A stepping foot is lifted off the floor, over where it goes by half-way through the
        // step, and lands there: the model's foot when let go, its new lock when stepping to
        // one.
        let (lock, w_step, wh) = match state.from {
            Some(from) => {
                let t = state.travel.clamp(0.0, 1.0);
                (from.lerp(lock, (2.0 * t).min(1.0)), 1.0 - t, 1.0)
            }
            None if state.stepping => (lock, w, (2.0 * w - 1.0).max(0.0)),
            None => (lock, w, w),
        };
        let target = Vec3::new(
            ankle.x + (lock.x - ankle.x) * wh,
            ankle.y + (-below_ankle - ankle.y) * w,
            ankle.z + (lock.z - ankle.z) * wh,
        );
        let mut target = Vec3::new(target.x, target.y.max(-below_ankle), target.z);
        let (target, foot_rotation) = if state.stepping || state.from.is_some() {
            let lifted = -below_ankle + STEP_HEIGHT_M * (1.0 - (2.0 * w_step - 1.0).powi(2));
            target.y = target.y.max(lifted);
            (target, foot_rotation)
        } else if state.held() {
            self.heel_rise(side, target, foot_rotation, turn)
        } else {
            (target, foot_rotation)
        };
        self.solve_leg(side, rotations, target, foot_rotation);
    }

    /// A planted foot whose ankle `target` its leg cannot reach rolls onto its toes, as a foot
    /// does behind a walker before it leaves the floor: the foot turns about its toe tip (the
    /// foot point farthest from the ankle, held where it is) just enough for the ankle to come
    /// within reach, at most [`MAX_HEEL_RISE_RAD`], and only for a foot whose toes point towards
    /// the hip (a foot ahead of the body, toes away from it, stays flat). `turn`: the world
    /// rotation from the model's foot to `foot_rotation`. Returns the ankle's target and the
    /// foot's world rotation.
    pub(super) fn heel_rise(
        &self,
        side: usize,
        target: Vec3,
        foot_rotation: Quat,
        turn: Quat,
    ) -> (Vec3, Quat) {
        let leg = &self.parts.legs[side];
        let (hip, knee, ankle) = (
            self.positions[leg.hip],
            self.positions[leg.knee],
            self.positions[leg.ankle],
        );
        let reach = ((knee - hip).length() + (ankle - knee).length()) * REACH_USED;
        let flat = (target - hip).length();
        if flat <= reach {
            return (target, foot_rotation);
        }
        let toe = leg
            .foot_points
            .iter()
            .map(|&j| turn * (self.positions[j] - ankle))
            .fold(Vec3::ZERO, |a, b| {
                if b.length_squared() > a.length_squared() {
                    b
                } else {
                    a
                }
            });
        let forward = Vec3::new(toe.x, 0.0, toe.z);
        let to_hip = Vec3::new(hip.x - target.x, 0.0, hip.z - target.z);
        if forward.length_squared() < 1e-8 || forward.dot(to_hip) <= 0.0 {
            return (target, foot_rotation);
        }
        let axis = Vec3::Y.cross(forward).normalize();
        let pivot = target + toe;
        let ankle_at = |angle: f32| pivot + Quat::from_axis_angle(axis, angle) * -toe;
        let distance = |angle: f32| (ankle_at(angle) - hip).length();
        let rolled = distance(MAX_HEEL_RISE_RAD);
        if rolled >= flat {
            return (target, foot_rotation);
        }
        let angle = if rolled > reach {
            MAX_HEEL_RISE_RAD
        } else {
            let (mut lo, mut hi) = (0.0, MAX_HEEL_RISE_RAD);
            for _ in 0..16 {
                let mid = 0.5 * (lo + hi);
                if distance(mid) > reach {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi
        };
        (
            ankle_at(angle),
            (Quat::from_axis_angle(axis, angle) * foot_rotation).normalize(),
        )
    }

    /// Two-bone IK of leg `side` bringing its ankle to `target` with the foot's world rotation
    /// `foot_rotation` (scratch positions are this frame's, before any IK of this leg).
    fn solve_leg(&self, side: usize, rotations: &mut [Quat], target: Vec3, foot_rotation: Quat) {
        let leg = &self.parts.legs[side];
        let (hip_j, knee_j, ankle_j) = (leg.hip, leg.knee, leg.ankle);
        let ankle = self.positions[ankle_j];
        let toe = *leg.foot_points.last().expect("the ankle at least");
        let parent = self.parents[hip_j].map_or(Quat::IDENTITY, |p| self.rotations[p]);
        let forward = {
            let f = self.positions[toe] - ankle;
            if f.length_squared() > 1e-8 {
                f
            } else {
                self.rotations[0] * Vec3::Z
            }
        };
        let chain = ik::Chain {
            a: self.positions[hip_j],
            b: self.positions[knee_j],
            c: ankle,
            parent_rotation: parent,
            hip_rotation: self.rotations[hip_j],
            knee_rotation: self.rotations[knee_j],
            forward,
        };
        let (hip_local, knee_local) = ik::solve(&chain, rotations[knee_j], target);
        rotations[hip_j] = hip_local;
        rotations[knee_j] = knee_local;
        let knee_world = parent * hip_local * knee_local;
        rotations[ankle_j] = (knee_world.inverse() * foot_rotation).normalize();
    }
}
