//! The fast paths agree with the definitions: NPSS (real-input FFT, half spectra, one pass)
//! against a naive DFT to 1e-9 on shapes and inputs that stress its shortcuts, and every exact
//! nearest-neighbour index against the naive scan, bit for bit, on motion-like words, random
//! words, duplicates and consecutive query words.
use motion_metrics::ndms::index::{nearest_naive, NearestIndex, Neighbour};
use motion_metrics::ndms::{word, NdmsConfig};
use motion_metrics::reference::npss_naive;
use motion_metrics::{MetricError, NnMethod, Npss, SpectrumPower};
use ndarray::{s, Array3};

/// Deterministic numbers in [-1, 1) (splitmix64).
fn noise(i: u64) -> f64 {
    let mut z = i
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(0x2545_F491_4F6C_DD1D);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The naive reference of the library (one copy for every accuracy test).
fn naive_npss(gt: &Array3<f64>, pred: &Array3<f64>, real_only: bool) -> f64 {
    npss_naive(gt.view(), pred.view(), real_only)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

fn signals(shape: (usize, usize, usize), salt: u64) -> Array3<f64> {
    Array3::from_shape_fn(shape, |(i, t, j)| {
        let key = salt * 7919 + (i * shape.2 + j) as u64;
        (0.3 * t as f64 * (1.0 + noise(key)) + 3.0 * noise(key + 1)).sin() + 0.2 * noise(key + 2)
    })
}

#[test]
fn npss_agrees_with_a_naive_dft_on_odd_even_and_tiny_lengths() {
    for frames in [1, 2, 3, 4, 5, 7, 16, 25, 31, 50, 64] {
        for dims in [1, 3, 8, 9, 17] {
            let gt = signals((3, frames, dims), 1);
            let pred = signals((3, frames, dims), 2);
            let mut npss = Npss::new();
            for (power, real_only) in [
                (SpectrumPower::Modulus, false),
                (SpectrumPower::RealPart, true),
            ] {
                let fast = npss.score(gt.view(), pred.view(), power).unwrap();
                let naive = naive_npss(&gt, &pred, real_only);
                assert!(
                    close(fast, naive),
                    "T={frames} D={dims} {power:?}: {fast} vs {naive}"
                );
            }
        }
    }
}

#[test]
fn npss_of_zero_constant_and_tiny_dims_follows_the_definition() {
    // Dims 0-2 of the ground truth are zero (as the H3.6M protocol zeroes the root), the
    // prediction has a zero dim, a constant dim and one 1e-12 times smaller than the others.
    let mut gt = signals((4, 20, 6), 3);
    let mut pred = signals((4, 20, 6), 4);
    gt.slice_mut(s![.., .., 0..3]).fill(0.0);
    pred.slice_mut(s![.., .., 3]).fill(0.0);
    pred.slice_mut(s![.., .., 4]).fill(2.5);
    pred.slice_mut(s![.., .., 5]).mapv_inplace(|v| 1e-12 * v);
    for (power, real_only) in [
        (SpectrumPower::Modulus, false),
        (SpectrumPower::RealPart, true),
    ] {
        let fast = Npss::new().score(gt.view(), pred.view(), power).unwrap();
        assert!(close(fast, naive_npss(&gt, &pred, real_only)), "{power:?}");
    }
}

#[test]
fn npss_reads_strided_views_like_owned_arrays() {
    let gt = signals((5, 40, 9), 5);
    let pred = signals((5, 40, 9), 6);
    // Every second frame and every second dim: neither axis is contiguous.
    let (gv, pv) = (gt.slice(s![.., ..;2, ..;2]), pred.slice(s![.., ..;2, ..;2]));
    let (go, po) = (gv.to_owned(), pv.to_owned());
    let mut npss = Npss::new();
    let strided = npss.score(gv, pv, SpectrumPower::Modulus).unwrap();
    let owned = npss
        .score(go.view(), po.view(), SpectrumPower::Modulus)
        .unwrap();
    assert_eq!(strided, owned);
    assert!(close(owned, naive_npss(&go, &po, false)));
}

#[test]
fn npss_names_the_first_non_finite_value() {
    let gt = signals((3, 10, 4), 7);
    let mut pred = signals((3, 10, 4), 8);
    pred[[2, 7, 1]] = f64::NAN;
    pred[[2, 8, 3]] = f64::INFINITY;
    match Npss::new().score(gt.view(), pred.view(), SpectrumPower::Modulus) {
        Err(MetricError::NonFinite { what, index }) => {
            assert_eq!(what, "prediction");
            assert_eq!(index, vec![2, 7, 1]);
        }
        other => panic!("{other:?}"),
    }
    let mut gt = gt;
    gt[[0, 0, 0]] = f64::NEG_INFINITY;
    assert!(matches!(
        Npss::new().score(gt.view(), pred.view(), SpectrumPower::RealPart),
        Err(MetricError::NonFinite { what, .. }) if what == "ground truth"
    ));
}

#[test]
fn npss_result_does_not_depend_on_the_thread_count() {
    let gt = signals((64, 30, 5), 9);
    let pred = signals((64, 30, 5), 10);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| Npss::new().score(gt.view(), pred.view(), SpectrumPower::Modulus))
        .unwrap();
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| Npss::new().score(gt.view(), pred.view(), SpectrumPower::Modulus))
        .unwrap();
    assert_eq!(one, three);
}

