//! Huge pages for the decoder's large arrays ([`HugeVec`]).
//!
//! Why: a record touches a handful of vertices whose ids are spread over the
//! whole level (a split's anchor is any older vertex), so on a large mesh
//! nearly every record walks into pages the TLB does not hold. With 4 KiB
//! pages the split bunny's frontier and level arrays (~20 MB: codes, corner
//! blocks, quads, positions) span ~5,000 pages; with 2 MiB pages, ~10. And
//! a new decoder's arrays are faulted in page by page as they are first
//! written: 512× fewer faults with 2 MiB pages.
//!
//! How: a [`HugeVec`] buffer of at least [`HUGE_FROM`] bytes is, on Linux,
//! a mapping of its own (`mmap`), placed at a 2 MiB boundary, whose whole
//! 2 MiB pages the kernel is advised to back with transparent huge pages
//! (`madvise(MADV_HUGEPAGE)`); the tail past the last whole page keeps
//! small pages, so that it maps only what is written. A freed
//! mapping is kept for the next buffer of about its size (a new decoder
//! for the next file): at most 8 of them and 64 MiB in all, the oldest
//! unmapped first, so that a loop of new decoders finds its pages mapped,
//! as glibc's heap gave them before, and pays no page faults
//! ([`release_cached`] gives them back). (Through the
//! heap instead, with 2 MiB-aligned blocks, glibc kept every freed huge
//! page: a loop of new decoders on the split bunny grew to 128 MB resident
//! where one decode needs 23 MB. Unmapping at once made that loop 4–7 %
//! slower than before.) The advice is only advice: contents and results
//! are unchanged, and a kernel without transparent huge pages, or with them
//! `never`, ignores it; at `always` the alignment alone lets the kernel use
//! them, at `madvise` (Debian's default) only advised memory gets them.
//! Smaller buffers, and every buffer on other systems, are ordinary heap
//! allocations.
//!
//! The cost: a huge page is mapped (and zeroed) whole on its first write,
//! so a client that stops refining early may hold up to 2 MiB more per
//! array than it wrote (one whole decode of the split bunny: 26.9 MB
//! resident, 22.7 MB before), and up to 64 MiB of freed arrays stay mapped
//! for the next decoder. The gain, on the split bunny: decodes 6–10 %
//! faster, with a reused decoder, a new one, or in a new process; the
//! smaller bench meshes have no array of 1 MiB (session 19 in
//! `docs/figures-history.md`).
//!
//! Why not `Vec` with an allocator (the `allocator-api2` crate on stable
//! Rust): measured, its `push` and `extend` cost loki's decode 1.0–1.7 %
//! more instructions than `std`'s, which ate most of the gain on the
//! smaller meshes. The arrays hold `Copy` values only, so this buffer needs
//! no element drops and stays small.

use std::alloc::Layout;
use std::ptr::NonNull;

/// Size (and alignment) of a transparent huge page on x86-64, and on
/// aarch64 kernels with 4 KiB base pages.
const HUGE: usize = 2 << 20;

/// Buffers from this size on get whole, aligned huge pages; below it, a
/// huge page would be mostly rounding.
pub const HUGE_FROM: usize = 1 << 20;

/// A growable array of `Copy` values (a `Vec` for the decoder's per-vertex
/// and per-face arrays) whose buffer, once it reaches [`HUGE_FROM`] bytes,
/// sits on 2 MiB-aligned huge pages (module documentation). Derefs to a
/// slice; grows like `Vec` (doubling, amortized O(1) `push`).
pub struct HugeVec<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    cap: usize,
}

// SAFETY: a HugeVec owns its buffer exclusively, like Vec<T>.
unsafe impl<T: Copy + Send> Send for HugeVec<T> {}
// SAFETY: shared access only reads, like &[T].
unsafe impl<T: Copy + Sync> Sync for HugeVec<T> {}

/// Gives the kernel back the freed arrays kept for the next decoder (see
/// the module documentation; at most 64 MiB); returns how many bytes that
/// was. For a long-running process that decoded a large file and will not
/// decode another soon. Arrays in use are not touched, nor those of the
/// dropped decoder kept whole for the next one:
/// [`crate::release_recycled`] frees those too.
pub fn release_cached() -> usize {
    os::release()
}

