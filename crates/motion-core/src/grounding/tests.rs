use super::*;

const DT: f32 = 0.04;

/// An H3.6M standing pose with both knees bent by `knee` radians (hip flexed, ankle flexed back
/// by half of it each, so the shin leans and the foot stays flat).
fn crouch(knee: f32) -> Vec<Quat> {
    let mut q = vec![Quat::IDENTITY; Skeleton::h36m().len()];
    for (hip, kn, ankle) in [(1, 2, 3), (6, 7, 8)] {
        q[hip] = Quat::from_rotation_x(-knee / 2.0);
        q[kn] = Quat::from_rotation_x(knee);
        q[ankle] = Quat::from_rotation_x(-knee / 2.0);
    }
    q
}

fn grounder() -> Grounder {
    Grounder::new(&Skeleton::h36m(), 1e-3, GroundingConfig::default()).unwrap()
}

/// World positions of `rotations` at `root` (metres).
fn positions(root: Vec3, rotations: &[Quat]) -> Vec<Vec3> {
    let skeleton = Skeleton::h36m();
    let mut world = vec![Quat::IDENTITY; rotations.len()];
    let mut out = vec![Vec3::ZERO; rotations.len()];
    for (j, joint) in skeleton.joints().iter().enumerate() {
        let offset = Vec3::from_array(joint.offset.map(|v| v as f32)) * 1e-3;
        match joint.parent {
            None => {
                world[j] = rotations[j];
                out[j] = root;
            }
            Some(p) => {
                world[j] = world[p] * rotations[j];
                out[j] = out[p] + world[p] * offset;
            }
        }
    }
    out
}

#[test]
fn a_planted_foot_stays_within_a_centimetre_while_the_body_slides_and_floats() {
    let mut g = grounder();
    let pose = crouch(0.5);
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 0.95, 0.0), &pose);
    }
    // The model slides the body 0.15 m forward and floats it 0.4 m up over 1 s, feet still.
    let mut planted: Option<[Vec3; 2]> = None;
    let mut worst = 0.0f32;
    for t in 0..25 {
        let s = t as f32 / 24.0;
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.95 + 0.4 * s, 0.15 * s), pose.clone());
        g.ground(&mut root, &mut rotations, DT);
        assert_eq!(g.contacts(), [true, true], "frame {t}");
        let p = positions(root, &rotations);
        let feet = [p[3], p[8]];
        let first = *planted.get_or_insert(feet);
        for side in 0..2 {
            worst = worst.max((feet[side] - first[side]).length());
        }
        let lowest = [3, 4, 5, 8, 9, 10]
            .map(|j| p[j].y)
            .into_iter()
            .fold(f32::INFINITY, f32::min);
        assert!(
            lowest > -0.01,
            "frame {t}: a foot {lowest} m under the floor"
        );
    }
    assert!(worst < 0.01, "a planted ankle moved {worst} m");
}

#[test]
fn a_floating_body_is_put_back_on_the_floor() {
    let mut g = grounder();
    let rest = vec![Quat::IDENTITY; 32];
    for _ in 0..10 {
        g.observe_seed(Vec3::new(0.0, 0.9, 0.0), &rest);
    }
    for t in 0..50 {
        // The model climbs 2 cm a frame and steps its legs (no contact: the feet move fast).
        let mut rotations = crouch(0.3 * (t as f32 * 0.5).sin().abs());
        rotations[1] *= Quat::from_rotation_x(0.4 * (t as f32 * 0.5).sin());
        let mut root = Vec3::new(0.05 * t as f32, 0.9 + 0.02 * t as f32, 0.0);
        g.ground(&mut root, &mut rotations, DT);
        let p = positions(root, &rotations);
        let lowest = [3, 4, 5, 8, 9, 10]
            .map(|j| p[j].y)
            .into_iter()
            .fold(f32::INFINITY, f32::min);
        assert!(
            lowest.abs() < 0.02,
            "frame {t}: lowest foot point at {lowest} m"
        );
    }
}

