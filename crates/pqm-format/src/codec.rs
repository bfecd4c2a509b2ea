//! Coding of the base mesh and of refinement records (spec §6–§7).
//!
//! Both the encoder and the decoder run the same [`MeshState`] — quantized
//! positions, quads and vertex→face adjacency at the current level — because
//! the coding is *predictive*: the compact split form names a vertex and two
//! wings in its link ring, the local form names faces and vertices by their
//! index in the 2-ring of one anchor vertex (both need adjacency), and every
//! position is a residual against a prediction from positions the decoder
//! already has.
//!
//! A record is coded into five separate byte streams (symbols, connectivity
//! integers, vertex references, face slots, position residuals) because
//! each stream has its own statistics and zstd models them better apart.

use crate::huge_pages::HugeVec;
use crate::varint::{put_s, put_u, Reader};
use pqm_core::OpKind;
use std::collections::HashMap;

/// Stream indices inside a record chunk payload, in payload order.
pub const OPS: usize = 0;
/// Connectivity integers: counts, masks, corner codes, wing indices.
pub const CONN: usize = 1;
/// Vertex references (zigzag deltas against the running vertex cursor).
pub const REFS: usize = 2;
/// Face slots of rewritten faces.
pub const SLOTS: usize = 3;
/// Position residuals.
pub const POS: usize = 4;
/// Stream names, for errors and reports.
pub const STREAM_NAMES: [&str; 5] = ["ops", "conn", "refs", "slots", "pos"];

/// The split form is defined only for stars of at most this many faces
/// (bounds the decoder's ring walk, which is quadratic in the valence).
pub const MAX_SPLIT_STAR: usize = 255;

/// One record in explicit form with quantized positions (what both sides
/// agree on; the decoder stores these for moving between levels).
#[derive(Clone, Debug, PartialEq)]
pub struct QRecord {
    /// Operator kind.
    pub op: OpKind,
    /// Codes of the appended vertices.
    pub new_pos: Vec<[u32; 3]>,
    /// Moved vertices, ids strictly ascending, with their new codes.
    pub moved: Vec<(u32, [u32; 3])>,
    /// Rewritten slots, strictly ascending, with their new contents.
    pub rewritten: Vec<(u32, [u32; 4])>,
    /// Appended quads.
    pub appended: Vec<[u32; 4]>,
}

impl QRecord {
    /// Empties the four lists (the decoders reuse one record as scratch).
    pub fn clear_parts(&mut self) {
        self.new_pos.clear();
        self.moved.clear();
        self.rewritten.clear();
        self.appended.clear();
    }

    /// The coarsener's record on the quantization grid: positions quantized,
    /// moved vertices sorted by id (the form every coding reads).
    pub fn quantized(rec: &pqm_core::SplitRecord, quant: &crate::quant::Quantizer) -> Self {
        let mut moved: Vec<(u32, [u32; 3])> = rec
            .moved
            .iter()
            .map(|(v, p)| (*v, quant.quantize(*p)))
            .collect();
        moved.sort_unstable_by_key(|m| m.0);
        QRecord {
            op: rec.op,
            new_pos: rec
                .new_vertices
                .iter()
                .map(|p| quant.quantize(*p))
                .collect(),
            moved,
            rewritten: rec.rewritten.clone(),
            appended: rec.appended_faces.clone(),
        }
    }
}

impl Default for QRecord {
    /// An empty record (a buffer for [`decode_record_into`]).
    fn default() -> Self {
        QRecord {
            op: OpKind::QvMerge,
            new_pos: Vec::new(),
            moved: Vec::new(),
            rewritten: Vec::new(),
            appended: Vec::new(),
        }
    }
}

/// Sorts a list of *distinct* values ascending. Up to 64 entries (the
/// neighbourhoods of §7.7 hold ~20 faces and ~30 vertices on real meshes)
/// by rank: each value goes to the position given by the count of smaller
/// values — n² comparisons, but branch-free and vectorized, where insertion
/// sort or the general sort spend their time in mispredicted branches. The
/// standard unstable sort beyond. (Equal values would collide: callers
/// dedup first.)
fn sort_distinct(x: &mut [u32]) {
    const SMALL: usize = 64;
    if x.len() > SMALL {
        x.sort_unstable();
        return;
    }
    let mut out = [0u32; SMALL];
    for &v in x.iter() {
        let rank: u32 = x.iter().map(|&y| (y < v) as u32).sum();
        out[rank as usize] = v;
    }
    x.copy_from_slice(&out[..x.len()]);
    debug_assert!(x.windows(2).all(|w| w[0] < w[1]), "values not distinct");
}

/// Largest face count a [`MeshState`] holds: corner ids `4 s + k` must fit
/// in a `u32` below [`NIL`]. (A file beyond it is refused as exceeding the
/// decoder's limits; it would need tens of GiB anyway.)
pub const MAX_FACES: u32 = (1 << 30) - 1;

/// "No corner" in the adjacency lists of [`MeshState`].
pub const NIL: u32 = u32::MAX;

/// The decoder-side mesh at one level (see the module docs).
///
/// Vertex→face adjacency is kept as *corners*: corner `4 s + k` is corner
/// `k` of slot `s`. Each vertex owns one 32-byte block `inline[v]` =
/// `[n, c_1 … c_7]` holding up to [`INLINE`] of its corners; the rest (a
/// vertex in more than 7 faces, a few per cent on real meshes) are a doubly
/// linked list (`ov_head`: first corner per vertex, `ov_links`:
/// `[next, prev]` per corner, both `Paged`: only the 64-byte pages of 16
/// vertices or 8 corners that hold an entry are taken), flagged by
/// `OVERFLOW` in `n`. At most 32 bytes per vertex and 32 per slot, and
/// 1/16 of that for the page directories (within `Limits::estimate`). Reading a
/// star is then one cache miss for the block and independent misses for
/// the quads, where one linked list per vertex made every face a dependent
/// miss (the decoder's largest cost, issue 4); a rewrite is a scan of one
/// block and a swap-remove — O(1), and O(1) in the lists past the block,
/// so a hostile vertex in a million faces costs no more per corner. No
/// allocation per record once the blocks have grown. The order of the
/// corners carries no meaning: everything the format derives from a star
/// (§7.5) is defined by slot numbers, not by this order.
#[derive(Clone, Debug)]
pub struct MeshState {
    /// Largest quantization code.
    pub qmax: u32,
    /// Vertex codes.
    pub q: HugeVec<[u32; 3]>,
    /// Quads by slot.
    pub quads: HugeVec<[u32; 4]>,
    /// Per vertex: its [`Block`].
    inline: HugeVec<Block>,
    /// First overflow corner per vertex ([`NIL`]: none), valid where the
    /// block has the flag.
    ov_head: Paged<u32, 16>,
    /// `[next, prev]` per overflow corner ([`NIL`] ends a list).
    ov_links: Paged<[u32; 2], 8>,
}

impl MeshState {
    /// Makes this state equal to `base`, reusing its arrays' allocations
    /// (the decoder decodes its chunks again on its own frontier).
    pub fn reset_to(&mut self, base: &MeshState) {
        self.qmax = base.qmax;
        self.q.clone_from(&base.q);
        self.quads.clone_from(&base.quads);
        self.inline.clone_from(&base.inline);
        self.ov_head.clone_from(&base.ov_head);
        self.ov_links.clone_from(&base.ov_links);
    }
}

/// An array by index (vertex or corner id) whose entries are mostly never
/// written: pages of `P` entries (64 bytes each here) are taken on
/// their first write, and unwritten entries read as `fill`. The overflow
/// lists of [`MeshState`] are indexed by corner id but hold few corners
/// (on the bunny ~800 of 836k): as one array grown to the largest id
/// written (the first form) they were 6.7 MB filled, copied as they
/// doubled and faulted in, for a few kilobytes of entries.
///
/// The pages are entries of one pool, found through a directory of `u32`
/// indices. The previous form, a `Box` of 64 entries per page, allocated
/// and filled 512 bytes (256 for the heads) for what was nearly always a
/// single entry — new corners are new slots, so nearly every overflow
/// corner opened a page — and freed them all when a reset decoder took
/// the next base: on the skull (300k faces, ~14k overflow links per
/// decode) the overflow lists, their pages and `malloc` / `free` were
/// ~7 % of a reused decoder's samples. The pool is one allocation that a
/// reset keeps (`clone_from`), a new page one 64-byte push.
#[derive(Debug)]
struct Paged<T: Copy, const P: usize> {
    /// Page of ids `P i .. P (i + 1)`: its index in `pool`, or `NO_PAGE`.
    dir: Vec<u32>,
    pool: Vec<[T; P]>,
    fill: T,
}

/// A directory entry without a page.
const NO_PAGE: u32 = u32::MAX;

impl<T: Copy, const P: usize> Clone for Paged<T, P> {
    fn clone(&self) -> Self {
        Paged {
            dir: self.dir.clone(),
            pool: self.pool.clone(),
            fill: self.fill,
        }
    }

    /// Keeps this array's allocations (a reset decoder's frontier taking
    /// the next base, `MeshState::reset_to`).
    fn clone_from(&mut self, src: &Self) {
        self.dir.clone_from(&src.dir);
        self.pool.clone_from(&src.pool);
        self.fill = src.fill;
    }
}

impl<T: Copy, const P: usize> Paged<T, P> {
    fn new(fill: T) -> Self {
        Paged {
            dir: Vec::new(),
            pool: Vec::new(),
            fill,
        }
    }

    /// Bytes of the allocations.
    fn capacity_bytes(&self) -> usize {
        self.dir.capacity() * std::mem::size_of::<u32>()
            + self.pool.capacity() * std::mem::size_of::<[T; P]>()
    }

    /// Entry `i` (`fill` if never written).
    #[inline]
    fn get(&self, i: u32) -> T {
        match self.dir.get(i as usize / P) {
            Some(&p) if p != NO_PAGE => self.pool[p as usize][i as usize % P],
            _ => self.fill,
        }
    }

    /// Entry `i`, for writing (its page taken if new).
    #[inline]
    fn at(&mut self, i: u32) -> &mut T {
        let (pi, k) = (i as usize / P, i as usize % P);
        if self.dir.len() <= pi {
            self.dir.resize(pi + 1, NO_PAGE);
        }
        let mut p = self.dir[pi];
        if p == NO_PAGE {
            // At most one page per `P` ids below 2^32: the index fits.
            p = self.pool.len() as u32;
            self.pool.push([self.fill; P]);
            self.dir[pi] = p;
        }
        &mut self.pool[p as usize][k]
    }
}

/// Hints the CPU to fetch `x[i]` into the cache (off x86-64: nothing). It changes no result: a prefetch reads no
/// value and cannot fault. The decoder is bound by the latency of scattered
/// reads (a star's quads, its vertices' blocks and codes): issuing them all
/// before the loop that uses them overlaps the misses, where the loop's
/// data-dependent branches (insertion by slot) would replay them one by one.
#[inline(always)]
pub(crate) fn prefetch<T>(x: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        // No bounds check: the address is only a hint (`wrapping_add`
        // forms it without the in-bounds requirement of `add`).
        let p = x.as_ptr().wrapping_add(i).cast::<i8>();
        // SAFETY: `_mm_prefetch` dereferences nothing and cannot fault,
        // whatever the address (out of range, unmapped: the hint is
        // dropped); SSE, which provides it, is part of the x86-64 baseline.
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (x, i);
}

/// Vertex count from which the decoder prefetches ahead
/// ([`MeshState::prefetch_ahead`]): about where its scattered arrays (~60
/// bytes per vertex: block, code, quads) outgrow a 2 MiB L2 cache.
pub(crate) const PREFETCH_MIN_VERTICES: usize = 1 << 15;

/// How far past the end of the corner blocks (in blocks; twice as many
/// codes and quads, whose entries are half a block or less: each array
/// about 2 KiB ahead, a few dozen records' growth) the decoder
/// prefetches the lines of vertices and faces still to come
/// ([`MeshState::prefetch_ahead`]). The bunny's
/// forward-only loop measured 8 to 512 alike, all about 7 % faster than
/// none.
const PREFETCH_TAIL: usize = 64;

/// Corners stored in a vertex's own block (see [`MeshState`]).
pub const INLINE: usize = 7;

/// One vertex's corner block, `[n | OVERFLOW flag, corners…]`, aligned so
/// that it is always one cache line (a `[u32; 8]` at malloc's 16-byte
/// alignment straddles two lines every other vertex: measured, the subset
/// torus bench decoded 1.5× slower in a process whose heap gave such
/// addresses).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Block([u32; INLINE + 1]);

/// Flag in a block's count word: the vertex has overflow corners.
const OVERFLOW: u32 = 1 << 31;

/// The corners at one vertex: its block, then its overflow list.
struct CornerIter<'a> {
    st: &'a MeshState,
    block: &'a [u32],
    i: usize,
    ov: u32,
}

impl Iterator for CornerIter<'_> {
    type Item = u32;
    #[inline]
    fn next(&mut self) -> Option<u32> {
        if let Some(&c) = self.block.get(self.i) {
            self.i += 1;
            return Some(c);
        }
        if self.ov == NIL {
            return None;
        }
        let c = self.ov;
        self.ov = self.st.ov_links.get(c)[0];
        Some(c)
    }
}

/// Star of a vertex in canonical order (spec §7.5).
#[derive(Clone, Debug, Default)]
pub struct Star {
    /// Faces `f_0 … f_{K-1}` counter-clockwise.
    pub faces: Vec<u32>,
    /// Link ring `l_0 … l_{L-1}` (`L = K`, or `K + 1` on the boundary).
    pub link: Vec<u32>,
}

/// An interior star of at most [`INLINE`] faces from
/// [`MeshState::star_fast`]: face `f_i` of the canonical order (spec §7.5)
/// as the corner id `c[i] = 4 f_i + k_i` of `m` in it, and `nx[i] = l_i`;
/// entries past `n` mean nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FastStar {
    pub(crate) n: usize,
    pub(crate) c: [u32; 8],
    pub(crate) nx: [u32; 8],
}

impl Default for FastStar {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl FastStar {
    /// A buffer for [`MeshState::star_fast_into`].
    pub(crate) const EMPTY: FastStar = FastStar {
        n: 0,
        c: [NIL; 8],
        nx: [NIL; 8],
    };

    /// The same star as a [`Star`] (fixed 32-byte copies, then truncated:
    /// no per-element push).
    #[inline]
    pub(crate) fn write_into(&self, out: &mut Star) {
        let Star { faces, link } = out;
        faces.clear();
        faces.extend_from_slice(&self.c.map(|c| c >> 2));
        faces.truncate(self.n);
        link.clear();
        link.extend_from_slice(&self.nx);
        link.truncate(self.n);
    }
}

/// Neighbourhood of a local-form anchor `m` (spec §7.7): `faces` = every
/// slot whose quad has a corner in the closed star of `m` (the vertices of
/// the faces at `m`), ascending; `verts` = the corners of those faces,
/// ascending. Ascending ids make both lists cheap to build identically in
/// any decoder (no walk), and the record names its faces and vertices by
/// their small index here instead of by global slot / vertex deltas.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Local {
    /// Slots of the 2-ring faces, ascending.
    pub faces: Vec<u32>,
    /// Vertices of those faces, ascending.
    pub verts: Vec<u32>,
}

/// The local form is invalid when collecting its faces visits more than
/// this many corners (bounds the decoder's work per record: a hostile file
/// cannot make one record scan a huge fan).
pub const MAX_LOCAL_CORNERS: usize = 4096;

/// Generation stamps of [`MeshState::local_with`]: `v[u] == gen` marks
/// vertex `u` as seen in the current pass (star vertices and neighbourhood
/// vertices take one generation each, the decoder's moved-vertex vocabulary
/// a third), `f` the same for slots. Grown on demand; reset when the
/// counter wraps.
#[derive(Default)]
struct Marks {
    gen: u32,
    v: Vec<u32>,
    f: Vec<u32>,
    /// Scratch list of the star's vertices.
    star: Vec<u32>,
}

impl Marks {
    /// Fresh stamps for a mesh of `nv` vertices and `nf` slots: the vertex
    /// generation (the next one, +1, is also reserved) and the face one.
    fn next_gen(&mut self, nv: usize, nf: usize) -> (u32, u32) {
        if self.v.len() < nv {
            self.v.resize(nv, 0);
        }
        if self.f.len() < nf {
            self.f.resize(nf, 0);
        }
        if self.gen >= u32::MAX - 2 {
            self.gen = 0;
            self.v.fill(0);
            self.f.fill(0);
        }
        self.gen += 2;
        (self.gen - 1, self.gen)
    }

    /// One fresh vertex stamp (after [`Marks::next_gen`]'s two are used).
    fn next_v_gen(&mut self, nv: usize) -> u32 {
        if self.v.len() < nv {
            self.v.resize(nv, 0);
        }
        if self.gen >= u32::MAX - 2 {
            self.gen = 0;
            self.v.fill(0);
            self.f.fill(0);
        }
        self.gen += 1;
        self.gen
    }
}

/// Running cursors of one chunk (reset to 0 at every chunk start).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cursors {
    /// Last vertex reference coded in the `refs` stream.
    pub vref: u32,
    /// Last rewritten slot coded.
    pub slot: u32,
    /// The decoder's look-ahead into the chunk's `refs` stream
    /// (`MeshState::prefetch_ahead`): reset with the cursors.
    pub peek: crate::varint::Peek3,
}

impl MeshState {
    /// State for the given codes and quads (indices must be in range, at
    /// most [`MAX_FACES`] quads).
    pub fn new(qmax: u32, q: Vec<[u32; 3]>, quads: Vec<[u32; 4]>) -> Self {
        let mut inline = HugeVec::new();
        inline.resize(q.len(), Block::default());
        let mut st = MeshState {
            qmax,
            inline,
            ov_head: Paged::new(NIL),
            ov_links: Paged::new([NIL; 2]),
            q: HugeVec::from_slice(&q),
            quads: HugeVec::from_slice(&quads),
        };
        // `link`'s fast path over slices taken once (through `st` its
        // arrays' pointers were loaded again after every store), left for
        // `link_overflow` at a full block and taken again after it
        let corners = quads.as_flattened();
        let mut c = 0;
        while c < corners.len() {
            let inline = &mut st.inline[..];
            while let Some(&v) = corners.get(c) {
                let b = &mut inline[v as usize].0;
                let n = b[0] as usize;
                if n >= INLINE {
                    break;
                }
                b[n + 1] = c as u32;
                b[0] += 1;
                c += 1;
            }
            if let Some(&v) = corners.get(c) {
                st.link_overflow(c as u32, v);
                c += 1;
            }
        }
        st
    }

    /// Bytes of the arrays' allocations (codes, blocks, quads, and the
    /// overflow lists' pools and directories, which a reset keeps too).
    pub fn capacity_bytes(&self) -> usize {
        self.q.capacity() * std::mem::size_of::<[u32; 3]>()
            + self.inline.capacity() * std::mem::size_of::<Block>()
            + self.quads.capacity() * std::mem::size_of::<[u32; 4]>()
            + self.ov_head.capacity_bytes()
            + self.ov_links.capacity_bytes()
    }

    /// Reserves room for `nv` more vertices and `nf` more slots.
    pub fn reserve(&mut self, nv: usize, nf: usize) {
        self.q.reserve(nv);
        self.inline.reserve(nv);
        self.quads.reserve(nf);
    }

    /// Adds corner `c` to vertex `v`: into its block, or at the front of
    /// its overflow list when the block is full. The block case is the
    /// inlined fast path (a few instructions); the overflow one is cold and
    /// out of line, so that every caller does not carry its prologue.
    #[inline]
    fn link(&mut self, c: u32, v: u32) {
        let b = &mut self.inline[v as usize].0;
        let n = b[0] as usize;
        // `n < INLINE` also means "no overflow flag" (the flag is bit 31).
        if n < INLINE {
            b[n + 1] = c;
            b[0] += 1;
            return;
        }
        self.link_overflow(c, v);
    }

    /// [`MeshState::link`] past the fast path: a flagged block, or a full
    /// one (then at the front of the overflow list).
    #[cold]
    #[inline(never)]
    fn link_overflow(&mut self, c: u32, v: u32) {
        let b = &mut self.inline[v as usize].0;
        let n = (b[0] & !OVERFLOW) as usize;
        if n < INLINE {
            // A flagged block with room (an unlink drained it): the block
            // first, as for any vertex.
            b[n + 1] = c;
            b[0] += 1;
            return;
        }
        if b[0] & OVERFLOW == 0 {
            b[0] |= OVERFLOW;
            *self.ov_head.at(v) = NIL;
        }
        let h = std::mem::replace(self.ov_head.at(v), c);
        *self.ov_links.at(c) = [h, NIL];
        if h != NIL {
            self.ov_links.at(h)[1] = c;
        }
    }

    /// Removes corner `c` from vertex `v` (where it must be): a scan of the
    /// block (inlined), else the overflow list (cold, out of line).
    #[inline]
    fn unlink(&mut self, c: u32, v: u32) {
        let b = &mut self.inline[v as usize].0;
        let n = ((b[0] & !OVERFLOW) as usize).min(INLINE);
        // One vector compare of the block; bits 1..=n are the live corners
        // (the count word and the stale entries past `n` are masked out).
        let live = (2u32 << n) - 2;
        let hit = eq_mask8(b, c) & live;
        if hit != 0 {
            let i = hit.trailing_zeros() as usize;
            b[i] = b[n];
            b[0] -= 1;
            return;
        }
        if b[0] & OVERFLOW != 0 {
            self.unlink_overflow(c, v);
        }
    }

    /// [`MeshState::unlink`] of a corner that is not in the block.
    #[cold]
    #[inline(never)]
    fn unlink_overflow(&mut self, c: u32, v: u32) {
        let [nx, pv] = self.ov_links.get(c);
        // Not in the list (no previous corner, not the head): nothing to
        // remove (a consistent state never asks for it).
        if pv == NIL && self.ov_head.get(v) != c {
            return;
        }
        if pv != NIL {
            self.ov_links.at(pv)[0] = nx;
        } else {
            *self.ov_head.at(v) = nx;
            if nx == NIL {
                self.inline[v as usize].0[0] &= !OVERFLOW;
            }
        }
        if nx != NIL {
            self.ov_links.at(nx)[1] = pv;
        }
    }

