//! Zeroed `f32` buffers for the rasters of the window search, reused from scan to scan.
//!
//! Every searched scan builds a likelihood raster, its block maxima and some levels' values
//! beside their siblings' (up to a few MiB each) and drops them again. Fresh zeroed memory of
//! that size comes from the system page by page: on FR079 at every 3rd scan, page faults and
//! zeroing were about 12 % of the run (`perf`). A [`Buffer`] dropped goes back to a small
//! per-thread free list instead and is zeroed again when taken (or, for a caller that writes
//! every value it reads, taken as it is); the values read are the same, so outputs are
//! byte-identical. A kept buffer keeps every value it ever held (a buffer is only as long as
//! asked, the vector behind it stays at its longest): reusing it for more values than it
//! last held zeroes only values it never held (the rasters differ in size from scan to scan,
//! and zeroing the difference again at each reuse was 3 % of a sparse run's instructions).

use std::cell::RefCell;
use std::fmt;
use std::ops::{Deref, DerefMut};

/// At most this many buffers are kept per thread (the mapping thread and the loop thread each
/// have their own list; a search holds a raster, up to seven levels and up to six levels'
/// siblings at once)...
pub(crate) const MAX_KEPT: usize = 20;
/// ...holding at most this many `f32` values together (64 MiB).
const MAX_KEPT_VALUES: usize = 16 << 20;

thread_local! {
    /// Kept vectors, each as long as it ever was (every value initialized).
    static FREE: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// `len` values of a vector that may hold more (kept from an earlier use); given back to the
/// free list when dropped.
#[derive(Default)]
pub(crate) struct Buffer {
    values: Vec<f32>,
    len: usize,
}

impl Deref for Buffer {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        &self.values[..self.len]
    }
}

impl DerefMut for Buffer {
    fn deref_mut(&mut self) -> &mut [f32] {
        &mut self.values[..self.len]
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        recycle(std::mem::take(&mut self.values));
    }
}

impl Clone for Buffer {
    fn clone(&self) -> Self {
        let mut copy = reused(self.len);
        copy.copy_from_slice(self);
        copy
    }
}

impl PartialEq for Buffer {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl fmt::Debug for Buffer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (**self).fmt(f)
    }
}

/// A buffer of `len` zeros, reusing a kept one when there is one.
pub(crate) fn zeroed(len: usize) -> Buffer {
    let mut b = reused(len);
    b.fill(0.0);
    b
}

/// A buffer of `len` values of no particular value (those of a kept buffer, zeros beyond),
/// for a caller that writes every value it reads.
pub(crate) fn reused(len: usize) -> Buffer {
    let kept = FREE.with(|free| {
        let mut free = free.borrow_mut();
        // The shortest kept vector that holds `len` values, else the longest (it grows once).
        let fit = (0..free.len())
            .filter(|&i| free[i].len() >= len)
            .min_by_key(|&i| free[i].len())
            .or_else(|| (0..free.len()).max_by_key(|&i| free[i].len()));
        fit.map(|i| free.swap_remove(i))
    });
    let mut values = kept.unwrap_or_default();
    if values.len() < len {
        values.resize(len, 0.0);
    }
    Buffer { values, len }
}

/// Gives a vector back for reuse (dropped when the free list is full).
fn recycle(v: Vec<f32>) {
    if v.capacity() == 0 {
        return;
    }
    // While the thread ends its local storage may be gone: the vector is then just dropped.
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
        drop(v);
        let w = zeroed(500);
        assert_eq!(w.len(), 500);
        assert!(w.iter().all(|&x| x == 0.0));
        assert_eq!(w.as_ptr(), at, "the kept buffer is reused");
        drop(w);
        let big = zeroed(5000);
        assert_eq!(big.len(), 5000);
        assert!(big.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn a_reused_buffer_keeps_its_values_and_is_of_the_asked_length() {
        let mut v = zeroed(100);
        v.iter_mut().for_each(|x| *x = 7.0);
        let at = v.as_ptr();
        drop(v);
        let w = reused(80);
        assert_eq!(w.as_ptr(), at, "the kept buffer is reused");
        assert_eq!(w.len(), 80);
        assert!(w.iter().all(|&x| x == 7.0));
        drop(w);
        // The values past the 80 used are still held: nothing to zero.
        let w = reused(100);
        assert_eq!(w.as_ptr(), at, "the kept buffer is reused");
        assert!(w.iter().all(|&x| x == 7.0));
        drop(w);
        // Asked for more than it ever held, the kept buffer grows (the allocator may move it).
        let w = reused(150);
        assert_eq!(w.len(), 150);
        assert!(w[..100].iter().all(|&x| x == 7.0));
        assert!(w[100..].iter().all(|&x| x == 0.0));
        drop(w);
        let z = zeroed(120);
        assert!(z.iter().all(|&x| x == 0.0));
    }
}
