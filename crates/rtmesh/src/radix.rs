//! LSD radix sort of `u64` and `u128` keys, for the sorts in triangle pairing.
//!
//! Hand-written because pairing's speed target (25M triangles/s on one core) leaves no
//! room for a comparison sort of millions of keys, and the usual crates sort whole keys
//! where pairing needs only a bit range sorted (the low bits are already in order).
//! Cost: one histogram pass over all digits, then one stable scatter pass per 8-bit
//! digit that is not constant across the keys; O(n · digits), 2n words of memory.

/// Sort `keys` ascending by bits `low_bit..high_bit`, stably: keys equal in that range
/// keep their order.
pub fn sort_u64_by_bits(keys: &mut Vec<u64>, low_bit: u32, high_bit: u32) {
    sort_by_bits(keys, low_bit, high_bit, |k, shift, mask| {
        (k >> shift) as usize & mask
    });
}

/// Sort `keys` ascending by bits `low_bit..high_bit`, stably.
pub fn sort_u128_by_bits(keys: &mut Vec<u128>, low_bit: u32, high_bit: u32) {
    sort_by_bits(keys, low_bit, high_bit, |k, shift, mask| {
        (k >> shift) as usize & mask
    });
}

fn sort_by_bits<K: Copy + Default>(
    keys: &mut Vec<K>,
    low_bit: u32,
    high_bit: u32,
    digit: impl Fn(K, u32, usize) -> usize,
) {
    // (shift, mask) per digit; the last digit stops at `high_bit`.
    let shifts: Vec<(u32, usize)> = (low_bit..high_bit)
        .step_by(8)
        .map(|shift| (shift, (1usize << (high_bit - shift).min(8)) - 1))
        .collect();
    if keys.len() < 2 || shifts.is_empty() {
        return;
    }
    let mut histograms = vec![[0usize; 256]; shifts.len()];
    for &k in keys.iter() {
        for (histogram, &(shift, mask)) in histograms.iter_mut().zip(&shifts) {
            histogram[digit(k, shift, mask)] += 1;
        }
    }
    let mut scratch = vec![K::default(); keys.len()];
    for (histogram, &(shift, mask)) in histograms.iter().zip(&shifts) {
        if histogram.contains(&keys.len()) {
            continue; // every key has this digit: the pass would not move anything
        }
        let mut offsets = [0usize; 256];
        let mut sum = 0;
        for (offset, &count) in offsets.iter_mut().zip(histogram) {
            *offset = sum;
            sum += count;
        }
        for &k in keys.iter() {
            let d = digit(k, shift, mask);
            scratch[offsets[d]] = k;
            offsets[d] += 1;
        }
        std::mem::swap(keys, &mut scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn sorts_like_a_stable_sort_on_the_bit_range(
            keys in proptest::collection::vec(any::<u64>(), 0..300),
            low in 0u32..40,
            width in 1u32..24,
        ) {
            let high = low + width;
            let field = |k: u64| (k >> low) & ((1u64 << width) - 1);
            let mut expected = keys.clone();
            expected.sort_by_key(|&k| field(k));
            let mut got = keys.clone();
            sort_u64_by_bits(&mut got, low, high);
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
