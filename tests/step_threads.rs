//! Batched steps and threads: a paper-size model's batch-1 step allocates nothing on any thread;
//! the row split (products split by output rows, the step on a pool thread) and shards give the
//! same frames as one piece.
//!
//! Its own test binary: the allocation counter is global (rayon's threads allocate on their own
//! stacks of calls), so no other test may run beside it.
use motion::core::model::{Architecture, BatchGenerator, ModelConfig, MotionModel, Noise};
use motion::core::nn::simd::{set_simd_path, SimdPath};
use ndarray::Array3;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

struct CountingAllocator;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; only counts calls.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn seeds(rows: usize, frames: usize) -> Array3<f32> {
    Array3::from_shape_fn((rows, frames, 99), |(b, t, d)| {
        0.3 * ((t as f32) * 0.2 + d as f32 * 0.7 + b as f32).sin()
    })
}

/// Allocations made by `steps` steps of `g` after `warm_up` steps.
fn allocations_per(g: &mut BatchGenerator, warm_up: usize, steps: usize) -> usize {
    for _ in 0..warm_up {
        g.step().unwrap();
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for _ in 0..steps {
        g.step().unwrap();
    }
    ALLOCATIONS.load(Ordering::Relaxed) - before
}

fn started(model: &Arc<MotionModel>, batch: usize, shards: usize) -> BatchGenerator {
    let mut g = BatchGenerator::with_shards(Arc::clone(model), batch, shards);
    let noise: Vec<Noise> = (0..batch).map(|b| Noise::Seed(b as u64)).collect();
    g.start(seeds(batch, 20).view(), &["walking"], &noise)
        .unwrap();
    g
}

#[test]
fn threaded_steps_allocate_nothing_and_shards_agree() {
    // Two threads whatever the machine, so the split paths run.
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()
        .unwrap();
    for arch in [Architecture::GruD, Architecture::VgruD] {
        let model = Arc::new(MotionModel::random(&ModelConfig::paper(arch), 3).unwrap());
        // The default batch-1 step runs in place. (Batch 256 in 2 shards forks through rayon's
        // queue every step, which allocates a block now and then: documented, not held to zero.)
        let mut g = started(&model, 1, 1);
        assert_eq!(g.shards(), 1);
        // Warm up: first steps may size lazily created state.
        let count = allocations_per(&mut g, 300, 200);
        assert_eq!(
            count, 0,
            "{arch:?} batch 1: {count} allocations in 200 steps"
        );
        // With the row split the step runs on a pool thread and gives the same frames, on
        // every SIMD path the machine has (each splits its batch-1 products by output rows).
        for path in SimdPath::available() {
            set_simd_path(path).unwrap();
            let model = Arc::new(MotionModel::random(&ModelConfig::paper(arch), 3).unwrap());
            let (mut plain, mut split) = (started(&model, 1, 1), started(&model, 1, 1));
            assert!(
                split.set_row_split(true),
                "{arch:?} {path}: the row split applies at batch 1"
            );
            for _ in 0..30 {
                let (a, b) = (plain.step().unwrap().to_owned(), split.step().unwrap());
                assert_eq!(a, b, "{arch:?} {path}: row split changes frames");
            }
        }
        set_simd_path(SimdPath::best()).unwrap();
        // Rows are independent: 3 shards of a batch of 100 give the frames of one piece, stepped
        // from this thread (more shards than the crew's two threads: they go to the crate's
        // shard helpers, one thread here, so two shards queue on it) and from a thread of a
        // rayon pool (its shards go to that pool); 2 shards of 8 rows (the crew: this thread
        // and one spinning helper) likewise.
        let inner = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        for (batch, shards) in [(100, 3), (8, 2)] {
            let mut one = started(&model, batch, 1);
            let mut outside = started(&model, batch, shards);
            let mut inside = started(&model, batch, shards);
            for _ in 0..30 {
                let a = one.step().unwrap().to_owned();
                let b = outside.step().unwrap().to_owned();
                let c = inner.install(|| inside.step().unwrap().to_owned());
                for (other, place) in [(b, "outside"), (c, "inside")] {
                    let diff = (&a - &other).iter().fold(0f32, |m, v| m.max(v.abs()));
                    assert!(
                        diff <= 1e-5,
                        "{arch:?}: {shards} shards of {batch} stepped {place} a pool differ by {diff}"
                    );
                }
            }
        }
        // Two shards handed to the crew allocate nothing per step (rayon's spawn allocates a job
        // record per handed shard; `MOTION_CREW=off` sends them there).
        if std::env::var("MOTION_CREW").is_ok_and(|v| v.eq_ignore_ascii_case("off")) {
            continue;
        }
        let count = allocations_per(&mut started(&model, 16, 2), 50, 200);
        assert_eq!(
            count, 0,
            "{arch:?} batch 16 in 2 shards: {count} allocations in 200 steps"
        );
    }
}
