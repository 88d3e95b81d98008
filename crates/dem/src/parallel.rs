//! Small parallel building blocks of the step and the list rebuilds: a pointer for disjoint
//! writes from rayon tasks, the CSR row starts of sorted keys, a gather by a permutation, and
//! reductions whose result does not depend on the thread count.
//!
//! Every helper here gives the same answer for any number of threads: keys are unique before
//! they are sorted, writes go to disjoint slots, and minima and maxima do not depend on order.

use glam::DVec3;
use rayon::prelude::*;

/// Items per task in the helpers below: large enough that a task outweighs its scheduling.
pub(crate) const CHUNK: usize = 4096;

/// Raw pointer that may be shared between rayon tasks that write disjoint slots.
#[derive(Clone, Copy)]
pub(crate) struct Shared<T>(pub(crate) *mut T);
unsafe impl<T> Send for Shared<T> {}
unsafe impl<T> Sync for Shared<T> {}

impl<T> Shared<T> {
    /// Going through a method makes closures capture the whole wrapper (which is Send), not the
    /// raw pointer field.
    #[inline(always)]
    pub(crate) fn ptr(self) -> *mut T {
        self.0
    }
}

/// Row starts of CSR rows from keys sorted by row (`row(k)` of the k-th key, non-decreasing):
/// `starts[r]` is the first key of row r or later, and `starts[rows] = keys`. `starts` must hold
/// `rows + 1` entries. Each key fills the starts of the rows between its predecessor's row and
/// its own, so the writes are disjoint.
pub(crate) fn row_starts(keys: usize, row: impl Fn(usize) -> usize + Sync, starts: &mut [u32]) {
    let rows = starts.len() - 1;
    let out = Shared(starts.as_mut_ptr());
    (0..keys.div_ceil(CHUNK)).into_par_iter().for_each(|b| {
        for k in b * CHUNK..((b + 1) * CHUNK).min(keys) {
            let r = row(k);
            let first = if k == 0 { 0 } else { row(k - 1) + 1 };
            for s in first..=r {
                // SAFETY: row s is filled by the one key that first reaches it.
                unsafe { out.ptr().add(s).write(k as u32) };
            }
        }
    });
    // Rows after the last key (all of them when there are no keys).
    let tail = if keys == 0 { 0 } else { row(keys - 1) + 1 };
    starts[tail..=rows]
        .par_iter_mut()
        .for_each(|s| *s = keys as u32);
}

/// `out[k] = values[order[k]]` for every k, in parallel.
pub(crate) fn gather<T: Copy + Send + Sync>(values: &[T], order: &[u32], out: &mut [T]) {
    out.par_chunks_mut(CHUNK)
        .zip(order.par_chunks(CHUNK))
        .for_each(|(o, idx)| {
            for (slot, &i) in o.iter_mut().zip(idx) {
                *slot = values[i as usize];
            }
        });
}

/// The box around the points, grown by each radius when `radii` is given (infinite bounds for
/// no points).
pub(crate) fn bounds(points: &[DVec3], radii: Option<&[f64]>) -> (DVec3, DVec3) {
    let empty = || (DVec3::INFINITY, DVec3::NEG_INFINITY);
    points
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(b, xs)| {
            let (mut lo, mut hi) = empty();
            for (k, x) in xs.iter().enumerate() {
                let pad = DVec3::splat(radii.map_or(0.0, |r| r[b * CHUNK + k]));
                lo = lo.min(*x - pad);
                hi = hi.max(*x + pad);
            }
            (lo, hi)
        })
        .reduce(empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// The largest value (0 for none).
pub(crate) fn max(values: &[f64]) -> f64 {
    values
        .par_chunks(CHUNK)
        .map(|c| c.iter().cloned().fold(0.0, f64::max))
        .reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_starts_of_sorted_keys() {
        // Rows 0..6; keys in rows 1, 1, 3, 3, 3, 4: rows 0, 2, 5 are empty.
        let rows = [1usize, 1, 3, 3, 3, 4];
        let mut starts = vec![99u32; 7];
        row_starts(rows.len(), |k| rows[k], &mut starts);
        assert_eq!(starts, [0, 0, 2, 2, 5, 6, 6]);
        let mut none = vec![99u32; 3];
        row_starts(0, |_| 0, &mut none);
        assert_eq!(none, [0, 0, 0]);
        // Enough keys for several tasks.
        let many: Vec<usize> = (0..3 * CHUNK + 5).map(|k| k / 7).collect();
        let last = many[many.len() - 1];
        let mut starts = vec![0u32; last + 3];
        row_starts(many.len(), |k| many[k], &mut starts);
        for (r, &s) in starts.iter().enumerate() {
            assert_eq!(s as usize, many.partition_point(|&x| x < r), "row {r}");
        }
    }

    #[test]
    fn gather_bounds_and_max() {
        let values: Vec<f64> = (0..10_000).map(|k| k as f64).collect();
        let order: Vec<u32> = (0..10_000u32).rev().collect();
        let mut out = vec![0.0; 10_000];
        gather(&values, &order, &mut out);
        assert_eq!(out[0], 9999.0);
        assert_eq!(out[9999], 0.0);
        assert_eq!(max(&values), 9999.0);
        let points: Vec<DVec3> = values.iter().map(|&v| DVec3::new(v, -v, 1.0)).collect();
        let radii = vec![0.5; points.len()];
        let (lo, hi) = bounds(&points, Some(&radii));
        assert_eq!(lo, DVec3::new(-0.5, -9999.5, 0.5));
        assert_eq!(hi, DVec3::new(9999.5, 0.5, 1.5));
    }
}
