//! Zeroed `f32` buffers for the rasters of the window search, reused from scan to scan.
//!
//! Every searched scan builds a likelihood raster, its block maxima and some levels' values
//! beside their siblings' (up to a few MiB each) and drops them again. Fresh zeroed memory of
//! that size comes from the system page by page: on FR079 at every 3rd scan, page faults and
//! zeroing were about 12 % of the run (`perf`). Buffers dropped by
//! [`ScoreRaster`](super::ScoreRaster), the correlative matcher and its searches go back to a
//! small per-thread free list instead and are zeroed again when taken (or, for a caller that
//! writes every value it reads, taken as they are); the values read are the same, so
//! outputs are byte-identical.

use std::cell::RefCell;

/// At most this many buffers are kept per thread (the mapping thread and the loop thread each
/// have their own list; a search holds a raster, up to seven levels and up to six levels'
/// siblings at once)...
pub(crate) const MAX_KEPT: usize = 20;
/// ...holding at most this many `f32` values together (64 MiB).
const MAX_KEPT_VALUES: usize = 16 << 20;

thread_local! {
    static FREE: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `len` zeros, reusing a kept one when there is one.
pub(crate) fn zeroed(len: usize) -> Vec<f32> {
    let mut v = reused(len);
    v.fill(0.0);
    v
}

/// A buffer of `len` values of no particular value (those of a kept buffer, zeros beyond),
/// for a caller that writes every value it reads.
pub(crate) fn reused(len: usize) -> Vec<f32> {
    let kept = FREE.with(|free| {
        let mut free = free.borrow_mut();
        // The smallest kept buffer that holds `len`, else the largest (it grows once).
        let fit = (0..free.len())
            .filter(|&i| free[i].capacity() >= len)
            .min_by_key(|&i| free[i].capacity())
            .or_else(|| (0..free.len()).max_by_key(|&i| free[i].capacity()));
        fit.map(|i| free.swap_remove(i))
    });
    match kept {
        Some(mut v) => {
            v.truncate(len);
            v.resize(len, 0.0);
            v
        }
        None => vec![0.0; len],
    }
}

/// Gives a buffer back for reuse (dropped when the free list is full).
pub(crate) fn recycle(v: Vec<f32>) {
    if v.capacity() == 0 {
        return;
    }
    // While the thread ends its local storage may be gone: the buffer is then just dropped.
    let _ = FREE.try_with(|free| {
        let mut free = free.borrow_mut();
        let held: usize = free.iter().map(Vec::capacity).sum();
        if free.len() < MAX_KEPT && held + v.capacity() <= MAX_KEPT_VALUES {
            free.push(v);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reused_buffer_comes_back_zeroed_and_of_the_asked_length() {
        let mut v = zeroed(1000);
        v.iter_mut().for_each(|x| *x = 7.0);
        let at = v.as_ptr();
        recycle(v);
        let w = zeroed(500);
        assert_eq!(w.len(), 500);
        assert!(w.iter().all(|&x| x == 0.0));
        assert_eq!(w.as_ptr(), at, "the kept buffer is reused");
        recycle(w);
        let big = zeroed(5000);
        assert_eq!(big.len(), 5000);
        assert!(big.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn a_reused_buffer_keeps_its_values_and_is_of_the_asked_length() {
        let mut v = zeroed(100);
        v.iter_mut().for_each(|x| *x = 7.0);
        let at = v.as_ptr();
        recycle(v);
        let w = reused(80);
        assert_eq!(w.as_ptr(), at, "the kept buffer is reused");
        assert_eq!(w.len(), 80);
        assert!(w.iter().all(|&x| x == 7.0));
        recycle(w);
        // Asked for more than it holds, the kept buffer grows (the allocator may move it).
        let w = reused(150);
        assert_eq!(w.len(), 150);
        assert!(w[..80].iter().all(|&x| x == 7.0));
        assert!(w[80..].iter().all(|&x| x == 0.0));
        recycle(w);
        let z = zeroed(120);
        assert!(z.iter().all(|&x| x == 0.0));
    }
}
