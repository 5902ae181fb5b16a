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

thread_local! {
    static SERIAL: Cell<bool> = const { Cell::new(false) };
}

/// The thread pool the crate splits work over: rayon with the `parallel` feature.
#[cfg(feature = "parallel")]
pub(crate) mod pool {
    pub(crate) use rayon::{
        current_num_threads, current_thread_index, in_place_scope, join, prelude, scope,
    };
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
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))] // the AVX-512 row split's
    pub(crate) fn current_thread_index() -> Option<usize> {
        None
    }

    /// Runs `a` then `b`.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))] // the AVX-512 row split's
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

    /// Runs `op` with a serial [`Scope`] (rayon's runs `op` on the calling thread).
    pub(crate) fn in_place_scope<'scope, OP, R>(op: OP) -> R
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