#[test]
fn a_reclined_body_is_stood_up_to_the_lean_limit() {
    let mut g = grounder();
    g.set_action(Some("walking"));
    let limit = g.lean_limit();
    let rest = vec![Quat::IDENTITY; 32];
    for _ in 0..10 {
        g.observe_seed(Vec3::new(0.0, 0.9, 0.0), &rest);
    }
    for degrees in [0.0f32, 20.0, 60.0, 95.0] {
        let mut rotations = rest.clone();
        rotations[0] = Quat::from_rotation_x(-degrees.to_radians());
        let mut root = Vec3::new(0.0, 0.9, 0.0);
        g.ground(&mut root, &mut rotations, DT);
        let p = positions(root, &rotations);
        let torso = (p[13] - p[0]).normalize();
        let lean = torso.dot(Vec3::Y).acos().to_degrees();
        assert!(
            lean <= limit + 1e-3,
            "{degrees}° -> {lean}° (limit {limit}°)"
        );
        if degrees <= limit - LEAN_SOFTNESS_DEG {
            assert!((lean - degrees).abs() < 0.01, "{degrees}° -> {lean}°");
        }
    }
}

#[test]
fn a_seed_on_a_tilted_floor_comes_out_level() {
    let mut g = grounder();
    let rest = vec![Quat::IDENTITY; 32];
    // The seed walks 3 m up a 4° slope: its world is tilted; the floor frame levels it.
    let tilt = Quat::from_rotation_x(-4f32.to_radians());
    for t in 0..50 {
        let root = tilt * Vec3::new(0.0, 0.9, 0.06 * t as f32);
        g.observe_seed(root, &[&[tilt][..], &rest[1..]].concat());
    }
    assert!(
        (g.floor().tilt_deg() - 4.0).abs() < 0.6,
        "{}",
        g.floor().tilt_deg()
    );
    let mut root = tilt * Vec3::new(0.0, 0.9, 3.0);
    let mut rotations = [&[tilt][..], &rest[1..]].concat();
    g.ground(&mut root, &mut rotations, DT);
    let up = rotations[0] * Vec3::Y;
    assert!(up.angle_between(Vec3::Y).to_degrees() < 0.6, "{up}");
}

#[test]
fn switched_off_it_changes_nothing() {
    let mut g = Grounder::new(&Skeleton::h36m(), 1e-3, GroundingConfig::off()).unwrap();
    let pose = crouch(0.4);
    g.observe_seed(Vec3::ZERO, &pose);
    let (mut root, mut rotations) = (Vec3::new(1.0, 2.0, 3.0), pose.clone());
    g.ground(&mut root, &mut rotations, DT);
    assert_eq!((root, rotations), (Vec3::new(1.0, 2.0, 3.0), pose));
}

#[test]
fn a_lifted_foot_is_released_to_the_model() {
    let mut g = grounder();
    let pose = crouch(0.5);
    for _ in 0..10 {
        g.observe_seed(Vec3::new(0.0, 0.95, 0.0), &pose);
    }
    let (mut root, mut rotations) = (Vec3::new(0.0, 0.95, 0.0), pose.clone());
    g.ground(&mut root, &mut rotations, DT);
    assert_eq!(g.contacts(), [true, true]);
    // The model lifts the left foot (knee up) and keeps it up: after the release blend the
    // grounded foot is the model's.
    let mut lifted = pose.clone();
    lifted[6] = Quat::from_rotation_x(-1.0);
    lifted[7] = Quat::from_rotation_x(1.2);
    for _ in 0..10 {
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.95, 0.0), lifted.clone());
        g.ground(&mut root, &mut rotations, DT);
        let model = positions(root, &lifted);
        let grounded = positions(root, &rotations);
        assert!(!g.contacts()[1]);
        let _ = (model, grounded);
    }
    let (mut root, mut rotations) = (Vec3::new(0.0, 0.95, 0.0), lifted.clone());
    g.ground(&mut root, &mut rotations, DT);
    let (model, grounded) = (positions(root, &lifted), positions(root, &rotations));
    assert!(
        (model[8] - grounded[8]).length() < 1e-4,
        "{} vs {}",
        model[8],
        grounded[8]
    );
}

