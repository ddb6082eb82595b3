//! Fixed-length arrays on transparent huge pages, for the tree's nodes and triangle packs.
//!
//! Traversal of a large tree touches nodes and packs all over its memory, and with 4 KiB pages
//! a 1M-triangle tree (about 60 MB) spans some 15,000 pages, far more than a core's
//! second-level TLB holds (1,500–2,000 entries): most node visits of a random ray then pay a
//! page walk on top of their cache miss. With 2 MiB pages it spans 30. Embree allocates its
//! trees that way (its `os_malloc` advises the kernel to back large blocks with huge pages;
//! its process shows them in `AnonHugePages`), which pir's BVH did not. Debian's kernels grant
//! transparent huge pages only to memory that asks for them (`madvise` mode), so an array of
//! at least [`MAP_MIN`] bytes is an anonymous mapping of its own, rounded up to whole huge
//! pages and advised `MADV_HUGEPAGE` before it is first touched; smaller ones, other systems,
//! or a failed mapping fall back to a `Vec`. The advice is a hint: where the kernel has no huge
//! page to give, the array works the same on small pages. The build's primitive records and
//! its partition's second buffer are such arrays too: their first touch takes 16 huge-page
//! faults instead of 8,000 small ones (1M scene).
//!
//! Why 8 MiB (2026-12-04, `accel_ratio`, alternating binaries, one thread for queries, builds on
//! two): from 2 MiB, the bunny's build took 1.03× Embree's time against 0.93× from 8 MiB (its
//! arrays, 2–5 MB, each cost a fresh mapping and whole huge pages to clear, where a `Vec`
//! reuses memory the allocator kept from the previous build), and its traversal gained
//! nothing (its tree is within the TLB's reach). From 16 MiB, the dragon's packs (9.5 MB) stay
//! on small pages: its build ran at 0.97–0.98× Embree's time against 1.03–1.04× from 8 MiB, but
//! its closest hits at 0.78–0.79× Embree's rate against 0.82×, and the 1M scene's occlusion
//! (whose nodes, 10 MB, then stay on small pages too) at 0.70–0.71× against 0.74×. A render
//! builds once, from fresh memory, where huge pages fault faster than small ones (48 MB: 6 ms
//! against 16 ms once the machine has backed the memory).
//!
//! No `unsafe`: `memmap2` maps and advises, `bytemuck` views the bytes as `T` (the element
//! types are plain old data, and a mapping is page-aligned, which satisfies their alignment).

use std::ops::{Deref, DerefMut};

use bytemuck::Pod;

/// The size of a transparent huge page on x86-64 (a PMD).
pub(super) const HUGE: usize = 2 << 20;
/// The smallest array mapped on its own (see the module docs).
pub(super) const MAP_MIN: usize = 8 << 20;

/// `len` elements of `T`, on huge pages when large (see the module docs).
pub(super) struct Pages<T: Pod> {
    store: Store<T>,
    len: usize,
}

enum Store<T> {
    Vec(Vec<T>),
    #[cfg(target_os = "linux")]
    Map(memmap2::MmapMut),
}

impl<T: Pod> Pages<T> {
    /// `len` elements with all bits zero.
    pub fn zeroed(len: usize) -> Self {
        let bytes = len * std::mem::size_of::<T>();
        #[cfg(target_os = "linux")]
        if Self::maps(len)
            && let Ok(map) = memmap2::MmapMut::map_anon(bytes.next_multiple_of(HUGE))
        {
            // A hint: without huge pages the mapping is still good memory.
            let _ = map.advise(memmap2::Advice::HugePage);
            if map.as_ptr().align_offset(std::mem::align_of::<T>()) == 0 {
                return Pages { store: Store::Map(map), len };
            }
        }
        Pages { store: Store::Vec(vec![T::zeroed(); len]), len }
    }

    /// A copy of `items`.
    pub fn from_slice(items: &[T]) -> Self {
        let mut p = Self::zeroed(items.len());
        p.copy_from_slice(items);
        p
    }

    /// `items`, moved to a mapping of their own if large (a copy), else kept as they are.
    pub fn from_vec(items: Vec<T>) -> Self {
        if Self::maps(items.len()) {
            Self::from_slice(&items)
        } else {
            let len = items.len();
            Pages { store: Store::Vec(items), len }
        }
    }

    /// Whether `len` elements get a mapping of their own.
    fn maps(len: usize) -> bool {
        cfg!(target_os = "linux") && len * std::mem::size_of::<T>() >= MAP_MIN
    }

    /// Whether the array is on a mapping of its own (which the kernel was asked to back with
    /// huge pages).
    #[cfg(test)]
    pub fn is_mapped(&self) -> bool {
        !matches!(self.store, Store::Vec(_))
    }
}

impl<T: Pod> Deref for Pages<T> {
    type Target = [T];

    #[inline]
    fn deref(&self) -> &[T] {
        match &self.store {
            Store::Vec(v) => v,
            #[cfg(target_os = "linux")]
            Store::Map(m) => bytemuck::cast_slice(&m[..self.len * std::mem::size_of::<T>()]),
        }
    }
}

impl<T: Pod> DerefMut for Pages<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        let bytes = self.len * std::mem::size_of::<T>();
        match &mut self.store {
            Store::Vec(v) => v,
            #[cfg(target_os = "linux")]
            Store::Map(m) => bytemuck::cast_slice_mut(&mut m[..bytes]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small arrays are vectors, large ones mappings; both hold what was put in them, with
    /// the lengths asked for.
    #[test]
    fn arrays_hold_their_elements() {
        for len in [0, 1, 1000, MAP_MIN / 16 + 3] {
            let items: Vec<[u64; 2]> = (0..len as u64).map(|i| [i, !i]).collect();
            let p = Pages::from_slice(&items);
            assert_eq!(p.len(), len);
            assert_eq!(&p[..], &items[..]);
            assert_eq!(p.is_mapped(), cfg!(target_os = "linux") && len * 16 >= MAP_MIN, "{len}");
        }
        let mut z = Pages::<u32>::zeroed(HUGE);
        assert!(z.iter().all(|&x| x == 0));
        z[HUGE - 1] = 7;
        assert_eq!(z[HUGE - 1], 7);
    }
}
