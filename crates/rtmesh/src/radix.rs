//! Radix sort of `u128` keys on a bit range, for the compressed-key triangle pairing.
//!
//! Hand-written because pairing's speed target (15M triangles/s on one core in
//! compressed mode) leaves no room for a comparison sort of millions of keys, and the
//! usual crates sort whole keys where pairing needs only a bit range sorted (the low
//! bits, a half-edge id, are already in order).
//!
//! Most significant digit first while a part is larger than the cache: one stable
//! scatter on the top `MSD_BITS` bits that vary within the part splits it into buckets,
//! each sorted on its remaining bits the same way, in parallel. Parts of at most
//! `IN_CACHE` keys are sorted least significant digit first, 8 bits per pass, in
//! cache. Bits that are equal across a part are never passed over. Cost: O(n · digits)
//! with one out-of-cache pass per MSD level (one or two for millions of keys) instead
//! of one per digit, and 2n words of memory.

use rayon::prelude::*;

/// Bits of a most-significant-digit pass (65,536 buckets).
const MSD_BITS: u32 = 16;
/// Parts up to this many keys (2 MiB of keys and as much scratch) are sorted by
/// least significant digits.
const IN_CACHE: usize = 1 << 16;

/// Sort `keys` ascending by bits `low_bit..high_bit`, stably.
pub fn sort_u128_by_bits(keys: &mut [u128], low_bit: u32, high_bit: u32) {
    let mut scratch = crate::pages::filled_on_huge_pages(keys.len(), 0u128);
    let field = if high_bit >= 128 {
        !0u128
    } else {
        (1u128 << high_bit) - 1
    } & !((1u128 << low_bit) - 1);
    sort_part(keys, &mut scratch, field);
}

/// Sort `keys` stably by the bits of `field`, with `scratch` as long as `keys`.
fn sort_part(keys: &mut [u128], scratch: &mut [u128], field: u128) {
    let (any, all) = keys
        .iter()
        .fold((0u128, !0u128), |(any, all), &k| (any | k, all & k));
    let varying = (any ^ all) & field;
    if keys.len() < 2 || varying == 0 {
        return;
    }
    let (low, high) = (varying.trailing_zeros(), 128 - varying.leading_zeros());
    if keys.len() <= IN_CACHE {
        return sort_by_digits(keys, scratch, low, high);
    }
    let shift = high.saturating_sub(MSD_BITS).max(low);
    let digit = |k: u128| (k >> shift) as usize & ((1 << (high - shift)) - 1);
    let mut starts = vec![0usize; (1 << (high - shift)) + 1];
    for &k in keys.iter() {
        starts[digit(k) + 1] += 1;
    }
    for d in 1..starts.len() {
        starts[d] += starts[d - 1];
    }
    let mut next = starts.clone();
    for &k in keys.iter() {
        let d = digit(k);
        scratch[next[d]] = k;
        next[d] += 1;
    }
    keys.copy_from_slice(scratch);
    // The buckets, each with its share of the scratch, sorted on the bits below.
    let mut buckets = Vec::new();
    let (mut keys, mut scratch) = (keys, scratch);
    for w in starts.windows(2) {
        let (bucket, rest) = std::mem::take(&mut keys).split_at_mut(w[1] - w[0]);
        let (bucket_scratch, scratch_rest) = std::mem::take(&mut scratch).split_at_mut(w[1] - w[0]);
        if bucket.len() > 1 {
            buckets.push((bucket, bucket_scratch));
        }
        (keys, scratch) = (rest, scratch_rest);
    }
    let below = field & ((1u128 << shift) - 1);
    buckets
        .into_par_iter()
        .with_max_len(1)
        .for_each(|(bucket, scratch)| sort_part(bucket, scratch, below));
}

/// Least significant digit radix sort of `keys` on bits `low..high`, 8 bits per stable
/// pass, skipping digits every key shares; the result ends in `keys`.
fn sort_by_digits<'a>(keys: &'a mut [u128], scratch: &'a mut [u128], low: u32, high: u32) {
    // (shift, mask) per digit; the last digit stops at `high`.
    let digits: Vec<(u32, usize)> = (low..high)
        .step_by(8)
        .map(|shift| (shift, (1 << (high - shift).min(8)) - 1))
        .collect();
    let mut histograms = vec![[0u32; 256]; digits.len()];
    for &k in keys.iter() {
        for (histogram, &(shift, mask)) in histograms.iter_mut().zip(&digits) {
            histogram[(k >> shift) as usize & mask] += 1;
        }
    }
    let (mut from, mut to) = (keys, scratch);
    let mut in_scratch = false;
    for (histogram, &(shift, mask)) in histograms.iter().zip(&digits) {
        if histogram.contains(&(from.len() as u32)) {
            continue; // every key has this digit: the pass would not move anything
        }
        let mut next = [0u32; 256];
        let mut sum = 0;
        for d in 0..256 {
            next[d] = sum;
            sum += histogram[d];
        }
        for &k in from.iter() {
            let d = (k >> shift) as usize & mask;
            to[next[d] as usize] = k;
            next[d] += 1;
        }
        (from, to) = (to, from);
        in_scratch = !in_scratch;
    }
    if in_scratch {
        // `from` is the scratch: the keys go back.
        to.copy_from_slice(from);
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

    /// Enough keys for the most-significant-digit passes: five values in the top bits
    /// make buckets over the in-cache limit, which split again on the random middle
    /// bits; the bottom bits are left out of some ranges, so order among equal fields
    /// shows stability.
    #[test]
    fn large_inputs_sort_by_buckets_like_a_stable_sort() {
        let mut rng = crate::random::SplitMix64::new(3);
        let keys: Vec<u128> = (0..600_000)
            .map(|_| {
                let top = (rng.next_u64() % 5) as u128;
                let middle = rng.next_u64() as u128;
                top << 100 | middle << 20 | (rng.next_u64() & 0xF_FFFF) as u128
            })
            .collect();
        for (low, high) in [(20, 128), (32, 104), (0, 64), (84, 128)] {
            let field = |k: u128| (k >> low) & ((1u128 << (high - low)) - 1);
            let mut expected = keys.clone();
            expected.sort_by_key(|&k| field(k));
            let mut got = keys.clone();
            sort_u128_by_bits(&mut got, low, high);
            assert!(got == expected, "bits {low}..{high}");
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