#[test]
fn the_lean_limit_follows_the_action() {
    for (name, value) in LEAN_P95_DEG {
        assert_eq!(lean_limit_deg(Some(name)), value);
    }
    let widest = LEAN_P95_DEG.iter().map(|&(_, v)| v).fold(0.0, f32::max);
    assert_eq!(lean_limit_deg(None), widest);
    assert_eq!(lean_limit_deg(Some("juggling")), widest);
    assert!(soft_limit(100.0, 30.0, 6.0) <= 30.0);
    assert!(soft_limit(27.0, 30.0, 6.0) < 27.0);
    assert_eq!(soft_limit(10.0, 30.0, 6.0), 10.0);
}

/// The lowest foot point and the root height of a grounded deep crouch held for 1 s, and how far
/// the ankles moved.
fn grounded_crouch(action: Option<&str>, config: GroundingConfig) -> (f32, f32, f32) {
    let mut g = Grounder::new(&Skeleton::h36m(), 1e-3, config).unwrap();
    g.set_action(action);
    let pose = crouch(1.6);
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 0.7, 0.0), &pose);
    }
    let (mut lowest, mut root_y, mut moved) = (f32::INFINITY, 0.0, 0.0f32);
    let mut first: Option<[Vec3; 2]> = None;
    for _ in 0..25 {
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.7, 0.0), pose.clone());
        g.ground(&mut root, &mut rotations, DT);
        let p = positions(root, &rotations);
        let feet = [p[3], p[8]];
        let start = *first.get_or_insert(feet);
        moved = moved.max(
            (feet[0] - start[0])
                .length()
                .max((feet[1] - start[1]).length()),
        );
        lowest = [3, 4, 5, 8, 9, 10]
            .map(|j| p[j].y)
            .into_iter()
            .fold(f32::INFINITY, f32::min);
        root_y = root.y;
    }
    (lowest, root_y, moved)
}

#[test]
fn a_crouch_stands_up_to_the_actions_hip_height_with_the_feet_planted() {
    // Knees bent by 1.6 rad: the root 0.62 m over the floor; real walking keeps it over 0.85 m
    // (HIP_P5_MM; the hold 13.5 mm over it), sitting down to under the floor (no hold).
    let hold = hip_floor_fraction(Some("walking")) * H36M_STANDING_HEIGHT_MM * 1e-3;
    assert!((hold - 0.8607).abs() < 1e-3, "{hold}");
    let (lowest, root_y, moved) = grounded_crouch(Some("walking"), GroundingConfig::default());
    assert!(
        root_y >= hold - 1e-3,
        "walking: the root at {root_y} m, the hold {hold} m"
    );
    assert!(
        lowest.abs() < 0.01,
        "walking: lowest foot point at {lowest} m"
    );
    assert!(moved < 0.01, "walking: an ankle moved {moved} m");
    let (_, sitting_y, _) = grounded_crouch(Some("sittingdown"), GroundingConfig::default());
    assert!(
        sitting_y < 0.66,
        "sittingdown keeps the crouch: {sitting_y} m"
    );
    let off = GroundingConfig {
        min_hip_fraction: Some(0.0),
        ..GroundingConfig::default()
    };
    let (lowest, off_y, _) = grounded_crouch(Some("walking"), off);
    assert!(
        off_y < 0.66 && lowest.abs() < 0.01,
        "no hold: {off_y} m, {lowest} m"
    );
}