    /// Prefetches (see [`prefetch`]) for the next three records, a
    /// pipeline of dependent reads, one stage per record: the block of the
    /// anchor three records on; the quads of the one two on (its block was
    /// fetched one record ago); the codes and blocks of the vertices of
    /// the next one's faces (its quads were fetched one record ago) — what
    /// its star, prediction and corner links read. The anchors are guessed
    /// from the `refs` stream: the split, face-split, edge-split and local
    /// forms read one reference, their anchor, so the next values there
    /// are the next records' first references. A wrong guess (a
    /// general-form record, the end of the chunk) costs a few useless
    /// fetches, nothing else.
    ///
    /// Measured on the bunny (callgrind, one decode): the look-ahead is
    /// ~10 % of the instructions and ~15 % of the wall time saved. A stage
    /// is skipped only where its anchor repeats the one before (delta 0,
    /// a third of the records): 334.3 → 328.2 M instructions (−1.8 %),
    /// wall time even or better. Skipping on small nonzero deltas too
    /// (ids close, lines not: up to 16 or 64) or dropping any one kind of
    /// fetch (the tail, a link vertex's code, the far corners' codes, the
    /// 2- or 3-ahead stage) saved 0.1–3 % of the instructions but cost
    /// about 2–8 % of the wall time.
    #[inline]
    fn prefetch_ahead(&self, refs: &Reader, m: u32, peek: &mut crate::varint::Peek3) {
        // A small mesh stays in the core's cache, where the look-ahead is
        // pure overhead (measured: spot, 2.9k faces, 13 % slower; loki,
        // 27k, even; the bunny, 209k, 9 % faster).
        if self.q.len() < PREFETCH_MIN_VERTICES {
            return;
        }
        // The lines the next records' new vertices and faces go to, a few
        // dozen records ahead: pushing a code, a block or a quad writes a
        // line the decoder has not touched yet, and the corner links read
        // the new block straight back. On memory that an earlier mesh
        // used (a process decoding more than once, as `decode_loop`
        // does), that line is in no cache, and each write waited for it;
        // fresh pages come zeroed by the kernel, already cached, and a
        // hint to a page not yet mapped is dropped, so a first decode
        // neither gains nor loses (measured on the bunny).
        prefetch(&self.inline, self.inline.len() + PREFETCH_TAIL);
        prefetch(&self.q, self.q.len() + 2 * PREFETCH_TAIL);
        prefetch(&self.quads, self.quads.len() + 2 * PREFETCH_TAIL);
        // Each value is parsed once, not three times (it is the third,
        // second and first peeked value of three records).
        let [d1, d2, d3] = refs.peek_s3_cached(peek);
        let nv = self.inline.len() as i64;
        let at = |v: i64| (0..nv).contains(&v).then_some(v as usize);
        let Some(d1) = d1 else {
            return;
        };
        let m1 = (m as i64).wrapping_add(d1);
        let m2 = d2.map(|d| m1.wrapping_add(d));
        let m3 = m2.zip(d3).map(|(v, d)| v.wrapping_add(d));
        if let Some(v) = m3.and_then(at) {
            prefetch(&self.inline, v);
        }
        // A zero delta repeats the anchor (a third of the bunny's records:
        // several records at one vertex). The stage would then fetch what
        // is already coming: with `m2 == m1`, the quads the stage below
        // reads; with `m1 == m`, the star this record reads and rewrites
        // (its lines fetched one record ago, its new vertex and faces
        // written by this record).
        if let Some(v) = m2.filter(|_| d2 != Some(0)).and_then(at) {
            let b = &self.inline[v].0;
            let k = ((b[0] & !OVERFLOW) as usize).min(INLINE);
            for &c in &b[1..=k] {
                prefetch(&self.quads, (c >> 2) as usize);
            }
        }
        if d1 == 0 {
            return;
        }
        if let Some(v) = at(m1) {
            let b = &self.inline[v].0;
            let k = ((b[0] & !OVERFLOW) as usize).min(INLINE);
            prefetch(&self.q, v);
            for &c in &b[1..=k] {
                if let Some(q) = self.quads.get((c >> 2) as usize) {
                    // Per face the next corner (a link vertex: its code and
                    // block) and the far one (its code, and its block: a
                    // face split whose quad turns moves all four corners,
                    // the far one's too; bunny +1.5–2.6 % in wall time,
                    // session 19): the previous corner is the next face's
                    // next one.
                    let a = q[(c as usize + 1) & 3] as usize;
                    prefetch(&self.q, a);
                    prefetch(&self.inline, a);
                    let f = q[(c as usize + 2) & 3] as usize;
                    prefetch(&self.q, f);
                    prefetch(&self.inline, f);
                }
            }
        }
    }

    /// Sets slot `s` to `quad`, moving the changed corners between lists.
    /// (Always inlined: out of line, its call cost ~10 % of a record's
    /// apply.)
    #[inline(always)]
    fn set_quad(&mut self, s: u32, quad: [u32; 4]) -> [u32; 4] {
        let (old, new, mut changed) = swap_quad(&mut self.quads[s as usize], quad);
        if changed == 15 {
            // A quad that turns: every corner moves, each vertex to another
            // corner of the same quad. All unlinks before the links: an
            // unlink right after the link of the same vertex read its block
            // as two 16-byte vectors just after the link's 4-byte stores,
            // which store-to-load forwarding cannot serve.
            for (k, &v) in old.iter().enumerate() {
                self.unlink(4 * s + k as u32, v);
            }
            for (k, &v) in new.iter().enumerate() {
                self.link(4 * s + k as u32, v);
            }
            return old;
        }
        while changed != 0 {
            let k = changed.trailing_zeros() as usize;
            changed &= changed - 1;
            let c = 4 * s + k as u32;
            self.unlink(c, old[k]);
            self.link(c, new[k]);
        }
        old
    }

    /// The corner ids at vertex `v` (none for an id out of range).
    #[inline]
    fn corner_ids(&self, v: u32) -> CornerIter<'_> {
        match self.inline.get(v as usize) {
            Some(Block(b)) => {
                let n = (b[0] & !OVERFLOW) as usize;
                let ov = if b[0] & OVERFLOW != 0 {
                    self.ov_head.get(v)
                } else {
                    NIL
                };
                CornerIter {
                    st: self,
                    block: &b[1..=n],
                    i: 0,
                    ov,
                }
            }
            None => CornerIter {
                st: self,
                block: &[],
                i: 0,
                ov: NIL,
            },
        }
    }

    /// Corners `(slot, k)` at vertex `v`, in no particular order.
    pub fn corners(&self, v: u32) -> impl Iterator<Item = (u32, usize)> + '_ {
        self.corner_ids(v).map(|c| (c >> 2, (c & 3) as usize))
    }

    /// Number of faces at vertex `v`.
    pub fn valence(&self, v: u32) -> usize {
        self.corners(v).count()
    }

    /// Applies `r` (already checked against this state) and returns the old
    /// codes of its moved vertices and the old contents of its rewritten
    /// slots, in record order (the undo log).
    pub fn apply(&mut self, r: &QRecord) -> (Vec<[u32; 3]>, Vec<[u32; 4]>) {
        let (mut moved, mut rw) = (Vec::new(), Vec::new());
        self.apply_delta_logged(r, &mut moved, &mut rw);
        // Old = new ^ (new ^ old), entry by entry in record order.
        (
            moved
                .iter()
                .zip(&r.moved)
                .map(|(&(_, d), &(_, p))| xor3(p, d))
                .collect(),
            rw.iter()
                .zip(&r.rewritten)
                .map(|(&(_, d), &(_, q))| xor4(q, d))
                .collect(),
        )
    }

    /// The first step of applying a record: its new vertices, with empty
    /// corner blocks (their corners come with the rewritten and appended
    /// quads).
    #[inline(always)]
    fn push_new_vertices(&mut self, new_pos: &[[u32; 3]]) {
        for &p in new_pos {
            self.q.push(p);
            self.inline.push(Block::default());
        }
    }

    /// The last step of applying a record: its appended quads, at the next
    /// slots. The corners go to their blocks through one slice of them, so that
    /// its address and length stay in registers (through `self.inline`
    /// each link loaded them again after the previous one's stores); the
    /// rare corner whose block is full or flagged goes to
    /// [`MeshState::link_overflow`] after them (another vertex's list: the
    /// order does not matter).
    #[inline(always)]
    fn append_quads(&mut self, appended: &[[u32; 4]]) {
        for &quad in appended {
            let s = self.quads.len() as u32;
            self.quads.push(quad);
            let blocks = &mut self.inline[..];
            let mut full = 0u32;
            for (k, &v) in quad.iter().enumerate() {
                let b = &mut blocks[v as usize].0;
                let n = b[0] as usize;
                // `n < INLINE` also means "no overflow flag", as in `link`.
                if n < INLINE {
                    b[n + 1] = 4 * s + k as u32;
                    b[0] += 1;
                } else {
                    full |= 1 << k;
                }
            }
            while full != 0 {
                let k = full.trailing_zeros() as usize;
                full &= full - 1;
                // The corner from the slot just written (one 16-byte
                // store): indexing `quad` by `k` kept it in a stack array
                // written as four 4-byte stores, which the push then read
                // back as one 16-byte load, a failed store forwarding.
                let v = self.quads[s as usize][k];
                self.link_overflow(4 * s + k as u32, v);
            }
        }
    }

    /// Applies `r` (already checked against this state), appending the
    /// compact undo log the decoder keeps, without allocating per record:
    /// `(vertex, new ^ old code)` per moved vertex and `(slot, new ^ old
    /// quad)` per rewritten slot, in record order, bitwise exclusive or. A level holds the
    /// old value where a record is applied and the new one where it is
    /// undone, so one delta does both ways (`x ^= delta`), in 16 and 20
    /// bytes where the pair took 28 and 36: on the bunny the general
    /// decoder's logs were most of its extra memory over a forward-only
    /// one, and its extra page faults most of its extra time.
    pub fn apply_delta_logged(
        &mut self,
        r: &QRecord,
        moved: &mut MoveDeltas,
        rw: &mut RewriteDeltas,
    ) {
        self.push_new_vertices(&r.new_pos);
        for &(v, p) in &r.moved {
            let old = std::mem::replace(&mut self.q[v as usize], p);
            moved.push((v, xor3(p, old)));
        }
        for &(s, quad) in &r.rewritten {
            let old = self.set_quad(s, quad);
            rw.push((s, xor4(quad, old)));
        }
        self.append_quads(&r.appended);
    }

    /// [`MeshState::apply_delta_logged`] of a record that moves nothing,
    /// given as its parts: the fused decoding of the compact forms makes
    /// the rewritten quads in stack arrays, in star order (not by slot:
    /// the log's entries of one record name distinct slots, and each
    /// delta is applied on its own, so their order changes no level).
    #[inline(always)]
    pub(crate) fn apply_parts_logged(
        &mut self,
        new_pos: &[[u32; 3]],
        rewritten: &[(u32, [u32; 4])],
        appended: &[[u32; 4]],
        rw: &mut RewriteDeltas,
    ) {
        self.push_new_vertices(new_pos);
        for &(s, quad) in rewritten {
            let old = self.set_quad(s, quad);
            rw.push((s, xor4(quad, old)));
        }
        self.append_quads(appended);
    }

    /// [`MeshState::apply_delta_logged`] of an edge split decoded on the
    /// fast path (`edge_split::build_fast`), given as its parts: the
    /// sector faces of one endpoint as `sectors` (corner id of the
    /// endpoint, new vertex: the one corner that changes) and the other
    /// rewritten quads whole in `rewritten`, in star order (not by slot:
    /// the log's entries of one record name distinct slots — no slot is in
    /// both lists — and each delta is applied on its own, so their order
    /// changes no level), the appended quads, the
    /// four new codes, and the corner changes of the six vertices whose
    /// every corner the record decides written whole (the split form's
    /// way, `decode_apply_split`): `blocks` = the corner blocks of `ends =
    /// [X0, X1]` and of the four new vertices after the rewrites. The
    /// endpoints' blocks held exactly their fast stars, every one of those
    /// faces is rewritten, and every corner of the new vertices is in a
    /// rewritten quad, so `blocks` hold their corners as one unlink and
    /// one link per changed corner left them (the order of a block's
    /// corners carries no meaning, see [`MeshState`]). Only the other
    /// vertices' changed corners (in the fan quads: `masks`, bits 0–3 to
    /// unlink, 4–7 to link, per rewritten slot) are moved one by one; the
    /// appended quads then link as in any record.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) fn apply_edge_split_parts(
        &mut self,
        ends: [u32; 2],
        blocks: &[[u32; 8]; 6],
        new_pos: &[[u32; 3]; 4],
        sectors: &[(u32, u32)],
        rewritten: &[(u32, [u32; 4])],
        masks: &[u8],
        appended: &[[u32; 4]],
        rw: &mut RewriteDeltas,
    ) {
        for (&p, &b) in new_pos.iter().zip(&blocks[2..]) {
            self.q.push(p);
            self.inline.push(Block(b));
        }
        self.inline[ends[0] as usize] = Block(blocks[0]);
        self.inline[ends[1] as usize] = Block(blocks[1]);
        // A sector face: one corner, the endpoint's, becomes a new vertex;
        // both blocks are written whole above.
        for &(c, v) in sectors {
            let (s, k) = (c >> 2, (c & 3) as usize);
            let old = std::mem::replace(&mut self.quads[s as usize][k], v);
            rw.push((s, one_corner(k, old ^ v)));
        }
        for (&(s, quad), &mk) in rewritten.iter().zip(masks) {
            let (old, new, _) = swap_quad(&mut self.quads[s as usize], quad);
            let mut un = (mk & 15) as u32;
            while un != 0 {
                let k = un.trailing_zeros() as usize;
                un &= un - 1;
                self.unlink(4 * s + k as u32, old[k]);
            }
            let mut ln = (mk >> 4) as u32;
            while ln != 0 {
                let k = ln.trailing_zeros() as usize;
                ln &= ln - 1;
                self.link(4 * s + k as u32, new[k]);
            }
            rw.push((s, xor4(quad, old)));
        }
        self.append_quads(appended);
    }

    /// Undoes one record applied by [`MeshState::apply_delta_logged`] with
    /// these log entries: removes the slots from `f_before` on and the
    /// vertices from `v_before` on, and restores the old quads of `rw` and
    /// the old codes of `moved`. Records must be undone in reverse order.
    ///
    /// Also undoes several consecutive records at once, given the counts
    /// before the first and all their entries: entries for slots and
    /// vertices that the records themselves made (at or past the counts)
    /// are skipped, as those are removed; the others compose (`x ^= d`),
    /// and each `set_quad` unlinks the corners it links before.
    pub fn undo_deltas(
        &mut self,
        v_before: usize,
        f_before: usize,
        moved: &[MoveDelta],
        rw: &[RewriteDelta],
    ) {
        for s in (f_before..self.quads.len()).rev() {
            let quad = self.quads[s];
            for (k, &v) in quad.iter().enumerate() {
                self.unlink(4 * s as u32 + k as u32, v);
            }
        }
        self.quads.truncate(f_before);
        for &(s, d) in rw.iter().rev() {
            if (s as usize) < f_before {
                self.set_quad(s, xor4(self.quads[s as usize], d));
            }
        }
        for &(v, d) in moved.iter().rev() {
            if (v as usize) < v_before {
                let q = &mut self.q[v as usize];
                *q = xor3(*q, d);
            }
        }
        self.q.truncate(v_before);
        self.inline.truncate(v_before);
    }

    /// Local neighbourhood of anchor `m` (spec §7.7), or why it has none.
    pub fn local(&self, m: u32) -> Result<Local, String> {
        let mut out = Local::default();
        self.local_into(m, &mut out)?;
        Ok(out)
    }

    /// [`MeshState::local`] into `out` (reusing its buffers), with
    /// per-thread stamps (the decoder passes its own, see [`DecodeScratch`]).
    pub fn local_into(&self, m: u32, out: &mut Local) -> Result<(), String> {
        thread_local! {
            static MARKS: std::cell::RefCell<Marks> = std::cell::RefCell::new(Marks::default());
        }
        MARKS.with(|cell| self.local_with(m, &mut cell.borrow_mut(), out))
    }

    /// [`MeshState::local_into`] with the caller's stamps: the faces, then
    /// their vertices.
    fn local_with(&self, m: u32, mk: &mut Marks, out: &mut Local) -> Result<(), String> {
        self.local_faces_with(m, mk, out)?;
        self.local_verts_with(mk, out);
        Ok(())
    }

    /// The faces of [`MeshState::local`] into `out.faces` (`out.verts` is
    /// cleared: the decoder builds it only for the records that name a
    /// vertex by local index, see [`MeshState::local_verts_with`]).
    /// Duplicates are dropped with generation stamps instead of sorting
    /// every raw entry: only the distinct faces get sorted.
    fn local_faces_with(&self, m: u32, mk: &mut Marks, out: &mut Local) -> Result<(), String> {
        let (gv, gf) = mk.next_gen(self.q.len(), self.quads.len());
        let Marks { v, f, star, .. } = mk;
        let Local { faces, verts } = out;
        star.clear();
        faces.clear();
        verts.clear();
        // A few dozen scattered reads per record: one block per vertex, then
        // independent reads of the quads.
        let mut n = 0usize;
        for c in self.corner_ids(m) {
            n += 1;
            if n > MAX_SPLIT_STAR {
                return Err(format!(
                    "anchor {m} has more than {MAX_SPLIT_STAR} faces (local form needs 1..=255)"
                ));
            }
            for &u in &self.quads[(c >> 2) as usize] {
                if v[u as usize] != gv {
                    v[u as usize] = gv;
                    star.push(u);
                }
            }
        }
        if n == 0 {
            return Err(format!("anchor {m} has no face"));
        }
        let mut entries = 0usize;
        for &u in star.iter() {
            for c in self.corner_ids(u) {
                entries += 1;
                if entries > MAX_LOCAL_CORNERS {
                    return Err(format!(
                        "the faces around anchor {m} have more than {MAX_LOCAL_CORNERS} corners"
                    ));
                }
                let s = c >> 2;
                if f[s as usize] != gf {
                    f[s as usize] = gf;
                    faces.push(s);
                }
            }
        }
        sort_distinct(faces);
        Ok(())
    }

    /// The vertices of [`MeshState::local`] (the distinct corners of
    /// `out.faces`, ascending) into `out.verts`. Separate from the faces
    /// because most decoded local-form records (no moved vertex, no
    /// explicit corner) never index them: skipping them saves reading the
    /// quads of the whole 2-ring and sorting ~30 vertices per record.
    fn local_verts_with(&self, mk: &mut Marks, out: &mut Local) {
        let gu = mk.next_v_gen(self.q.len());
        let Local { faces, verts } = out;
        verts.clear();
        for &s in faces.iter() {
            for &x in &self.quads[s as usize] {
                if mk.v[x as usize] != gu {
                    mk.v[x as usize] = gu;
                    verts.push(x);
                }
            }
        }
        sort_distinct(verts);
    }

    /// The slots whose quad contains `m`, ascending, into `out` (spec §7.9
    /// step 2), or why the face-split form cannot name them: none, or more
    /// than [`MAX_SPLIT_STAR`] (counting stops there, so a hostile fan costs
    /// no more than 256 faces).
    pub fn slots_at(&self, m: u32, out: &mut Vec<u32>) -> Result<(), String> {
        self.slots_at_unsorted(m, out)?;
        sort_distinct(out);
        Ok(())
    }

    /// [`MeshState::slots_at`] in block order (not sorted), same errors:
    /// the decoder needs only one slot of a given rank.
    fn slots_at_unsorted(&self, m: u32, out: &mut Vec<u32>) -> Result<(), String> {
        out.clear();
        for c in self.corner_ids(m) {
            if out.len() == MAX_SPLIT_STAR {
                return Err(format!(
                    "vertex {m} has more than {MAX_SPLIT_STAR} faces (face split needs 1..=255)"
                ));
            }
            out.push(c >> 2);
        }
        if out.is_empty() {
            return Err(format!("vertex {m} has 0 faces (face split needs 1..=255)"));
        }
        Ok(())
    }

    /// Canonical star of `m` (spec §7.5), or why it is not a single fan.
    pub fn star(&self, m: u32) -> Result<Star, String> {
        let mut out = Star {
            faces: Vec::new(),
            link: Vec::new(),
        };
        self.star_into(m, &mut out)?;
        Ok(out)
    }

    /// [`MeshState::star`] into `out`, reusing its buffers (the decoder's
    /// split-form and edge-split paths: no allocation per record).
    ///
    /// The usual star — an interior vertex whose 2..=[`INLINE`] corners all
    /// sit in its block, with distinct previous corners `pv` — straight
    /// from the block, without sorting: the walk starts at the smallest
    /// slot and follows `succ` (the face whose next corner `nx` is the
    /// current face's `pv`), each step one branch-free compare of the seven
    /// padded entries. When that walk closes a cycle over all `n` faces,
    /// the `nx` of the faces are the `n` distinct `pv` values, so every
    /// `succ` had exactly one candidate and `MeshState::star_sorted`'s
    /// walk over the faces sorted by slot makes the same steps: same
    /// result. Anything else (a boundary, a repeated link vertex, a broken
    /// fan, an overflow list) is left to `MeshState::star_sorted`.
    /// Property tests `fast_star_equals_general` and the real-mesh levels
    /// check both against [`MeshState::star_general`].
    #[inline]
    pub fn star_into(&self, m: u32, out: &mut Star) -> Result<(), String> {
        match self.star_fast(m) {
            Some(s) => {
                s.write_into(out);
                Ok(())
            }
            None => self.star_sorted(m, out),
        }
    }

    /// The fast path of [`MeshState::star_into`] (see there), as corner
    /// ids on the stack: `None` where it leaves the star to
    /// [`MeshState::star_sorted`]. The decoder's fused forms read the
    /// corner ids, which give each face's corner of `m` without a search.
    #[inline]
    pub(crate) fn star_fast(&self, m: u32) -> Option<FastStar> {
        let mut out = FastStar::EMPTY;
        self.star_fast_into(m, &mut out).then_some(out)
    }

    /// [`MeshState::star_fast`] into `out` (entries past `out.n` are left
    /// as they were): false where that gives `None`. (Returned by value,
    /// the 72-byte star was copied once more per call.)
    #[inline]
    pub(crate) fn star_fast_into(&self, m: u32, out: &mut FastStar) -> bool {
        let Some(Block(b)) = self.inline.get(m as usize) else {
            return false;
        };
        // The overflow flag (bit 31) makes `n` too large too.
        let n = b[0] as usize;
        if !(2..=INLINE).contains(&n) {
            return false;
        }
        // Padding `nx` and `pv` with NIL (never a vertex id) keeps the
        // padding out of every match.
        let mut cs = [NIL; 8];
        let mut nx = [NIL; 8];
        let mut pv = [NIL; 8];
        let mut start = 0usize;
        for i in 0..n {
            let c = b[1 + i];
            let k = (c & 3) as usize;
            let q = &self.quads[(c >> 2) as usize];
            (cs[i], nx[i], pv[i]) = (c, q[(k + 1) & 3], q[(k + 3) & 3]);
            // The smallest slot (none are equal: a quad holds `m` once),
            // as the stable sort puts first; corner `4 s + k` orders as
            // its slot `s`.
            if c < cs[start] {
                start = i;
            }
        }
        // `nx` is read below as vectors (the masks) and by index (the
        // walk): through one copy stored as two 16-byte vectors built in
        // registers. Read in place, its 4-byte stores from the loop
        // above were loaded straight back as 16 bytes, which store-to-load
        // forwarding cannot serve (17 % of the function's samples on the
        // bunny).
        let nx = copy8(nx);
        let live = (1u32 << n) - 1;
        // No face whose next and previous corners are one vertex (only a
        // quad repeating a vertex has one).
        if eq_mask8x8(&nx, &pv) & live != 0 {
            return false;
        }
        // Per face its `succ` candidates: the other faces whose `nx` is its
        // `pv`. There must be exactly one each, and the walk along them
        // must close over all `n` faces. This accepts exactly the stars
        // that "all `pv` distinct, then the walk by the first candidate"
        // accepts, with the same steps: if the walk closes, `nx` of the
        // faces are their successors' `pv`, so with distinct `pv` every
        // candidate is unique; and two faces `a`, `b` with one `pv` would
        // give `a` two candidates, `succ(a)` and `succ(b)` — unless
        // `succ(b) = a`, i.e. `nx[a] = pv[a]`, refused above. (The masks
        // are computed up front, independent of each other, so that the
        // walk is a short chain of loads: a mask per step of the walk,
        // measured, took fewer instructions but 1–3 % more time.)
        let mut succ = [0u32; 8];
        for a in 0..n {
            succ[a] = eq_mask8(&nx, pv[a]) & !(1u32 << a);
        }
        // "Exactly one candidate" is checked on the walk, face by face, not
        // over all `n` up front: a walk that closes over all `n` faces
        // steps from each of them once (the last one's step is the closing
        // compare, itself exact), so it checks every face; a walk that
        // does not close refuses anyway. Same stars accepted, 0.5 % fewer
        // instructions per decoded face on the real meshes (the check is a
        // predicted branch beside the walk's chain of loads, not in it).
        out.n = n;
        let (mut f, mut seen) = (start, 1u32 << start);
        (out.c[0], out.nx[0]) = (cs[f], nx[f]);
        for i in 1..n {
            let s = succ[f];
            // Refuses a face with no candidate (`s == 0`), with two or
            // more (`s & (s - 1)`), or one already walked (`s & seen`).
            if (s & (s.wrapping_sub(1) | seen)) | (s == 0) as u32 != 0 {
                return false;
            }
            // `& 7`: `s` is one bit of the eight, the index needs no check.
            let g = (s.trailing_zeros() & 7) as usize;
            seen |= s;
            (out.c[i], out.nx[i]) = (cs[g], nx[g]);
            f = g;
        }
        succ[f] == 1 << start
    }

    /// [`MeshState::star_into`] past its fast path.
    ///
    /// Up to [`STAR_SMALL`] faces (every real mesh vertex) the faces live in
    /// three stack arrays (slot, next and previous vertex of `m`), sorted by
    /// slot, so that `succ` / `pred` are short scans of one `u32` array
    /// (no tuples, no closures over a slice of unknown length). Larger stars take
    /// [`MeshState::star_general`]; both give the same result on every
    /// input, manifold or not (property test `fast_star_equals_general`).
    #[cold]
    #[inline(never)]
    fn star_sorted(&self, m: u32, out: &mut Star) -> Result<(), String> {
        let mut fs = [0u32; STAR_SMALL];
        let mut nx = [NIL; STAR_SMALL];
        let mut pv = [NIL; STAR_SMALL];
        let mut n = 0usize;
        for c in self.corner_ids(m) {
            if n == STAR_SMALL {
                return self.star_general(m, out);
            }
            let (f, k) = (c >> 2, (c & 3) as usize);
            let q = &self.quads[f as usize];
            let (a, b) = (q[(k + 1) & 3], q[(k + 3) & 3]);
            // Insertion by slot, after equal slots (stable: list order).
            let mut i = n;
            while i > 0 && fs[i - 1] > f {
                fs[i] = fs[i - 1];
                nx[i] = nx[i - 1];
                pv[i] = pv[i - 1];
                i -= 1;
            }
            (fs[i], nx[i], pv[i]) = (f, a, b);
            n += 1;
        }
        if n == 0 {
            return Err(format!("vertex {m} has 0 faces (split form needs 1..=255)"));
        }
        // The first entry `g != f` with `keys[g] == key` (ascending slots:
        // the smallest slot of §7.5), over the `n` live entries only. (A
        // branch-free compare of all `STAR_SMALL` entries into a bit mask
        // was measured: 40 % more instructions per star — the early exit
        // of this scan wins at the usual valence 4–6.)
        let first_other =
            |keys: &[u32; STAR_SMALL], key: u32, f: usize| first_other_in(&keys[..n], key, f);
        let succ = |f: usize| first_other(&nx, pv[f], f);
        let pred = |f: usize| first_other(&pv, nx[f], f);
        let Star { faces, link } = out;
        faces.clear();
        link.clear();
        // The usual interior star without the rewind: when the `succ` walk
        // from index 0 visits all `n` faces and returns to 0, and no vertex
        // is the previous corner `pv` of two faces, then `pred` inverts
        // `succ` (`pred(succ(f))` is the one face whose `pv` is
        // `nx[succ(f)] = pv[f]`: `f`), so [`fan_walk`]'s rewind from 0
        // would come back to 0 after `n` steps — interior, starting at 0 —
        // and its walk is this one. Anything else (a boundary, a repeated
        // link vertex, a broken fan) takes the general walk.
        let mut distinct = true;
        for a in 0..n {
            for b in a + 1..n {
                distinct &= pv[a] != pv[b];
            }
        }
        if distinct && n >= 2 {
            let mut order = [0u8; STAR_SMALL];
            let (mut f, mut len, mut seen) = (0usize, 1usize, 1u32);
            loop {
                match succ(f) {
                    Some(0) if len == n => {
                        faces.extend(order[..n].iter().map(|&i| fs[i as usize]));
                        link.extend(order[..n].iter().map(|&i| nx[i as usize]));
                        return Ok(());
                    }
                    Some(g) if g != 0 && seen & (1 << g) == 0 && len < n => {
                        order[len] = g as u8;
                        len += 1;
                        seen |= 1 << g;
                        f = g;
                    }
                    _ => break,
                }
            }
        }
        let last = fan_walk(n, succ, pred, |i| {
            faces.push(fs[i]);
            link.push(nx[i]);
        })
        .ok_or_else(|| format!("star of vertex {m} is not a single fan"))?;
        if let Some(f) = last {
            link.push(pv[f]);
        }
        Ok(())
    }

    /// [`MeshState::star_into`] for any number of faces (up to the limit):
    /// the faces sorted by slot in a `Vec`, `succ` / `pred` by scans.
    /// Counting stops past the limit, so a vertex in a million faces costs
    /// no more than one in 256.
    pub fn star_general(&self, m: u32, out: &mut Star) -> Result<(), String> {
        // (slot, next of m, prev of m) per face, sorted by slot (stable, so
        // repeated slots keep list order).
        let mut ring: Vec<(u32, u32, u32)> = Vec::new();
        for c in self.corner_ids(m) {
            if ring.len() == MAX_SPLIT_STAR {
                return Err(format!(
                    "vertex {m} has more than {MAX_SPLIT_STAR} faces (split form needs 1..=255)"
                ));
            }
            let (f, k) = (c >> 2, (c & 3) as usize);
            let q = &self.quads[f as usize];
            ring.push((f, q[(k + 1) % 4], q[(k + 3) % 4]));
        }
        if ring.is_empty() {
            return Err(format!("vertex {m} has 0 faces (split form needs 1..=255)"));
        }
        ring.sort_by_key(|e| e.0);
        let ring = &ring;
        // Index (into `ring`) of the smallest slot g != ring[f] with
        // next(g) == key (want_next) or prev(g) == key.
        let find = |f: usize, key: u32, want_next: bool| -> Option<usize> {
            ring.iter()
                .enumerate()
                .position(|(g, e)| g != f && if want_next { e.1 == key } else { e.2 == key })
        };
        let succ = |f: usize| find(f, ring[f].2, true);
        let pred = |f: usize| find(f, ring[f].1, false);
        let Star { faces, link } = out;
        faces.clear();
        link.clear();
        let last = fan_walk(ring.len(), succ, pred, |i| {
            faces.push(ring[i].0);
            link.push(ring[i].1);
        })
        .ok_or_else(|| format!("star of vertex {m} is not a single fan"))?;
        if let Some(f) = last {
            link.push(ring[f].2);
        }
        Ok(())
    }
}