/// The layout of a buffer of `cap` elements, `None` on overflow.
fn buffer_layout<T>(cap: usize) -> Option<Layout> {
    Layout::array::<T>(cap).ok()
}

/// Whether a buffer of `layout` is a mapping of its own (module docs): a
/// function of the capacity alone, so that a buffer is freed the way it
/// was allocated.
#[inline]
fn mapped(layout: Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= HUGE_FROM
}

/// Allocates a buffer of `layout` (non-zero size), mapped or from the
/// heap, and says how many bytes it holds (a cached mapping may hold more).
fn allocate(layout: Layout) -> Option<(NonNull<u8>, usize)> {
    if mapped(layout) {
        os::map(layout.size())
    } else {
        // SAFETY: the caller passes a non-zero size.
        Some((
            NonNull::new(unsafe { std::alloc::alloc(layout) })?,
            layout.size(),
        ))
    }
}

/// Frees a buffer from [`allocate`].
///
/// # Safety
/// `p` came from `allocate(layout)` and is not used again.
unsafe fn free(p: NonNull<u8>, layout: Layout) {
    if mapped(layout) {
        // SAFETY: the caller's contract; `mapped` gave the same answer then.
        unsafe { os::unmap(p, layout.size()) }
    } else {
        // SAFETY: as above, a heap block of this layout.
        unsafe { std::alloc::dealloc(p.as_ptr(), layout) }
    }
}

impl<T: Copy> HugeVec<T> {
    /// An empty array (allocates nothing).
    pub const fn new() -> Self {
        HugeVec {
            ptr: NonNull::dangling(),
            len: 0,
            cap: 0,
        }
    }

    /// An empty array with room for `cap` elements.
    pub fn with_capacity(cap: usize) -> Self {
        let mut v = Self::new();
        v.reserve(cap);
        v
    }

    /// A copy of `s`.
    pub fn from_slice(s: &[T]) -> Self {
        let mut v = Self::with_capacity(s.len());
        v.extend_from_slice(s);
        v
    }

    /// Number of elements.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no elements.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Elements the buffer holds without growing.
    #[inline(always)]
    pub fn capacity(&self) -> usize {
        if std::mem::size_of::<T>() == 0 {
            usize::MAX
        } else {
            self.cap
        }
    }

    /// Room for at least `additional` more elements (doubling, as `Vec`).
    #[inline]
    pub fn reserve(&mut self, additional: usize) {
        let need = self.len.checked_add(additional).expect("capacity overflow");
        if need > self.capacity() {
            self.grow(need);
        }
    }

    /// Moves the elements to a buffer of at least `need` (> capacity)
    /// elements. Cold: a decoder reserves its final size up front.
    #[cold]
    #[inline(never)]
    fn grow(&mut self, need: usize) {
        let new_cap = need.max(self.cap.saturating_mul(2)).max(4);
        let new_layout = buffer_layout::<T>(new_cap).expect("capacity overflow");
        // T is not zero-sized here (capacity() is usize::MAX for those, so
        // no growth is ever needed): the size is at least 4 elements'.
        let Some((raw, bytes)) = allocate(new_layout) else {
            std::alloc::handle_alloc_error(new_layout)
        };
        let new_ptr = raw.cast::<T>();
        // All of a cached mapping is ours; its layout (`buffer_layout` of
        // this capacity) is still mapped and rounds to the same length.
        let new_cap = new_cap.max(bytes / std::mem::size_of::<T>());
        if self.cap > 0 {
            // SAFETY: both buffers hold at least `len` elements and do not
            // overlap (the new one is fresh); the old one came from
            // `allocate(buffer_layout(cap))`, which succeeded then, so
            // does now.
            unsafe {
                std::ptr::copy_nonoverlapping(self.ptr.as_ptr(), new_ptr.as_ptr(), self.len);
                let old = buffer_layout::<T>(self.cap).expect("allocated before");
                free(self.ptr.cast(), old);
            }
        }
        self.ptr = new_ptr;
        self.cap = new_cap;
    }

