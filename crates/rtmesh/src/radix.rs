//! LSD radix sort of `u128` keys, for the compressed-key triangle pairing.
//!
//! Hand-written because pairing's speed target (15M triangles/s on one core in
//! compressed mode) leaves no room for a comparison sort of millions of keys, and the
//! usual crates sort whole keys where pairing needs only a bit range sorted (the low
//! bits, a half-edge id, are already in order).
//! Cost: one histogram pass over all digits, then one stable scatter pass per 8-bit
//! digit that is not constant across the keys; O(n · digits), 2n words of memory.
//! With several rayon threads and over 128k keys, each thread scatters its own part.

use rayon::prelude::*;

/// Sort `keys` ascending by bits `low_bit..high_bit`, stably.
pub fn sort_u128_by_bits(keys: &mut Vec<u128>, low_bit: u32, high_bit: u32) {
    sort_by_bits(keys, low_bit, high_bit, |k, shift, mask| {
        (k >> shift) as usize & mask
    });
}

fn sort_by_bits<K: Copy + Default + Send + Sync>(
    keys: &mut Vec<K>,
    low_bit: u32,
    high_bit: u32,
    digit: impl Fn(K, u32, usize) -> usize + Sync,
) {
    // (shift, mask) per digit; the last digit stops at `high_bit`.
    let shifts: Vec<(u32, usize)> = (low_bit..high_bit)
        .step_by(8)
        .map(|shift| (shift, (1usize << (high_bit - shift).min(8)) - 1))
        .collect();
    if keys.len() < 2 || shifts.is_empty() {
        return;
    }
    // Each pool thread scatters one contiguous part of the keys, from its own offsets
    // (its part's keys of digit d go after every earlier part's), which keeps the
    // sort stable. Parts of at least 64k keys, else one.
    let parts = rayon::current_num_threads().min(keys.len() >> 16).max(1);
    let part_len = keys.len().div_ceil(parts);
    let histogram_of = |keys: &[K], shift: u32, mask: usize| {
        let mut histogram = [0usize; 256];
        for &k in keys {
            histogram[digit(k, shift, mask)] += 1;
        }
        histogram
    };
    let mut totals = vec![[0usize; 256]; shifts.len()];
    for &k in keys.iter() {
        for (histogram, &(shift, mask)) in totals.iter_mut().zip(&shifts) {
            histogram[digit(k, shift, mask)] += 1;
        }
    }
    let mut scratch = crate::pages::vec_on_huge_pages(keys.len());
    scratch.resize(keys.len(), K::default());
    for (total, &(shift, mask)) in totals.iter().zip(&shifts) {
        if total.contains(&keys.len()) {
            continue; // every key has this digit: the pass would not move anything
        }
        let histograms: Vec<[usize; 256]> = if parts == 1 {
            vec![*total]
        } else {
            keys.par_chunks(part_len)
                .map(|part| histogram_of(part, shift, mask))
                .collect()
        };
        let mut offsets = vec![[0usize; 256]; histograms.len()];
        let mut sum = 0;
        for d in 0..256 {
            for (offset, histogram) in offsets.iter_mut().zip(&histograms) {
                offset[d] = sum;
                sum += histogram[d];
            }
        }
        let destination = SharedSlice(scratch.as_mut_ptr());
        let destination = &destination;
        keys.par_chunks(part_len)
            .zip(offsets)
            .for_each(|(part, mut offset)| {
                for &k in part {
                    let d = digit(k, shift, mask);
                    // SAFETY: the offsets give every key of every part its own slot
                    // below `keys.len()` (they count each part's keys per digit).
                    unsafe { destination.0.add(offset[d]).write(k) };
                    offset[d] += 1;
                }
            });
        std::mem::swap(keys, &mut scratch);
    }
}

/// A scatter's destination, shared by threads that write disjoint slots of it (the
/// radix sort's passes, the half-edge table's counting sort).
pub(crate) struct SharedSlice<K>(pub(crate) *mut K);
// SAFETY: threads write disjoint elements only (see `sort_by_bits`).
unsafe impl<K: Send> Sync for SharedSlice<K> {}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn sorts_like_a_stable_sort_on_the_bit_range(
            keys in proptest::collection::vec(any::<u128>(), 0..300),
            low in 0u32..100,
            width in 1u32..24,
        ) {
            let high = low + width;
            let field = |k: u128| (k >> low) & ((1u128 << width) - 1);
            let mut expected = keys.clone();
            expected.sort_by_key(|&k| field(k));
            let mut got = keys.clone();
            sort_u128_by_bits(&mut got, low, high);
            prop_assert_eq!(got, expected);
        }
    }

    #[test]
    fn u128_keys_sort_on_high_bits() {
        let mut keys: Vec<u128> = vec![3 << 100 | 7, 1 << 100 | 9, 3 << 100 | 1, 2 << 100];
        sort_u128_by_bits(&mut keys, 96, 128);
        assert_eq!(
            keys,
            vec![1 << 100 | 9, 2 << 100, 3 << 100 | 7, 3 << 100 | 1]
        );
    }
}
