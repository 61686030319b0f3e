//! Input triangle ids found again from corners alone, for libraries that return
//! triangles as vertex triples (meshoptimizer's strips and clusters): a table of every
//! triangle's corners rotated to start at the smallest index ([`super::smallest_first`]),
//! sorted, where each triple takes the first input triangle of the same corners and
//! winding not yet taken. Cost: O(T log T) to build, O(log T) a lookup.

use super::smallest_first;
use rayon::prelude::*;

/// The input ids of a mesh's triangles, looked up by corners.
pub(crate) struct TriangleIds {
    /// (corners smallest first, id), sorted: the copies of one triangle are a run, by id.
    ids: Vec<([u32; 3], u32)>,
    /// At the first entry of each run, how many of the run are taken. A run is taken in
    /// order, so a lookup never walks past the taken ones: a million copies of one
    /// triangle stay O(log T) a lookup.
    run_taken: Vec<u32>,
}

impl TriangleIds {
    /// The table of `triangles`.
    pub(crate) fn new(triangles: &[[u32; 3]]) -> Self {
        let mut ids: Vec<([u32; 3], u32)> = triangles
            .iter()
            .enumerate()
            .map(|(t, &v)| (smallest_first(v), t as u32))
            .collect();
        ids.par_sort_unstable();
        let run_taken = vec![0; ids.len()];
        Self { ids, run_taken }
    }

    /// The lowest untaken id of a triangle with corners `t` in `t`'s winding, taken.
    pub(crate) fn take(&mut self, t: [u32; 3]) -> Option<u32> {
        let key = smallest_first(t);
        let first = self.ids.partition_point(|e| e.0 < key);
        let slot = first + *self.run_taken.get(first)? as usize;
        if slot >= self.ids.len() || self.ids[slot].0 != key {
            return None;
        }
        self.run_taken[first] += 1;
        Some(self.ids[slot].1)
    }

    /// The ids never taken, run by run (the untaken copies of one triangle together,
    /// ascending; the runs in the order of their corners).
    pub(crate) fn untaken_runs(&self) -> impl Iterator<Item = Vec<u32>> + '_ {
        self.ids
            .chunk_by(|a, b| a.0 == b.0)
            .scan(0, |first, run| {
                let start = *first;
                *first += run.len();
                let taken = self.run_taken[start] as usize;
                Some(run[taken..].iter().map(|e| e.1).collect::<Vec<u32>>())
            })
            .filter(|left| !left.is_empty())
    }

    /// The ids never taken, ascending.
    pub(crate) fn untaken(&self) -> Vec<u32> {
        let mut left: Vec<u32> = self.untaken_runs().flatten().collect();
        left.sort_unstable();
        left
    }
}