#[test]
fn feet_held_too_wide_to_stand_up_step_in_over_the_floor() {
    // A deep crouch with the legs spread, then the model slides its feet in under the hips over
    // 0.8 s (still crouched, slow enough to stay in contact): the held feet step in (lifted,
    // not slid) and the body stands to the hold.
    let spread = |angle: f32| {
        let mut q = crouch(1.6);
        q[1] = Quat::from_rotation_z(angle) * q[1];
        q[6] = Quat::from_rotation_z(-angle) * q[6];
        q
    };
    let width = |q: &[Quat]| {
        let p = positions(Vec3::ZERO, q);
        (p[3].x - p[8].x).abs()
    };
    let sign = if width(&spread(0.5)) > width(&spread(-0.5)) {
        1.0
    } else {
        -1.0
    };
    let wide = spread(0.5 * sign);
    assert!(width(&wide) > width(&crouch(1.6)) + 0.3);
    let mut g = grounder();
    g.set_action(Some("walking"));
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 0.7, 0.0), &wide);
    }
    let hold = g.min_hip_height();
    let mut previous: Option<Vec<Vec3>> = None;
    let (mut skating, mut root_y, mut stepped) = (0, 0.0, 0.0f32);
    for t in 0..60 {
        let s = ((t as f32 - 10.0) / 20.0).clamp(0.0, 1.0);
        let pose = spread(0.5 * sign * (1.0 - s));
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.7, 0.0), pose);
        g.ground(&mut root, &mut rotations, DT);
        let p = positions(root, &rotations);
        stepped = stepped.max(p[3].y).max(p[8].y);
        if let Some(before) = &previous {
            for j in [3, 4, 5, 8, 9, 10] {
                let d = p[j] - before[j];
                let speed = (d.x * d.x + d.z * d.z).sqrt() / DT;
                if p[j].y < 0.05 && speed > 0.5 {
                    skating += 1;
                }
            }
        }
        previous = Some(p);
        root_y = root.y;
    }
    assert!(
        stepped > 0.05,
        "no foot stepped: ankles {stepped} m up at most"
    );
    assert_eq!(skating, 0, "foot points slid over the floor");
    assert!(
        root_y >= hold - 1e-3,
        "the root at {root_y} m, the hold {hold} m"
    );
}

/// Frames on which a foot point under 5 cm moves faster than 0.5 m/s horizontally (the
/// skating measure), over consecutive grounded position sets.
fn skating_frames(frames: &[Vec<Vec3>]) -> usize {
    frames
        .windows(2)
        .filter(|w| {
            [3, 4, 5, 8, 9, 10].iter().any(|&j| {
                let d = w[1][j] - w[0][j];
                w[1][j].y < 0.05 && (d.x * d.x + d.z * d.z).sqrt() / DT > 0.5
            })
        })
        .count()
}

#[test]
fn a_foot_landing_mid_swing_is_held_where_it_came_down() {
    // The right leg stands; the left, straight, swings in from 0.6 rad off the vertical at
    // about 0.8 m/s (under the contact speed), touching the floor before it stops at 0.25 rad:
    // it is held where it was drawn and does not slide the end of the model's swing along the
    // floor.
    let swing = |angle: f32| {
        let mut q = vec![Quat::IDENTITY; Skeleton::h36m().len()];
        q[6] = Quat::from_rotation_x(angle);
        q
    };
    let mut g = grounder();
    for _ in 0..10 {
        g.observe_seed(Vec3::new(0.0, 0.9, 0.0), &swing(0.0));
    }
    let (mut frames, mut landed) = (Vec::new(), None);
    for t in 0..25 {
        let model = swing((-0.6 + 0.036 * t as f32).min(-0.25));
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.9, 0.0), model);
        g.ground(&mut root, &mut rotations, DT);
        if g.contacts()[1] {
            landed.get_or_insert(t);
        }
        frames.push(positions(root, &rotations));
    }
    assert!(
        landed.is_some_and(|t| t > 0),
        "the left foot landed at {landed:?}"
    );
    assert_eq!(
        skating_frames(&frames),
        0,
        "a landing foot slid over the floor"
    );
}

