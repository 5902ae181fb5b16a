//! How many threads a layer's products and element-wise loops may split over.
//!
//! A product or gate update large enough to pay for a fork is split over the current rayon pool.
//! When the caller has already split the work at a coarser level (a batch of characters divided
//! into shards, one per thread: [`crate::model::BatchGenerator`]), splitting again inside each
//! shard only adds fork-join round trips, so the shard runs its layers inside [`serial`].

use std::cell::Cell;

thread_local! {
    static SERIAL: Cell<bool> = const { Cell::new(false) };
}

/// Threads the layers called on this thread may use: 1 inside [`serial`], else the current
/// rayon pool's size.
pub fn threads() -> usize {
    if SERIAL.with(Cell::get) {
        1
    } else {
        rayon::current_num_threads()
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
        assert_eq!(outer, rayon::current_num_threads());
        serial(|| {
            assert_eq!(threads(), 1);
            serial(|| assert_eq!(threads(), 1));
            assert_eq!(threads(), 1);
        });
        assert_eq!(threads(), outer);
    }
}
