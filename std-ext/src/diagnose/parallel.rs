//! Independent jobs side by side on a few cores ([`map`]), for the
//! hypotheses of the bank: scoped threads and a shared counter, no pool.

use std::sync::atomic::{AtomicUsize, Ordering};

/// The cores to use: those the operating system offers (1 when it cannot
/// tell).
pub fn available_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `f` of every item, in the order of `items`, computed on up to
/// `threads` scoped threads that take the items in turn (the first items
/// first: put the longest jobs there). With one thread (or one item) on
/// the calling thread alone. A panic in a job is resumed on the caller.
pub fn map<T: Sync, R: Send>(items: &[T], threads: usize, f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = threads.clamp(1, items.len().max(1));
    if threads == 1 {
        return items.iter().map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(item) = items.get(i) else {
                return done;
            };
            done.push((i, f(item)));
        }
    };
    let mut out: Vec<(usize, R)> = Vec::with_capacity(items.len());
    std::thread::scope(|s| {
        let helpers: Vec<_> = (1..threads).map(|_| s.spawn(work)).collect();
        out.extend(work());
        for h in helpers {
            match h.join() {
                Ok(done) => out.extend(done),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
    });
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_order_on_any_number_of_threads() {
        let items: Vec<u64> = (0..37).collect();
        let f = |&x: &u64| (0..x * 1000).fold(x, |a, b| a.wrapping_mul(31).wrapping_add(b));
        let one = map(&items, 1, f);
        for threads in [2, 3, 8, 100] {
            assert_eq!(map(&items, threads, f), one);
        }
        assert!(map(&[] as &[u64], 4, f).is_empty());
    }
}