/// The first index `g != f` of `keys` holding `key` (the scans of
/// [`MeshState::star_into`]; always inlined: it is called from two closures
/// and the fast path, and out of line its call cost as much as the scan).
#[inline(always)]
fn first_other_in(keys: &[u32], key: u32, f: usize) -> Option<usize> {
    keys.iter()
        .enumerate()
        .position(|(g, &k)| k == key && g != f)
}

/// Bit `h` set where `v[h] == key` (the star's match masks): two SSE2
/// compares (x86-64 baseline), where the scalar loop took ~30
/// instructions per mask.
#[inline(always)]
pub(crate) fn eq_mask8(v: &[u32; 8], key: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; both unaligned loads
        // read 16 bytes inside `v` (32 bytes).
        unsafe {
            let k = _mm_set1_epi32(key as i32);
            let lo = _mm_loadu_si128(v.as_ptr().cast::<__m128i>());
            let hi = _mm_loadu_si128(v.as_ptr().add(4).cast::<__m128i>());
            let ml = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(lo, k)));
            let mh = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(hi, k)));
            (ml | (mh << 4)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut mask = 0u32;
        for (h, &x) in v.iter().enumerate() {
            mask |= ((x == key) as u32) << h;
        }
        mask
    }
}

/// Bit `h` in `1..=n` (`n <= 7`) set where exactly `rank` of `v[1..=n]`
/// are smaller than `v[h]` (the face split's corner of a given rank in a
/// vertex's block; `v[0]` and `v[n + 1..]` take no part). On x86-64 the
/// counts of all eight lanes at once, one SSE2 compare and subtract per
/// entry (unsigned order: sign bits flipped), where the scalar double loop
/// took ~140 instructions per face split.
#[inline(always)]
pub(crate) fn rank_mask8(v: &[u32; 8], n: usize, rank: u32) -> u32 {
    let live = (2u32 << n) - 2;
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned loads
        // read 16 bytes inside `v` (32 bytes) each.
        unsafe {
            let sign = _mm_set1_epi32(i32::MIN);
            let lo = _mm_xor_si128(_mm_loadu_si128(v.as_ptr().cast::<__m128i>()), sign);
            let hi = _mm_xor_si128(_mm_loadu_si128(v.as_ptr().add(4).cast::<__m128i>()), sign);
            let (mut cl, mut ch) = (_mm_setzero_si128(), _mm_setzero_si128());
            for &x in &v[1..=n.min(7)] {
                // Lanes greater than `x` count one more smaller entry.
                let k = _mm_set1_epi32((x ^ 0x8000_0000) as i32);
                cl = _mm_sub_epi32(cl, _mm_cmpgt_epi32(lo, k));
                ch = _mm_sub_epi32(ch, _mm_cmpgt_epi32(hi, k));
            }
            let r = _mm_set1_epi32(rank as i32);
            let ml = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(cl, r)));
            let mh = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(ch, r)));
            (ml | (mh << 4)) as u32 & live
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let cs = &v[1..=n.min(7)];
        let mut mask = 0u32;
        for (h, &c) in cs.iter().enumerate() {
            if cs.iter().map(|&o| (o < c) as u32).sum::<u32>() == rank {
                mask |= 2 << h;
            }
        }
        mask & live
    }
}

/// A copy of `a` written as two 16-byte stores of vectors built in
/// registers from its eight values (see `star_fast_into`).
#[inline(always)]
fn copy8(a: [u32; 8]) -> [u32; 8] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let mut out = [0u32; 8];
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned
        // stores write the 32 bytes of `out`, 16 at a time.
        unsafe {
            let lo = _mm_set_epi32(a[3] as i32, a[2] as i32, a[1] as i32, a[0] as i32);
            let hi = _mm_set_epi32(a[7] as i32, a[6] as i32, a[5] as i32, a[4] as i32);
            _mm_storeu_si128(out.as_mut_ptr().cast::<__m128i>(), lo);
            _mm_storeu_si128(out.as_mut_ptr().add(4).cast::<__m128i>(), hi);
        }
        out
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        a
    }
}

/// Bit `h` set where `a[h] == b[h]` (two SSE2 compares on x86-64).
#[inline(always)]
fn eq_mask8x8(a: &[u32; 8], b: &[u32; 8]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned loads
        // read the 32 bytes of `a` and of `b`, 16 at a time.
        unsafe {
            let (a0, a1) = (
                _mm_loadu_si128(a.as_ptr().cast::<__m128i>()),
                _mm_loadu_si128(a.as_ptr().add(4).cast::<__m128i>()),
            );
            let (b0, b1) = (
                _mm_loadu_si128(b.as_ptr().cast::<__m128i>()),
                _mm_loadu_si128(b.as_ptr().add(4).cast::<__m128i>()),
            );
            let ml = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(a0, b0)));
            let mh = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(a1, b1)));
            (ml | (mh << 4)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        (0..8).fold(0, |m, h| m | ((a[h] == b[h]) as u32) << h)
    }
}

/// Bit `k` set where `q[k] == key` (one SSE2 compare on x86-64).
#[inline(always)]
fn eq_mask4(q: &[u32; 4], key: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned load
        // reads the 16 bytes of `q`.
        unsafe {
            let v = _mm_loadu_si128(q.as_ptr().cast::<__m128i>());
            let e = _mm_cmpeq_epi32(v, _mm_set1_epi32(key as i32));
            _mm_movemask_ps(_mm_castsi128_ps(e)) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        (0..4).fold(0, |m, k| m | ((q[k] == key) as u32) << k)
    }
}

/// `[0; 4]` with `x` at index `k` (`k < 4`), made in a register: the
/// decoders log a one-corner rewrite as this delta. Written into a zeroed
/// stack array (`delta[k] = x`), it was a 4-byte store that the 16-byte
/// load of the log entry's push read straight back, which store-to-load
/// forwarding cannot serve (the load waits for the store to retire).
#[inline(always)]
pub(crate) fn one_corner(k: usize, x: u32) -> [u32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; `__m128i` and
        // `[u32; 4]` are both 16 plain bytes.
        unsafe {
            let lane = _mm_cmpeq_epi32(_mm_set1_epi32(k as i32), _mm_setr_epi32(0, 1, 2, 3));
            std::mem::transmute::<__m128i, [u32; 4]>(_mm_and_si128(lane, _mm_set1_epi32(x as i32)))
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::array::from_fn(|i| if i == k { x } else { 0 })
    }
}

/// Writes `quad` to `*slot` and returns `(old, new, changed)`: the slot's
/// old contents, a copy of `quad` to index by corner, and bit `k` set
/// where corner `k` differs. The fused decoders make `quad` from four
/// scalars; copied whole (`mem::replace`) or compared as a vector, it
/// went through a stack array written as four 4-byte stores and read back
/// as one 16-byte load, which store-to-load forwarding cannot serve. Here
/// the vector is built in a register from the four values, stored once to
/// the slot and once to the copy (16-byte stores, which the 4-byte loads
/// of the corner loop do forward from).
#[inline(always)]
pub(crate) fn swap_quad(slot: &mut [u32; 4], quad: [u32; 4]) -> ([u32; 4], [u32; 4], u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned load
        // and stores access the 16 bytes of `slot`, `old` and `new`.
        unsafe {
            let nv = _mm_set_epi32(
                quad[3] as i32,
                quad[2] as i32,
                quad[1] as i32,
                quad[0] as i32,
            );
            let p = slot.as_mut_ptr().cast::<__m128i>();
            let ov = _mm_loadu_si128(p);
            _mm_storeu_si128(p, nv);
            let (mut old, mut new) = ([0u32; 4], [0u32; 4]);
            _mm_storeu_si128(old.as_mut_ptr().cast::<__m128i>(), ov);
            _mm_storeu_si128(new.as_mut_ptr().cast::<__m128i>(), nv);
            let eq = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(ov, nv))) as u32;
            (old, new, !eq & 15)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let old = std::mem::replace(slot, quad);
        (old, quad, !eq_mask4x4(&old, &quad) & 15)
    }
}

/// Bit `k` set where `a[k] == b[k]` (one SSE2 compare on x86-64).
#[inline(always)]
pub(crate) fn eq_mask4x4(a: &[u32; 4], b: &[u32; 4]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of the x86-64 baseline; the unaligned loads
        // read the 16 bytes of `a` and of `b`.
        unsafe {
            let va = _mm_loadu_si128(a.as_ptr().cast::<__m128i>());
            let vb = _mm_loadu_si128(b.as_ptr().cast::<__m128i>());
            _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(va, vb))) as u32
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        (0..4).fold(0, |m, k| m | ((a[k] == b[k]) as u32) << k)
    }
}

/// Stars of at most this many faces are built on the stack by
/// [`MeshState::star_into`].
pub const STAR_SMALL: usize = 16;

/// The rewind and walk of spec §7.5 step 2 over `n` faces sorted by slot
/// (indices `0..n`, `0` = the smallest slot), given `succ` and `pred` as
/// indices; `emit` gets the walked indices in order. Returns `None` when
/// the star is not a single fan, else `Some(last)` on the boundary (`last`
/// = the index of `f_{K−1}`, whose `p` closes the link) and `Some(None)`
/// inside.
fn fan_walk(
    n: usize,
    succ: impl Fn(usize) -> Option<usize>,
    pred: impl Fn(usize) -> Option<usize>,
    mut emit: impl FnMut(usize),
) -> Option<Option<usize>> {
    let first = 0;
    let mut start = None;
    let mut boundary = false;
    let mut f = first;
    for _ in 0..n {
        match pred(f) {
            None => {
                start = Some(f);
                boundary = true;
                break;
            }
            Some(g) if g == first => {
                start = Some(first);
                break;
            }
            Some(g) => f = g,
        }
    }
    let start = start?;
    // Indices already walked, as a bit set (n <= 255).
    let mut seen = [0u64; MAX_SPLIT_STAR.div_ceil(64)];
    emit(start);
    seen[start / 64] |= 1 << (start % 64);
    let mut walked = 1usize;
    let mut f = start;
    loop {
        match succ(f) {
            None if boundary => break,
            Some(g) if g == start && !boundary => break,
            Some(g) if seen[g / 64] & (1 << (g % 64)) == 0 && walked < n => {
                emit(g);
                seen[g / 64] |= 1 << (g % 64);
                walked += 1;
                f = g;
            }
            _ => return None,
        }
    }
    if walked != n {
        return None;
    }
    Some(boundary.then_some(f))
}

/// Rewritten slots with their new quads.
type Rewrites = Vec<(u32, [u32; 4])>;

/// A moved vertex in the compact log: `(vertex, new ^ old code)`.
pub type MoveDelta = (u32, [u32; 3]);
/// A rewritten slot in the compact log: `(slot, new ^ old quad)`.
pub type RewriteDelta = (u32, [u32; 4]);
/// Compact log of moved vertices ([`MeshState::apply_delta_logged`]).
pub type MoveDeltas = Vec<MoveDelta>;
/// Compact log of rewritten slots ([`MeshState::apply_delta_logged`]).
pub type RewriteDeltas = Vec<RewriteDelta>;

/// `a ^ b` per axis.
#[inline(always)]
pub fn xor3(a: [u32; 3], b: [u32; 3]) -> [u32; 3] {
    [a[0] ^ b[0], a[1] ^ b[1], a[2] ^ b[2]]
}

/// `a ^ b` per corner.
#[inline(always)]
pub fn xor4(a: [u32; 4], b: [u32; 4]) -> [u32; 4] {
    [a[0] ^ b[0], a[1] ^ b[1], a[2] ^ b[2], a[3] ^ b[3]]
}

/// The explicit connectivity of a split (spec §7.5): rewritten slots of the
/// `c` side (sorted) and the appended quad.
fn build_split(
    st: &MeshState,
    m: u32,
    star: &Star,
    i: usize,
    j: usize,
    rot: usize,
) -> Result<(Rewrites, [u32; 4]), String> {
    let mut rewritten = Vec::new();
    let appended = build_split_into(st, m, star, i, j, rot, &mut rewritten)?;
    Ok((rewritten, appended))
}

/// [`build_split`] with the rewritten slots into `rewritten` (cleared
/// first; its buffer reused), returning the appended quad.
fn build_split_into(
    st: &MeshState,
    m: u32,
    star: &Star,
    i: usize,
    j: usize,
    rot: usize,
    rewritten: &mut Rewrites,
) -> Result<[u32; 4], String> {
    let c = st.q.len() as u32;
    let (b, d) = (star.link[i], star.link[j]);
    if b == d {
        return Err(format!("split of vertex {m}: both wings are vertex {b}"));
    }
    let base = [m, d, c, b];
    let appended = rotl(base, rot as u8);
    let in_a = |t: usize| {
        if i < j {
            i <= t && t < j
        } else {
            t >= i || t < j
        }
    };
    rewritten.clear();
    if star.faces.len() <= STAR_SMALL {
        // The `c` side's slots (a few) by insertion into a stack array,
        // then their quads in slot order: cheaper than collecting the
        // (slot, quad) pairs and sorting those. Same order as below (a
        // star names each face once, so the slots are distinct).
        let mut side = [0u32; STAR_SMALL];
        let mut n = 0usize;
        for (t, &s) in star.faces.iter().enumerate() {
            if !in_a(t) {
                let mut i = n;
                while i > 0 && side[i - 1] > s {
                    side[i] = side[i - 1];
                    i -= 1;
                }
                side[i] = s;
                n += 1;
            }
        }
        for &s in &side[..n] {
            let q = st.quads[s as usize];
            rewritten.push((s, q.map(|x| if x == m { c } else { x })));
        }
    } else {
        rewritten.extend((0..star.faces.len()).filter(|&t| !in_a(t)).map(|t| {
            let s = star.faces[t];
            (s, st.quads[s as usize].map(|x| if x == m { c } else { x }))
        }));
        rewritten.sort_unstable_by_key(|r| r.0);
    }
    Ok(appended)
}

/// The explicit quads of a face split (spec §7.9 steps 4–5): slot `s`
/// (whose quad contains `m`) is cut along its diagonal through `m` by the
/// new vertex `c = V`; returns `(X', Y')`, the rewritten quad of `s` and the
/// appended one, with the rotations of symbol bits 4–5 and 6–7.
fn build_face_split(st: &MeshState, m: u32, s: u32, swap: bool, sym: u8) -> ([u32; 4], [u32; 4]) {
    let c = st.q.len() as u32;
    let f = st.quads[s as usize];
    let k = f.iter().position(|&x| x == m).unwrap_or(0);
    let (p, o, q) = (f[(k + 1) % 4], f[(k + 2) % 4], f[(k + 3) % 4]);
    let (a, b) = ([m, p, o, c], [m, c, o, q]);
    let (x, y) = if swap { (b, a) } else { (a, b) };
    let (rx, ry) = (((sym >> 4) & 3) as usize, (sym >> 6) as usize);
    (
        [0, 1, 2, 3].map(|i| x[(i + rx) % 4]),
        [0, 1, 2, 3].map(|i| y[(i + ry) % 4]),
    )
}

/// [`predict_scan`] of a face split's new vertex `c` (version 2 and later,
/// the only ones with the form), without the scan. [`build_face_split`]
/// cuts slot `s`, `[m, p, o, q]` from `m`, into `[m, p, o, c]` and
/// `[m, c, o, q]` (swapped and rotated by the symbol: rotations keep the
/// cyclic order, so not the parallelograms). `c` is once in each, its
/// other corners are old (known): neighbours `m`, `o` and opposite corner
/// `p` in one, neighbours `o`, `m` and opposite `q` in the other. So the
/// neighbour sum is `2 (m + o)` and the opposite sum `p + q` over two
/// quads: versions 2 and 3 give `floor((2m + 2o − p − q) / 2)`, version 4
/// `floor((10 (m + o) − 2 (p + q)) / 16)` — what the scan computes from
/// the same two entries ([`stencil_mean`]).
fn predict_face_split(st: &MeshState, m: u32, s: u32, major: u16) -> [u32; 3] {
    let f = st.quads[s as usize];
    // The corner `build_face_split` takes as `m` (same fallback).
    let k = f.iter().position(|&x| x == m).unwrap_or(0);
    let q = &st.q;
    let (pm, pp, po, pq) = (
        q[f[k] as usize],
        q[f[(k + 1) & 3] as usize],
        q[f[(k + 2) & 3] as usize],
        q[f[(k + 3) & 3] as usize],
    );
    let (mut nb, mut op) = ([0i64; 3], [0i64; 3]);
    for t in 0..3 {
        nb[t] = 2 * (pm[t] as i64 + po[t] as i64);
        op[t] = pp[t] as i64 + pq[t] as i64;
    }
    stencil_mean(nb, op, 2, major, st.qmax)
}

