//! How many threads a layer's products and element-wise loops may split over.
//!
//! A product or gate update large enough to pay for a fork is split over the current rayon pool.
//! When the caller has already split the work at a coarser level (a batch of characters divided
//! into shards, one per thread: [`crate::model::BatchGenerator`]), splitting again inside each
//! shard only adds fork-join round trips, so the shard runs its layers inside [`serial`].
//!
//! Without the crate's `parallel` feature (a thread-free build, e.g. for a browser), `pool` is
//! a serial stand-in for the few rayon calls the crate makes: one thread, every "parallel"
//! iterator a plain one, every join and spawn run in place.

use std::cell::Cell;

#[cfg(feature = "parallel")]
pub(crate) mod crew;

thread_local! {
    static SERIAL: Cell<bool> = const { Cell::new(false) };
    static CREW_PRODUCTS: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with the large products this thread calls split by output columns between it and
/// the crew's helpers ([`crew`]; the same halves on the same threads every call, so each core
/// keeps reading its own half of every weight). Only from a thread outside any rayon pool and
/// outside [`serial`]; elsewhere, or when the crew is busy, products run as without it.
pub fn crew_products<R>(f: impl FnOnce() -> R) -> R {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            CREW_PRODUCTS.with(|s| s.set(self.0));
        }
    }
    let _restore = Restore(CREW_PRODUCTS.with(|s| s.replace(cfg!(feature = "parallel"))));
    f()
}

/// Whether this thread's products may split over the crew now (see [`crew_products`]).
#[cfg(feature = "parallel")]
pub(crate) fn crew_products_enabled() -> bool {
    CREW_PRODUCTS.with(Cell::get) && threads() > 1 && pool::current_thread_index().is_none()
}

/// The thread pool the crate splits work over: rayon with the `parallel` feature.
#[cfg(feature = "parallel")]
pub(crate) mod pool {
    pub(crate) use rayon::{current_num_threads, current_thread_index, join, prelude, scope};
    use std::sync::OnceLock;

    /// Runs `op` on the calling thread with a scope whose spawned jobs run on the threads that
    /// share a sharded step with its caller (a batch's shards, see
    /// [`crate::model::BatchGenerator`]): the caller advances one shard and the scope's jobs the
    /// others.
    ///
    /// Called from a thread of a rayon pool, the jobs go to that pool (the caller is one of its
    /// threads, and takes back a job no other thread has started). From any other thread (a
    /// game's main loop, the CLI) they go to the current pool, or with `helpers` to the crate's
    /// **shard helpers**: a pool of one thread fewer than the current pool's (created at the
    /// first such call), so that the caller and the helpers together are as many threads as the
    /// pool has. The whole pool leaves one thread more than there are shards, which made 1 %
    /// of long steps about twice the median, while short steps gain from it (a spare thread
    /// still spinning picks a shard up sooner than a sleeping helper wakes), so the caller
    /// chooses by the shard's size (the rule and its measurements:
    /// `model::batch::SHARD_HELPERS_MIN_MACS`).
    pub(crate) fn shard_scope<'scope, OP, R>(helpers: bool, op: OP) -> R
    where
        OP: FnOnce(&rayon::Scope<'scope>) -> R,
    {
        if helpers && current_thread_index().is_none() {
            if let Some(pool) = shard_helpers() {
                return pool.in_place_scope(op);
            }
        }
        rayon::in_place_scope(op)
    }

    /// The shard helpers (`None` when their threads could not be started: the current pool
    /// runs the shards then).
    fn shard_helpers() -> Option<&'static rayon::ThreadPool> {
        static HELPERS: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
        HELPERS
            .get_or_init(|| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(current_num_threads().saturating_sub(1).max(1))
                    .thread_name(|i| format!("motion-shard-{i}"))
                    .build()
                    .ok()
            })
            .as_ref()
    }
}

/// The thread pool the crate splits work over: without the `parallel` feature, the calling
/// thread alone (same call shapes as rayon's, run serially).
#[cfg(not(feature = "parallel"))]
pub(crate) mod pool {
    use std::marker::PhantomData;

    /// One thread: the caller's.
    pub(crate) fn current_num_threads() -> usize {
        1
    }

    /// Never on a pool thread.
    pub(crate) fn current_thread_index() -> Option<usize> {
        None
    }

    /// Runs `a` then `b`.
    pub(crate) fn join<A, B, RA, RB>(a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA,
        B: FnOnce() -> RB,
    {
        (a(), b())
    }

    /// A scope whose spawned jobs run at once on the caller's thread.
    pub(crate) struct Scope<'scope>(PhantomData<&'scope mut &'scope ()>);

    impl<'scope> Scope<'scope> {
        /// Runs `job` now.
        pub(crate) fn spawn<F: FnOnce(&Scope<'scope>) + 'scope>(&self, job: F) {
            job(self)
        }
    }

    /// Runs `op` with a serial [`Scope`].
    pub(crate) fn scope<'scope, OP, R>(op: OP) -> R
    where
        OP: FnOnce(&Scope<'scope>) -> R,
    {
        op(&Scope(PhantomData))
    }

    /// Runs `op` with a serial [`Scope`] (the parallel build's hands the scope's jobs to the
    /// threads sharing a sharded step).
    pub(crate) fn shard_scope<'scope, OP, R>(_helpers: bool, op: OP) -> R
    where
        OP: FnOnce(&Scope<'scope>) -> R,
    {
        op(&Scope(PhantomData))
    }

    /// Rayon's slice iterator names, as std's sequential iterators.
    pub(crate) mod prelude {
        /// `par_iter` and `par_chunks_mut` on slices, sequentially.
        pub(crate) trait SerialSlice<T> {
            fn par_iter(&self) -> std::slice::Iter<'_, T>;
            fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T>;
        }

        impl<T> SerialSlice<T> for [T] {
            fn par_iter(&self) -> std::slice::Iter<'_, T> {
                self.iter()
            }
            fn par_chunks_mut(&mut self, size: usize) -> std::slice::ChunksMut<'_, T> {
                self.chunks_mut(size)
            }
        }
    }
}

/// Threads the layers called on this thread may use: 1 inside [`serial`], else the current
/// rayon pool's size (1 without the `parallel` feature).
pub fn threads() -> usize {
    if SERIAL.with(Cell::get) {
        1
    } else {
        pool::current_num_threads()
    }
}

/// Runs `f` with every layer product and gate update on the calling thread.
pub fn serial<R>(f: impl FnOnce() -> R) -> R {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            SERIAL.with(|s| s.set(self.0));
        }
    }
    let _restore = Restore(SERIAL.with(|s| s.replace(true)));
    f()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serial_scopes_nest_and_restore() {
        let outer = threads();
        assert_eq!(outer, pool::current_num_threads());
        serial(|| {
            assert_eq!(threads(), 1);
            serial(|| assert_eq!(threads(), 1));
            assert_eq!(threads(), 1);
        });
        assert_eq!(threads(), outer);
    }
}