    /// Appends `x`.
    #[inline(always)]
    pub fn push(&mut self, x: T) {
        if self.len == self.capacity() {
            self.grow(self.len + 1);
        }
        // SAFETY: len < capacity, so the slot is inside the buffer.
        unsafe { self.ptr.as_ptr().add(self.len).write(x) };
        self.len += 1;
    }

    /// Appends a copy of `s`.
    #[inline]
    pub fn extend_from_slice(&mut self, s: &[T]) {
        self.reserve(s.len());
        // SAFETY: room for s.len() more after `reserve`; `s` cannot alias
        // the spare capacity (no slice of it exists).
        unsafe {
            std::ptr::copy_nonoverlapping(s.as_ptr(), self.ptr.as_ptr().add(self.len), s.len());
        }
        self.len += s.len();
    }

    /// Appends `f(x)` for each `x` of `src`, each element written once
    /// straight into the spare capacity (a `resize` then a loop over the
    /// slice writes every element twice; `Extend` checks the capacity per
    /// element).
    #[inline]
    pub fn extend_map<S: Copy>(&mut self, src: &[S], mut f: impl FnMut(S) -> T) {
        self.reserve(src.len());
        // SAFETY: room for `src.len()` more after `reserve`; `len` is
        // raised once all are written (`T: Copy`: a panic in `f` leaves
        // nothing to drop, only unwritten spare capacity).
        unsafe {
            let p = self.ptr.as_ptr().add(self.len);
            for (i, &x) in src.iter().enumerate() {
                p.add(i).write(f(x));
            }
        }
        self.len += src.len();
    }

    /// Sets the length to `n`, filling new slots with `x`.
    pub fn resize(&mut self, n: usize, x: T) {
        if n <= self.len {
            self.len = n;
            return;
        }
        self.reserve(n - self.len);
        for i in self.len..n {
            // SAFETY: i < n <= capacity.
            unsafe { self.ptr.as_ptr().add(i).write(x) };
        }
        self.len = n;
    }

    /// Keeps the first `n` elements (no-op if there are fewer).
    #[inline]
    pub fn truncate(&mut self, n: usize) {
        self.len = self.len.min(n);
    }

    /// Removes every element, keeping the buffer.
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Removes and returns the last element.
    #[inline]
    pub fn pop(&mut self) -> Option<T> {
        let x = *self.last()?;
        self.len -= 1;
        Some(x)
    }
}

impl<T: Copy> Drop for HugeVec<T> {
    fn drop(&mut self) {
        if self.cap > 0 && std::mem::size_of::<T>() > 0 {
            let layout = buffer_layout::<T>(self.cap).expect("allocated before");
            // SAFETY: allocated in `grow` with this layout; T: Copy needs
            // no element drops.
            unsafe { free(self.ptr.cast(), layout) };
        }
    }
}

impl<T: Copy> std::ops::Deref for HugeVec<T> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: the first `len` elements are initialized; a dangling,
        // aligned pointer is valid for an empty slice.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> std::ops::DerefMut for HugeVec<T> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and `&mut self` is exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Default for HugeVec<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy> Clone for HugeVec<T> {
    fn clone(&self) -> Self {
        Self::from_slice(self)
    }

    /// Reuses `self`'s buffer when it is large enough (a reset decoder's
    /// frontier keeps its pages).
    fn clone_from(&mut self, other: &Self) {
        self.clear();
        self.extend_from_slice(other);
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for HugeVec<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<T: Copy + PartialEq> PartialEq for HugeVec<T> {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

impl<T: Copy + Eq> Eq for HugeVec<T> {}

impl<T: Copy + PartialEq> PartialEq<Vec<T>> for HugeVec<T> {
    fn eq(&self, other: &Vec<T>) -> bool {
        self[..] == other[..]
    }
}

impl<T: Copy + PartialEq, const N: usize> PartialEq<[T; N]> for HugeVec<T> {
    fn eq(&self, other: &[T; N]) -> bool {
        self[..] == other[..]
    }
}

impl<T: Copy> Extend<T> for HugeVec<T> {
    fn extend<I: IntoIterator<Item = T>>(&mut self, iter: I) {
        let iter = iter.into_iter();
        self.reserve(iter.size_hint().0);
        for x in iter {
            self.push(x);
        }
    }
}

impl<'a, T: Copy> IntoIterator for &'a HugeVec<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T: Copy> FromIterator<T> for HugeVec<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut v = Self::new();
        v.extend(iter);
        v
    }
}