/// Prediction of the split vertex `a` (spec §7.5): `m`'s old code plus a
/// quarter of the difference between the mean far corners (the corner
/// opposite `m`) of the faces that keep `m` and of the faces that go to `c`.
/// On a regular grid split across its middle this is the midpoint-merge
/// answer, half an edge towards the `a` side.
fn predict_a(st: &MeshState, m: u32, star: &Star, i: usize, j: usize) -> [u32; 3] {
    let pm = st.q[m as usize];
    let in_a = |t: usize| {
        if i < j {
            i <= t && t < j
        } else {
            t >= i || t < j
        }
    };
    let mut sum = [[0i64; 3]; 2];
    let mut n = [0i64; 2];
    for (t, &f) in star.faces.iter().enumerate() {
        let quad = st.quads[f as usize];
        let k = quad.iter().position(|&x| x == m).unwrap_or(0);
        let far = st.q[quad[(k + 2) % 4] as usize];
        let side = if in_a(t) { 0 } else { 1 };
        for a in 0..3 {
            sum[side][a] += far[a] as i64;
        }
        n[side] += 1;
    }
    let mean = |s: usize, a: usize| {
        if n[s] > 0 {
            sum[s][a].div_euclid(n[s])
        } else {
            pm[a] as i64
        }
    };
    let qmax = st.qmax as i64;
    [0, 1, 2]
        .map(|a| (pm[a] as i64 + (mean(0, a) - mean(1, a)).div_euclid(4)).clamp(0, qmax) as u32)
}

/// Reflection prediction of `c` (spec §7.5): `2 m_old − a`, as a midpoint
/// merge leaves it.
fn reflect(st: &MeshState, m_old: [u32; 3], a: [u32; 3]) -> [u32; 3] {
    let qmax = st.qmax as i64;
    [0, 1, 2].map(|t| (2 * m_old[t] as i64 - a[t] as i64).clamp(0, qmax) as u32)
}

fn residual_cost(pred: [u32; 3], p: [u32; 3]) -> u64 {
    (0..3)
        .map(|t| (p[t] as i64 - pred[t] as i64).unsigned_abs())
        .sum()
}

/// The record quads containing each new vertex (spec §7.6), as linked
/// lists over *record corners*: record quad `i` is appended quad `i` for
/// `i < n_app`, else rewritten quad `i − n_app` (the spec's order: appended,
/// then rewritten by ascending slot); corner entry `4 i + k`. `head[t]` is
/// the first entry of new vertex `V + t`, `next` links entries in record
/// quad order. Built in one pass, so predicting every new vertex of a
/// record is linear in its size (a hostile record with many new vertices
/// and quads cannot make it quadratic) and allocates nothing once grown.
#[derive(Clone, Debug, Default)]
pub struct NewFaces {
    head: Vec<u32>,
    next: Vec<u32>,
}

impl NewFaces {
    /// Lists for the `n_new` new vertices (`v0 ..`) of `r`'s quads.
    pub fn build(&mut self, r: &QRecord, v0: u32, n_new: usize) {
        let n_app = r.appended.len();
        let nq = n_app + r.rewritten.len();
        self.head.clear();
        self.head.resize(n_new, NIL);
        self.next.clear();
        self.next.resize(4 * nq, NIL);
        // Backwards, so that each list comes out in record quad order.
        for i in (0..nq).rev() {
            let quad = record_quad(r, i);
            for (k, &u) in quad.iter().enumerate() {
                let t = u.wrapping_sub(v0) as usize;
                if u >= v0 && t < n_new {
                    let e = (4 * i + k) as u32;
                    self.next[e as usize] = self.head[t];
                    self.head[t] = e;
                }
            }
        }
    }
}

/// Record quad `i` in the order of spec §7.6 (appended, then rewritten).
#[inline]
fn record_quad(r: &QRecord, i: usize) -> [u32; 4] {
    if i < r.appended.len() {
        r.appended[i]
    } else {
        r.rewritten[i - r.appended.len()].1
    }
}

/// Prediction of the code of new vertex `x` (spec §7.6). `r.new_pos` holds
/// the codes of the new vertices before `x` (`v0 ..= x − 1`), `r.moved` is
/// sorted by id, and `nf` was built from `r`'s quads. `major` picks the
/// rule: from version 2 on the mean of every parallelogram around `x`
/// whose three other corners are known (the curvature errors of opposite
/// parallelograms cancel; version 4 blends each with its edge neighbours'
/// mean, [`stencil_mean`]), else the version-1 rule on the first quad.
fn predict(st: &MeshState, r: &QRecord, v0: u32, x: u32, major: u16, nf: &NewFaces) -> [u32; 3] {
    let head = nf.head.get((x - v0) as usize).copied().unwrap_or(NIL);
    let mut e = head;
    let entries = std::iter::from_fn(move || {
        (e != NIL).then(|| {
            let out = (record_quad(r, (e >> 2) as usize), (e & 3) as usize);
            e = nf.next[e as usize];
            out
        })
    });
    predict_from(st, r, v0, x, major, entries)
}

/// [`predict`] without [`NewFaces`], for a record with few new vertices:
/// the record quads containing `x` are found by one scan, in the order
/// [`NewFaces`] lists them (record quad order; within a quad, corners
/// descending), and fed straight to [`predict_from`] (one pass, nothing
/// buffered) — the same prediction without building the lists. A scan is
/// linear in the record, so callers use it only for a bounded number of
/// new vertices per record (one for the split and face-split forms, four
/// for the edge split, at most `SCAN_NEW` in the general and local forms);
/// the lists keep a hostile record with many new vertices linear.
fn predict_scan(st: &MeshState, r: &QRecord, v0: u32, x: u32, major: u16) -> [u32; 3] {
    let mut p = Prediction::new(st, r, v0, x, major);
    // Two plain loops and one vector compare per quad (an iterator chain
    // here was measured at 3× the instructions, four compares and
    // branches per quad at twice).
    for quad in &r.appended {
        p.add_quad(quad);
    }
    for (_, quad) in &r.rewritten {
        p.add_quad(quad);
    }
    p.finish()
}

/// Most new vertices [`OnePass`] predicts (an edge split's four).
const ONE_PASS_NEW: usize = 4;

/// Room for quads with two or more new corners in [`OnePass`] (an edge
/// split has two appended quads and the rare face of both endpoints); a
/// record with more takes the per-vertex scans.
const ONE_PASS_DEFERRED: usize = 12;

/// The predictions of spec §7.6 for the (at most [`ONE_PASS_NEW`]) new
/// vertices of a record that moves nothing (version 2 or later), gathered
/// in one pass over the record's quads instead of one [`predict_scan`] per
/// new vertex — with the same values.
///
/// Why the same: a quad contributes its parallelogram to new vertex `x`
/// when `x` is one of its corners and the other three are known, i.e.
/// below `x` (nothing moves, and what is known while `x` is decoded are
/// the old vertices and the new ones before it). A quad holds a vertex at
/// most once (every record quad passes [`check_distinct`]), so a quad with
/// new corners contributes to exactly one of them, the largest: at once
/// when that is its only new corner (the other three are old:
/// [`OnePass::add_single`]), else once the smaller new corners are decoded
/// (kept aside until then). The sums are integers, so their order does not
/// matter, and the counts are the same; a vertex left without a
/// parallelogram takes [`predict_scan`] itself (its fallbacks read the
/// first entry in record order). Callers must feed every record quad
/// exactly once.
#[derive(Clone, Debug, Default)]
pub(crate) struct OnePass {
    /// Per new vertex, the sums of [`stencil_mean`]: its quads' edge
    /// neighbours, their opposite corners, and the count of quads.
    /// (One row per vertex, `[nb; 3], count, [op; 3], unused`: one base
    /// address per update.)
    acc: [[i64; 8]; ONE_PASS_NEW],
    /// (quad, corner of its largest new vertex).
    later: [([u32; 4], u8); ONE_PASS_DEFERRED],
    n_later: usize,
    /// Per new vertex (index below [`ONE_PASS_NEW`]), bit `i` set where
    /// `later[i]` goes to it: [`OnePass::finish`] visits each deferred
    /// quad once, not each once per new vertex.
    later_of: [u16; ONE_PASS_NEW],
    /// More quads to defer than there is room for: use the scans.
    overflow: bool,
}

impl OnePass {
    /// Empty sums.
    #[inline]
    pub(crate) fn clear(&mut self) {
        self.acc = [[0; 8]; ONE_PASS_NEW];
        self.n_later = 0;
        self.later_of = [0; ONE_PASS_NEW];
        self.overflow = false;
    }

    /// The quad of new vertex `t` (index from `v0`) whose neighbours in
    /// it are the old vertices `a`, `e` and whose opposite corner is the
    /// old vertex `o` (its parallelogram `a + e − o`; version 4's stencil
    /// `5 (a + e) − 2 o`).
    #[inline(always)]
    pub(crate) fn add_single(&mut self, q: &[[u32; 3]], t: usize, a: u32, o: u32, e: u32) {
        let (a, o, e) = (q[a as usize], q[o as usize], q[e as usize]);
        let row = &mut self.acc[t & (ONE_PASS_NEW - 1)];
        for c in 0..3 {
            row[c] += a[c] as i64 + e[c] as i64;
            row[4 + c] += o[c] as i64;
        }
        row[3] += 1;
    }

    /// Any record quad, new vertices `v0 .. v0 + nn` (`nn <=`
    /// [`ONE_PASS_NEW`]).
    #[inline(always)]
    pub(crate) fn add_quad(&mut self, q: &[[u32; 3]], quad: &[u32; 4], v0: u32, nn: u32) {
        let d = quad.map(|u| u.wrapping_sub(v0));
        let mask = (d[0] < nn) as u32
            | ((d[1] < nn) as u32) << 1
            | ((d[2] < nn) as u32) << 2
            | ((d[3] < nn) as u32) << 3;
        if mask == 0 {
            return;
        }
        // A corner past the new vertices (no decoded record has one) is
        // never known: the quad contributes to none of them.
        let lim = v0.saturating_add(nn);
        if quad.iter().any(|&u| u >= lim) {
            return;
        }
        if mask & (mask - 1) == 0 {
            let k = mask.trailing_zeros() as usize;
            let (a, o, e) = (quad[(k + 1) & 3], quad[(k + 2) & 3], quad[(k + 3) & 3]);
            self.add_single(q, d[k] as usize, a, o, e);
            return;
        }
        self.defer(quad, v0, mask);
    }

    /// A quad whose largest new corner is `quad[k]`, new vertex `t`, with
    /// other new corners (all below it): kept until they are decoded.
    #[inline]
    pub(crate) fn defer_at(&mut self, quad: &[u32; 4], k: usize, t: usize) {
        if self.n_later == ONE_PASS_DEFERRED {
            self.overflow = true;
            return;
        }
        self.push_later(quad, k, t);
    }

    /// A quad with new corners `mask` (two or more), kept for its largest.
    #[inline(never)]
    fn defer(&mut self, quad: &[u32; 4], v0: u32, mask: u32) {
        if self.n_later == ONE_PASS_DEFERRED {
            self.overflow = true;
            return;
        }
        let d = quad.map(|u| u.wrapping_sub(v0));
        let mut k = mask.trailing_zeros() as usize;
        let mut rest = mask & (mask - 1);
        while rest != 0 {
            let j = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if d[j] > d[k] {
                k = j;
            }
        }
        self.push_later(quad, k, d[k] as usize);
    }

    /// Defers `quad` (room checked by the caller) to new vertex `t`,
    /// its corner `k`. (A vertex index past [`ONE_PASS_NEW`] is never
    /// predicted: its quad is kept but goes to none.)
    #[inline(always)]
    fn push_later(&mut self, quad: &[u32; 4], k: usize, t: usize) {
        if let Some(bits) = self.later_of.get_mut(t) {
            *bits |= 1 << self.n_later;
        }
        self.later[self.n_later] = (*quad, k as u8);
        self.n_later += 1;
    }

    /// Reads the codes of the `n_new` new vertices of `r` (all its quads
    /// fed) into `r.new_pos`, in order, each its prediction plus the next
    /// residual of `pos`. The caller ensures what [`OnePass`] needs:
    /// `n_new <=` [`ONE_PASS_NEW`], version 2 or later, nothing moved (an
    /// edge split always; `decode_patch` tests it).
    pub(crate) fn finish(
        &mut self,
        st: &MeshState,
        r: &mut QRecord,
        n_new: usize,
        major: u16,
        pos: &mut Reader,
    ) -> Result<(), String> {
        if self.overflow {
            return scan_new_positions(st, r, n_new, major, pos);
        }
        let mut out = [[0u32; 3]; ONE_PASS_NEW];
        // The rule chosen once per record: a loop for each.
        if major >= 4 {
            self.finish_rule::<true, true>(st, r, n_new, major, pos, &mut out)
        } else {
            self.finish_rule::<false, true>(st, r, n_new, major, pos, &mut out)
        }
    }

    /// [`OnePass::finish`] of an edge split on the decoder's fast path
    /// (`edge_split::build_fast`): its four codes into `out`, not pushed
    /// to `r.new_pos`. `r` holds none of the record's quads, which only the
    /// scans would read: the fast path never needs them (see
    /// `decode_apply_edge_split`: every new vertex has a parallelogram of
    /// old corners, and the deferred quads fit).
    pub(crate) fn finish_edge_split(
        &mut self,
        st: &MeshState,
        r: &mut QRecord,
        major: u16,
        pos: &mut Reader,
        out: &mut [[u32; 3]; ONE_PASS_NEW],
    ) -> Result<(), String> {
        if self.overflow {
            // Not reached (see above); the scans, as `finish` would.
            scan_new_positions(st, r, 4, major, pos)?;
            for (o, &p) in out.iter_mut().zip(&r.new_pos) {
                *o = p;
            }
            Ok(())
        } else if major >= 4 {
            self.finish_rule::<true, false>(st, r, 4, major, pos, out)
        } else {
            self.finish_rule::<false, false>(st, r, 4, major, pos, out)
        }
    }

    /// [`OnePass::finish`] with version 4's rule (`V4`) or the earlier one,
    /// the codes into `out` and, with `PUSH`, to `r.new_pos` too.
    #[inline(always)]
    fn finish_rule<const V4: bool, const PUSH: bool>(
        &mut self,
        st: &MeshState,
        r: &mut QRecord,
        n_new: usize,
        major: u16,
        pos: &mut Reader,
        out: &mut [[u32; 3]; ONE_PASS_NEW],
    ) -> Result<(), String> {
        let (v0, q) = (st.q.len() as u32, &st.q);
        for t in 0..n_new {
            // Its deferred quads, in the order they came.
            let mut bits = self.later_of.get(t).copied().unwrap_or(0);
            while bits != 0 {
                let (quad, k) = self.later[bits.trailing_zeros() as usize];
                bits &= bits - 1;
                let k = k as usize;
                // The other new corners are below `v0 + t`: decoded.
                let code = |u: u32| {
                    if u < v0 {
                        q[u as usize]
                    } else {
                        out[(u - v0) as usize & (ONE_PASS_NEW - 1)]
                    }
                };
                let (a, o, e) = (
                    code(quad[(k + 1) & 3]),
                    code(quad[(k + 2) & 3]),
                    code(quad[(k + 3) & 3]),
                );
                let row = &mut self.acc[t];
                for c in 0..3 {
                    row[c] += a[c] as i64 + e[c] as i64;
                    row[4 + c] += o[c] as i64;
                }
                row[3] += 1;
            }
            let row = &self.acc[t];
            let pred = if row[3] > 0 {
                let (nb, op) = ([row[0], row[1], row[2]], [row[4], row[5], row[6]]);
                stencil_mean_rule::<V4>(nb, op, row[3], st.qmax)
            } else {
                predict_scan(st, r, v0, v0 + t as u32, major)
            };
            let p = add_residual(pred, pos, st.qmax)?;
            out[t & (ONE_PASS_NEW - 1)] = p;
            if PUSH {
                r.new_pos.push(p);
            }
        }
        Ok(())
    }
}

/// One [`predict_scan`] per new vertex of `r`, each followed by its
/// residual from `pos`, into `r.new_pos`.
#[cold]
#[inline(never)]
fn scan_new_positions(
    st: &MeshState,
    r: &mut QRecord,
    n_new: usize,
    major: u16,
    pos: &mut Reader,
) -> Result<(), String> {
    let v0 = st.q.len() as u32;
    for t in 0..n_new {
        let pred = predict_scan(st, r, v0, v0 + t as u32, major);
        let p = add_residual(pred, pos, st.qmax)?;
        r.new_pos.push(p);
    }
    Ok(())
}

/// The codes of the `n_new` new vertices of `r` (quads complete) by one
/// [`OnePass`] over its quads: the same values as [`predict_scan`] each
/// (preconditions as [`OnePass::finish`]).
fn decode_new_positions(
    st: &MeshState,
    r: &mut QRecord,
    n_new: usize,
    major: u16,
    pos: &mut Reader,
    op: &mut OnePass,
) -> Result<(), String> {
    op.clear();
    let (v0, nn) = (st.q.len() as u32, n_new as u32);
    for quad in &r.appended {
        op.add_quad(&st.q, quad, v0, nn);
    }
    for (_, quad) in &r.rewritten {
        op.add_quad(&st.q, quad, v0, nn);
    }
    op.finish(st, r, n_new, major, pos)
}

/// [`predict_scan`] of the split form's new vertex `c = V` (record `r`
/// just built by [`build_split_into`], wings `b = l_i`, `d = l_j`, `m`'s
/// code after the record `m_new`), without the scan: `c` is corner
/// `k` of the appended quad (a rotation of `[m, d, c, b]`, so its
/// parallelogram is `b + d − m_new`) and, where `m` was, of each rewritten
/// quad, whose other corners are old vertices other than `m` (a quad holds
/// each vertex once: every stored quad passed [`check_distinct`] or is a
/// star face with `m` replaced), so unmoved. Same entries, same sum, same
/// count, so the same value as the scan (the sum's order does not matter;
/// version 1 reads the appended quad only; [`stencil_mean`] picks the
/// rule).
fn predict_split(
    st: &MeshState,
    r: &QRecord,
    b: u32,
    d: u32,
    m_new: [u32; 3],
    major: u16,
) -> [u32; 3] {
    let q = &st.q;
    let (qb, qd) = (q[b as usize], q[d as usize]);
    let (mut nb, mut op) = ([0i64; 3], [0i64; 3]);
    for t in 0..3 {
        nb[t] = qb[t] as i64 + qd[t] as i64;
        op[t] = m_new[t] as i64;
    }
    let mut n = 1i64;
    if major >= 2 {
        let c = q.len() as u32;
        for (_, quad) in &r.rewritten {
            let k =
                (quad[1] == c) as usize + 2 * (quad[2] == c) as usize + 3 * (quad[3] == c) as usize;
            add_stencil_corner(q, quad, k, &mut nb, &mut op);
            n += 1;
        }
    }
    stencil_mean(nb, op, n, major, st.qmax)
}

/// Adds corner `k` of `quad` to a §7.6 stencil's sums: its two edge
/// neighbours' codes to `nb`, its opposite corner's to `op`.
#[inline(always)]
pub(crate) fn add_stencil_corner(
    q: &[[u32; 3]],
    quad: &[u32; 4],
    k: usize,
    nb: &mut [i64; 3],
    op: &mut [i64; 3],
) {
    let (a, o, e) = (
        q[quad[(k + 1) & 3] as usize],
        q[quad[(k + 2) & 3] as usize],
        q[quad[(k + 3) & 3] as usize],
    );
    for t in 0..3 {
        nb[t] += a[t] as i64 + e[t] as i64;
        op[t] += o[t] as i64;
    }
}

/// `floor(sum / n)` per axis, clamped to the grid (spec §7.6's mean of
/// `n > 0` parallelograms).
#[inline(always)]
pub(crate) fn floor_mean(sum: [i64; 3], n: i64, qmax: u32) -> [u32; 3] {
    let qmax = qmax as i64;
    [
        floor_div(sum[0], n).clamp(0, qmax) as u32,
        floor_div(sum[1], n).clamp(0, qmax) as u32,
        floor_div(sum[2], n).clamp(0, qmax) as u32,
    ]
}

/// Spec §7.6's prediction from `n > 0` qualifying quads around a new
/// vertex, per axis: `nb` is the sum of the codes of their corners next to
/// it (`n1`, `n3`), `op` of their opposite corners (`o`). Versions 1–3
/// (version 1 with `n = 1`): the mean parallelogram, `floor((nb − op) /
/// n)`; version 4: the stencil `floor((5 nb − 2 op) / (8 n))` — taken as
/// `floor(floor(s / n) / 8)`, the same value (nested floors of positive
/// divisors), so the usual 1, 2 or 4 quads stay shifts. The rule is
/// chosen here, once per vertex: the per-quad sums are the same for
/// every version.
#[inline(always)]
fn stencil_mean(nb: [i64; 3], op: [i64; 3], n: i64, major: u16, qmax: u32) -> [u32; 3] {
    if major >= 4 {
        stencil_mean_rule::<true>(nb, op, n, qmax)
    } else {
        stencil_mean_rule::<false>(nb, op, n, qmax)
    }
}

/// [`stencil_mean`] with version 4's rule (`V4`) or the earlier one.
#[inline(always)]
pub(crate) fn stencil_mean_rule<const V4: bool>(
    nb: [i64; 3],
    op: [i64; 3],
    n: i64,
    qmax: u32,
) -> [u32; 3] {
    if V4 {
        // Per axis by hand: `[0, 1, 2].map(…)` was an out-of-line array
        // drain (3 M instructions of a loki decode), a closure a call.
        let qmax = qmax as i64;
        [
            (floor_div(5 * nb[0] - 2 * op[0], n) >> 3).clamp(0, qmax) as u32,
            (floor_div(5 * nb[1] - 2 * op[1], n) >> 3).clamp(0, qmax) as u32,
            (floor_div(5 * nb[2] - 2 * op[2], n) >> 3).clamp(0, qmax) as u32,
        ]
    } else {
        floor_mean([nb[0] - op[0], nb[1] - op[1], nb[2] - op[2]], n, qmax)
    }
}

/// `s.div_euclid(n)` for `n > 0` (then the floor of `s / n`): for the
/// usual 1, 2 or 4 parallelograms an arithmetic shift (the same value; a
/// 64-bit division costs tens of cycles), else one inlined division (the
/// library's `div_euclid` by a variable is a call).
#[inline(always)]
fn floor_div(s: i64, n: i64) -> i64 {
    debug_assert!(n > 0);
    match n {
        1 => s,
        2 => s >> 1,
        4 => s >> 2,
        _ => s / n - ((s % n) < 0) as i64,
    }
}

/// The prediction of spec §7.6 for new vertex `x`, given the record quads
/// containing `x` with the corner index of `x` in each (`entries`, in
/// record quad order).
fn predict_from(
    st: &MeshState,
    r: &QRecord,
    v0: u32,
    x: u32,
    major: u16,
    entries: impl Iterator<Item = ([u32; 4], usize)>,
) -> [u32; 3] {
    let mut p = Prediction::new(st, r, v0, x, major);
    for (quad, k) in entries {
        p.add(&quad, k);
    }
    p.finish()
}

/// The running state of one prediction (spec §7.6), fed the record quads
/// containing the new vertex `x` in record quad order, in one pass: the
/// sums and count of [`stencil_mean`] (from version 2 on) and the first
/// entry, for the fallbacks.
struct Prediction<'a> {
    st: &'a MeshState,
    r: &'a QRecord,
    v0: u32,
    x: u32,
    major: u16,
    /// Codes of the qualifying quads' corners next to `x` ([`stencil_mean`]).
    nb: [i64; 3],
    /// Codes of their corners opposite `x`.
    op: [i64; 3],
    n: i64,
    first: Option<([u32; 4], usize)>,
}

