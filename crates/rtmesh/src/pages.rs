//! Transparent huge pages for big arrays: the tracer's nodes and leaf blocks, and the
//! pairing's half-edge table, records and sort scratch.
//!
//! A traversal of a large mesh touches nodes and leaves all over tens of megabytes; with
//! 4 KiB pages nearly every visit misses the TLB and waits for a page walk on top of the
//! cache miss. Backing the arrays with 2 MiB pages (as Embree does for its BVH memory)
//! leaves a few dozen TLB entries to cover them. Scratch arrays written once in a
//! scattered order (a counting sort's output) fault in one page per 2 MiB instead of
//! one per 4 KiB. On Linux, whose transparent huge pages
//! are often enabled only on request (`/sys/kernel/mm/transparent_hugepage/enabled` =
//! `madvise`), a vector's reserved but untouched memory is marked `MADV_HUGEPAGE`
//! before it is filled, so its first writes fault in huge pages. Elsewhere, or when the
//! kernel declines, the vector is an ordinary one: this changes speed, never results.
//! Cost: one system call per array.

/// Size of a huge page on x86-64 and AArch64 Linux.
const HUGE_PAGE: usize = 2 << 20;

/// An empty vector with room for `capacity` items whose memory the kernel is asked to
/// back with huge pages (arrays smaller than one huge page are left alone).
pub(crate) fn vec_on_huge_pages<T>(capacity: usize) -> Vec<T> {
    let v = Vec::<T>::with_capacity(capacity);
    advise_huge_pages(v.as_ptr().cast(), v.capacity() * std::mem::size_of::<T>());
    v
}

/// `len` copies of `value` on huge pages, written in one sequential pass. Memory a
/// random-order pass would touch first (and, for zeroed memory, first fault in for
/// reading and then again for writing) is faulted in here, a huge page at a time.
pub(crate) fn filled_on_huge_pages<T: Clone>(len: usize, value: T) -> Vec<T> {
    let mut v = vec_on_huge_pages(len);
    v.resize(len, value);
    v
}

/// A copy of `items` on huge pages (see [`vec_on_huge_pages`]).
pub(crate) fn copy_to_huge_pages<T: Clone>(items: &[T]) -> Vec<T> {
    let mut v = vec_on_huge_pages(items.len());
    v.extend_from_slice(items);
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(start: *const u8, bytes: usize) {
    // Only whole huge pages inside the allocation can be huge pages.
    let first = (start as usize).next_multiple_of(HUGE_PAGE);
    let end = (start as usize + bytes) / HUGE_PAGE * HUGE_PAGE;
    if end > first {
        // SAFETY: the range lies inside one live allocation of ours; the advice changes
        // how the kernel backs it, not its contents. A failure (no THP) is harmless.
        unsafe { libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: *const u8, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_page_vectors_hold_what_they_are_given() {
        let items: Vec<u64> = (0..(3 * HUGE_PAGE / 8) as u64).collect();
        let copy = copy_to_huge_pages(&items);
        assert_eq!(copy, items);
        let empty: Vec<u64> = vec_on_huge_pages(0);
        assert!(empty.is_empty());
    }
}