impl<T: Copy> From<&[T]> for HugeVec<T> {
    fn from(s: &[T]) -> Self {
        Self::from_slice(s)
    }
}

impl<T: Copy> From<Vec<T>> for HugeVec<T> {
    fn from(v: Vec<T>) -> Self {
        Self::from_slice(&v)
    }
}

/// Buffers of their own, on 2 MiB boundaries, advised to huge pages.
#[cfg(target_os = "linux")]
mod os {
    use super::HUGE;
    use std::ptr::NonNull;
    use std::sync::Mutex;

    /// Mapping lengths are rounded to this (a multiple of every Linux base
    /// page size), so that the tail cut off below starts on a page.
    const GRAIN: usize = 64 << 10;

    fn mapped_len(bytes: usize) -> Option<usize> {
        Some(bytes.checked_add(GRAIN - 1)? & !(GRAIN - 1))
    }

    /// Freed mappings kept for the next buffers, `(address, length)`,
    /// oldest first: at most [`CACHE_COUNT`] of them and [`CACHE_BYTES`]
    /// in all (see the module documentation).
    static CACHE: Mutex<Vec<(usize, usize)>> = Mutex::new(Vec::new());
    const CACHE_COUNT: usize = 8;
    const CACHE_BYTES: usize = 64 << 20;

    /// A mapping of at least `bytes` on a 2 MiB boundary, its whole 2 MiB
    /// pages advised to huge pages, and its usable length (a multiple of
    /// [`GRAIN`], up to a quarter more than asked when it is a cached one).
    /// Its contents are unspecified (zeroes, or an earlier buffer's).
    pub(super) fn map(bytes: usize) -> Option<(NonNull<u8>, usize)> {
        let len = mapped_len(bytes)?;
        {
            let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
            let fit = cache
                .iter()
                .enumerate()
                .filter(|(_, &(_, l))| l >= len && l - len <= len / 4)
                .min_by_key(|(_, &(_, l))| l)
                .map(|(i, _)| i);
            if let Some(i) = fit {
                let (addr, l) = cache.remove(i);
                return Some((NonNull::new(addr as *mut u8)?, l));
            }
        }
        let span = len.checked_add(HUGE)?;
        // SAFETY: a new private anonymous mapping; no existing memory is
        // touched. Its address is checked below.
        let p = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                span,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if p == libc::MAP_FAILED {
            return None;
        }
        let start = p as usize;
        let aligned = (start + HUGE - 1) & !(HUGE - 1);
        let (head, tail) = (aligned - start, span - (aligned - start) - len);
        // SAFETY: [start, aligned) and [aligned + len, start + span) are
        // parts of the mapping just made, page-aligned (start is; aligned
        // is a multiple of 2 MiB; len of GRAIN), outside what is returned.
        // MADV_HUGEPAGE only sets a flag on the mapping; its result is
        // ignored (EINVAL where the kernel has no transparent huge pages).
        unsafe {
            if head > 0 {
                libc::munmap(p, head);
            }
            if tail > 0 {
                libc::munmap((aligned + len) as *mut libc::c_void, tail);
            }
            let whole = len & !(HUGE - 1);
            if whole > 0 {
                libc::madvise(aligned as *mut libc::c_void, whole, libc::MADV_HUGEPAGE);
            }
        }
        Some((NonNull::new(aligned as *mut u8)?, len))
    }