impl<'a> Prediction<'a> {
    #[inline]
    fn new(st: &'a MeshState, r: &'a QRecord, v0: u32, x: u32, major: u16) -> Self {
        Prediction {
            st,
            r,
            v0,
            x,
            major,
            nb: [0; 3],
            op: [0; 3],
            n: 0,
            first: None,
        }
    }

    /// The code of `u` if the decoder knows it at this point: an old vertex
    /// (its moved code if the record moves it), or a new vertex before `x`.
    #[inline]
    fn known(&self, u: u32) -> Option<[u32; 3]> {
        let (st, r, v0) = (self.st, self.r, self.v0);
        if u < v0 {
            if r.moved.is_empty() {
                return Some(st.q[u as usize]);
            }
            match r.moved.binary_search_by_key(&u, |m| m.0) {
                Ok(i) => Some(r.moved[i].1),
                Err(_) => Some(st.q[u as usize]),
            }
        } else if u < self.x {
            r.new_pos.get((u - v0) as usize).copied()
        } else {
            None
        }
    }

    /// Every corner of `quad` that is `x`, corners descending (the order
    /// of [`NewFaces`]).
    #[inline(always)]
    fn add_quad(&mut self, quad: &[u32; 4]) {
        let mut mask = eq_mask4(quad, self.x);
        while mask != 0 {
            let k = 31 - mask.leading_zeros() as usize;
            mask &= !(1 << k);
            self.add(quad, k);
        }
    }

    /// One entry: `x` is corner `k` of `quad`.
    #[inline(always)]
    fn add(&mut self, quad: &[u32; 4], k: usize) {
        if self.first.is_none() {
            self.first = Some((*quad, k));
        }
        if self.major < 2 {
            // Version 1 reads the first entry only.
            return;
        }
        let (u1, u2, u3) = (quad[(k + 1) & 3], quad[(k + 2) & 3], quad[(k + 3) & 3]);
        let codes = if self.r.moved.is_empty() {
            // The usual case (a subset-placement file moves nothing): what
            // `known` gives without the moved-vertex search, and with one
            // test for "all three known" (a vertex is known iff it is
            // below `x`: `new_pos` holds `v0 .. x`).
            let x = self.x;
            if u1 >= x || u2 >= x || u3 >= x {
                return;
            }
            let (q, v0, new) = (&self.st.q, self.v0, &self.r.new_pos);
            let code = |u: u32| {
                if u < v0 {
                    q.get(u as usize).copied()
                } else {
                    new.get((u - v0) as usize).copied()
                }
            };
            match (code(u1), code(u2), code(u3)) {
                (Some(a), Some(b), Some(c)) => Some((a, b, c)),
                _ => None,
            }
        } else {
            match (self.known(u1), self.known(u2), self.known(u3)) {
                (Some(a), Some(b), Some(c)) => Some((a, b, c)),
                _ => None,
            }
        };
        if let Some((a, b, c)) = codes {
            for t in 0..3 {
                self.nb[t] += a[t] as i64 + c[t] as i64;
                self.op[t] += b[t] as i64;
            }
            self.n += 1;
        }
    }

    /// The prediction: [`stencil_mean`] of the qualifying quads, else
    /// (none had three known corners, or version 1) the fallbacks, out of
    /// line.
    #[inline(always)]
    fn finish(&self) -> [u32; 3] {
        if self.n > 0 {
            return stencil_mean(self.nb, self.op, self.n, self.major, self.st.qmax);
        }
        self.finish_fallback()
    }

    /// [`Prediction::finish`] without a parallelogram.
    #[inline(never)]
    fn finish_fallback(&self) -> [u32; 3] {
        let (st, r, v0, x) = (self.st, self.r, self.v0, self.x);
        let qmax = st.qmax as i64;
        if let Some((face, k)) = self.first {
            let n1 = self.known(face[(k + 1) % 4]);
            let o = self.known(face[(k + 2) % 4]);
            let n3 = self.known(face[(k + 3) % 4]);
            if let (Some(a), Some(b), Some(c)) = (n1, o, n3) {
                return [0, 1, 2]
                    .map(|t| (a[t] as i64 + c[t] as i64 - b[t] as i64).clamp(0, qmax) as u32);
            }
            // Mean of the known ones (summed in place: no list per vertex).
            let (mut sum, mut n) = ([0u64; 3], 0u64);
            for p in [n1, o, n3].into_iter().flatten() {
                for t in 0..3 {
                    sum[t] += p[t] as u64;
                }
                n += 1;
            }
            if n > 0 {
                return sum.map(|x| (x / n) as u32);
            }
        }
        if x > v0 {
            if let Some(&p) = r.new_pos.last() {
                return p;
            }
        }
        [st.qmax.div_ceil(2); 3]
    }
}

/// `pred` plus the next three residuals of `rd`, which must stay on the
/// grid (a negative sum is a huge `u64`: one test per axis). The sum
/// wraps: `pred < 2^32`, so only a residual near `i64::MAX` overflows,
/// and then the wrapped sum is negative and refused as the true one is
/// (the error names the saturated sum, as before).
#[inline(always)]
pub(crate) fn add_residual(pred: [u32; 3], rd: &mut Reader, qmax: u32) -> Result<[u32; 3], String> {
    let mut out = [0u32; 3];
    for t in 0..3 {
        let d = rd.s()?;
        let v = (pred[t] as i64).wrapping_add(d);
        if v as u64 > qmax as u64 {
            return Err(off_grid((pred[t] as i64).saturating_add(d), qmax));
        }
        out[t] = v as u32;
    }
    Ok(out)
}

/// The error of [`add_residual`] (cold: only bad input gets here).
#[cold]
#[inline(never)]
fn off_grid(v: i64, qmax: u32) -> String {
    format!("position code {v} outside the grid 0..={qmax}")
}

fn put_residual(out: &mut Vec<u8>, pred: [u32; 3], p: [u32; 3]) {
    for t in 0..3 {
        put_s(out, p[t] as i64 - pred[t] as i64);
    }
}

/// `q` rotated left by `t`: `rotl(q, t)[k] = q[(k + t) mod 4]` (the
/// rotation rule of every record form's 2-bit rotation codes).
#[inline]
pub(crate) fn rotl(q: [u32; 4], t: u8) -> [u32; 4] {
    let t = t as usize;
    [q[t & 3], q[(t + 1) & 3], q[(t + 2) & 3], q[(t + 3) & 3]]
}

/// Checks that the 4 corners of `q` are distinct; `what` names the face in
/// the error (a closure, so that no string is built on the hot path).
/// Always inlined: six compares, where a call cost as much.
#[inline(always)]
pub(crate) fn check_distinct(q: &[u32; 4], what: impl FnOnce() -> String) -> Result<(), String> {
    // All six comparisons at once (no branch per pair): a quad with a
    // repeated corner is an error, so the hot path is one test.
    let dup = (q[0] == q[1])
        | (q[0] == q[2])
        | (q[0] == q[3])
        | (q[1] == q[2])
        | (q[1] == q[3])
        | (q[2] == q[3]);
    if dup {
        return Err(repeated_corner(q, what()));
    }
    Ok(())
}

/// The error of [`check_distinct`] (cold: only bad input gets here).
#[cold]
#[inline(never)]
fn repeated_corner(q: &[u32; 4], what: String) -> String {
    for a in 0..4 {
        for b in a + 1..4 {
            if q[a] == q[b] {
                return format!("{what} repeats vertex {}", q[a]);
            }
        }
    }
    format!("{what} repeats a vertex")
}

/// Vertex `cursor + delta`, which must be `< limit`.
fn vref(cursor: u32, delta: i64, limit: u32, what: &str) -> Result<u32, String> {
    let v = (cursor as i64).saturating_add(delta);
    if v < 0 || v >= limit as i64 {
        return Err(format!(
            "{what} references vertex {v} but only {limit} vertices exist"
        ));
    }
    Ok(v as u32)
}

/// Reusable buffers of [`decode_record_into`]: the local neighbourhood and
/// its generation stamps, the moved-vertex vocabulary, rewritten slots,
/// explicit corners and first faces. One per decoder, so that decoding a
/// record allocates nothing once the buffers have grown.
#[derive(Default)]
pub struct DecodeScratch {
    marks: Marks,
    /// Neighbourhood of the current local-form anchor.
    local: Local,
    w: Vec<u32>,
    slots: Vec<u32>,
    extra: Vec<u32>,
    nf: NewFaces,
    /// Star of the current split-form vertex.
    star: Star,
    /// The fused split's star, the fused edge split's two (here, not on
    /// the stack: no 72-byte fill per star; entries past a star's `n` are
    /// stale, which nothing reads).
    fast: [FastStar; 2],
    /// Stars and lists of the edge-split form.
    edge: crate::edge_split::Scratch,
    /// Fan rotations of the current edge-split record.
    rots: Vec<u8>,
    /// Predictions of the current record's new vertices.
    one_pass: OnePass,
}

impl DecodeScratch {
    /// Empty buffers (they grow to the largest record seen).
    pub fn new() -> Self {
        Self::default()
    }
}

/// Decodes one record against `st` (level before the record). `max_v` /
/// `max_f` are the file's final counts: no record may exceed them; `major`
/// is the file's major version (1: the 1.x rules, 2: multi-parallelogram
/// prediction and the face-split form, spec §9).
/// (Convenience over [`decode_record_into`] with per-thread buffers.)
pub fn decode_record(
    st: &MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
) -> Result<QRecord, String> {
    thread_local! {
        static SCRATCH: std::cell::RefCell<DecodeScratch> =
            std::cell::RefCell::new(DecodeScratch::default());
    }
    let mut r = QRecord::default();
    SCRATCH.with(|cell| {
        decode_record_into(
            st,
            rd,
            cur,
            max_v,
            max_f,
            major,
            &mut r,
            &mut cell.borrow_mut(),
        )
    })?;
    Ok(r)
}

/// [`decode_record`] into `r` (its lists are cleared first and their
/// buffers reused) with the caller's scratch buffers: the decoder's hot
/// path, which allocates nothing per record.
#[allow(clippy::too_many_arguments)]
pub fn decode_record_into(
    st: &MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
) -> Result<(), String> {
    let v0 = st.q.len() as u32;
    let sym = rd[OPS].byte()?;
    let op = OpKind::from_code(sym & 3).ok_or("bad op")?;
    let mut form = (sym >> 2) & 3;
    if form == 0 && sym >> 4 != 0 {
        // Bits 2-3 = 0: bits 4-7 select the general (0) or edge-split (1)
        // form (spec §7.3).
        if sym >> 4 != 1 {
            return Err(format!("symbol {sym:#04x}: unknown record form"));
        }
        if major < 3 {
            return Err(format!(
                "record form 4 (edge split) in a version {major} file (symbol {sym:#04x}; version 3 only)"
            ));
        }
        form = 4;
    }
    r.op = op;
    r.clear_parts();
    match form {
        4 => decode_edge_split(st, rd, cur, max_v, max_f, major, r, sc)?,
        0 | 2 => {
            if sym & 0xf0 != 0 {
                return Err(format!(
                    "symbol {sym:#04x} of form {form} has split-form bits set"
                ));
            }
            let local = form == 2;
            if local {
                let m = vref(cur.vref, rd[REFS].s()?, v0, "local-form anchor")?;
                cur.vref = m;
                st.prefetch_ahead(&rd[REFS], m, &mut cur.peek);
                st.local_faces_with(m, &mut sc.marks, &mut sc.local)?;
            }
            decode_patch(st, rd, cur, max_v, max_f, local, major, sc, r)?;
        }
        1 => {
            let m = read_anchor(st, rd, cur, max_v, max_f, 1, "split")?;
            split_after_anchor(st, rd, m, sym, major, r, sc)?;
        }
        _ if major < 2 => {
            return Err(format!(
                "record form {form} (face split) in a version {major} file (symbol {sym:#04x}; version 2 only)"
            ))
        }
        _ => {
            // Face-split form (spec §7.9).
            let m = read_anchor(st, rd, cur, max_v, max_f, 1, "face split")?;
            face_split_after_anchor(st, rd, m, sym, major, r, sc)?;
        }
    }
    Ok(())
}

/// A split-form record (spec §7.5) after its anchor `m`, from symbol
/// `sym`, into `r` (cleared).
#[allow(clippy::too_many_arguments)]
fn split_after_anchor(
    st: &MeshState,
    rd: &mut [Reader; 5],
    m: u32,
    sym: u8,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
) -> Result<(), String> {
    let rot = ((sym >> 4) & 3) as usize;
    st.star_into(m, &mut sc.star)?;
    let star = &sc.star;
    let l = star.link.len();
    if l < 2 {
        return Err(format!("vertex {m} has fewer than two link vertices"));
    }
    let i = rd[CONN].u_max(l as u64 - 1, "first wing index")? as usize;
    let e = rd[CONN].u_max(l as u64 - 2, "second wing offset")? as usize;
    let j = (i + 1 + e) % l;
    let appended = build_split_into(st, m, star, i, j, rot, &mut r.rewritten)?;
    r.appended.push(appended);
    let m_old = st.q[m as usize];
    if sym & 0x40 != 0 {
        let p = add_residual(predict_a(st, m, star, i, j), &mut rd[POS], st.qmax)?;
        r.moved.push((m, p));
    }
    let m_new = r.moved.first().map_or(m_old, |mv| mv.1);
    let pred = if sym & 0x80 != 0 {
        reflect(st, m_old, m_new)
    } else {
        predict_split(st, r, star.link[i], star.link[j], m_new, major)
    };
    let p = add_residual(pred, &mut rd[POS], st.qmax)?;
    r.new_pos.push(p);
    Ok(())
}

/// The split case of [`decode_apply_record`]: when `m`'s star is on the
/// fast path ([`MeshState::star_fast`], nearly always), the record is
/// applied straight from its wings — each face on the `c` side gets `c`
/// at the corner the star's corner id names (one corner moved between two
/// lists, one log entry), its parallelogram summed on the way — instead of
/// a sorted rewritten list that the prediction and then the apply read
/// again. The same values as [`split_after_anchor`] then
/// [`MeshState::apply_delta_logged`] (the sums of [`predict_a`] and
/// [`predict_split`] over the same faces; test `fused_split_equals_explicit`
/// and every real-mesh level), and nothing applied on error.
///
/// Always inlined (into [`decode_apply_record`], itself inlined into the
/// decoder's chunk loop): the call, its eleven arguments and the returned
/// `Result` were ~1.1 % of the bunny's decode (callgrind, one forward
/// decode: 313.4 M -> 309.9 M instructions; wall time 1-3 % better on
/// spot, makehuman and loki, even on the bunny). The face split inlined as
/// well saved another 5.2 M on the bunny but was 1-2 % slower on loki and
/// makehuman in two A/B runs: not kept.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn decode_apply_split(
    st: &mut MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
    moved: &mut MoveDeltas,
    rw: &mut RewriteDeltas,
    kept: Kept,
) -> Result<(), String> {
    let v0 = st.q.len() as u32;
    let sym = rd[OPS].byte()?;
    r.op = OpKind::from_code(sym & 3).ok_or("bad op")?;
    let m = read_anchor(st, rd, cur, max_v, max_f, 1, "split")?;
    if !st.star_fast_into(m, &mut sc.fast[0]) {
        r.clear_parts();
        split_after_anchor(st, rd, m, sym, major, r, sc)?;
        st.apply_delta_logged(r, moved, rw);
        keep(r, kept);
        return Ok(());
    }
    let s = &sc.fast[0];
    let l = s.n;
    let i = rd[CONN].u_max(l as u64 - 1, "first wing index")? as usize;
    let e = rd[CONN].u_max(l as u64 - 2, "second wing offset")? as usize;
    let j = if i + 1 + e < l {
        i + 1 + e
    } else {
        i + 1 + e - l
    };
    let (b, d) = (s.nx[i], s.nx[j]);
    if b == d {
        return Err(format!("split of vertex {m}: both wings are vertex {b}"));
    }
    let c = v0;
    let appended = rotl([m, d, c, b], (sym >> 4) & 3);
    // Faces `t` in `[i, j)` (cyclic) keep `m`; the others go to `c`.
    let in_a = |t: usize| {
        if i < j {
            i <= t && t < j
        } else {
            t >= i || t < j
        }
    };
    let (q, quads) = (&st.q, &st.quads);
    let m_old = q[m as usize];
    let m_new = if sym & 0x40 != 0 {
        // `predict_a`: the mean far corner of each side.
        let mut sum = [[0i64; 3]; 2];
        let mut n = [0i64; 2];
        for t in 0..l {
            let ct = s.c[t];
            let far = q[quads[(ct >> 2) as usize][(ct as usize + 2) & 3] as usize];
            let side = (!in_a(t)) as usize;
            for a in 0..3 {
                sum[side][a] += far[a] as i64;
            }
            n[side] += 1;
        }
        let mean = |s: usize, a: usize| {
            if n[s] > 0 {
                floor_div(sum[s][a], n[s])
            } else {
                m_old[a] as i64
            }
        };
        let qmax = st.qmax as i64;
        let pred = [0, 1, 2].map(|a| {
            (m_old[a] as i64 + (mean(0, a) - mean(1, a)).div_euclid(4)).clamp(0, qmax) as u32
        });
        Some(add_residual(pred, &mut rd[POS], st.qmax)?)
    } else {
        None
    };
    let m_moved = m_new;
    let m_new = m_new.unwrap_or(m_old);
    // The `c` side's corners, and (`predict_split`) their parallelograms
    // around `c` plus the appended quad's.
    let mut side = [0u32; 8];
    let mut n_side = 0usize;
    // The corners that stay at `m`: its block after the record.
    let mut stay = [0u32; 8];
    let mut n_stay = 0usize;
    let (qb, qd) = (q[b as usize], q[d as usize]);
    let (mut nb, mut op) = ([0i64; 3], [0i64; 3]);
    for t in 0..3 {
        nb[t] = qb[t] as i64 + qd[t] as i64;
        op[t] = m_new[t] as i64;
    }
    let mut cnt = 1i64;
    // Faces `i .. j` (cyclic) stay at `m`, faces `j .. i` go to `c`: two
    // runs of the star, walked in turn without a side test per face (`i
    // != j`: both runs are non-empty; `& 7` spares the bounds checks,
    // `l <= INLINE`).
    let step = |t: usize| if t + 1 < l { t + 1 } else { 0 };
    let mut t = i;
    while t != j {
        stay[n_stay & 7] = s.c[t & 7];
        n_stay += 1;
        t = step(t);
    }
    loop {
        let ct = s.c[t & 7];
        side[n_side & 7] = ct;
        n_side += 1;
        t = step(t);
        if major >= 2 {
            add_stencil_corner(q, &quads[(ct >> 2) as usize], ct as usize, &mut nb, &mut op);
            cnt += 1;
        }
        if t == i {
            break;
        }
    }
    let pred = if sym & 0x80 != 0 {
        reflect(st, m_old, m_new)
    } else {
        stencil_mean(nb, op, cnt, major, st.qmax)
    };
    let p = add_residual(pred, &mut rd[POS], st.qmax)?;
    // Applied: nothing can fail from here. (`r` is left as it was: the
    // caller reads the new code and quad from `kept`.)
    if let Some((new_pos, app)) = kept {
        new_pos.push(p);
        app.push(appended);
    }
    st.q.push(p);
    // The corner blocks of `m` and `c` written whole, not by one unlink and
    // one link per moved corner (a block scan, a swap-remove and an
    // append each): `m`'s block held exactly the star's `l` corners (the
    // fast star has no overflow list), `c`'s is new, and both keep room
    // for the appended quad's corner (`1 <= n_side, n_stay < l <= 7`).
    // The order of a block's corners carries no meaning (see
    // [`MeshState`]): the same corners as the unlink / link pairs. All 7
    // entries are copied (fixed size: two vector moves, where a copy of
    // `n` entries was a `memcpy` call); those past the count are stale,
    // as a swap-remove leaves them, and nothing reads them.
    let mut cb = Block::default();
    cb.0[0] = n_side as u32;
    cb.0[1..].copy_from_slice(&side[..INLINE]);
    st.inline.push(cb);
    let mb = &mut st.inline[m as usize].0;
    mb[0] = n_stay as u32;
    mb[1..].copy_from_slice(&stay[..INLINE]);
    if let Some(pm) = m_moved {
        let old = std::mem::replace(&mut st.q[m as usize], pm);
        moved.push((m, xor3(pm, old)));
    }
    for &ct in &side[..n_side] {
        let (slot, k) = (ct >> 2, (ct & 3) as usize);
        st.quads[slot as usize][k] = c;
        rw.push((slot, one_corner(k, m ^ c)));
    }
    st.append_quads(&[appended]);
    Ok(())
}

/// A face-split record (spec §7.9) after its anchor `m`, from symbol
/// `sym`, into `r` (cleared).
fn face_split_after_anchor(
    st: &MeshState,
    rd: &mut [Reader; 5],
    m: u32,
    sym: u8,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
) -> Result<(), String> {
    st.slots_at_unsorted(m, &mut sc.slots)?;
    let n = sc.slots.len() as u64;
    let x = rd[CONN].u_max(2 * n - 1, "face-split index")?;
    // The slot of rank `x / 2` in ascending order (a vertex is a
    // corner of a quad at most once, so the slots are distinct):
    // a selection, linear in the star also for a hostile 255-face
    // one, instead of sorting the 4–6 slots.
    let s = *sc.slots.select_nth_unstable((x >> 1) as usize).1;
    let (rewritten, appended) = build_face_split(st, m, s, x & 1 != 0, sym);
    r.rewritten.push((s, rewritten));
    r.appended.push(appended);
    let pred = predict_face_split(st, m, s, major);
    let p = add_residual(pred, &mut rd[POS], st.qmax)?;
    r.new_pos.push(p);
    Ok(())
}

