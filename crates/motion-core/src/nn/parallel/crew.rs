//! The shard crew: helper threads that run a sharded step's other shards and **spin** between
//! steps instead of sleeping.
//!
//! A sharded step ([`crate::model::BatchGenerator`]) hands its shards after the first to other
//! threads and waits for them. Through rayon, every step wakes a sleeping worker and the caller
//! sleeps until the worker is done; each wake is a futex call and, on a virtual machine whose
//! idle vCPU has halted, an inter-processor interrupt. On a 2-vCPU Intel Xeon (Firecracker VM)
//! that hand-off measured 60-70 µs per step: 103 µs of work split in two took 163-180 µs through
//! `rayon::in_place_scope` and 113-122 µs between two spinning threads. The crew's helpers spin
//! on an atomic for [`SPIN`] after each job, so a step that follows within that time is handed
//! over with two cache-line transfers; after it they park, and the next step unparks them.
//!
//! One crew per process, started at the first sharded step called from outside a rayon pool:
//! one helper thread fewer than the current rayon pool has threads (`RAYON_NUM_THREADS`), so
//! caller and helpers are as many threads as the pool. One step uses it at a time; a step that
//! finds it busy (another thread's generator stepping at the same moment), or with more shards
//! than threads, goes through rayon as before ([`run`] returns `false`). Posting a job and
//! waiting allocate nothing. `MOTION_CREW=off` in the environment keeps the crew from starting
//! (several processes sharing few cores may prefer no spinning threads): every step then runs
//! as it would without it.
use std::cell::UnsafeCell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// How long a helper spins after its last job before it parks. A game stepping its characters
/// once per model frame (every 40 ms at 25 Hz) then spends about this much of a core per step
/// spinning; back-to-back steps (`predict`, `eval`, `bench`, a crowd catching up) never park.
pub const SPIN: Duration = Duration::from_micros(1000);

/// A job: called once per helper with the helper's number (1-based; the caller is 0).
type Job = dyn Fn(usize) + Sync;

/// What a helper and the caller share.
struct Slot {
    /// Incremented by the caller to post a job.
    epoch: AtomicU64,
    /// Set to the epoch of the last job the helper finished.
    done: AtomicU64,
    /// The posted job: written by the caller only while the helper is idle (`done == epoch`),
    /// read by the helper after it sees the new epoch.
    job: UnsafeCell<Option<*const Job>>,
    /// The helper is parked (or about to park): the caller unparks it after posting.
    parked: AtomicBool,
    /// The last job panicked on this helper.
    panicked: AtomicBool,
    thread: OnceLock<Thread>,
}

// SAFETY: `job` is written by the caller only while the helper is idle (the caller waited for
// `done == epoch` before posting again) and read by the helper only after the Release store of
// the epoch that follows the write; the pointee is `Sync` and outlives the job (the caller
// waits for `done` before `run` returns).
unsafe impl Sync for Slot {}
// SAFETY: as above; the raw pointer is only dereferenced under that protocol.
unsafe impl Send for Slot {}

/// The process's crew.
pub(crate) struct Crew {
    slots: Vec<Arc<Slot>>,
    busy: AtomicBool,
    /// The process the helpers run in: a child made by `fork` has none of them.
    pid: u32,
}

impl Crew {
    /// The crew, started at the first call with one helper fewer than the rayon pool's threads;
    /// `None` when the pool has one thread or a helper could not be started.
    fn get() -> Option<&'static Crew> {
        static CREW: OnceLock<Option<Crew>> = OnceLock::new();
        CREW.get_or_init(|| {
            if std::env::var("MOTION_CREW").is_ok_and(|v| v.eq_ignore_ascii_case("off")) {
                return None;
            }
            let helpers = rayon::current_num_threads().saturating_sub(1);
            if helpers == 0 {
                return None;
            }
            let mut slots = Vec::with_capacity(helpers);
            for index in 1..=helpers {
                let slot = Arc::new(Slot {
                    epoch: AtomicU64::new(0),
                    done: AtomicU64::new(0),
                    job: UnsafeCell::new(None),
                    parked: AtomicBool::new(false),
                    panicked: AtomicBool::new(false),
                    thread: OnceLock::new(),
                });
                let mine = Arc::clone(&slot);
                let handle = std::thread::Builder::new()
                    .name(format!("motion-crew-{index}"))
                    .spawn(move || helper(&mine, index))
                    .ok()?;
                let _ = slot.thread.set(handle.thread().clone());
                slots.push(slot);
            }
            Some(Crew {
                slots,
                busy: AtomicBool::new(false),
                pid: std::process::id(),
            })
        })
        .as_ref()
    }

    /// Threads of a step run by the crew: the caller and its helpers.
    pub(crate) fn threads() -> usize {
        Self::get().map_or(1, |c| c.slots.len() + 1)
    }
}