#[test]
fn a_lunge_too_long_to_stand_up_in_steps_the_feet_in_under_the_hips() {
    // The model holds a long lunge (both feet about 0.5 m from under the hips, the root well
    // under the walking hold): its own feet are no nearer, so the held feet step in towards
    // under the hips, one at a time and lifted, and the body stands to the hold.
    // Straight legs 0.6 rad either way from the vertical, feet flat.
    let mut lunge = vec![Quat::IDENTITY; Skeleton::h36m().len()];
    for (hip, ankle, angle) in [(1, 3, 0.6f32), (6, 8, -0.6)] {
        lunge[hip] = Quat::from_rotation_x(angle);
        lunge[ankle] = Quat::from_rotation_x(-angle);
    }
    let mut g = grounder();
    g.set_action(Some("walking"));
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 0.8, 0.0), &lunge);
    }
    let hold = g.min_hip_height();
    let (mut frames, mut root_y, mut stepped) = (Vec::new(), 0.0, 0.0f32);
    for _ in 0..40 {
        let (mut root, mut rotations) = (Vec3::new(0.0, 0.8, 0.0), lunge.clone());
        g.ground(&mut root, &mut rotations, DT);
        let p = positions(root, &rotations);
        stepped = stepped.max(p[3].y.min(p[8].y));
        root_y = root.y;
        frames.push(p);
    }
    let p = frames.last().unwrap();
    let stance = (p[3].z - p[8].z).abs();
    let model = positions(Vec3::ZERO, &lunge);
    assert!(
        stance < (model[3].z - model[8].z).abs() - 0.2,
        "the stance stayed {stance} m long"
    );
    assert!(
        stepped < 0.01,
        "both feet off the floor at once ({stepped} m)"
    );
    assert_eq!(
        skating_frames(&frames),
        0,
        "foot points slid over the floor"
    );
    assert!(
        root_y >= hold - 1e-3,
        "the root at {root_y} m, the hold {hold} m"
    );
}

#[test]
fn the_balance_offset_stays_while_the_body_stands_on_one_foot() {
    // The offset that put the body over a lone held foot returns towards zero unless the body
    // has stood on that one foot for longer than a step's single support.
    let mut g = grounder();
    g.balance = Vec3::new(0.3, 0.0, 0.0);
    g.one_foot = Some((0, 1.0));
    assert_eq!(g.carried(DT), Vec3::new(0.3, 0.0, 0.0));
    g.one_foot = Some((0, 0.2));
    let back = g.carried(DT);
    assert!(back.x < 0.3 && back.x > 0.3 - 0.04 * 0.3 - 1e-6, "{back}");
    g.balance = Vec3::new(0.3, 0.0, 0.0);
    g.one_foot = None;
    assert!(g.carried(DT).x < 0.3);
}

#[test]
fn a_planted_foot_out_of_reach_behind_the_hip_rolls_onto_its_toes() {
    // A straight standing leg asked to hold its ankle 0.25 m behind where it stands, at the same
    // height: out of reach flat, so the foot turns about its toe tip (held where it is) until
    // the ankle is within reach, heel up by less than the most allowed. The same foot asked to
    // stand 0.25 m ahead (toes pointing away from the hip) stays flat.
    let mut g = grounder();
    let rest = vec![Quat::IDENTITY; Skeleton::h36m().len()];
    g.forward_kinematics(Vec3::new(0.0, 0.9, 0.0), &rest);
    let side = usize::from(g.parts.legs[1].ankle == 3);
    let leg = g.parts.legs[side].clone();
    let (hip, knee, ankle) = (
        g.positions[leg.hip],
        g.positions[leg.knee],
        g.positions[leg.ankle],
    );
    let reach = (knee - hip).length() + (ankle - knee).length();
    let tip = *leg
        .foot_points
        .iter()
        .max_by(|&&a, &&b| {
            (g.positions[a] - ankle)
                .length()
                .total_cmp(&(g.positions[b] - ankle).length())
        })
        .unwrap();
    let toe = g.positions[tip] - ankle;
    let forward = Vec3::new(toe.x, 0.0, toe.z).normalize();
    let flat = Quat::IDENTITY;

    let behind = ankle - forward * 0.25;
    assert!((behind - hip).length() > reach);
    let (target, rotation) = g.heel_rise(side, behind, flat, Quat::IDENTITY);
    assert!(
        (target - hip).length() <= reach + 1e-4,
        "the ankle still {} m from the hip, reach {reach}",
        (target - hip).length()
    );
    let tip_after = target + rotation * toe;
    assert!(
        (tip_after - (behind + toe)).length() < 1e-4,
        "the toe tip moved {} m",
        (tip_after - (behind + toe)).length()
    );
    let heel_up = (rotation * forward).y.asin();
    assert!(
        heel_up < -0.05 && heel_up > -0.7 - 1e-4,
        "the foot pitched {heel_up} rad (toes down is negative)"
    );
    assert!(target.y > behind.y + 0.01, "the ankle did not rise");

    let ahead = ankle + forward * 0.25;
    assert_eq!(
        g.heel_rise(side, ahead, flat, Quat::IDENTITY),
        (ahead, flat)
    );
    // Within reach: unchanged.
    assert_eq!(
        g.heel_rise(side, ankle, flat, Quat::IDENTITY),
        (ankle, flat)
    );
}