/// The face-split case of [`decode_apply_record`] (version 2 and later):
/// when `m`'s corners all sit in its block (nearly always), the slot of
/// rank `x / 2` is the corner whose id has that rank (corner ids order as
/// their slots, which are distinct), and that corner id gives `m`'s place
/// in the quad without a search; the two quads, the closed-form
/// prediction and the apply follow without the slot list, the selection
/// or the explicit record. The same values as [`face_split_after_anchor`]
/// then [`MeshState::apply_delta_logged`] (test
/// `fused_face_split_equals_explicit`), nothing applied on error.
#[allow(clippy::too_many_arguments)]
fn decode_apply_face_split(
    st: &mut MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
    moved: &mut MoveDeltas,
    rw: &mut RewriteDeltas,
    kept: Kept,
) -> Result<(), String> {
    let v0 = st.q.len() as u32;
    let sym = rd[OPS].byte()?;
    r.op = OpKind::from_code(sym & 3).ok_or("bad op")?;
    let m = read_anchor(st, rd, cur, max_v, max_f, 1, "face split")?;
    // `n` in 1..=INLINE, no overflow flag (bit 31 makes `n` too large).
    let b = st.inline[m as usize].0;
    let n = b[0] as usize;
    if !(1..=INLINE).contains(&n) {
        r.clear_parts();
        face_split_after_anchor(st, rd, m, sym, major, r, sc)?;
        st.apply_delta_logged(r, moved, rw);
        keep(r, kept);
        return Ok(());
    }
    let x = rd[CONN].u_max(2 * n as u64 - 1, "face-split index")?;
    let rank = (x >> 1) as u32;
    // The corner whose id has `rank` smaller ones among the block's `n`
    // (distinct ids, `rank < n`: exactly one; were there none, the first,
    // as the scalar loop this replaced).
    let hit = rank_mask8(&b, n, rank);
    let ct = b[if hit == 0 {
        1
    } else {
        hit.trailing_zeros() as usize
    }];
    let (s, k) = (ct >> 2, (ct & 3) as usize);
    let f = st.quads[s as usize];
    let c = v0;
    let (p, o, q) = (f[(k + 1) & 3], f[(k + 2) & 3], f[(k + 3) & 3]);
    // As `build_face_split` and `predict_face_split`, from corner `k`.
    let (a, bq) = ([m, p, o, c], [m, c, o, q]);
    let (xq, yq) = if x & 1 != 0 { (bq, a) } else { (a, bq) };
    let xq = rotl(xq, (sym >> 4) & 3);
    let yq = rotl(yq, sym >> 6);
    let pos = &st.q;
    let (pm, pp, po, pq) = (
        pos[m as usize],
        pos[p as usize],
        pos[o as usize],
        pos[q as usize],
    );
    let (mut nb, mut op) = ([0i64; 3], [0i64; 3]);
    for t in 0..3 {
        nb[t] = 2 * (pm[t] as i64 + po[t] as i64);
        op[t] = pp[t] as i64 + pq[t] as i64;
    }
    let pred = stencil_mean(nb, op, 2, major, st.qmax);
    let pc = add_residual(pred, &mut rd[POS], st.qmax)?;
    if let Some((new_pos, appended)) = kept {
        new_pos.push(pc);
        appended.push(yq);
    }
    st.apply_parts_logged(&[pc], &[(s, xq)], &[yq], rw);
    Ok(())
}

/// Decodes an edge-split record (spec §7.10) after its symbol.
#[allow(clippy::too_many_arguments)]
fn decode_edge_split(
    st: &MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
) -> Result<(), String> {
    let a = read_anchor(st, rd, cur, max_v, max_f, 4, "edge split")?;
    // The anchor's star first: `r` is bounded by its size.
    let ka = crate::edge_split::anchor_star(st, a, &mut sc.edge)? as u64;
    let link = rd[CONN].u_max(ka - 1, "edge-split link index")? as usize;
    edge_split_after_link(st, rd, a, link, major, r, sc)
}

/// A compact form's count check and anchor: the record adds `grows`
/// vertices and faces at most (split and face split 1, edge split 4; spec
/// §7.5, §7.9, §7.10 step 1), then its anchor, `what` naming the form in
/// the errors.
#[inline(always)]
fn read_anchor(
    st: &MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    grows: u32,
    what: &str,
) -> Result<u32, String> {
    let v0 = st.q.len() as u32;
    let f0 = st.quads.len() as u32;
    if v0 as u64 + grows as u64 > max_v as u64 || f0 as u64 + grows as u64 > max_f as u64 {
        return Err(format!("{what} exceeds the final vertex or face count"));
    }
    let a = vref(cur.vref, rd[REFS].s()?, v0, what)?;
    cur.vref = a;
    st.prefetch_ahead(&rd[REFS], a, &mut cur.peek);
    Ok(a)
}

/// [`decode_edge_split`] once the anchor's star is in `sc.edge.stars[0]`
/// and its link index is read.
#[allow(clippy::too_many_arguments)]
fn edge_split_after_link(
    st: &MeshState,
    rd: &mut [Reader; 5],
    a: u32,
    link: usize,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
) -> Result<(), String> {
    let (ends, rho) = crate::edge_split::stars(st, a, link, &mut sc.edge)?;
    let k = sc.edge.stars.each_ref().map(|s| s.faces.len());
    let (n1, m, p, ra) = edge_split_fields(rd, ends, k, &mut sc.rots)?;
    crate::edge_split::build(st, ends, rho, n1, m, p, ra, &sc.rots, &mut sc.edge, r)?;
    // `build` gathered the four predictions while it made the quads.
    sc.edge.pred.finish(st, r, 4, major, &mut rd[POS])
}

/// The edge split's fields after the link index (spec §7.10 steps 4–7),
/// `k` = the endpoints' face counts: `(n1, m, p, ra)`, the fan rotations
/// into `rots`.
#[inline(always)]
fn edge_split_fields(
    rd: &mut [Reader; 5],
    ends: [u32; 2],
    k: [usize; 2],
    rots: &mut Vec<u8>,
) -> Result<([usize; 2], [usize; 2], usize, u8), String> {
    let (mut n1, mut m) = ([0usize; 2], [0usize; 2]);
    for x in 0..2 {
        let k = k[x] as u64;
        if k < 3 {
            return Err(format!(
                "edge split: endpoint {} has {k} faces (needs at least 3)",
                ends[x]
            ));
        }
        n1[x] = rd[CONN].u_max(k - 3, "edge-split first sector")? as usize;
        m[x] = 1 + rd[CONN].u_max(k - 3 - n1[x] as u64, "edge-split fan length")? as usize;
    }
    let p = rd[CONN].u_max(crate::edge_split::MAX_P, "edge-split permutations")? as usize;
    let ra = rd[CONN].u_max(255, "edge-split appended rotations")? as u8;
    rots.clear();
    for _ in 0..m[0] + m[1] {
        rots.push(rd[CONN].u_max(3, "edge-split fan rotation")? as u8);
    }
    Ok((n1, m, p, ra))
}

/// Where [`decode_apply_record`] appends a record's new vertex codes and
/// appended quads for the caller (a decoder that can replay records keeps
/// them; a forward-only one passes `None`).
pub type Kept<'a> = Option<(&'a mut Vec<[u32; 3]>, &'a mut Vec<[u32; 4]>)>;

/// [`decode_record_into`] followed by [`MeshState::apply_delta_logged`]:
/// the decoder's loop. An edge split whose stars are both on the fast
/// path (`MeshState::star_fast`) is decoded and applied fused
/// (`edge_split::build_fast`), and so are the split and
/// face-split forms (`decode_apply_split`, `decode_apply_face_split`):
/// no explicit record. The record's new codes and appended quads are
/// appended to `kept` when given; `r` is scratch (only `r.op` is
/// meaningful after the call). Same level, same log entries (within a
/// record in another order), the same records refused before anything is
/// applied — on error `st` is unchanged; where several slots of a record
/// break a rule the message may name another of them (star order, not
/// slot order; found by the fuzz target). Always inlined: in the decoder's
/// chunk loop, its one caller there, the call and its eleven arguments
/// were a fixed cost per record.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn decode_apply_record(
    st: &mut MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
    moved: &mut MoveDeltas,
    rw: &mut RewriteDeltas,
    kept: Kept,
) -> Result<(), String> {
    // Symbol `0x1?` with bits 2–3 clear: the edge-split form (version 3).
    match rd[OPS].peek_byte() {
        Some(b) if major >= 3 && b & 0xfc == 0x10 => {
            return decode_apply_edge_split(
                st, rd, cur, max_v, max_f, major, r, sc, moved, rw, kept,
            );
        }
        // Bits 2–3 = 1: the split form; 3: the face split (version 2):
        // their one new vertex and quad go to `kept` directly.
        Some(b) if b & 0x0c == 0x04 => {
            return decode_apply_split(st, rd, cur, max_v, max_f, major, r, sc, moved, rw, kept);
        }
        Some(b) if major >= 2 && b & 0x0c == 0x0c => {
            return decode_apply_face_split(
                st, rd, cur, max_v, max_f, major, r, sc, moved, rw, kept,
            );
        }
        _ => {
            decode_record_into(st, rd, cur, max_v, max_f, major, r, sc)?;
            st.apply_delta_logged(r, moved, rw);
        }
    }
    keep(r, kept);
    Ok(())
}

/// Appends `r`'s new codes and appended quads to `kept`, when given.
#[inline(always)]
fn keep(r: &QRecord, kept: Kept) {
    if let Some((new_pos, appended)) = kept {
        // Element by element: a record holds 1–4 of each, where
        // `extend_from_slice` is a call to `memcpy`.
        for &p in &r.new_pos {
            new_pos.push(p);
        }
        for &q in &r.appended {
            appended.push(q);
        }
    }
}

/// The edge-split case of [`decode_apply_record`].
#[allow(clippy::too_many_arguments)]
fn decode_apply_edge_split(
    st: &mut MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    major: u16,
    r: &mut QRecord,
    sc: &mut DecodeScratch,
    moved: &mut MoveDeltas,
    rw: &mut RewriteDeltas,
    kept: Kept,
) -> Result<(), String> {
    let sym = rd[OPS].byte()?;
    r.op = OpKind::from_code(sym & 3).ok_or("bad op")?;
    r.clear_parts();
    let a = read_anchor(st, rd, cur, max_v, max_f, 4, "edge split")?;
    // Either star off the fast path: the explicit record, then applied.
    let mut slow = |st: &mut MeshState,
                    rd: &mut [Reader; 5],
                    r: &mut QRecord,
                    sc: &mut DecodeScratch,
                    link: usize,
                    kept: Kept|
     -> Result<(), String> {
        edge_split_after_link(st, rd, a, link, major, r, sc)?;
        st.apply_delta_logged(r, moved, rw);
        keep(r, kept);
        Ok(())
    };
    if !st.star_fast_into(a, &mut sc.fast[0]) {
        let ka = crate::edge_split::anchor_star(st, a, &mut sc.edge)? as u64;
        let link = rd[CONN].u_max(ka - 1, "edge-split link index")? as usize;
        return slow(st, rd, r, sc, link, kept);
    }
    let link = rd[CONN].u_max(sc.fast[0].n as u64 - 1, "edge-split link index")? as usize;
    let d = sc.fast[0].nx[link];
    if !st.star_fast_into(d, &mut sc.fast[1]) {
        sc.fast[0].write_into(&mut sc.edge.stars[0]);
        return slow(st, rd, r, sc, link, kept);
    }
    let [sa, sd] = &sc.fast;
    // `A` in `D`'s link (the fast path's links are distinct).
    let live = (1u32 << sd.n) - 1;
    let hit = eq_mask8(&sd.nx, a) & live;
    if hit == 0 {
        return Err(format!("edge split: vertex {a} is not in the link of {d}"));
    }
    let rda = hit.trailing_zeros() as usize;
    let (ends, rho, fs) = if a < d {
        ([a, d], [link, rda], [sa, sd])
    } else {
        ([d, a], [rda, link], [sd, sa])
    };
    let (n1, m, p, ra) = edge_split_fields(rd, ends, [fs[0].n, fs[1].n], &mut sc.rots)?;
    let mut app = [[0u32; 4]; 4];
    let crate::edge_split::Scratch {
        pred,
        rws,
        sec,
        blocks,
        masks,
        ..
    } = &mut sc.edge;
    let (n, ns) = crate::edge_split::build_fast(
        st, ends, fs, rho, n1, m, p, ra, &sc.rots, pred, rws, sec, &mut app, blocks, masks,
    )?;
    // Every new vertex has a parallelogram of three old corners (`T_x`
    // for `U_{2x}`, the last fan quad for `U_{2x+1}`) and at most
    // 2 + INLINE quads are deferred, so `finish_edge_split` never falls
    // back to the scans, which would read `r`'s quads: the appended ones
    // are not even there (they go from `app` to the state and to `kept`).
    // (Written in place by `finish_edge_split`: returned by value, the
    // array made `decode_loop` 3-6 % slower at 0.8 % fewer instructions —
    // presumably its copy's 16-byte stores, which the 12-byte loads of
    // the codes straddle, defeating store forwarding; not measured with
    // hardware counters.)
    let mut new_pos_codes = [[0u32; 3]; 4];
    pred.finish_edge_split(st, r, major, &mut rd[POS], &mut new_pos_codes)?;
    st.apply_edge_split_parts(
        ends,
        blocks,
        &new_pos_codes,
        &sec[..ns],
        &rws[..n],
        masks,
        &app,
        rw,
    );
    if let Some((new_pos, appended)) = kept {
        // Element by element (`extend_from_slice` is a call to `memcpy`).
        for p in new_pos_codes {
            new_pos.push(p);
        }
        for q in app {
            appended.push(q);
        }
    }
    Ok(())
}

/// Decodes the body of a general-form (`local` false, spec §7.4) or
/// local-form (spec §7.7, neighbourhood faces in `sc.local`) record into
/// `r`: the two differ only in how moved vertices, rewritten slots and
/// explicit corners are named.
#[allow(clippy::too_many_arguments)]
fn decode_patch(
    st: &MeshState,
    rd: &mut [Reader; 5],
    cur: &mut Cursors,
    max_v: u32,
    max_f: u32,
    local: bool,
    major: u16,
    sc: &mut DecodeScratch,
    r: &mut QRecord,
) -> Result<(), String> {
    let DecodeScratch {
        marks,
        local: l,
        w,
        slots,
        extra,
        nf,
        one_pass,
        ..
    } = sc;
    let v0 = st.q.len() as u32;
    let f0 = st.quads.len() as u32;
    let n_new = rd[CONN].u_max((max_v - v0) as u64, "new vertex count")? as usize;
    let (max_moved, max_rw) = if local {
        (0, l.faces.len())
    } else {
        (v0 as usize, f0 as usize)
    };
    // The local form's vertex list is built only when the record indexes
    // it (a moved vertex or an explicit corner); it is never empty once
    // built (the anchor has a face).
    let n_moved = if local {
        let n = rd[CONN].u()?;
        if n > 0 && l.verts.is_empty() {
            st.local_verts_with(marks, l);
        }
        if n > l.verts.len() as u64 {
            return Err(format!(
                "moved vertex count = {n} exceeds {}",
                l.verts.len()
            ));
        }
        n as usize
    } else {
        rd[CONN].u_max(max_moved as u64, "moved vertex count")? as usize
    };
    let n_rw = rd[CONN].u_max(max_rw as u64, "rewritten face count")? as usize;
    let n_app = rd[CONN].u_max((max_f - f0) as u64, "appended face count")? as usize;
    let v1 = v0 + n_new as u32;
    slots.clear();
    if local {
        // Local form (spec §7.7): rewritten slots first, then the moved
        // vertices as indices into `W` (the old corners of those slots —
        // where most moved vertices are — then the rest of `U`).
        let mut next = 0u64;
        for t in 0..n_rw {
            let i = local_index(&mut rd[SLOTS], t, next, l.faces.len(), "rewritten face")?;
            next = i + 1;
            slots.push(l.faces[i as usize]);
        }
        if n_moved > 0 {
            // `W` is a permutation of `l.verts`, so its length is known
            // before it is built; its tail (the vertices that are not old
            // corners of rewritten slots) is built only as far as the
            // ascending indices reach — most moved vertices are in the head.
            let g = moved_vocabulary_head(st, slots, w, marks);
            let mut tail = l.verts.iter();
            let mut next = 0u64;
            for t in 0..n_moved {
                let i = local_index(&mut rd[SLOTS], t, next, l.verts.len(), "moved vertex")?;
                next = i + 1;
                while w.len() <= i as usize {
                    let &u = tail.next().ok_or("moved-vertex vocabulary too short")?;
                    if marks.v[u as usize] != g {
                        w.push(u);
                    }
                }
                let v = w[i as usize];
                let p = add_residual(st.q[v as usize], &mut rd[POS], st.qmax)?;
                r.moved.push((v, p));
            }
            r.moved.sort_unstable_by_key(|mv| mv.0);
        }
    } else {
        for _ in 0..n_moved {
            let d = rd[REFS].s()?;
            let v = vref(cur.vref, d, v0, "moved vertex")?;
            if r.moved.last().is_some_and(|&(p, _)| p >= v) {
                return Err(format!(
                    "moved vertex {v} is not in strictly ascending order"
                ));
            }
            cur.vref = v;
            let p = add_residual(st.q[v as usize], &mut rd[POS], st.qmax)?;
            r.moved.push((v, p));
        }
        for t in 0..n_rw {
            let s = if t == 0 {
                (cur.slot as i64).saturating_add(rd[SLOTS].s()?)
            } else {
                let gap = rd[SLOTS].u_max(f0 as u64, "slot gap")? as i64;
                slots.last().map_or(0, |&p: &u32| p as i64) + 1 + gap
            };
            if s < 0 || s >= f0 as i64 {
                return Err(format!("rewrites slot {s} but only {f0} faces exist"));
            }
            slots.push(s as u32);
        }
        if let Some(&s) = slots.last() {
            cur.slot = s;
        }
    }
    extra.clear();
    let slots: &[u32] = slots;
    let mut corner = |rd: &mut [Reader; 5], cur: &mut Cursors| -> Result<u32, String> {
        let x = rd[CONN].u()?;
        if x == 0 {
            let v = if local {
                if l.verts.is_empty() {
                    st.local_verts_with(marks, l);
                }
                let i = rd[SLOTS].u_max(l.verts.len() as u64 - 1, "local corner index")?;
                l.verts[i as usize]
            } else {
                let v = vref(cur.vref, rd[REFS].s()?, v1, "face corner")?;
                cur.vref = v;
                v
            };
            extra.push(v);
            return Ok(v);
        }
        let idx = x - 1;
        if idx < n_new as u64 {
            return Ok(v0 + idx as u32);
        }
        let idx = idx - n_new as u64;
        if idx < 4 * n_rw as u64 {
            let s = slots[(idx / 4) as usize];
            return Ok(st.quads[s as usize][(idx % 4) as usize]);
        }
        let idx = idx - 4 * n_rw as u64;
        extra
            .get(idx as usize)
            .copied()
            .ok_or_else(|| format!("corner code {x} out of range"))
    };
    // The local form's mask also carries a rotation (bits 4-5): the
    // coarsener may restore a face starting at another corner, and naming
    // all four corners again would cost far more than two bits.
    let max_mask = if local { 63 } else { 15 };
    for &s in slots {
        let mask = rd[CONN].u_max(max_mask, "corner mask")?;
        let mut q = st.quads[s as usize];
        for (c, qc) in q.iter_mut().enumerate() {
            if mask & (1 << c) != 0 {
                *qc = corner(rd, cur)?;
            }
        }
        let q = rotl(q, (mask >> 4) as u8);
        check_distinct(&q, || format!("rewritten slot {s}"))?;
        r.rewritten.push((s, q));
    }
    for a in 0..n_app {
        let mut q = [0u32; 4];
        for qc in q.iter_mut() {
            *qc = corner(rd, cur)?;
        }
        check_distinct(&q, || format!("appended face {a}"))?;
        r.appended.push(q);
    }
    // Few new vertices (most records): each found by a scan of the record
    // quads; the lists are built only for the others (at most `SCAN_NEW`
    // scans per record, so a hostile record stays linear).
    const SCAN_NEW: usize = 8;
    if n_new <= ONE_PASS_NEW && major >= 2 && r.moved.is_empty() {
        return decode_new_positions(st, r, n_new, major, &mut rd[POS], one_pass);
    }
    let mut built = false;
    for t in 0..n_new {
        let x = v0 + t as u32;
        let scanned = (n_new <= SCAN_NEW).then(|| predict_scan(st, r, v0, x, major));
        let pred = match scanned {
            Some(p) => p,
            None => {
                if !built {
                    nf.build(r, v0, n_new);
                    built = true;
                }
                predict(st, r, v0, x, major, nf)
            }
        };
        let p = add_residual(pred, &mut rd[POS], st.qmax)?;
        r.new_pos.push(p);
    }
    Ok(())
}

/// The local form's vocabulary for moved vertices (spec §7.7): the distinct
/// corners of the old quads of the rewritten `slots` (in slot order, corners
/// 0..3), then the other vertices of `l.verts`, ascending — a permutation of
/// `l.verts` (rewritten slots lie in `l.faces`).
fn moved_vocabulary(
    st: &MeshState,
    slots: &[u32],
    l: &Local,
    w: &mut Vec<u32>,
    in_head: &mut Vec<bool>,
) {
    // Membership by position in the sorted `l.verts` (binary search), so a
    // hostile record with thousands of rewritten slots stays O(n log n).
    in_head.clear();
    in_head.resize(l.verts.len(), false);
    w.clear();
    for &s in slots {
        for &v in &st.quads[s as usize] {
            if let Ok(k) = l.verts.binary_search(&v) {
                if !in_head[k] {
                    in_head[k] = true;
                    w.push(v);
                }
            }
        }
    }
    w.extend(
        l.verts
            .iter()
            .zip(in_head.iter())
            .filter(|(_, &h)| !h)
            .map(|(&v, _)| v),
    );
}

/// The head of [`moved_vocabulary`]'s `W` for the decoder: the distinct
/// old corners of the rewritten `slots` into `w`, each stamped in
/// `marks.v` with the returned generation (stamps instead of binary
/// searches: O(corners) per record). The rest of `W` is the vertices of
/// `l.verts` without that stamp, ascending — the same list as
/// [`moved_vocabulary`], because every old corner of a rewritten slot is in
/// `l.verts` (the slots are taken from `l.faces`, whose corners `l.verts` are).
fn moved_vocabulary_head(
    st: &MeshState,
    slots: &[u32],
    w: &mut Vec<u32>,
    marks: &mut Marks,
) -> u32 {
    let g = marks.next_v_gen(st.q.len());
    w.clear();
    for &s in slots {
        for &v in &st.quads[s as usize] {
            if marks.v[v as usize] != g {
                marks.v[v as usize] = g;
                w.push(v);
            }
        }
    }
    g
}

/// Reads the `t`-th ascending local index from `rd` (the first as is, the
/// next ones as gaps after `next`), which must be `< len`.
fn local_index(
    rd: &mut Reader,
    t: usize,
    next: u64,
    len: usize,
    what: &str,
) -> Result<u64, String> {
    let i = if t == 0 {
        rd.u()?
    } else {
        next.saturating_add(rd.u()?)
    };
    if i >= len as u64 {
        return Err(format!("{what} local index {i} outside 0..{len}"));
    }
    Ok(i)
}

/// The split-form parameters `(m, i, e, rot, moved)` that reproduce `r`
/// exactly, if any.
struct SplitParams {
    m: u32,
    star: Star,
    i: usize,
    j: usize,
    rot: usize,
}

fn split_params(st: &MeshState, r: &QRecord) -> Option<SplitParams> {
    if r.new_pos.len() != 1 || r.appended.len() != 1 {
        return None;
    }
    let v0 = st.q.len() as u32;
    let quad = r.appended[0];
    let kc = quad.iter().position(|&x| x == v0)?;
    let km = (kc + 2) % 4;
    let m = quad[km];
    if m >= v0 || r.moved.iter().any(|&(v, _)| v != m) {
        return None;
    }
    let rot = (4 - km) % 4;
    let (b, d) = (quad[(km + 3) % 4], quad[(km + 1) % 4]);
    let star = st.star(m).ok()?;
    let l = star.link.len();
    let i = star.link.iter().position(|&x| x == b)?;
    let j = star.link.iter().position(|&x| x == d)?;
    if i == j || l < 2 {
        return None;
    }
    let (rewritten, appended) = build_split(st, m, &star, i, j, rot).ok()?;
    (rewritten == r.rewritten && appended == quad).then_some(SplitParams { m, star, i, j, rot })
}