/// Runs `job(0)` on the calling thread and `job(1..parts)` on the crew's helpers, and returns
/// when all are done: `true`. Returns `false` without running anything when the crew cannot
/// take it (no helpers, fewer helpers than `parts - 1`, busy with another thread's step, or
/// called in a child process made by `fork`, where the helpers do not exist);
/// the caller then runs the parts its own way. A panic in a helper's part panics here.
pub(crate) fn run<'a>(parts: usize, job: &'a (dyn Fn(usize) + Sync + 'a)) -> bool {
    let Some(crew) = Crew::get() else {
        return false;
    };
    if parts < 2 || parts - 1 > crew.slots.len() || crew.pid != std::process::id() {
        return false;
    }
    if crew
        .busy
        .compare_exchange(false, true, Ordering::Acquire, Ordering::Relaxed)
        .is_err()
    {
        return false;
    }
    // SAFETY: only the lifetime is erased; `run` waits below until every helper that got the
    // pointer has finished with it (its `done` reached the posted epoch).
    let job_ptr: *const Job =
        unsafe { std::mem::transmute::<&'a (dyn Fn(usize) + Sync + 'a), &'static Job>(job) };
    let helpers = &crew.slots[..parts - 1];
    for slot in helpers {
        let epoch = slot.epoch.load(Ordering::Relaxed) + 1;
        // SAFETY: the helper is idle (every earlier job was waited for), so nothing reads `job`.
        unsafe { *slot.job.get() = Some(job_ptr) };
        slot.epoch.store(epoch, Ordering::SeqCst);
        if slot.parked.load(Ordering::SeqCst) {
            if let Some(t) = slot.thread.get() {
                t.unpark();
            }
        }
    }
    let mine = catch_unwind(AssertUnwindSafe(|| job(0)));
    let mut helper_panicked = false;
    for slot in helpers {
        // This thread wrote the epoch (the crew's only writer while `busy`).
        let epoch = slot.epoch.load(Ordering::Relaxed);
        wait_until(|| slot.done.load(Ordering::Acquire) == epoch);
        helper_panicked |= slot.panicked.swap(false, Ordering::Relaxed);
    }
    crew.busy.store(false, Ordering::Release);
    if let Err(payload) = mine {
        std::panic::resume_unwind(payload);
    }
    assert!(
        !helper_panicked,
        "a shard of the step panicked on a crew thread"
    );
    true
}

/// Spins until `ready`, yielding the core now and then after [`SPIN`] (the other parts are
/// usually as long as the caller's own, so this is short).
fn wait_until(ready: impl Fn() -> bool) {
    let start = Instant::now();
    let mut spins = 0u32;
    while !ready() {
        spins = spins.wrapping_add(1);
        if spins.is_multiple_of(256) && start.elapsed() > SPIN {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }
}

/// A helper's loop: wait for a new epoch (spinning for [`SPIN`], then parked), run the job with
/// its number, report it done.
fn helper(slot: &Slot, index: usize) {
    let mut seen = 0u64;
    loop {
        let mut start = Instant::now();
        let mut spins = 0u32;
        let epoch = loop {
            let e = slot.epoch.load(Ordering::Acquire);
            if e != seen {
                break e;
            }
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(256) && start.elapsed() > SPIN {
                slot.parked.store(true, Ordering::SeqCst);
                if slot.epoch.load(Ordering::SeqCst) == seen {
                    std::thread::park();
                }
                slot.parked.store(false, Ordering::SeqCst);
                start = Instant::now();
            } else {
                std::hint::spin_loop();
            }
        };
        seen = epoch;
        // SAFETY: the caller wrote the job before its SeqCst store of `epoch`, which the Acquire
        // load above observed; it stays valid until `done` reaches `epoch`.
        let job = unsafe { *slot.job.get() };
        if let Some(job) = job {
            // SAFETY: see above.
            let job = unsafe { &*job };
            if catch_unwind(AssertUnwindSafe(|| job(index))).is_err() {
                slot.panicked.store(true, Ordering::Relaxed);
            }
        }
        slot.done.store(epoch, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;
    use std::sync::Mutex;

    /// The crew is one per process: tests that need it idle take turns.
    static TURN: Mutex<()> = Mutex::new(());

    #[test]
    fn every_part_runs_once_on_its_own_thread() {
        let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
        let threads = Crew::threads();
        if threads < 2 {
            eprintln!("skipped: one thread");
            return;
        }
        for round in 0..200 {
            let hits: Vec<AtomicUsize> = (0..threads).map(|_| AtomicUsize::new(0)).collect();
            let ids = Mutex::new(Vec::new());
            let ran = run(threads, &|k| {
                hits[k].fetch_add(round + 1, Ordering::Relaxed);
                ids.lock().unwrap().push(std::thread::current().id());
            });
            assert!(ran);
            for h in &hits {
                assert_eq!(h.load(Ordering::Relaxed), round + 1);
            }
            let mut ids = ids.into_inner().unwrap();
            ids.sort_by_key(|id| format!("{id:?}"));
            ids.dedup();
            assert_eq!(ids.len(), threads, "each part on its own thread");
            if round % 50 == 0 {
                std::thread::sleep(SPIN * 3); // the helpers park; the next post must wake them
            }
        }
    }

    #[test]
    fn more_parts_than_threads_or_a_busy_crew_are_declined() {
        let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
        let threads = Crew::threads();
        assert!(!run(threads + 1, &|_| panic!("must not run")));
        assert!(!run(1, &|_| panic!("must not run")));
        if threads < 2 {
            return;
        }
        let inner = AtomicBool::new(true);
        assert!(run(2, &|k| {
            if k == 0 {
                // The crew is busy with this very step: a nested request is declined.
                inner.store(run(2, &|_| ()), Ordering::Relaxed);
            }
        }));
        assert!(!inner.load(Ordering::Relaxed));
    }

    #[test]
    fn a_panicking_part_panics_the_caller_and_the_crew_keeps_working() {
        let _turn = TURN.lock().unwrap_or_else(|e| e.into_inner());
        if Crew::threads() < 2 {
            return;
        }
        let result = catch_unwind(|| {
            run(2, &|k| {
                if k == 1 {
                    panic!("part 1 fails");
                }
            })
        });
        assert!(result.is_err());
        let count = AtomicUsize::new(0);
        assert!(run(2, &|_| {
            count.fetch_add(1, Ordering::Relaxed);
        }));
        assert_eq!(count.load(Ordering::Relaxed), 2);
    }
}
