//! Storage for the BVH's nodes and triangle blocks on transparent huge pages.
//!
//! Traversing a large tree is bound by the latency of its loads: each node
//! and each leaf block is a cache miss at an address that depends on the
//! previous one. With 4 KiB pages each of those misses is a TLB miss too,
//! and inside a virtual machine a TLB miss walks two sets of page tables.
//! Linux backs memory with 2 MiB pages only where asked to
//! (`/sys/kernel/mm/transparent_hugepage/enabled` is `madvise` on Debian
//! and many other systems), and Rust's allocator never asks; Embree does
//! (`madvise(MADV_HUGEPAGE)` on its allocations). So arrays of at least
//! [`HUGE_MIN`] bytes live in an anonymous mapping advised for huge pages,
//! smaller ones (and every array on other systems) in a `Vec`.
//!
//! On the 1M-triangle `cornell-mesh` scene this took the BVH from 0.70x to
//! 0.79x Embree's rate on shadow rays, 0.63x to 0.77x on diffuse rays and
//! 0.71x to 0.82x on random ones; camera rays, which mostly stay in cached
//! nodes, measured alike (0.81x, 0.80x). Medians of six runs of `bench
//! --accel embree,bvh -t 1` each, alternating the two binaries, one thread,
//! on the 2-core AMD EPYC VM of the README's "Speed" section.

use bytemuck::Pod;

/// Arrays at least this large (one huge page) are mapped.
pub const HUGE_MIN: usize = 2 << 20;

/// A fixed-length array of plain data, on huge pages where it is large
/// enough (see the module documentation).
pub struct PageArray<T: Pod> {
    storage: Storage<T>,
}

enum Storage<T> {
    Heap(Vec<T>),
    #[cfg(target_os = "linux")]
    Mapped {
        map: memmap2::MmapMut,
        len: usize,
    },
}

impl<T: Pod> PageArray<T> {
    /// `len` zeroed elements. A mapping comes zeroed from the kernel, and
    /// its pages are touched (faulted in) first by whoever fills them: the
    /// builder does so in parallel.
    pub fn zeroed(len: usize) -> Self {
        let bytes = len.saturating_mul(std::mem::size_of::<T>());
        PageArray {
            storage: match Self::map(len, bytes) {
                Some(s) => s,
                None => Storage::Heap(vec![T::zeroed(); len]),
            },
        }
    }

    /// An anonymous mapping of `bytes` advised for huge pages (zeroed), or
    /// `None` when the array is small, the system is not Linux or mapping
    /// fails (the caller falls back to the heap).
    #[cfg(target_os = "linux")]
    fn map(len: usize, bytes: usize) -> Option<Storage<T>> {
        // a mapping is page-aligned, enough for any `T` the BVH stores
        if bytes < HUGE_MIN || std::mem::align_of::<T>() > 4096 {
            return None;
        }
        let map = memmap2::MmapMut::map_anon(bytes).ok()?;
        // only advice: without it the mapping still works, on small pages
        let _ = map.advise(memmap2::Advice::HugePage);
        Some(Storage::Mapped { map, len })
    }

    #[cfg(not(target_os = "linux"))]
    fn map(_len: usize, _bytes: usize) -> Option<Storage<T>> {
        None
    }

    /// Whether the array lives in a mapping advised for huge pages.
    #[cfg(test)]
    pub fn is_mapped(&self) -> bool {
        !matches!(self.storage, Storage::Heap(_))
    }

    /// Bytes the array occupies.
    pub fn memory_bytes(&self) -> usize {
        match &self.storage {
            Storage::Heap(v) => v.capacity() * std::mem::size_of::<T>(),
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, .. } => map.len(),
        }
    }

    /// The elements.
    #[inline(always)]
    pub fn as_slice(&self) -> &[T] {
        match &self.storage {
            Storage::Heap(v) => v,
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, len } => &bytemuck::cast_slice(&map[..])[..*len],
        }
    }

    /// The elements, mutably.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        match &mut self.storage {
            Storage::Heap(v) => v,
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, len } => &mut bytemuck::cast_slice_mut(&mut map[..])[..*len],
        }
    }
}

impl<T: Pod> std::ops::Deref for PageArray<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        self.as_slice()
    }
}

impl<T: Pod> std::ops::DerefMut for PageArray<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        self.as_mut_slice()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_arrays_stay_on_the_heap() {
        let a = PageArray::<u32>::zeroed(100);
        assert!(!a.is_mapped());
        assert_eq!((a.len(), a[0], a[99]), (100, 0, 0));
        let e: PageArray<u64> = PageArray::zeroed(0);
        assert!(e.is_empty() && !e.is_mapped());
        assert_eq!(a.memory_bytes(), 400);
    }

    #[test]
    fn large_arrays_are_mapped_filled_and_writable() {
        // not a multiple of the element size in huge pages: the tail counts
        let n = HUGE_MIN / 12 + 5;
        let mut a = PageArray::<[f32; 3]>::zeroed(n);
        assert_eq!(a.is_mapped(), cfg!(target_os = "linux"));
        assert_eq!(a.len(), n);
        assert!(a.memory_bytes() >= n * 12);
        assert!(a.iter().all(|x| *x == [0.0; 3]));
        for (i, x) in a.iter_mut().enumerate() {
            *x = [i as f32, -2.0, 3.0];
        }
        assert_eq!(a[n - 1], [(n - 1) as f32, -2.0, 3.0]);
        assert_eq!(a[12_345][0], 12_345.0);
    }
}