/// Which rules and record forms [`encode_record`] may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coding {
    /// Major version of the file (1: the 1.x rules — no face-split form,
    /// version-1 prediction; 2: spec §7.6's multi-parallelogram prediction
    /// and the face-split form).
    pub major: u16,
    /// Try the split form (§7.5).
    pub split: bool,
    /// Try the face-split form (§7.9; ignored when `major < 2`).
    pub face_split: bool,
    /// Try the local form (§7.7).
    pub local: bool,
    /// Try the edge-split form (§7.10; ignored when `major < 3`).
    pub edge_split: bool,
    /// Try the face-split form before the split form. Both can fit one
    /// record: a doublet removal's inverse whose quads start where the
    /// split form builds them (turning quads, as `CornerOrder::Diagonal`
    /// and `Canonical` do, can make it so). The
    /// face split names one quad by its rank among the anchor's where the
    /// split names two wings, and it decodes with no star walk
    /// (session 22: `canonical` files 0.7–1.6 % smaller on the six bench
    /// meshes, decoding 0.1–0.5 % fewer instructions). Off by default, so
    /// that the files of [`crate::CornerOrder::Input`] stay as they were.
    pub face_split_first: bool,
}

impl Default for Coding {
    /// Version 3, every form, the split form first.
    fn default() -> Self {
        Coding {
            major: 3,
            split: true,
            face_split: true,
            local: true,
            edge_split: true,
            face_split_first: false,
        }
    }
}

/// Writes `r` in the face-split form (spec §7.9) if it is one, and tells
/// its two quads' rotation fields in `built` (see
/// [`encode_record_rotations`]); `false`, with nothing written, if not.
fn put_face_split(
    st: &MeshState,
    r: &QRecord,
    cur: &mut Cursors,
    s: &mut [Vec<u8>; 5],
    built: &mut Vec<(u32, u8)>,
    major: u16,
) -> bool {
    let Some((m, x, rot_bits)) = face_split_params(st, r, cur) else {
        return false;
    };
    let (v0, f0) = (st.q.len() as u32, st.quads.len() as u32);
    built.push((r.rewritten[0].0, (rot_bits >> 4) & 3));
    built.push((f0, rot_bits >> 6));
    s[OPS].push(r.op as u8 | (3 << 2) | rot_bits);
    put_s(&mut s[REFS], m as i64 - cur.vref as i64);
    cur.vref = m;
    put_u(&mut s[CONN], x);
    let mut partial = r.clone();
    partial.new_pos.clear();
    let mut nf = NewFaces::default();
    nf.build(&partial, v0, 1);
    put_residual(
        &mut s[POS],
        predict(st, &partial, v0, v0, major, &nf),
        r.new_pos[0],
    );
    true
}

/// The face-split parameters `(m, x, sym bits 4–7)` that reproduce `r`
/// exactly (spec §7.9), with the anchor `m` among the corners of the
/// rewritten slot's old quad whose reference and index take the fewest
/// bytes; `None` when the record is not a face split.
fn face_split_params(st: &MeshState, r: &QRecord, cur: &Cursors) -> Option<(u32, u64, u8)> {
    if r.new_pos.len() != 1
        || !r.moved.is_empty()
        || r.rewritten.len() != 1
        || r.appended.len() != 1
    {
        return None;
    }
    let (s, want_x) = r.rewritten[0];
    let want_y = r.appended[0];
    let rotation = |q: [u32; 4], want: [u32; 4]| {
        (0..4u8).find(|&rot| [0, 1, 2, 3].map(|i| q[(i + rot as usize) % 4]) == want)
    };
    let mut best: Option<(usize, (u32, u64, u8))> = None;
    let mut slots = Vec::new();
    for m in st.quads[s as usize] {
        if st.slots_at(m, &mut slots).is_err() {
            continue;
        }
        let Ok(t) = slots.binary_search(&s) else {
            continue;
        };
        for swap in [false, true] {
            let (x, y) = build_face_split(st, m, s, swap, 0);
            let (Some(rx), Some(ry)) = (rotation(x, want_x), rotation(y, want_y)) else {
                continue;
            };
            let code = 2 * t as u64 + swap as u64;
            let cost = varint_len(zigzag(m as i64 - cur.vref as i64)) + varint_len(code);
            if !matches!(best, Some((c, _)) if c <= cost) {
                best = Some((cost, (m, code, rx << 4 | ry << 6)));
            }
        }
    }
    best.map(|b| b.1)
}

/// Bytes of the LEB128 varint of `v`.
fn varint_len(v: u64) -> usize {
    (64 - (v | 1).leading_zeros() as usize).div_ceil(7)
}

/// Zigzag of `v` (spec §1).
fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

/// Encodes `r` (normalized: moved ids and rewritten slots strictly
/// ascending, indices valid against `st`) into `s` under the rules of
/// `coding`. Uses the split form when allowed and it reproduces `r`
/// exactly; else the face-split form likewise; else, when allowed, the
/// local form (spec §7.7) with the anchor that writes the fewest bytes, if
/// that is no larger than the general form. The edge-split form (version 3)
/// is tried after the face split and before the local form. Returns the
/// form used (spec §7.3: 0 general, 1 split, 2 local, 3 face split, 4 edge
/// split).
pub fn encode_record(
    st: &MeshState,
    r: &QRecord,
    cur: &mut Cursors,
    s: &mut [Vec<u8>; 5],
    coding: Coding,
) -> u8 {
    encode_record_rotations(st, r, cur, s, coding, &mut Vec::new())
}

/// [`encode_record`] that also tells, in `built` (cleared first), each
/// quad the chosen form builds with a 2-bit rotation field, as `(slot,
/// rotation)`: the split form's appended quad, the face split's rewritten
/// and appended quads, the edge split's four appended quads and its fan
/// quads. Rotating such a quad by 2 before encoding changes only that
/// field, by 2 (what `crate::encoder`'s [`crate::CornerOrder::Diagonal`]
/// does), and rotating it by 1 or 3 only that field too (what
/// [`crate::CornerOrder::Canonical`] does, to make it 0) — except that a
/// face split's turned quads may then fit the split form, tried first
/// unless [`Coding::face_split_first`]. No other field depends on a quad's
/// first corner.
pub fn encode_record_rotations(
    st: &MeshState,
    r: &QRecord,
    cur: &mut Cursors,
    s: &mut [Vec<u8>; 5],
    coding: Coding,
    built: &mut Vec<(u32, u8)>,
) -> u8 {
    built.clear();
    let v0 = st.q.len() as u32;
    let f0 = st.quads.len() as u32;
    let op = r.op as u8;
    let major = coding.major;
    let mut nf = NewFaces::default();
    let face_split = coding.face_split && major >= 2;
    if face_split && coding.face_split_first && put_face_split(st, r, cur, s, built, major) {
        return 3;
    }
    if coding.split {
        if let Some(SplitParams { m, star, i, j, rot }) = split_params(st, r) {
            built.push((f0, rot as u8));
            let l = star.link.len();
            let m_old = st.q[m as usize];
            let a = r.moved.first().map_or(m_old, |mv| mv.1);
            let mut partial = r.clone();
            partial.new_pos.clear();
            nf.build(&partial, v0, 1);
            let by_quad = predict(st, &partial, v0, v0, major, &nf);
            let by_reflection = reflect(st, m_old, a);
            let c = r.new_pos[0];
            let use_reflection = residual_cost(by_reflection, c) < residual_cost(by_quad, c);
            let moved = !r.moved.is_empty();
            s[OPS].push(
                op | (1 << 2)
                    | ((rot as u8) << 4)
                    | if moved { 0x40 } else { 0 }
                    | if use_reflection { 0x80 } else { 0 },
            );
            put_s(&mut s[REFS], m as i64 - cur.vref as i64);
            cur.vref = m;
            put_u(&mut s[CONN], i as u64);
            put_u(&mut s[CONN], ((j + l - i - 1) % l) as u64);
            if moved {
                put_residual(&mut s[POS], predict_a(st, m, &star, i, j), a);
            }
            put_residual(
                &mut s[POS],
                if use_reflection {
                    by_reflection
                } else {
                    by_quad
                },
                c,
            );
            return 1;
        }
    }
    if face_split && put_face_split(st, r, cur, s, built, major) {
        return 3;
    }
    if coding.edge_split && major >= 3 {
        let mut sc = crate::edge_split::Scratch::default();
        if let Some(e) = crate::edge_split::derive(st, r, cur.vref, &mut sc) {
            let pf = crate::edge_split::PERMS[e.p % 24];
            for (i, &j) in pf.iter().enumerate() {
                built.push((f0 + j as u32, (e.ra >> (2 * i)) & 3));
            }
            built.extend(sc.fan_slots.iter().copied().zip(e.rots.iter().copied()));
            s[OPS].push(op | 0x10);
            put_s(&mut s[REFS], e.a as i64 - cur.vref as i64);
            cur.vref = e.a;
            put_u(&mut s[CONN], e.r as u64);
            for x in 0..2 {
                put_u(&mut s[CONN], e.n1[x] as u64);
                put_u(&mut s[CONN], e.m[x] as u64 - 1);
            }
            put_u(&mut s[CONN], e.p as u64);
            put_u(&mut s[CONN], e.ra as u64);
            for &t in &e.rots {
                put_u(&mut s[CONN], t as u64);
            }
            let mut partial = r.clone();
            partial.new_pos.clear();
            nf.build(&partial, v0, 4);
            for t in 0..4 {
                let pred = predict(st, &partial, v0, v0 + t as u32, major, &nf);
                put_residual(&mut s[POS], pred, r.new_pos[t]);
                partial.new_pos.push(r.new_pos[t]);
            }
            return 4;
        }
    }
    if coding.local {
        let mut best: Option<([Vec<u8>; 5], Cursors)> = None;
        let mut best_len = usize::MAX;
        for m in local_candidates(st, r) {
            let Ok(local) = st.local(m) else { continue };
            let mut tmp: [Vec<u8>; 5] = Default::default();
            let mut c2 = *cur;
            tmp[OPS].push(op | (2 << 2));
            put_s(&mut tmp[REFS], m as i64 - c2.vref as i64);
            c2.vref = m;
            if !encode_patch(st, r, &mut c2, &mut tmp, Some(&local), major) {
                continue;
            }
            let len: usize = tmp.iter().map(|x| x.len()).sum();
            if len < best_len {
                best_len = len;
                best = Some((tmp, c2));
            }
        }
        let mut tmp: [Vec<u8>; 5] = Default::default();
        let mut c2 = *cur;
        tmp[OPS].push(op);
        encode_patch(st, r, &mut c2, &mut tmp, None, major);
        let len: usize = tmp.iter().map(|x| x.len()).sum();
        let (form, (tmp, c2)) = match best {
            Some(b) if best_len <= len => (2, b),
            _ => (0, (tmp, c2)),
        };
        for t in 0..5 {
            s[t].extend_from_slice(&tmp[t]);
        }
        *cur = c2;
        return form;
    }
    s[OPS].push(op);
    encode_patch(st, r, cur, s, None, major);
    0
}

/// Anchors worth trying for the local form of `r`: the old corners of its
/// rewritten slots, else its moved vertices, else the existing corners of
/// its appended quads (at most 16, ascending).
fn local_candidates(st: &MeshState, r: &QRecord) -> Vec<u32> {
    let v0 = st.q.len() as u32;
    let mut c: Vec<u32> = r
        .rewritten
        .iter()
        .flat_map(|&(slot, _)| st.quads[slot as usize])
        .collect();
    if c.is_empty() {
        c = r.moved.iter().map(|m| m.0).collect();
    }
    if c.is_empty() {
        c = r
            .appended
            .iter()
            .flatten()
            .copied()
            .filter(|&v| v < v0)
            .collect();
    }
    c.sort_unstable();
    c.dedup();
    c.truncate(16);
    c
}

/// Writes the body of a general-form (`local = None`, spec §7.4) or
/// local-form (spec §7.7) record — everything after the symbol and, for the
/// local form, the anchor. Returns false (having written partial data) when
/// the local form cannot name one of the record's slots or vertices.
fn encode_patch(
    st: &MeshState,
    r: &QRecord,
    cur: &mut Cursors,
    s: &mut [Vec<u8>; 5],
    local: Option<&Local>,
    major: u16,
) -> bool {
    let v0 = st.q.len() as u32;
    let n_new = r.new_pos.len();
    let n_rw = r.rewritten.len();
    for n in [n_new, r.moved.len(), n_rw, r.appended.len()] {
        put_u(&mut s[CONN], n as u64);
    }
    if let Some(l) = local {
        let mut next = 0;
        for &(slot, _) in &r.rewritten {
            let Ok(i) = l.faces.binary_search(&slot) else {
                return false;
            };
            put_u(&mut s[SLOTS], (i - next) as u64);
            next = i + 1;
        }
        if !r.moved.is_empty() {
            let slots: Vec<u32> = r.rewritten.iter().map(|rw| rw.0).collect();
            let (mut w, mut in_head) = (Vec::new(), Vec::new());
            moved_vocabulary(st, &slots, l, &mut w, &mut in_head);
            let mut idx = Vec::with_capacity(r.moved.len());
            for &(v, p) in &r.moved {
                let Some(i) = w.iter().position(|&x| x == v) else {
                    return false;
                };
                idx.push((i, v, p));
            }
            idx.sort_unstable_by_key(|e| e.0);
            next = 0;
            for &(i, v, p) in &idx {
                put_u(&mut s[SLOTS], (i - next) as u64);
                next = i + 1;
                put_residual(&mut s[POS], st.q[v as usize], p);
            }
        }
    } else {
        for &(v, p) in &r.moved {
            put_s(&mut s[REFS], v as i64 - cur.vref as i64);
            cur.vref = v;
            put_residual(&mut s[POS], st.q[v as usize], p);
        }
        for (t, &(slot, _)) in r.rewritten.iter().enumerate() {
            if t == 0 {
                put_s(&mut s[SLOTS], slot as i64 - cur.slot as i64);
            } else {
                put_u(&mut s[SLOTS], (slot - r.rewritten[t - 1].0 - 1) as u64);
            }
        }
        if let Some(&(slot, _)) = r.rewritten.last() {
            cur.slot = slot;
        }
    }
    // Corner vocabulary: new vertices, old corners of rewritten slots, then
    // explicitly coded vertices (first occurrence wins).
    let mut vocab: HashMap<u32, u64> = HashMap::new();
    for (t, &(slot, _)) in r.rewritten.iter().enumerate() {
        for (c, &v) in st.quads[slot as usize].iter().enumerate() {
            vocab.entry(v).or_insert((n_new + 4 * t + c) as u64);
        }
    }
    let mut n_extra = 0u64;
    let mut corner = |v: u32, s: &mut [Vec<u8>; 5], cur: &mut Cursors| -> bool {
        if v >= v0 && ((v - v0) as usize) < n_new {
            put_u(&mut s[CONN], 1 + (v - v0) as u64);
        } else if let Some(&idx) = vocab.get(&v) {
            put_u(&mut s[CONN], 1 + idx);
        } else {
            put_u(&mut s[CONN], 0);
            if let Some(l) = local {
                let Ok(i) = l.verts.binary_search(&v) else {
                    return false;
                };
                put_u(&mut s[SLOTS], i as u64);
            } else {
                put_s(&mut s[REFS], v as i64 - cur.vref as i64);
                cur.vref = v;
            }
            vocab.insert(v, (n_new + 4 * n_rw) as u64 + n_extra);
            n_extra += 1;
        }
        true
    };
    for &(slot, q) in &r.rewritten {
        let old = st.quads[slot as usize];
        // Local form: the rotation that keeps the most old corners.
        let rot = if local.is_some() {
            (0..4)
                .min_by_key(|&rot| (0..4).filter(|&j| q[(j + 4 - rot) % 4] != old[j]).count())
                .unwrap_or(0)
        } else {
            0
        };
        let q = [0, 1, 2, 3].map(|j| q[(j + 4 - rot) % 4]);
        let mask = (0..4)
            .filter(|&c| q[c] != old[c])
            .fold(0u64, |m, c| m | 1 << c);
        put_u(&mut s[CONN], mask | (rot as u64) << 4);
        for (c, &v) in q.iter().enumerate() {
            if mask & (1 << c) != 0 && !corner(v, s, cur) {
                return false;
            }
        }
    }
    for q in &r.appended {
        for &v in q {
            if !corner(v, s, cur) {
                return false;
            }
        }
    }
    let mut partial = r.clone();
    partial.new_pos.clear();
    let mut nf = NewFaces::default();
    nf.build(&partial, v0, n_new);
    for t in 0..n_new {
        let pred = predict(st, &partial, v0, v0 + t as u32, major, &nf);
        put_residual(&mut s[POS], pred, r.new_pos[t]);
        partial.new_pos.push(r.new_pos[t]);
    }
    true
}

/// Concatenates the five streams, each prefixed by its LEB128 length.
pub fn join_streams(s: &[Vec<u8>; 5]) -> Vec<u8> {
    join_streams_at(s).0
}

/// [`join_streams`], with where each stream (its length varint first)
/// starts in the payload; entry 5 is the payload's length.
pub fn join_streams_at(s: &[Vec<u8>; 5]) -> (Vec<u8>, [usize; 6]) {
    let mut out = Vec::with_capacity(s.iter().map(|x| x.len() + 5).sum());
    let mut starts = [0; 6];
    for (t, x) in s.iter().enumerate() {
        put_u(&mut out, x.len() as u64);
        out.extend_from_slice(x);
        starts[t + 1] = out.len();
    }
    (out, starts)
}

/// Splits a chunk payload into its five streams.
pub fn split_streams(buf: &[u8]) -> Result<[Reader<'_>; 5], String> {
    let mut r = Reader::new(buf, "payload");
    let mut parts: [&[u8]; 5] = [&[]; 5];
    for (k, part) in parts.iter_mut().enumerate() {
        let n = r.u()?;
        let n = usize::try_from(n).map_err(|_| "stream length too large".to_string())?;
        *part = r
            .bytes(n)
            .map_err(|_| format!("stream {} is longer than the payload", STREAM_NAMES[k]))?;
    }
    if r.remaining() != 0 {
        return Err(format!("{} bytes after the last stream", r.remaining()));
    }
    Ok([0, 1, 2, 3, 4].map(|k| Reader::new(parts[k], STREAM_NAMES[k])))
}

/// Base mesh payload (spec §6): corners as zigzag deltas of the previous
/// corner, then codes as zigzag deltas of the previous vertex.
pub fn encode_base(q: &[[u32; 3]], quads: &[[u32; 4]]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut prev = 0i64;
    for quad in quads {
        for &v in quad {
            put_s(&mut out, v as i64 - prev);
            prev = v as i64;
        }
    }
    let mut pp = [0i64; 3];
    for p in q {
        for t in 0..3 {
            put_s(&mut out, p[t] as i64 - pp[t]);
            pp[t] = p[t] as i64;
        }
    }
    out
}

/// Decodes a base payload with `nv` vertices and `nf` quads.
pub fn decode_base(buf: &[u8], nv: u32, nf: u32, qmax: u32) -> Result<MeshState, String> {
    // Every corner and every coordinate takes at least one byte: check the
    // claimed counts against the payload before allocating.
    if (nf as u64) * 4 + (nv as u64) * 3 > buf.len() as u64 {
        return Err(format!(
            "{nv} vertices and {nf} faces cannot fit in {} bytes",
            buf.len()
        ));
    }
    let mut r = Reader::new(buf, "base");
    let mut quads = Vec::with_capacity(nf as usize);
    let mut prev = 0i64;
    for f in 0..nf {
        let mut q = [0u32; 4];
        for qc in q.iter_mut() {
            let v = prev.saturating_add(r.s()?);
            if v < 0 || v >= nv as i64 {
                return Err(format!(
                    "face {f} references vertex {v} but only {nv} vertices exist"
                ));
            }
            *qc = v as u32;
            prev = v;
        }
        check_distinct(&q, || format!("face {f}"))?;
        quads.push(q);
    }
    let mut pos = Vec::with_capacity(nv as usize);
    let mut pp = [0u32; 3];
    for _ in 0..nv {
        pp = add_residual(pp, &mut r, qmax)?;
        pos.push(pp);
    }
    if r.remaining() != 0 {
        return Err(format!("{} unused bytes at the end", r.remaining()));
    }
    Ok(MeshState::new(qmax, pos, quads))
}

#[cfg(test)]
mod tests {
    use super::{
        build_face_split, copy8, decode_new_positions, floor_div, one_corner, predict,
        predict_face_split, predict_scan, rank_mask8, sort_distinct, swap_quad, MeshState,
        NewFaces, OnePass, QRecord, Star, INLINE, MAX_SPLIT_STAR, STAR_SMALL,
    };
    use crate::varint::{put_s, Reader};
    use pqm_core::OpKind;
    use proptest::prelude::*;

    proptest! {
        /// The vector rank selection of the face split marks exactly the
        /// entry of `v[1..=n]` with `rank` smaller ones, as the scalar
        /// double loop it replaced, whatever the count word and the stale
        /// entries past `n` hold (ids across the whole `u32` range: the
        /// order is unsigned).
        #[test]
        fn rank_mask_selects_the_entry_of_that_rank(
            ids in proptest::collection::hash_set(any::<u32>(), 1..=INLINE),
            junk in any::<[u32; 8]>(),
            pick in any::<usize>(),
        ) {
            let ids: Vec<u32> = ids.into_iter().collect();
            let n = ids.len();
            let mut v = junk;
            v[1..=n].copy_from_slice(&ids);
            let rank = (pick % n) as u32;
            let mut want = 0u32;
            for (h, &c) in ids.iter().enumerate() {
                if ids.iter().filter(|&&o| o < c).count() as u32 == rank {
                    want |= 2 << h;
                }
            }
            prop_assert_eq!(want.count_ones(), 1);
            prop_assert_eq!(rank_mask8(&v, n, rank), want);
        }

        /// `floor_div` is `div_euclid` for every positive divisor.
        #[test]
        fn floor_div_is_div_euclid(s in any::<i64>(), n in 1i64..1000) {
            prop_assert_eq!(floor_div(s, n), s.div_euclid(n));
        }
    }

    /// A fan of `n` quads `[0, a_i, a_i + 1, a_{i+1}]` around vertex 0
    /// (closed, or open when `open`: the last quad left out), quad `i` in
    /// slot `(i * step) % n` (`step` coprime with `n`: the slot order is
    /// shuffled against the fan order). Returns the state and the slot of
    /// each fan quad.
    fn fan(n: u32, step: u32, open: bool) -> (MeshState, Vec<u32>) {
        let a = |i: u32| 1 + 2 * (i % n);
        let kept = if open { n - 1 } else { n };
        let slot_of: Vec<u32> = (0..kept).map(|i| (i * step) % n).collect();
        let mut order: Vec<u32> = slot_of.clone();
        order.sort_unstable();
        let mut quads = vec![[0u32; 4]; kept as usize];
        for i in 0..kept {
            // Dense slots 0..kept: rank of `slot_of[i]` among the kept ones.
            let s = order.binary_search(&slot_of[i as usize]).unwrap_or(0);
            quads[s] = [0, a(i), a(i) + 1, a(i + 1)];
        }
        let dense: Vec<u32> = slot_of
            .iter()
            .map(|s| order.binary_search(s).unwrap_or(0) as u32)
            .collect();
        (
            MeshState::new(1, vec![[0; 3]; 1 + 2 * n as usize], quads),
            dense,
        )
    }