const METHODS: [NnMethod; 3] = [
    NnMethod::BruteForce,
    NnMethod::PcaKdTree,
    NnMethod::PoseBound,
];

/// 32-joint positions (mm) of a walk-like motion: joints swing around their rest place while the
/// body moves forward and turns.
fn walk(frames: usize, salt: u64) -> Array3<f64> {
    Array3::from_shape_fn((frames, 32, 3), |(t, j, c)| {
        let key = salt * 997 + (j * 3 + c) as u64;
        let t = t as f64;
        let rest = 400.0 * noise(key + 101) + if c == 1 { 900.0 } else { 0.0 };
        let swing = 120.0 * (0.25 * t * (1.0 + 0.3 * noise(key)) + 6.0 * noise(key + 5)).sin();
        let forward = match c {
            0 => 25.0 * t * (0.01 * t).cos(),
            2 => 25.0 * t * (0.01 * t).sin(),
            _ => 0.0,
        };
        rest + swing + forward
    })
}

fn words_of(sequences: &[Array3<f64>], config: &NdmsConfig) -> Vec<f64> {
    let mut words = Vec::new();
    for s in sequences {
        word::append_all_words(s.view(), config, &mut words);
    }
    words
}

fn check_all_methods(words: &[f64], dim: usize, frames: usize, queries: &[f64]) {
    let expected: Vec<Neighbour> = queries
        .chunks_exact(dim)
        .map(|q| nearest_naive(words, dim, q))
        .collect();
    for method in METHODS {
        let index = NearestIndex::build_frames(method, words.to_vec(), dim, frames);
        assert_eq!(index.nearest_batch(queries), expected, "{method:?}");
        let single = NearestIndex::build(method, words.to_vec(), dim);
        assert_eq!(
            single.nearest_batch(queries),
            expected,
            "{method:?}, 1 frame"
        );
    }
}

#[test]
fn indexes_agree_with_the_naive_scan_on_motion_words() {
    let config = NdmsConfig::h36m();
    let database = [walk(300, 1), walk(220, 2)];
    let words = words_of(&database, &config);
    // Consecutive words of other motions (the evaluation's case), and words of the database
    // itself (distance 0) shifted by a little.
    let mut queries = words_of(&[walk(60, 3), walk(40, 4)], &config);
    let dim = config.word_len();
    for (k, w) in words.chunks_exact(dim).step_by(37).enumerate() {
        queries.extend(w.iter().map(|x| x + 1e-3 * noise(k as u64)));
        queries.extend_from_slice(w);
    }
    check_all_methods(&words, dim, config.kappa, &queries);
}

#[test]
fn indexes_agree_with_the_naive_scan_on_duplicates_and_random_words() {
    // Every word twice (ties: the lower index wins) and words of independent noise.
    let (dim, frames) = (24, 4);
    let base: Vec<f64> = (0..150 * dim).map(|i| 10.0 * noise(i as u64)).collect();
    let mut words = base.clone();
    words.extend_from_slice(&base);
    let mut queries: Vec<f64> = (0..40 * dim)
        .map(|i| 10.0 * noise(9_999 + i as u64))
        .collect();
    queries.extend_from_slice(&base[5 * dim..9 * dim]);
    check_all_methods(&words, dim, frames, &queries);
}

#[test]
fn indexes_agree_with_the_naive_scan_on_one_word_and_on_flat_words() {
    let dim = 12;
    let one: Vec<f64> = (0..dim).map(|i| i as f64).collect();
    let queries: Vec<f64> = (0..5 * dim).map(|i| noise(i as u64)).collect();
    check_all_methods(&one, dim, 3, &queries);
    // All words equal in every frame (no motion: ρ = 0) and at one of two places.
    let flat: Vec<f64> = (0..60)
        .flat_map(|w| std::iter::repeat_n((w % 2) as f64, dim))
        .collect();
    check_all_methods(&flat, dim, 4, &queries);
}

#[test]
fn database_scores_match_brute_force_scores() {
    use motion_metrics::NdmsDatabase;
    let config = NdmsConfig::h36m();
    let database = [walk(200, 5), walk(150, 6)];
    let views: Vec<_> = database.iter().map(|d| d.view()).collect();
    let forecasts = [walk(30, 7), walk(30, 8)];
    let forecast_views: Vec<_> = forecasts.iter().map(|f| f.view()).collect();
    let reports: Vec<_> = METHODS
        .iter()
        .map(|&m| {
            NdmsDatabase::from_sequences(config.clone(), &views, m)
                .unwrap()
                .score_forecasts(&forecast_views, None)
                .unwrap()
        })
        .collect();
    for r in &reports[1..] {
        assert_eq!(r, &reports[0]);
    }
    // A database rebuilt from another's words (shared between processes) scores the same.
    let built = NdmsDatabase::from_sequences(config.clone(), &views, METHODS[0]).unwrap();
    for m in METHODS {
        let shared = NdmsDatabase::from_words(config.clone(), built.words().to_vec(), m).unwrap();
        assert_eq!(shared.len(), built.len());
        let report = shared.score_forecasts(&forecast_views, None).unwrap();
        assert_eq!(report, reports[0]);
    }
    assert!(NdmsDatabase::from_words(config.clone(), vec![0.0; 5], METHODS[0]).is_err());
    assert!(NdmsDatabase::from_words(
        config,
        vec![f64::NAN; built.config().word_len()],
        METHODS[0]
    )
    .is_err());
}
