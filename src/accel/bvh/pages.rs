//! Fixed-length arrays on transparent huge pages, for the tree's nodes and triangle packs.
//!
//! Traversal of a large tree touches nodes and packs all over its memory, and with 4 KiB pages
//! a 1M-triangle tree (about 60 MB) spans some 15,000 pages, far more than a core's
//! second-level TLB holds (1,500–2,000 entries): most node visits of a random ray then pay a
//! page walk on top of their cache miss. With 2 MiB pages it spans 30. Embree allocates its
//! trees that way (its `os_malloc` advises the kernel to back large blocks with huge pages;
//! its process shows them in `AnonHugePages`), which pir's BVH did not. Debian's kernels grant
//! transparent huge pages only to memory that asks for them (`madvise` mode), so an array of
//! at least [`MAP_MIN`] bytes is an anonymous mapping of its own, starting at a 2 MiB boundary
//! and rounded up to whole huge pages, advised `MADV_HUGEPAGE` before it is first touched;
//! smaller ones (written in parallel when large, as the build's records are), other systems,
//! or a failed mapping fall back to a `Vec`. The advice is a hint: where the kernel has no huge
//! page to give, the array works the same on small pages. The build's primitive records and
//! its partition's second buffer are such arrays too: their first touch takes 16 huge-page
//! faults instead of 8,000 small ones (1M scene).
//!
//! Why 8 MiB ([`MAP_MIN`]): smaller arrays gain nothing in traversal (a tree that small is
//! within the TLB's reach) and build slower on mappings of their own (each a fresh mapping
//! with whole huge pages to clear, where a `Vec` reuses memory the allocator kept), while
//! larger thresholds leave the dragon's packs and the 1M scene's nodes on small pages, whose
//! queries then ran slower. Measurements: `docs/accel/huge-pages.md`.
//!
//! No `unsafe`: `memmap2` maps and advises, `bytemuck` views the bytes as `T` (the element
//! types are plain old data, and a mapping is page-aligned, which satisfies their alignment).

use std::ops::{Deref, DerefMut};

use bytemuck::Pod;
use rayon::prelude::*;

/// The size of a transparent huge page on x86-64 (a PMD).
#[cfg(target_os = "linux")]
const HUGE: usize = 2 << 20;
/// The smallest array mapped on its own (see the module docs).
pub(super) const MAP_MIN: usize = 8 << 20;

/// `len` elements of `T`, on huge pages when large (see the module docs).
pub(super) struct Pages<T: Pod> {
    store: Store<T>,
    len: usize,
}

enum Store<T> {
    Vec(Vec<T>),
    /// A mapping and where in it the elements start: its first 2 MiB boundary. Kernels since
    /// 6.7 place large anonymous mappings on such a boundary themselves; older ones (Debian
    /// 12's 6.1) do not, and only whole, aligned 2 MiB blocks can be huge pages, so the
    /// mapping is one huge page longer than the elements and they start at the boundary.
    #[cfg(target_os = "linux")]
    Map(memmap2::MmapMut, usize),
}

impl<T: Pod + Send + Sync> Pages<T> {
    /// `len` elements with all bits zero.
    pub fn zeroed(len: usize) -> Self {
        #[cfg(target_os = "linux")]
        if Self::maps(len) {
            let bytes = len * std::mem::size_of::<T>();
            if let Ok(map) = memmap2::MmapMut::map_anon(bytes.next_multiple_of(HUGE) + HUGE) {
                // A hint: without huge pages the mapping is still good memory.
                let _ = map.advise(memmap2::Advice::HugePage);
                let start = map.as_ptr().align_offset(HUGE);
                if start <= HUGE {
                    return Pages { store: Store::Map(map, start), len };
                }
            }
        }
        // Written in parallel when large: a zero-filled `vec!` of a struct is written on one
        // thread (the allocator's zeroed pages serve only primitive types).
        let v = (0..len).into_par_iter().with_min_len(64 << 10).map(|_| T::zeroed()).collect();
        Pages { store: Store::Vec(v), len }
    }

    /// A copy of `items`.
    pub fn from_slice(items: &[T]) -> Self {
        let mut p = Self::zeroed(items.len());
        p.copy_from_slice(items);
        p
    }

    /// `items`, moved to a mapping of their own if large (a copy), else kept as they are
    /// (without their spare capacity).
    pub fn from_vec(mut items: Vec<T>) -> Self {
        if Self::maps(items.len()) {
            Self::from_slice(&items)
        } else {
            items.shrink_to_fit();
            let len = items.len();
            Pages { store: Store::Vec(items), len }
        }
    }

    /// Whether `len` elements get a mapping of their own.
    fn maps(len: usize) -> bool {
        cfg!(target_os = "linux") && len * std::mem::size_of::<T>() >= MAP_MIN
    }

    /// Whether the array is on a mapping of its own (which the kernel was asked to back with
    /// huge pages), starting at a 2 MiB boundary.
    #[cfg(test)]
    pub fn is_mapped(&self) -> bool {
        match &self.store {
            Store::Vec(_) => false,
            #[cfg(target_os = "linux")]
            Store::Map(..) => self.as_ptr().align_offset(HUGE) == 0,
        }
    }
}

impl<T: Pod> Deref for Pages<T> {
    type Target = [T];

    #[inline]
    fn deref(&self) -> &[T] {
        match &self.store {
            Store::Vec(v) => v,
            #[cfg(target_os = "linux")]
            Store::Map(m, start) => {
                bytemuck::cast_slice(&m[*start..*start + self.len * std::mem::size_of::<T>()])
            }
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
            Store::Map(m, start) => bytemuck::cast_slice_mut(&mut m[*start..*start + bytes]),
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
        let n = MAP_MIN / 4;
        let mut z = Pages::<u32>::zeroed(n);
        assert!(z.iter().all(|&x| x == 0));
        z[n - 1] = 7;
        assert_eq!(z[n - 1], 7);
        assert_eq!(z.is_mapped(), cfg!(target_os = "linux"));
    }
}
