//! Fixed-length arrays on transparent huge pages, for the tree's nodes and triangle packs.
//!
//! Traversal of a large tree touches nodes and packs all over its memory, and with 4 KiB pages
//! a 1M-triangle tree (about 60 MB) spans some 15,000 pages, far more than a core's
//! second-level TLB holds (1,500–2,000 entries): most node visits of a random ray then pay a
//! page walk on top of their cache miss. With 2 MiB pages it spans 30. Embree allocates its
//! trees that way (its `os_malloc` advises the kernel to back large blocks with huge pages;
//! its process shows them in `AnonHugePages`), which pir's BVH did not. Debian's kernels grant
//! transparent huge pages only to memory that asks for them (`madvise` mode), so an array of
//! at least [`HUGE`] bytes is an anonymous mapping of its own, rounded up to whole huge pages
//! and advised `MADV_HUGEPAGE` before it is first touched; smaller ones, other systems, or a
//! failed mapping fall back to a `Vec`. The advice is a hint: where the kernel has no huge page
//! to give, the array works the same on small pages.
//!
//! No `unsafe`: `memmap2` maps and advises, `bytemuck` views the bytes as `T` (the element
//! types are plain old data, and a mapping is page-aligned, which satisfies their alignment).

use std::ops::{Deref, DerefMut};

use bytemuck::Pod;

/// The size of a transparent huge page on x86-64 (a PMD), and the smallest array mapped on
/// its own.
pub(super) const HUGE: usize = 2 << 20;

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
        if bytes >= HUGE
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

    /// Keeps the first `len` elements (the pages of the others stay mapped, and unbacked if
    /// they were never touched).
    pub fn truncate(&mut self, len: usize) {
        assert!(len <= self.len, "truncate to {len} of {}", self.len);
        self.len = len;
        if let Store::Vec(v) = &mut self.store {
            v.truncate(len);
            v.shrink_to_fit();
        }
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
        for len in [0, 1, 1000, HUGE / 8 + 3] {
            let items: Vec<[u64; 2]> = (0..len as u64).map(|i| [i, !i]).collect();
            let p = Pages::from_slice(&items);
            assert_eq!(p.len(), len);
            assert_eq!(&p[..], &items[..]);
            assert_eq!(p.is_mapped(), cfg!(target_os = "linux") && len * 16 >= HUGE, "{len}");
        }
        let mut z = Pages::<u32>::zeroed(HUGE);
        assert!(z.iter().all(|&x| x == 0));
        z[HUGE - 1] = 7;
        assert_eq!(z[HUGE - 1], 7);
    }
}
