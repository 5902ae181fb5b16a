//! Library-level tests of the metrics: identities, hand-computed cases (derivations written out),
//! NPSS against a naive O(T²) DFT, and both exact nearest-neighbour indexes against naive search.
use motion::metrics::ndms::index::{nearest_naive, NearestIndex};
use motion::metrics::ndms::{similarity, word, WordFrame};
use motion::metrics::reference::npss_naive;
use motion::metrics::{
    apd, apd_batch, euler_error, euler_error_at_horizons, npss, npss_reference, npss_windows,
    MetricError, NdmsConfig, NdmsDatabase, NnMethod, SpectrumPower,
};
use ndarray::{Array2, Array3, Axis};

/// splitmix64: a fixed-seed generator so the tests need no RNG crate.
struct SplitMix(u64);
impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn random_array3(rng: &mut SplitMix, shape: (usize, usize, usize)) -> Array3<f64> {
    Array3::from_shape_simple_fn(shape, || rng.uniform())
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

// ---------- NPSS ----------

/// The naive reference of the library (one copy for every accuracy test).
fn naive_npss(gt: &Array3<f64>, pred: &Array3<f64>, real_only: bool) -> f64 {
    npss_naive(gt.view(), pred.view(), real_only)
}

#[test]
fn npss_matches_a_naive_dft_to_1e9() {
    let mut rng = SplitMix(7);
    for &(n, t, d) in &[(3, 37, 5), (2, 100, 4), (1, 16, 3)] {
        let gt = random_array3(&mut rng, (n, t, d));
        let pred = random_array3(&mut rng, (n, t, d));
        let fast = npss(gt.view(), pred.view()).unwrap();
        let fast_ref = npss_reference(gt.view(), pred.view()).unwrap();
        assert!(close(fast, naive_npss(&gt, &pred, false), 1e-9), "T={t}");
        assert!(close(fast_ref, naive_npss(&gt, &pred, true), 1e-9), "T={t}");
    }
}

#[test]
fn npss_of_identical_sequences_is_zero() {
    let mut rng = SplitMix(11);
    let x = random_array3(&mut rng, (4, 50, 6));
    assert_eq!(npss(x.view(), x.view()).unwrap(), 0.0);
    assert_eq!(npss_reference(x.view(), x.view()).unwrap(), 0.0);
}

#[test]
fn npss_four_frames_by_hand() {
    // dim 0: gt x = [1,0,0,0] -> DFT [1,1,1,1], power [1,1,1,1] (total 4), normalized cumulative
    //   [.25,.5,.75,1]; pred y = [1,1,1,1] -> DFT [4,0,0,0], normalized cumulative [1,1,1,1];
    //   emd = .75 + .5 + .25 + 0 = 1.5, weight 4.
    // dim 1: gt [2,0,0,0] -> power [4,4,4,4] (total 16), cumulative [.25,.5,.75,1]; pred all zero
    //   -> zero power stays zero, cumulative [0,0,0,0]; emd = .25+.5+.75+1 = 2.5, weight 16.
    // NPSS = (4·1.5 + 16·2.5) / (4 + 16) = 46 / 20 = 2.3 (DFTs are real: both variants agree).
    let gt = Array3::from_shape_vec((1, 4, 2), vec![1., 2., 0., 0., 0., 0., 0., 0.]).unwrap();
    let pred = Array3::from_shape_vec((1, 4, 2), vec![1., 0., 1., 0., 1., 0., 1., 0.]).unwrap();
    assert!(close(npss(gt.view(), pred.view()).unwrap(), 2.3, 1e-12));
    assert!(close(
        npss_reference(gt.view(), pred.view()).unwrap(),
        2.3,
        1e-12
    ));
}

#[test]
fn npss_reference_variant_drops_the_imaginary_part() {
    // gt x = [0,1,0,0] -> DFT [1,-i,-1,i]: |X|² = [1,1,1,1] but Re(X)² = [1,0,1,0].
    // pred y = [1,0,0,0] -> DFT [1,1,1,1], power [1,1,1,1] in both variants.
    // Paper: both spectra flat -> emd 0 -> NPSS 0.
    // Reference: gt cumulative [.5,.5,1,1], pred [.25,.5,.75,1]; emd = .25+0+.25+0 = .5; NPSS .5.
    let gt = Array3::from_shape_vec((1, 4, 1), vec![0., 1., 0., 0.]).unwrap();
    let pred = Array3::from_shape_vec((1, 4, 1), vec![1., 0., 0., 0.]).unwrap();
    assert!(close(npss(gt.view(), pred.view()).unwrap(), 0.0, 1e-12));
    assert!(close(
        npss_reference(gt.view(), pred.view()).unwrap(),
        0.5,
        1e-12
    ));
}

#[test]
fn npss_is_bounded_and_undefined_for_zero_power_ground_truth() {
    let mut rng = SplitMix(3);
    let gt = random_array3(&mut rng, (2, 20, 3));
    let pred = random_array3(&mut rng, (2, 20, 3));
    let v = npss(gt.view(), pred.view()).unwrap();
    assert!((0.0..=19.0).contains(&v));
    let zero = Array3::<f64>::zeros((2, 20, 3));
    assert!(matches!(
        npss(zero.view(), pred.view()),
        Err(MetricError::Undefined { .. })
    ));
}

#[test]
fn npss_windows_use_their_own_dft() {
    let mut rng = SplitMix(5);
    let gt = random_array3(&mut rng, (2, 100, 3));
    let pred = random_array3(&mut rng, (2, 100, 3));
    let windows = npss_windows(gt.view(), pred.view(), SpectrumPower::Modulus).unwrap();
    let bounds: Vec<(usize, usize)> = windows
        .iter()
        .map(|w| (w.window.start, w.window.end))
        .collect();
    assert_eq!(bounds, vec![(0, 25), (25, 50), (50, 100)]);
    for w in &windows {
        let r = ndarray::s![.., w.window.start..w.window.end, ..];
        let direct = npss(gt.slice(r), pred.slice(r)).unwrap();
        assert_eq!(w.value, direct);
    }
    // A 60-frame prediction has no 2-4 s window.
    let short = gt.slice(ndarray::s![.., ..60, ..]);
    assert_eq!(
        npss_windows(short, short, SpectrumPower::RealPart)
            .unwrap()
            .len(),
        2
    );
}

#[test]
fn npss_rejects_bad_input() {
    let a = Array3::<f64>::ones((1, 4, 2));
    let b = Array3::<f64>::ones((1, 5, 2));
    assert!(matches!(
        npss(a.view(), b.view()),
        Err(MetricError::ShapeMismatch { .. })
    ));
    let mut c = a.clone();
    c[[0, 2, 1]] = f64::NAN;
    match npss(a.view(), c.view()) {
        Err(MetricError::NonFinite { index, .. }) => assert_eq!(index, vec![0, 2, 1]),
        other => panic!("{other:?}"),
    }
    let empty = Array3::<f64>::zeros((0, 4, 2));
    assert!(matches!(
        npss(empty.view(), empty.view()),
        Err(MetricError::Empty { .. })
    ));
}

// ---------- Euler error ----------

#[test]
fn euler_error_by_hand() {
    // Sequence 0: gt dims over 2 frames: dim0 [0,0] (std 0: dropped), dim1 [1,3] (std 1: kept),
    //   dim2 [5,5] (dropped). pred dim1 [1,0] -> errors frame0 |1-1| = 0, frame1 |3-0| = 3.
    // Sequence 1: gt dim0 [0,4] kept (std 2), dim1 [2,2] dropped, dim2 [0,3] kept (std 1.5);
    //   pred all zero -> frame0 sqrt(0+0) = 0, frame1 sqrt(16+9) = 5.
    // Mean over sequences: [0, 4].
    let gt = Array3::from_shape_vec(
        (2, 2, 3),
        vec![0., 1., 5., 0., 3., 5., 0., 2., 0., 4., 2., 3.],
    )
    .unwrap();
    let pred = Array3::from_shape_vec(
        (2, 2, 3),
        vec![7., 1., 2., 7., 0., 2., 0., 0., 0., 0., 0., 0.],
    )
    .unwrap();
    let e = euler_error(gt.view(), pred.view()).unwrap();
    assert_eq!(e, vec![0.0, 4.0]);
}

#[test]
fn euler_error_horizons_and_identity() {
    let mut rng = SplitMix(9);
    let gt = random_array3(&mut rng, (3, 25, 10));
    let e = euler_error(gt.view(), gt.view()).unwrap();
    assert!(e.iter().all(|&v| v == 0.0));
    let series: Vec<f64> = (0..25).map(|f| f as f64).collect();
    let h = euler_error_at_horizons(&series);
    assert_eq!(h.map(|(ms, _)| ms), [80, 160, 320, 400, 560, 1000]);
    assert_eq!(h.map(|(_, v)| v.unwrap()), [1., 3., 7., 9., 13., 24.]);
    assert_eq!(euler_error_at_horizons(&series[..10])[4].1, None);
}

// ---------- APD ----------

#[test]
fn apd_by_hand_and_identities() {
    // Points (0,0), (3,0), (0,4): pairwise distances 3, 4, 5; ordered-pair mean = 2·12 / 6 = 4.
    let s = Array2::from_shape_vec((3, 2), vec![0., 0., 3., 0., 0., 4.]).unwrap();
    assert!(close(apd(s.view()).unwrap(), 4.0, 1e-12));
    // Two points: the one distance.
    assert!(close(
        apd(s.slice(ndarray::s![..2, ..])).unwrap(),
        3.0,
        1e-12
    ));
    // Identical samples and a single sample: 0.
    let same = Array2::from_shape_vec((3, 2), vec![1., 2., 1., 2., 1., 2.]).unwrap();
    assert_eq!(apd(same.view()).unwrap(), 0.0);
    assert_eq!(apd(s.slice(ndarray::s![..1, ..])).unwrap(), 0.0);
    let batch = ndarray::stack(Axis(0), &[s.view(), same.view()]).unwrap();
    let (per, mean) = apd_batch(batch.view()).unwrap();
    assert!(close(per[0], 4.0, 1e-12) && per[1] == 0.0 && close(mean, 2.0, 1e-12));
}

// ---------- NDMS ----------

#[test]
fn ndms_of_two_three_frame_words_by_hand() {
    // One joint, κ = 3. a: (0,0,0) (1,0,0) (2,0,0) -> velocities (1,0,0), (1,0,0).
    // b: (0,0,0) (2,0,0) (2,2,0) -> velocities (2,0,0), (0,2,0).
    // t=1: cos 1, ratio 1/2 -> ½(1+1)·½ = 0.5; t=2: cos 0, ratio 1/2 -> ½(1+0)·½ = 0.25.
    // NDMS = (0.5 + 0.25) / 2 = 0.375.
    let a = [0., 0., 0., 1., 0., 0., 2., 0., 0.];
    let b = [0., 0., 0., 2., 0., 0., 2., 2., 0.];
    assert!(close(similarity::ndms(&a, &b, 3), 0.375, 1e-15));
    assert!(close(similarity::ndms(&b, &a, 3), 0.375, 1e-15));
    assert!(close(similarity::ndms(&a, &a, 3), 1.0, 1e-15));
    // Opposite directions score 0; a joint at rest in both words scores ½ (ε clamping).
    let c = [0., 0., 0., -1., 0., 0., -2., 0., 0.];
    assert!(close(similarity::ndms(&a, &c, 3), 0.0, 1e-15));
    let rest = [1.; 9];
    assert!(close(similarity::ndms(&rest, &rest, 3), 0.5, 1e-15));
}

#[test]
fn word_normalization_by_hand() {
    // Two joints (0 = left hip, 1 = right hip), y up, κ = 2; frame 0: left (1,5,1), right (1,5,3).
    // Reordered to (x, z, y): left (1,1,5), right (1,3,5). Centre (1,2,0). Left→right = (0,2):
    // heading 90°, rotate by -90°: (x,y) -> (y,-x). left-centre (0,-1,5) -> (-1,0,5);
    // right-centre (0,1,5) -> (1,0,5). Frame 1 is frame 0 moved by +2 in y (up): (-1,0,7), (1,0,7).
    let config = NdmsConfig {
        kappa: 2,
        joints: vec![0, 1],
        left_hip: 0,
        right_hip: 1,
        vertical_axis: 1,
        words_per_bin: 10,
        frame: WordFrame::Heading,
    };
    let positions = Array3::from_shape_vec(
        (2, 2, 3),
        vec![1., 5., 1., 1., 5., 3., 1., 7., 1., 1., 7., 3.],
    )
    .unwrap();
    let mut out = vec![0.0; config.word_len()];
    word::normalize_word(positions.view(), 0, &config, &mut out);
    let expected = [-1., 0., 5., 1., 0., 5., -1., 0., 7., 1., 0., 7.];
    for (a, b) in out.iter().zip(expected) {
        assert!(close(*a, b, 1e-12), "{out:?}");
    }
}

/// Smooth random motion of `joints` joints over `frames` frames where every joint always moves.
fn moving_positions(rng: &mut SplitMix, frames: usize, joints: usize) -> Array3<f64> {
    let mut p = Array3::zeros((frames, joints, 3));
    let mut velocity: Vec<f64> = (0..joints * 3)
        .map(|_| 10.0 * rng.uniform() + 20.0)
        .collect();
    for j in 0..joints {
        for c in 0..3 {
            p[[0, j, c]] = 300.0 * rng.uniform();
        }
    }
    for t in 1..frames {
        for j in 0..joints {
            for c in 0..3 {
                velocity[j * 3 + c] += 3.0 * rng.uniform();
                p[[t, j, c]] = p[[t - 1, j, c]] + velocity[j * 3 + c];
            }
        }
    }
    p
}

#[test]
fn ndms_identities_on_the_h36m_layout() {
    let mut rng = SplitMix(21);
    let reference = moving_positions(&mut rng, 60, 32);
    for method in [NnMethod::BruteForce, NnMethod::PcaKdTree] {
        let db =
            NdmsDatabase::from_sequences(NdmsConfig::h36m(), &[reference.view()], method).unwrap();
        assert_eq!(db.len(), 60 - 8 + 1);
        // Forecast = frames 20..40 of the reference, seed = frames ..20: every word is in D.
        let forecast = reference.slice(ndarray::s![20..40, .., ..]);
        let seed = reference.slice(ndarray::s![..20, .., ..]);
        let report = db.score_forecasts(&[forecast], Some(&[seed])).unwrap();
        assert!(report.exact);
        assert_eq!(report.per_word.len(), 20);
        assert_eq!(report.first_word_end, 0);
        assert!(
            report.per_word.iter().all(|&s| close(s, 1.0, 1e-12)),
            "{report:?}"
        );
        assert_eq!(report.bins.len(), 2);
        // Without the seed: F - κ + 1 words, the first ending at frame κ-1 = 7; bins 7..9, 10..19.
        let report = db.score_forecasts(&[forecast], None).unwrap();
        assert_eq!(
            (
                report.per_word.len(),
                report.first_word_end,
                report.bins.len()
            ),
            (13, 7, 2)
        );
        // A different motion scores in [0, 1].
        let other = moving_positions(&mut rng, 30, 32);
        let report = db.score_forecasts(&[other.view()], None).unwrap();
        assert!(report.per_word.iter().all(|&s| (0.0..=1.0).contains(&s)));
        assert!(report.mean < 1.0);
    }
}

#[test]
fn ndms_rejects_short_and_bad_queries() {
    let mut rng = SplitMix(2);
    let reference = moving_positions(&mut rng, 30, 32);
    let db = NdmsDatabase::from_sequences(
        NdmsConfig::h36m(),
        &[reference.view()],
        NnMethod::BruteForce,
    )
    .unwrap();
    let short = reference.slice(ndarray::s![..5, .., ..]);
    assert!(matches!(
        db.score_forecasts(&[short], None),
        Err(MetricError::TooShort { .. })
    ));
    let few_joints = Array3::<f64>::zeros((10, 5, 3));
    assert!(matches!(
        db.score_forecasts(&[few_joints.view()], None),
        Err(MetricError::InvalidConfig(_))
    ));
    let mut nan = reference.clone();
    nan[[3, 4, 1]] = f64::NAN;
    assert!(matches!(
        db.score_forecasts(&[nan.view()], None),
        Err(MetricError::NonFinite { .. })
    ));
}

#[test]
fn both_exact_indexes_agree_with_naive_search() {
    let mut rng = SplitMix(1234);
    let dim = 288;
    // Clustered words (like motion words) plus exact duplicates to exercise ties.
    let centres: Vec<Vec<f64>> = (0..20)
        .map(|_| (0..dim).map(|_| 500.0 * rng.uniform()).collect())
        .collect();
    let mut words = Vec::new();
    for i in 0..3000 {
        let c = &centres[i % centres.len()];
        words.extend(c.iter().map(|x| x + 40.0 * rng.uniform()));
    }
    let duplicate: Vec<f64> = words[17 * dim..18 * dim].to_vec();
    words.extend_from_slice(&duplicate);
    let mut queries = Vec::new();
    for i in 0..150 {
        let c = &centres[(i * 7) % centres.len()];
        queries.extend(c.iter().map(|x| x + 60.0 * rng.uniform()));
    }
    queries.extend_from_slice(&duplicate); // in D twice: the lower index must win
    queries.extend((0..dim).map(|_| 2000.0 * rng.uniform())); // far from everything
    let expected: Vec<_> = queries
        .chunks(dim)
        .map(|q| nearest_naive(&words, dim, q))
        .collect();
    assert_eq!(expected[150].index, 17);
    assert_eq!(expected[150].distance_sq, 0.0);
    for method in [NnMethod::BruteForce, NnMethod::PcaKdTree] {
        let index = NearestIndex::build(method, words.clone(), dim);
        assert_eq!(index.nearest_batch(&queries), expected, "{method:?}");
    }
}

#[test]
fn body_frame_words_are_invariant_to_rigid_transforms() {
    // The same motion in two world frames that differ by a rotation (tilt and heading) and a
    // translation, as FK of root deltas integrated from two different start frames: identical words.
    let mut rng = SplitMix(77);
    let motion = moving_positions(&mut rng, 12, 32);
    let (a, b) = (0.3f64, -0.2f64);
    let rx = [
        [1.0, 0.0, 0.0],
        [0.0, a.cos(), -a.sin()],
        [0.0, a.sin(), a.cos()],
    ];
    let ry = [
        [b.cos(), 0.0, b.sin()],
        [0.0, 1.0, 0.0],
        [-b.sin(), 0.0, b.cos()],
    ];
    let moved = Array3::from_shape_fn((12, 32, 3), |(t, j, c)| {
        let p = [motion[[t, j, 0]], motion[[t, j, 1]], motion[[t, j, 2]]];
        let q: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|k| ry[i][k] * p[k]).sum())
            .collect();
        (0..3).map(|k| rx[c][k] * q[k]).sum::<f64>() + [100.0, -50.0, 700.0][c]
    });
    let config = NdmsConfig::h36m_body_frame();
    let (mut w1, mut w2) = (vec![0.0; config.word_len()], vec![0.0; config.word_len()]);
    for start in [0, 4] {
        word::normalize_word(motion.view(), start, &config, &mut w1);
        word::normalize_word(moved.view(), start, &config, &mut w2);
        for (x, y) in w1.iter().zip(&w2) {
            assert!(close(*x, *y, 1e-9), "{x} {y}");
        }
    }
    // The heading recipe is not invariant to a tilt (it assumes gravity-aligned positions).
    let heading = NdmsConfig::h36m();
    word::normalize_word(motion.view(), 0, &heading, &mut w1);
    word::normalize_word(moved.view(), 0, &heading, &mut w2);
    assert!(w1.iter().zip(&w2).any(|(x, y)| (x - y).abs() > 1.0));
}