    /// The face split through the decoder's fused path
    /// (`decode_apply_face_split`, whose apply moves the rewritten quad's
    /// corners in place) leaves the same codes, quads and corners of every
    /// vertex as the explicit record applied, also where a corner of the
    /// rewritten quad belongs to a full block or one with an overflow list
    /// (the hub of a 7-, 8- or 9-face fan): every anchor, face index and
    /// diagonal, five rotation pairs, versions 2–4.
    #[test]
    fn fused_face_split_equals_explicit_at_a_full_hub() {
        use super::{decode_apply_record, decode_record, Cursors, DecodeScratch};
        use crate::varint::put_u;
        let mut n_ok = 0;
        for (n, step) in [(7u32, 3u32), (8, 3), (9, 2)] {
            let (st, _) = fan(n, step, false);
            let nv = st.q.len() as u32;
            let nf = st.quads.len() as u32;
            for m in 0..nv {
                let faces = st.valence(m) as u64;
                for x in 0..2 * faces {
                    for sym in [0x0cu8, 0x1d, 0x6c, 0xbd, 0xfc] {
                        for major in 2..=4u16 {
                            let mut b: [Vec<u8>; 5] = Default::default();
                            b[0].push(sym);
                            put_u(&mut b[1], x);
                            put_s(&mut b[2], m as i64);
                            for _ in 0..3 {
                                put_s(&mut b[4], 0);
                            }
                            let rd = || [0, 1, 2, 3, 4].map(|k| Reader::new(&b[k], "s"));
                            let want_r = decode_record(
                                &st,
                                &mut rd(),
                                &mut Cursors::default(),
                                nv + 1,
                                nf + 1,
                                major,
                            );
                            let mut got = st.clone();
                            let (mut moved, mut rw) = (Vec::new(), Vec::new());
                            let res = decode_apply_record(
                                &mut got,
                                &mut rd(),
                                &mut Cursors::default(),
                                nv + 1,
                                nf + 1,
                                major,
                                &mut QRecord::default(),
                                &mut DecodeScratch::new(),
                                &mut moved,
                                &mut rw,
                                None,
                            );
                            let r = match want_r {
                                Ok(r) => r,
                                Err(e) => {
                                    assert_eq!(res, Err(e));
                                    continue;
                                }
                            };
                            res.unwrap();
                            let mut want = st.clone();
                            want.apply(&r);
                            assert_eq!(got.q, want.q);
                            assert_eq!(got.quads, want.quads);
                            for v in 0..want.q.len() as u32 {
                                let mut a: Vec<_> = got.corners(v).collect();
                                let mut w: Vec<_> = want.corners(v).collect();
                                a.sort_unstable();
                                w.sort_unstable();
                                assert_eq!(a, w, "fan {n}, anchor {m}, x {x}, vertex {v}");
                            }
                            // The log entry gives the old quad back.
                            assert_eq!(rw.len(), 1);
                            let (slot, d) = rw[0];
                            let old = got.quads[slot as usize];
                            let old = [0, 1, 2, 3].map(|k| old[k] ^ d[k]);
                            assert_eq!(old, st.quads[slot as usize]);
                            n_ok += 1;
                        }
                    }
                }
            }
        }
        assert!(n_ok > 1000, "{n_ok} face splits");
    }

    /// The canonical star (spec §7.5) of a shuffled fan, on both sides of
    /// `star_into`'s on-stack limit and up to the split form's 255: an
    /// interior star starts at its smallest slot, a boundary one at the
    /// face without predecessor, and both go counter-clockwise.
    #[test]
    fn canonical_star_of_shuffled_fans() {
        for n in [3u32, 4, 15, 16, 17, 40, 254, 255] {
            let step = (1..n).rev().find(|s| gcd(*s, n) == 1).unwrap_or(1);
            for open in [false, true] {
                let (st, slot) = fan(n, step, open);
                let star = st.star(0).unwrap();
                let kept = slot.len();
                let first = if open {
                    0
                } else {
                    (0..kept).min_by_key(|&i| slot[i]).unwrap_or(0)
                };
                let want: Vec<u32> = (0..kept).map(|t| slot[(first + t) % kept]).collect();
                assert_eq!(star.faces, want, "n = {n}, open = {open}");
                let want_link: Vec<u32> = (0..kept + open as usize)
                    .map(|t| 1 + 2 * ((first + t) as u32 % n))
                    .collect();
                assert_eq!(star.link, want_link, "n = {n}, open = {open}");
            }
        }
        // One face more than the split form allows.
        let (st, _) = fan(MAX_SPLIT_STAR as u32 + 1, 1, false);
        let e = st.star(0).unwrap_err();
        assert!(e.contains("more than 255"), "{e}");
    }

    fn gcd(a: u32, b: u32) -> u32 {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }

    /// Prefetching is a hint: any index (in range, past the end, of an
    /// empty slice) is accepted and changes nothing; the look-ahead on
    /// arbitrary `refs` bytes and anchors (out of range too) never panics.
    #[test]
    fn prefetch_is_a_no_op_on_any_index() {
        // Past the size from which the decoder looks ahead.
        let n = super::PREFETCH_MIN_VERTICES as u32 / 2;
        let (st, _) = fan(n, 3, false);
        assert!(st.q.len() >= super::PREFETCH_MIN_VERTICES);
        let before = (st.q.clone(), st.quads.clone());
        for i in [0usize, 1, 7, 8, 1 << 20, usize::MAX] {
            super::prefetch(&st.quads, i);
            super::prefetch(&st.q, i);
            super::prefetch::<u32>(&[], i);
        }
        let bytes: Vec<u8> = (0..=255u8).collect();
        for start in 0..bytes.len() {
            let refs = crate::varint::Reader::new(&bytes[start..], "refs");
            let mut peek = crate::varint::Peek3::default();
            for m in [0u32, 1, 8, 16, 17, 2 * n, 2 * n + 1, u32::MAX] {
                st.prefetch_ahead(&refs, m, &mut peek);
            }
        }
        assert_eq!((st.q.clone(), st.quads.clone()), before);
        check_corners(&st).unwrap();
    }

    /// Quads with four distinct corners below `nv`, from arbitrary words.
    fn quads_from(nv: u32, words: &[[u32; 4]]) -> Vec<[u32; 4]> {
        words
            .iter()
            .filter_map(|w| {
                let q = w.map(|x| x % nv);
                let distinct = (0..4).all(|a| (a + 1..4).all(|b| q[a] != q[b]));
                distinct.then_some(q)
            })
            .collect()
    }

    /// Both star builders on every vertex of `st`: the same faces and link,
    /// or the same error.
    fn same_stars(st: &MeshState) -> Result<(), TestCaseError> {
        let (mut fast, mut general) = (Star::default(), Star::default());
        for m in 0..st.q.len() as u32 + 1 {
            let a = st.star_into(m, &mut fast).map(|()| fast.clone());
            let b = st.star_general(m, &mut general).map(|()| general.clone());
            match (a, b) {
                (Ok(a), Ok(b)) => {
                    prop_assert_eq!(a.faces, b.faces, "vertex {}", m);
                    prop_assert_eq!(a.link, b.link, "vertex {}", m);
                }
                (Err(a), Err(b)) => prop_assert_eq!(a, b, "vertex {}", m),
                (a, b) => prop_assert!(false, "vertex {}: {:?} vs {:?}", m, a, b),
            }
        }
        Ok(())
    }

    /// Every vertex's corners, as the adjacency lists them and as the quads
    /// say (both sorted).
    fn check_corners(st: &MeshState) -> Result<(), TestCaseError> {
        let mut want = vec![Vec::new(); st.q.len()];
        for (s, q) in st.quads.iter().enumerate() {
            for (k, &v) in q.iter().enumerate() {
                want[v as usize].push((s as u32, k));
            }
        }
        for (v, w) in want.iter().enumerate() {
            let mut got: Vec<(u32, usize)> = st.corners(v as u32).collect();
            got.sort_unstable();
            prop_assert_eq!(&got, w, "vertex {}", v);
            prop_assert_eq!(st.valence(v as u32), w.len());
        }
        Ok(())
    }

    proptest! {
        /// The corner blocks and their overflow lists always hold exactly
        /// the corners of the quads: random rewrites, appends and undos on
        /// a few vertices, so that many are in more than `INLINE` faces
        /// (blocks fill, overflow, drain and refill).
        #[test]
        fn corner_lists_follow_rewrites_and_undo(
            nv in 5u32..9,
            words in proptest::collection::vec(any::<[u32; 4]>(), 0..40),
            steps in proptest::collection::vec((any::<u32>(), any::<[u32; 4]>(), 0u8..4), 0..60),
        ) {
            let mut st = MeshState::new(1, vec![[0; 3]; nv as usize], quads_from(nv, &words));
            check_corners(&st)?;
            for (pick, w, kind) in steps {
                let Some(&q) = quads_from(st.q.len() as u32, &[w]).first() else { continue };
                let nf = st.quads.len() as u32;
                if kind == 0 || nf == 0 {
                    // Append two quads and one vertex, then maybe undo.
                    let r = QRecord {
                        op: OpKind::QvMerge,
                        new_pos: vec![[0; 3]],
                        moved: Vec::new(),
                        rewritten: Vec::new(),
                        appended: vec![q, [st.q.len() as u32, q[0], q[1], q[2]]],
                    };
                    let (v0, f0) = (st.q.len(), st.quads.len());
                    let (mut mv, mut rw) = (Vec::new(), Vec::new());
                    st.apply_delta_logged(&r, &mut mv, &mut rw);
                    check_corners(&st)?;
                    if pick % 2 == 0 {
                        st.undo_deltas(v0, f0, &mv, &rw);
                    }
                } else {
                    // Rewrite one slot, logged, and undo it half the time.
                    let s = pick % nf;
                    let r = QRecord {
                        op: OpKind::QvMerge,
                        new_pos: Vec::new(),
                        moved: Vec::new(),
                        rewritten: vec![(s, q)],
                        appended: Vec::new(),
                    };
                    let (v0, f0) = (st.q.len(), st.quads.len());
                    let (mut mv, mut rw) = (Vec::new(), Vec::new());
                    st.apply_delta_logged(&r, &mut mv, &mut rw);
                    check_corners(&st)?;
                    if kind == 1 {
                        st.undo_deltas(v0, f0, &mv, &rw);
                    }
                }
                check_corners(&st)?;
            }
        }

        /// The stack star (short scans of `u32` arrays) equals the general one
        /// on random quads over a few vertices — mostly not fans, with
        /// repeated links, several fans and stars past `STAR_SMALL` — and on
        /// shuffled fans (closed and open) with random extra quads.
        #[test]
        fn fast_star_equals_general(
            nv in 4u32..9,
            words in proptest::collection::vec(any::<[u32; 4]>(), 0..40),
            n in 3u32..(STAR_SMALL as u32 + 3),
            step in 1u32..40,
            open in any::<bool>(),
            extra in proptest::collection::vec(any::<[u32; 4]>(), 0..4),
        ) {
            let quads = quads_from(nv, &words);
            same_stars(&MeshState::new(1, vec![[0; 3]; nv as usize], quads))?;
            let step = (step..step + n).find(|s| gcd(*s % n, n) == 1).unwrap_or(1) % n;
            let (st, _) = fan(n, step.max(1), open);
            // A closed fan within a block takes the fast path.
            prop_assert_eq!(st.star_fast(0).is_some(), !open && n as usize <= INLINE);
            let mut quads = st.quads.to_vec();
            quads.extend(quads_from(st.q.len() as u32, &extra));
            same_stars(&MeshState::new(1, st.q.to_vec(), quads))?;
        }

        /// The rank sort agrees with the standard sort on distinct values,
        /// on both sides of its small-list limit.
        #[test]
        fn sort_distinct_sorts(set in proptest::collection::btree_set(any::<u32>(), 0..100)) {
            let mut want: Vec<u32> = set.into_iter().collect();
            // A fixed shuffle (reversed halves) so the input is not sorted.
            let mid = want.len() / 2;
            let mut x: Vec<u32> = want[mid..].iter().rev().chain(want[..mid].iter()).copied().collect();
            sort_distinct(&mut x);
            want.sort_unstable();
            prop_assert_eq!(x, want);
        }

        /// A `Paged` array reads as a map with a default, whatever the
        /// order of writes, and after `clone_from` (which keeps its own
        /// pool and directory) reads as its source.
        #[test]
        fn paged_reads_as_a_map(
            writes in proptest::collection::vec((0u32..2000, any::<u32>()), 0..200),
            other in proptest::collection::vec((0u32..2000, any::<u32>()), 0..200),
            big in 0u32..1 << 20,
        ) {
            let mut pg = super::Paged::<u32, 8>::new(super::NIL);
            let mut want = std::collections::BTreeMap::new();
            for &(i, v) in writes.iter().chain(&[(big, 7)]) {
                *pg.at(i) = v;
                want.insert(i, v);
            }
            let reads = |pg: &super::Paged<u32, 8>, want: &std::collections::BTreeMap<u32, u32>| {
                (0..2100).chain([big, big ^ 1, u32::MAX]).all(|i| pg.get(i) == *want.get(&i).unwrap_or(&super::NIL))
            };
            prop_assert!(reads(&pg, &want));
            let mut o = super::Paged::<u32, 8>::new(super::NIL);
            let mut want_o = std::collections::BTreeMap::new();
            for &(i, v) in &other {
                *o.at(i) = v;
                want_o.insert(i, v);
            }
            pg.clone_from(&o);
            prop_assert!(reads(&pg, &want_o));
            prop_assert!(reads(&o.clone(), &want_o));
            *pg.at(3) = 5;
            want_o.insert(3, 5);
            prop_assert!(reads(&pg, &want_o));
        }

        /// The register-built helpers equal their plain definitions:
        /// `one_corner` a zero quad with one corner set, `swap_quad` a
        /// `mem::replace` with the changed corners' mask, `copy8` a copy.
        #[test]
        fn register_helpers_equal_plain_code(
            k in 0usize..4,
            x in any::<u32>(),
            a in any::<[u32; 4]>(),
            b in any::<[u32; 4]>(),
            same in any::<u8>(),
            c in any::<[u32; 8]>(),
        ) {
            let mut want = [0u32; 4];
            want[k] = x;
            prop_assert_eq!(one_corner(k, x), want);
            // Some corners equal, so the mask has both kinds of bit.
            let b: [u32; 4] = std::array::from_fn(|i| if same >> i & 1 != 0 { a[i] } else { b[i] });
            let mut slot = a;
            let (old, new, changed) = swap_quad(&mut slot, b);
            let mask = (0..4).filter(|&i| a[i] != b[i]).fold(0u32, |m, i| m | 1 << i);
            prop_assert_eq!((old, new, changed, slot), (a, b, mask, b));
            prop_assert_eq!(copy8(c), c);
        }
    }

    /// The 3 × 3 patch around a new centre vertex: the ring `E, NE, N, NW,
    /// W, SW, S, SE` (ids 0–7, counter-clockwise) on a bumped surface, and
    /// a record appending the centre `x = 8` in four quads `[x, E, NE, N]`,
    /// `[x, N, NW, W]`, `[x, W, SW, S]`, `[x, S, SE, E]` (`x` at corner 0:
    /// `n1` the first edge neighbour, `o` the diagonal, `n3` the second).
    fn bump() -> (MeshState, QRecord) {
        let ring = vec![
            [300, 200, 340], // E
            [300, 300, 290], // NE
            [200, 300, 345], // N
            [100, 300, 280], // NW
            [100, 200, 338], // W
            [100, 100, 287], // SW
            [200, 100, 342], // S
            [300, 100, 291], // SE
        ];
        let st = MeshState::new(1023, ring, Vec::new());
        let r = QRecord {
            appended: vec![[8, 0, 1, 2], [8, 2, 3, 4], [8, 4, 5, 6], [8, 6, 7, 0]],
            ..QRecord::default()
        };
        (st, r)
    }

    /// Every path of the decoder's general form on `r`'s new vertices,
    /// all residuals 0: the predictions themselves. [`predict_scan`],
    /// [`predict`] (the lists) and [`OnePass`] (`decode_new_positions`)
    /// must agree; returns the first's.
    fn all_paths(st: &MeshState, r: &QRecord, n_new: usize, major: u16) -> Vec<[u32; 3]> {
        let v0 = st.q.len() as u32;
        let (mut scan, mut listed) = (r.clone(), r.clone());
        let mut nf = NewFaces::default();
        nf.build(r, v0, n_new);
        for t in 0..n_new as u32 {
            let p = predict_scan(st, &scan, v0, v0 + t, major);
            scan.new_pos.push(p);
            let p = predict(st, &listed, v0, v0 + t, major, &nf);
            listed.new_pos.push(p);
        }
        assert_eq!(
            scan.new_pos, listed.new_pos,
            "scan and lists, version {major}"
        );
        if major >= 2 {
            let mut buf = Vec::new();
            for _ in 0..3 * n_new {
                put_s(&mut buf, 0);
            }
            let mut one = r.clone();
            let mut rd = Reader::new(&buf, "pos");
            decode_new_positions(st, &mut one, n_new, major, &mut rd, &mut OnePass::default())
                .unwrap();
            assert_eq!(
                scan.new_pos, one.new_pos,
                "scan and one pass, version {major}"
            );
        }
        scan.new_pos
    }

    /// Spec §7.6 by hand on [`bump`]: each edge neighbour is in two of the
    /// centre's quads and each diagonal in one, so per axis the sums are
    /// `2 E' − D'` over 4 quads (versions 2, 3) and `10 E' − 2 D'` over
    /// `8 · 4` (version 4), `E'` the sum of the edge neighbours
    /// (`x`: 800, `y`: 800, `z`: 340 + 345 + 338 + 342 = 1365) and `D'`
    /// of the diagonals (800, 800, 290 + 280 + 287 + 291 = 1148).
    #[test]
    fn version_4_stencil_by_hand_on_a_bump() {
        let (st, r) = bump();
        // z: (2730 − 1148) / 4 = 395.5; (13650 − 2296) / 32 = 354.8…
        assert_eq!(all_paths(&st, &r, 1, 2), vec![[200, 200, 395]]);
        assert_eq!(all_paths(&st, &r, 1, 3), vec![[200, 200, 395]]);
        assert_eq!(all_paths(&st, &r, 1, 4), vec![[200, 200, 354]]);
        // Version 1: the first quad's parallelogram E + N − NE.
        assert_eq!(all_paths(&st, &r, 1, 1), vec![[200, 200, 395]]);
        // One quad, `[x, E, NE, N]`: 5 (E + N) − 2 NE = (2500, 2500, 3425)
        // − (600, 600, 580), over 8: (237.5, 237.5, 355.6…).
        let one = QRecord {
            appended: vec![[8, 0, 1, 2]],
            ..QRecord::default()
        };
        assert_eq!(all_paths(&st, &one, 1, 4), vec![[237, 237, 355]]);
        assert_eq!(all_paths(&st, &one, 1, 2), vec![[200, 200, 395]]);
    }

    /// The stencil rounds toward −∞ and clamps to the grid: on a steep
    /// edge the sum goes negative (clamped to 0) or past `qmax`.
    #[test]
    fn version_4_stencil_floors_and_clamps() {
        // x = 3 in [x, 0, 1, 2]: n1 = 0, o = 1, n3 = 2.
        let st = MeshState::new(
            1023,
            vec![[0, 1000, 7], [900, 0, 0], [0, 1023, 9]],
            Vec::new(),
        );
        let r = QRecord {
            appended: vec![[3, 0, 1, 2]],
            ..QRecord::default()
        };
        // x: 5·0 − 1800 < 0 → 0; y: (5·2023 − 0) / 8 = 1264.4 → 1023;
        // z: (5·16 − 0) / 8 = 10.
        assert_eq!(all_paths(&st, &r, 1, 4), vec![[0, 1023, 10]]);
        // z with an odd sum: NE at 1 → (80 − 2) / 8 = 9.75 → 9.
        let mut st2 = st.clone();
        st2.q[1] = [900, 0, 1];
        assert_eq!(all_paths(&st2, &r, 1, 4), vec![[0, 1023, 9]]);
    }

    /// Two new vertices, the second in a quad with the first (known once
    /// decoded): version 4 sums the same quads as version 2, the first
    /// vertex's decoded code standing in for a corner of the second's.
    #[test]
    fn version_4_stencil_reads_earlier_new_vertices() {
        let (st, _) = bump();
        // A strip: x = 8 in `[8, 0, 1, 2]`, y = 9 in `[9, 8, 2, 3]` (its
        // n1 = x, o = N, n3 = NW).
        let r = QRecord {
            appended: vec![[8, 0, 1, 2], [9, 8, 2, 3]],
            ..QRecord::default()
        };
        let p = all_paths(&st, &r, 2, 4);
        assert_eq!(p[0], [237, 237, 355]);
        // y: 5 (x + NW) − 2 N = 5 (237 + 100, 237 + 300, 355 + 280)
        // − (400, 600, 690) = (1285, 2085, 2485), over 8: 160.6, 260.6,
        // 310.6.
        assert_eq!(p[1], [160, 260, 310]);
        let p2 = all_paths(&st, &r, 2, 2);
        // Version 2: x = E + N − NE = (200, 200, 395); y = x + NW − N.
        assert_eq!(p2, vec![[200, 200, 395], [100, 200, 330]]);
    }

    /// [`OnePass`] on random records of one to four new vertices whose
    /// quads mix old and new corners (up to four new ones a quad, new
    /// vertices as neighbours and as opposite corners of larger ones, some
    /// without a quad, enough quads to overflow the deferred list):
    /// the same predictions as the scans ([`all_paths`]), in versions 2–4.
    #[test]
    fn one_pass_equals_the_scans_on_random_records() {
        let (st, _) = bump();
        let v0 = st.q.len() as u32;
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        for _ in 0..3000 {
            let n_new = 1 + rnd(4) as u32;
            let n_quads = 1 + rnd(14) as usize;
            let mut r = QRecord::default();
            while r.appended.len() < n_quads {
                // Mostly new corners in some records, mostly old in others.
                let p_new = 1 + rnd(4);
                let quad = [0; 4].map(|_| {
                    if rnd(5) < p_new {
                        v0 + rnd(n_new as u64) as u32
                    } else {
                        rnd(v0 as u64) as u32
                    }
                });
                let distinct = (0..4).all(|a| (a + 1..4).all(|b| quad[a] != quad[b]));
                if distinct {
                    r.appended.push(quad);
                }
            }
            for major in 2..=4 {
                all_paths(&st, &r, n_new as usize, major);
            }
        }
    }

    /// The face split's closed form ([`predict_face_split`]) equals the
    /// scan of the record [`build_face_split`] makes, in versions 2–4, for
    /// every slot, corner, diagonal and rotation of a curved grid.
    #[test]
    fn face_split_closed_form_equals_the_scan() {
        // 4 × 4 vertices, 3 × 3 quads, pseudo-random codes.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let q: Vec<[u32; 3]> = (0..16)
            .map(|_| {
                [0; 3].map(|_| {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    (seed % 4096) as u32
                })
            })
            .collect();
        let v = |i: u32, j: u32| i + 4 * j;
        let mut quads = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                quads.push([v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        let st = MeshState::new(4095, q, quads);
        let mut differ = 0;
        for s in 0..9u32 {
            for m in st.quads[s as usize] {
                for swap in [false, true] {
                    for sym in [0x0cu8, 0x1c, 0x6c, 0xbc, 0xfc] {
                        let (xq, yq) = build_face_split(&st, m, s, swap, sym);
                        let r = QRecord {
                            rewritten: vec![(s, xq)],
                            appended: vec![yq],
                            ..QRecord::default()
                        };
                        for major in 2..=4u16 {
                            assert_eq!(
                                predict_face_split(&st, m, s, major),
                                all_paths(&st, &r, 1, major)[0],
                                "slot {s}, m {m}, swap {swap}, sym {sym:#x}, version {major}"
                            );
                        }
                        differ += (predict_face_split(&st, m, s, 4)
                            != predict_face_split(&st, m, s, 3))
                            as u32;
                    }
                }
            }
        }
        assert!(differ > 0, "version 4 never differs from version 3");
    }
}