    /// Gives back a buffer from [`map`]: into the cache, or unmapped (with
    /// the oldest cached ones, to make room).
    ///
    /// # Safety
    /// `p` came from `map` with a usable length `l`, `bytes` is in
    /// `(l - GRAIN, l]`, and `p` is not used again.
    pub(super) unsafe fn unmap(p: NonNull<u8>, bytes: usize) {
        let len = mapped_len(bytes).expect("mapped before");
        let mut gone = vec![];
        if len <= CACHE_BYTES {
            let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
            let mut total: usize = cache.iter().map(|&(_, l)| l).sum();
            while !cache.is_empty() && (cache.len() >= CACHE_COUNT || total + len > CACHE_BYTES) {
                let old = cache.remove(0);
                total -= old.1;
                gone.push(old);
            }
            cache.push((p.as_ptr() as usize, len));
        } else {
            gone.push((p.as_ptr() as usize, len));
        }
        for (addr, l) in gone {
            // SAFETY: the caller's contract (for `p`), or a mapping the
            // cache owned, taken out of it above: each exactly a mapping
            // `map` kept, used by no buffer.
            unsafe { libc::munmap(addr as *mut libc::c_void, l) };
        }
    }

    /// Unmaps every cached mapping; returns their bytes.
    pub(super) fn release() -> usize {
        let gone = std::mem::take(&mut *CACHE.lock().unwrap_or_else(|e| e.into_inner()));
        let mut bytes = 0;
        for (addr, l) in gone {
            // SAFETY: mappings the cache owned, taken out of it above:
            // each exactly a mapping `map` kept, used by no buffer.
            unsafe { libc::munmap(addr as *mut libc::c_void, l) };
            bytes += l;
        }
        bytes
    }
}

/// Other systems map nothing of their own (`mapped` is always false).
#[cfg(not(target_os = "linux"))]
mod os {
    use std::ptr::NonNull;
    pub(super) fn map(_bytes: usize) -> Option<(NonNull<u8>, usize)> {
        unreachable!("mapped() is false off Linux")
    }
    pub(super) unsafe fn unmap(_p: NonNull<u8>, _bytes: usize) {
        unreachable!("mapped() is false off Linux")
    }
    pub(super) fn release() -> usize {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// One step of the model test.
    #[derive(Clone, Debug)]
    enum Op {
        Push(u32),
        Extend(Vec<u32>),
        ExtendMap(Vec<u32>),
        Resize(usize, u32),
        Truncate(usize),
        Clear,
        Pop,
        Reserve(usize),
        CloneFrom(Vec<u32>),
        Set(usize, u32),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            any::<u32>().prop_map(Op::Push),
            prop::collection::vec(any::<u32>(), 0..40).prop_map(Op::Extend),
            prop::collection::vec(any::<u32>(), 0..40).prop_map(Op::ExtendMap),
            (0usize..300, any::<u32>()).prop_map(|(n, x)| Op::Resize(n, x)),
            (0usize..300).prop_map(Op::Truncate),
            Just(Op::Clear),
            Just(Op::Pop),
            (0usize..600_000).prop_map(Op::Reserve),
            prop::collection::vec(any::<u32>(), 0..40).prop_map(Op::CloneFrom),
            (any::<usize>(), any::<u32>()).prop_map(|(i, x)| Op::Set(i, x)),
        ]
    }

    proptest! {
        /// Every operation leaves a `HugeVec` equal to a `Vec` given the
        /// same operations (reserves large enough to cross into huge
        /// buffers included), with its capacity at least its length.
        #[test]
        fn behaves_like_vec(ops in prop::collection::vec(op(), 0..60)) {
            let (mut h, mut v) = (HugeVec::<u32>::new(), Vec::<u32>::new());
            for o in ops {
                match o {
                    Op::Push(x) => { h.push(x); v.push(x); }
                    Op::Extend(s) => { h.extend_from_slice(&s); v.extend_from_slice(&s); }
                    Op::ExtendMap(s) => {
                        h.extend_map(&s, |x| x.rotate_left(7));
                        v.extend(s.iter().map(|x| x.rotate_left(7)));
                    }
                    Op::Resize(n, x) => { h.resize(n, x); v.resize(n, x); }
                    Op::Truncate(n) => { h.truncate(n); v.truncate(n); }
                    Op::Clear => { h.clear(); v.clear(); }
                    Op::Pop => prop_assert_eq!(h.pop(), v.pop()),
                    Op::Reserve(n) => { h.reserve(n); v.reserve(n); }
                    Op::CloneFrom(s) => { h.clone_from(&HugeVec::from_slice(&s)); v.clone_from(&s); }
                    Op::Set(i, x) => if !v.is_empty() { let i = i % v.len(); h[i] = x; v[i] = x; }
                }
                prop_assert_eq!(&h, &v);
                prop_assert!(h.capacity() >= h.len());
                if cfg!(target_os = "linux") && h.capacity() * 4 >= HUGE_FROM {
                    prop_assert_eq!(h.as_ptr() as usize % HUGE, 0);
                }
            }
            prop_assert_eq!(h.clone(), HugeVec::from_slice(&v));
        }
    }

