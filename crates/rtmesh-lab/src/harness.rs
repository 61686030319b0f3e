//! The timing harness: configurations timed in alternating rounds (so a slow phase of
//! the machine slows them all alike), reported as medians.

pub use rtmesh::trace::measure::median;

/// Run every configuration of `configs` once per round for `rounds` rounds (at least
/// one), in the same order each round, timing each call with `time`; returns each
/// configuration's seconds, one per round.
pub fn alternate<T>(
    rounds: usize,
    configs: &[T],
    mut time: impl FnMut(&T) -> f64,
) -> Vec<Vec<f64>> {
    let mut seconds = vec![Vec::with_capacity(rounds.max(1)); configs.len()];
    for _ in 0..rounds.max(1) {
        for (config, times) in configs.iter().zip(&mut seconds) {
            times.push(time(config));
        }
    }
    seconds
}

/// The share of rays whose first hit is the same triangle id in `hits` as in
/// `reference` (misses agree with misses).
pub fn same_triangle_share(hits: &[rtmesh::trace::Hit], reference: &[rtmesh::trace::Hit]) -> f64 {
    let same = hits
        .iter()
        .zip(reference)
        .filter(|(a, b)| a.triangle == b.triangle)
        .count();
    same as f64 / hits.len().max(1) as f64
}

/// Seconds `f` takes once.
pub fn seconds(f: impl FnOnce()) -> f64 {
    let start = std::time::Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_alternate_configurations() {
        let mut order = Vec::new();
        let times = alternate(3, &["a", "b"], |&c| {
            order.push(c);
            order.len() as f64
        });
        assert_eq!(order, ["a", "b", "a", "b", "a", "b"]);
        assert_eq!(times, [vec![1.0, 3.0, 5.0], vec![2.0, 4.0, 6.0]]);
        assert_eq!(median(&times[1]), 4.0);
    }
}