/// An H3.6M seated pose: thighs forward by `hip` radians of flexion, knees bent back to
/// vertical shins when `hip` is a right angle, feet flat.
fn seated(hip: f32) -> Vec<Quat> {
    let mut q = vec![Quat::IDENTITY; Skeleton::h36m().len()];
    for (h, k) in [(1, 2), (6, 7)] {
        q[h] = Quat::from_rotation_x(-hip);
        q[k] = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
    }
    q
}

/// A grounder that saw 1 s of a seated seed (root 0.454 m over the feet, 0.443 m behind them).
fn seated_grounder(config: GroundingConfig) -> Grounder {
    let mut g = Grounder::new(&Skeleton::h36m(), 1e-3, config).unwrap();
    g.set_action(Some("sitting"));
    for _ in 0..25 {
        g.observe_seed(
            Vec3::new(0.0, 1.0, 0.0),
            &seated(std::f32::consts::FRAC_PI_2),
        );
    }
    g
}

#[test]
fn a_seated_seed_leaves_a_seat_and_a_standing_or_crouching_one_does_not() {
    let seat = seated_grounder(GroundingConfig::default()).seat().unwrap();
    assert!((seat.y - 0.454).abs() < 0.005, "{seat}");
    let off = GroundingConfig {
        seats: false,
        ..GroundingConfig::default()
    };
    assert_eq!(seated_grounder(off).seat(), None);
    // A crouch as deep keeps the root over the feet: no seat.
    let mut g = grounder();
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 0.6, 0.0), &crouch(1.6));
    }
    assert_eq!(g.seat(), None);
    let mut g = grounder();
    for _ in 0..25 {
        g.observe_seed(Vec3::new(0.0, 1.0, 0.0), &crouch(0.0));
    }
    assert_eq!(g.seat(), None);
}

#[test]
fn a_seated_body_that_leans_back_and_lifts_its_legs_stays_on_its_seat() {
    let mut g = seated_grounder(GroundingConfig::default());
    let seat = g.seat().unwrap();
    // Over 2 s the model raises its thighs to 130 degrees of flexion (feet off the floor, in
    // front), sinks its root and slides it 0.3 m back.
    let mut start: Option<Vec3> = None;
    for t in 0..50 {
        let s = t as f32 / 49.0;
        let hip = std::f32::consts::FRAC_PI_2 + 0.7 * s;
        let (mut root, mut rotations) = (Vec3::new(0.0, 1.0 - 0.3 * s, -0.3 * s), seated(hip));
        g.ground(&mut root, &mut rotations, DT);
        assert!(
            root.y >= seat.y - 1e-3,
            "frame {t}: root {root} under the seat {seat}"
        );
        let first = *start.get_or_insert(root);
        let slid = Vec3::new(root.x - first.x, 0.0, root.z - first.z).length();
        assert!(slid < 0.01, "frame {t}: the seated root slid {slid} m");
    }
}

#[test]
fn a_seated_body_stands_up_off_its_seat_onto_its_feet() {
    let mut g = seated_grounder(GroundingConfig::default());
    let seat = g.seat().unwrap();
    let mut root_y = 0.0;
    for _ in 0..25 {
        let (mut root, mut rotations) = (Vec3::new(0.0, 1.0, 0.0), crouch(0.0));
        g.ground(&mut root, &mut rotations, DT);
        root_y = root.y;
    }
    assert!(
        root_y > seat.y + 0.3,
        "standing: the root at {root_y} m, the seat at {} m",
        seat.y
    );
}