    /// A buffer reserved large is huge-page aligned and keeps its contents
    /// through growth; zero-sized and empty arrays work.
    #[test]
    fn large_buffers_are_aligned_and_keep_contents() {
        let mut v: HugeVec<[u32; 3]> = (0..1000u32).map(|i| [i, i + 1, i + 2]).collect();
        v.reserve(1 << 20);
        if cfg!(target_os = "linux") {
            assert_eq!(v.as_ptr() as usize % HUGE, 0);
        }
        v.extend((1000..1_000_000u32).map(|i| [i, i + 1, i + 2]));
        assert!(v
            .iter()
            .enumerate()
            .all(|(i, x)| x[0] == i as u32 && x[2] == i as u32 + 2));
        let mut z: HugeVec<()> = HugeVec::new();
        z.resize(1000, ());
        z.push(());
        assert_eq!((z.len(), z.capacity()), (1001, usize::MAX));
        assert!(HugeVec::<u8>::new().is_empty());
    }

    /// Buffers freed and allocated again, of equal, near and far sizes
    /// (the mapping cache's reuse, fit and eviction), hold what was
    /// written, and one too large for the cache works too.
    #[test]
    fn freed_buffers_are_reused_safely() {
        for round in 0..3u32 {
            for (i, n) in [
                300_000usize,
                300_000,
                320_000,
                1_000_000,
                270_000,
                17_000_000,
            ]
            .into_iter()
            .enumerate()
            {
                let tag = round * 10 + i as u32;
                let mut v = HugeVec::<u32>::with_capacity(n);
                v.resize(n, tag);
                v[n - 1] = tag + 1;
                let w = v.clone();
                assert!(w[..n - 1].iter().all(|&x| x == tag) && w[n - 1] == tag + 1);
                assert!(w.capacity() >= n);
            }
        }
    }

    /// Releasing the cache leaves buffers in use alone: a live large
    /// buffer stays readable and writable after a freed one is released.
    #[test]
    fn release_keeps_live_buffers() {
        let mut live = HugeVec::<u64>::with_capacity(400_000);
        live.resize(400_000, 3);
        let mut freed = HugeVec::<u64>::with_capacity(300_000);
        freed.resize(300_000, 4);
        drop(freed);
        release_cached();
        for (i, x) in live.iter_mut().enumerate() {
            *x += i as u64;
        }
        assert!(live.iter().enumerate().all(|(i, &x)| x == 3 + i as u64));
        let again = HugeVec::<u64>::from_slice(&live);
        assert_eq!(again, live);
    }

    /// Large buffers are mappings of their own on 2 MiB boundaries
    /// (Linux), small ones heap blocks, decided by the size alone.
    #[test]
    fn large_buffers_are_mapped_small_ones_are_not() {
        for bytes in [
            HUGE_FROM - 4,
            HUGE_FROM,
            HUGE - 4,
            HUGE,
            HUGE + 4,
            5 * HUGE + 8,
        ] {
            let l = buffer_layout::<u32>(bytes / 4).unwrap();
            assert_eq!(mapped(l), cfg!(target_os = "linux") && bytes >= HUGE_FROM);
            let mut v = HugeVec::<u32>::with_capacity(bytes / 4);
            v.resize(bytes / 4, 7);
            assert!(v.iter().all(|&x| x == 7));
            if mapped(l) {
                assert_eq!(v.as_ptr() as usize % HUGE, 0);
            }
        }
        assert!(buffer_layout::<u64>(usize::MAX / 4).is_none());
    }
}
