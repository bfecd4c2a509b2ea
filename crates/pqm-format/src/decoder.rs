//! The push (streaming) decoder, in the style of the `png` crate's
//! `StreamingDecoder`: feed bytes as they arrive with [`Decoder::push`] —
//! any number at a time, one byte at a time gives exactly the same result —
//! and get [`Event`]s as sections complete. Then move between any two
//! decoded levels with [`Decoder::refine_to`] / [`Decoder::coarsen_to`] /
//! [`Decoder::set_level`], each returning a [`Change`] that tells a renderer
//! which buffer sub-ranges to update.
//!
//! Internally the decoder keeps two meshes: the *frontier* (the deepest
//! decoded level, with vertex→face adjacency, needed to decode the next
//! record) and the *current* level the caller sees. Every decoded record is
//! stored as its counts and, once a move below the deepest level has needed
//! them, its undo data (`new ^ old` of its moved vertices and rewritten
//! slots); its new vertices and quads are the frontier's until a replay
//! below the deepest level first needs them (then unwound from the frontier
//! once). Until then a general decoder decodes as a forward-only one does
//! and keeps the compressed chunks instead of the undo data: the first
//! move below the deepest level decodes them again, once, for it (on the
//! bunny the first move to level 0 and back took 46 ms, a whole decode 31,
//! later moves 3); every later move replays the undo data and never
//! re-decodes anything.
//!
//! Every count and index in the input is checked before it is used or
//! allocated for; claims in the header and chunk table are checked against
//! [`Limits`] up front. Nothing here panics on any input.

use crate::codec::{self, Cursors, MeshState};
use crate::error::{DecodeError, FormatError, Section};
use crate::huge_pages::HugeVec;
use crate::layout::*;
use crate::quant::Quantizer;
use crate::varint::Reader;
use byteorder::{ByteOrder, LittleEndian as LE};
use glam::DVec3;
use pqm_core::{IndexedMesh, OpKind, ProgressiveMesh, SplitRecord};
use std::ops::Range;
use std::sync::Mutex;
use std::sync::OnceLock;

/// A `VORD` or `VNBR` section kept compressed until the order is asked for.
struct PendingOrder {
    /// Index of the optional section (for errors).
    index: u32,
    /// `VNBR` (else `VORD`).
    neighbours: bool,
    compressed: Vec<u8>,
    uncompressed_len: u32,
}

/// Resource budget of a decoder. The header's counts and the chunk table's
/// sizes are checked against it before anything is allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest final vertex count accepted.
    pub max_vertices: u32,
    /// Largest final face count accepted.
    pub max_faces: u32,
    /// Upper bound on the decoder's memory, estimated from the header and
    /// chunk table (see [`Limits::estimate`]).
    pub max_memory_bytes: u64,
}

impl Default for Limits {
    /// 2^26 vertices, 2^26 faces, 4 GiB.
    fn default() -> Self {
        Limits {
            max_vertices: 1 << 26,
            max_faces: 1 << 26,
            max_memory_bytes: 4 << 30,
        }
    }
}

impl Limits {
    /// No limits beyond what the format can express.
    pub fn none() -> Self {
        Limits {
            max_vertices: u32::MAX,
            max_faces: u32::MAX,
            max_memory_bytes: u64::MAX,
        }
    }

    /// Conservative memory estimate of a decoder for a file with `v` final
    /// vertices, `f` final faces, `r` records and `payload` uncompressed
    /// payload bytes in all: two meshes, adjacency, the explicit records
    /// (each stored entry is at most ~18 bytes per coded byte) and the
    /// largest decompression buffer.
    pub fn estimate(v: u64, f: u64, r: u64, payload: u64) -> u64 {
        v.saturating_mul(96)
            .saturating_add(f.saturating_mul(80))
            .saturating_add(r.saturating_mul(40))
            .saturating_add(payload.saturating_mul(20))
    }
}

/// What a [`Decoder::push`] call completed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Event {
    /// Header and chunk table are read: counts, bounding box, chunk sizes
    /// and errors are known ([`Decoder::header`], [`Decoder::chunks`]).
    HeaderReady,
    /// Level 0 is available.
    BaseMeshReady,
    /// Chunk `i` is decoded: its records can be applied.
    ChunkReady(u32),
    /// An optional section with this tag was read (or skipped, if unknown).
    SectionReady([u8; 4]),
    /// The whole file was read.
    Finished,
}

/// Which level to go to. Targets beyond the decoded levels clamp to the
/// deepest decoded level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// Level `k` (records `0..k` applied).
    Level(usize),
    /// The finest level with at most `n` faces (level 0 if none).
    Faces(usize),
    /// The coarsest chunk boundary (or level 0) whose geometric error is
    /// `<= e`; the deepest decoded level if none is.
    Error(f64),
}

/// What changed between two levels, in buffer terms. Quad slot `f` maps to
/// triangles `2f` = `(v0, v1, v2)` and `2f + 1` = `(v0, v2, v3)`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Change {
    /// Level before.
    pub from_level: usize,
    /// Level after.
    pub to_level: usize,
    /// New vertex ids (refining): upload these positions.
    pub vertices_appended: Range<u32>,
    /// Removed vertex ids (coarsening): the vertex buffer is truncated to
    /// `vertices_removed.start`.
    pub vertices_removed: Range<u32>,
    /// Vertices that existed before and after and whose position changed
    /// (sorted, distinct).
    pub vertices_moved: Vec<u32>,
    /// Face slots that existed before and after and whose quad changed
    /// (sorted, distinct).
    pub faces_rewritten: Vec<u32>,
    /// New face slots (refining).
    pub faces_appended: Range<u32>,
    /// Removed face slots (coarsening): truncate to `faces_truncated.start`.
    pub faces_truncated: Range<u32>,
}

impl Change {
    /// True when no buffer range changed.
    pub fn is_empty(&self) -> bool {
        self.vertices_appended.is_empty()
            && self.vertices_removed.is_empty()
            && self.vertices_moved.is_empty()
            && self.faces_rewritten.is_empty()
            && self.faces_appended.is_empty()
            && self.faces_truncated.is_empty()
    }

    /// `vertices_moved` merged into maximal runs of consecutive ids.
    pub fn moved_ranges(&self) -> Vec<Range<u32>> {
        runs(&self.vertices_moved)
    }

    /// `faces_rewritten` merged into maximal runs of consecutive slots.
    pub fn rewritten_ranges(&self) -> Vec<Range<u32>> {
        runs(&self.faces_rewritten)
    }
}

/// `ids` reduced to its distinct values below `bound`, ascending. Many ids
/// (a long refinement: loki from level 0 reports ~20k rewrites of its 1.8k
/// base slots) go through a bit set over `0..bound`, linear; few are
/// sorted (a sort of the long lists was half of a refinement's cost).
fn sorted_distinct_below(ids: &mut Vec<u32>, bound: u32) {
    ids.retain(|&v| v < bound);
    if ids.len() <= (bound as usize / 64).max(64) {
        ids.sort_unstable();
        ids.dedup();
        return;
    }
    let mut bits = vec![0u64; (bound as usize).div_ceil(64)];
    for &v in ids.iter() {
        bits[v as usize / 64] |= 1 << (v % 64);
    }
    ids.clear();
    for (w, &word) in bits.iter().enumerate() {
        let mut b = word;
        while b != 0 {
            ids.push(64 * w as u32 + b.trailing_zeros());
            b &= b - 1;
        }
    }
}

fn runs(sorted: &[u32]) -> Vec<Range<u32>> {
    let mut out: Vec<Range<u32>> = Vec::new();
    for &x in sorted {
        match out.last_mut() {
            Some(r) if r.end == x => r.end = x + 1,
            _ => out.push(x..x + 1),
        }
    }
    out
}

/// Where the decoder is in the byte stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Prefix,
    Header(u32),
    Table,
    Base,
    Chunk(u32),
    SectionHead(u32),
    SectionBody(u32, [u8; 4], u32, u32, u32),
    Done,
}

/// Progress report: what is decoded and what is missing.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    /// Bytes consumed so far (pushed and parsed).
    pub bytes_consumed: u64,
    /// Bytes pushed but waiting for the rest of their section.
    pub bytes_buffered: u64,
    /// Header and chunk table read.
    pub header_ready: bool,
    /// Level 0 available.
    pub base_ready: bool,
    /// Decoded chunks (always a prefix `0..chunks_ready`).
    pub chunks_ready: u32,
    /// Chunks in the file (once the header is read).
    pub chunk_count: Option<u32>,
    /// Deepest level that can be reached now (`None` before the base mesh).
    pub deepest_level: Option<usize>,
    /// Finest level of the file (once the header is read).
    pub final_level: Option<usize>,
    /// The section being waited for (`None` when finished or failed).
    pub waiting_for: Option<Section>,
    /// Bytes still needed to complete that section (known once its length is).
    pub bytes_needed: Option<u64>,
    /// Total file length (once the chunk table is read; optional sections
    /// after the chunks are not included).
    pub bytes_to_last_chunk: Option<u64>,
    /// The whole file was read.
    pub finished: bool,
    /// The decoder hit an error; it accepts no more input.
    pub failed: bool,
}

/// Explicit records with undo data, structure-of-arrays: every committed
/// record (a chunk being decoded appends to it and is truncated away if it
/// fails). The undo data covers every record only once a general decoder
/// needed it (`Decoder::logs`); before, as in a forward-only decoder, only
/// the chunk being decoded.
#[derive(Default)]
struct Records {
    op: Vec<OpKind>,
    /// Vertex / face count at level k (k = 0 ..= decoded records).
    v_at: Vec<u32>,
    f_at: Vec<u32>,
    /// Where record k's entries start in `moved` and `rw`, for levels
    /// `at0 ..`: entry `k - at0` (levels before `at0` have no entries). A
    /// decoder with its logs (`Decoder::logs`) keeps every level (`at0` =
    /// 0); one without only the chunk being decoded (it drops the logs at
    /// each commit, so the lists restart there: on the bunny 2.6 MB of
    /// writes fewer per decode). `u32`: the logs are bounded by that (see
    /// [`Records::push_level`]), half the memory of `usize`.
    moved_at: Vec<u32>,
    rw_at: Vec<u32>,
    at0: usize,
    /// `(vertex, new ^ old code)` per moved vertex, record by record (see
    /// [`MeshState::apply_delta_logged`]: one delta moves either way).
    moved: Vec<codec::MoveDelta>,
    /// `(slot, new ^ old quad)` per rewritten slot.
    rw: Vec<codec::RewriteDelta>,
    /// Codes of vertices `base_v..v_at[kept]` and quads of slots
    /// `base_f..f_at[kept]` as their records made them: what a replay to a
    /// level below the deepest appends. Not written while decoding (on the
    /// bunny 5.8 MB a decode, with a page fault per 4 KiB, for a level that
    /// a refinement to the deepest level copies from the frontier
    /// instead): the first such replay unwinds them from the frontier
    /// ([`Decoder::unwound`]) for every record decoded so far.
    new_pos: Vec<[u32; 3]>,
    appended: Vec<[u32; 4]>,
    /// Records `0..kept` have their entries in `new_pos` and `appended`.
    kept: usize,
}

impl Records {
    /// Empties every list, keeping their allocations ([`Decoder::reset`]).
    fn clear(&mut self) {
        self.op.clear();
        self.v_at.clear();
        self.f_at.clear();
        self.moved_at.clear();
        self.rw_at.clear();
        self.at0 = 0;
        self.moved.clear();
        self.rw.clear();
        self.new_pos.clear();
        self.appended.clear();
        self.kept = 0;
    }

    /// Prefetches the lines, 256 bytes past the end of each per-record
    /// list, that the next records' entries go to. Those lists grow by
    /// one entry per record for the whole decode, forward-only too; on
    /// memory an earlier mesh used (a process decoding more than once, as
    /// `decode_loop` does) each new line was in no cache and the pushes
    /// waited for it: the bunny's forward-only loop took 11 % less time
    /// with these hints (`moved_at` and `rw_at`, then 8 bytes an entry,
    /// most of it). A fresh process's pages come zeroed, already cached, and a
    /// hint to a page not yet mapped is dropped: its one decode measured
    /// even. The logs (`moved`, `rw`) gained nothing: the general
    /// decoder's large logs are fresh pages each decode.
    /// Without `LOGS` the offsets are not written (see
    /// [`Records::push_counts`]).
    #[inline(always)]
    fn prefetch_tail<const LOGS: bool>(&self) {
        codec::prefetch(&self.op, self.op.len() + 256);
        codec::prefetch(&self.v_at, self.v_at.len() + 64);
        codec::prefetch(&self.f_at, self.f_at.len() + 64);
        if LOGS {
            codec::prefetch(&self.moved_at, self.moved_at.len() + 64);
            codec::prefetch(&self.rw_at, self.rw_at.len() + 64);
        }
    }

    /// Start of level `k`'s entries in `moved` (0 before `at0`).
    #[inline]
    fn moved_at(&self, k: usize) -> usize {
        k.checked_sub(self.at0)
            .and_then(|i| self.moved_at.get(i))
            .map_or(0, |&x| x as usize)
    }

    /// Start of level `k`'s entries in `rw` (0 before `at0`).
    #[inline]
    fn rw_at(&self, k: usize) -> usize {
        k.checked_sub(self.at0)
            .and_then(|i| self.rw_at.get(i))
            .map_or(0, |&x| x as usize)
    }

    /// Record `k`'s moved-vertex entries.
    fn moved_of(&self, k: usize) -> &[codec::MoveDelta] {
        &self.moved[self.moved_at(k)..self.moved_at(k + 1)]
    }

    /// Record `k`'s rewritten-slot entries.
    fn rw_of(&self, k: usize) -> &[codec::RewriteDelta] {
        &self.rw[self.rw_at(k)..self.rw_at(k + 1)]
    }

    /// Ends the level of a record just applied to `st`: its counts and
    /// where its log entries end. `false` (nothing pushed) when a log has
    /// outgrown the `u32` offsets (4 G entries, beyond any real file; the
    /// caller undoes the record).
    #[inline(always)]
    fn push_level(&mut self, op: OpKind, st: &MeshState) -> bool {
        let (Ok(m), Ok(w)) = (
            u32::try_from(self.moved.len()),
            u32::try_from(self.rw.len()),
        ) else {
            return false;
        };
        self.push_counts(op, st);
        self.moved_at.push(m);
        self.rw_at.push(w);
        true
    }

    /// Ends the level of a record just applied to `st` without its log
    /// offsets: in a decoder without logs (`Decoder::logs`) nothing reads
    /// them (the chunk's log is dropped at its commit, and a failed chunk
    /// is undone as a whole), and they were two of its five pushes per
    /// record.
    #[inline(always)]
    fn push_counts(&mut self, op: OpKind, st: &MeshState) {
        self.op.push(op);
        self.v_at.push(st.q.len() as u32);
        self.f_at.push(st.quads.len() as u32);
    }

    /// Room for `records` more records (`at_records` more in the log
    /// offsets).
    fn reserve(&mut self, records: usize, at_records: usize) {
        self.op.reserve(records);
        self.v_at.reserve(records);
        self.f_at.reserve(records);
        self.moved_at.reserve(at_records);
        self.rw_at.reserve(at_records);
    }
}

/// Appends the `f32` positions of `codes` to `pos` (the origin without a
/// quantizer): the values `go_to`'s `f32_of` gives one by one, with the
/// quantizer's match out of the loop. A refinement to the deepest level converts
/// every new vertex at once, and with the match inside each took ~50
/// instructions.
fn extend_f32(pos: &mut HugeVec<[f32; 3]>, codes: &[[u32; 3]], quant: Option<&Quantizer>) {
    // Each position written once, into the spare capacity. Zero-filled
    // first, then written through a slice (the previous form), half of the
    // function's samples on the bunny were the fill's stores; without the
    // fill the bunny decoded 0.7-2.3 % faster (reused and new decoder, both
    // orders; 0.5 M fewer instructions), the smaller meshes even.
    match quant {
        Some(q) => pos.extend_map(codes, |c| q.dequantize(c).map(|x| x as f32)),
        None => pos.resize(pos.len() + codes.len(), [0.0; 3]),
    }
}

/// `frontier` when it is level `to` of `r` (the deepest decoded one).
fn frontier_at<'a>(
    frontier: &'a Option<MeshState>,
    r: &Records,
    to: usize,
) -> Option<&'a MeshState> {
    frontier.as_ref().filter(|st| {
        to + 1 == r.v_at.len()
            && st.q.len() == r.v_at[to] as usize
            && st.quads.len() == r.f_at[to] as usize
    })
}

/// Codes and quads of [`unwound`].
type UnwoundIds = (Vec<[u32; 3]>, Vec<[u32; 4]>);

/// What a general decoder keeps to rebuild its undo logs (see
/// `Decoder::logs`): the compressed base mesh and every committed chunk's
/// compressed bytes (on the bunny 1.4 MB, where the logs are 7.8 MB). The
/// base is decoded again too: a copy of its state was as large as the
/// whole file on spot, written at every decode.
struct Replay {
    base: Vec<u8>,
    bytes: Vec<u8>,
    /// Chunk `i`'s bytes are `bytes[ends[i - 1]..ends[i]]` (from 0 for
    /// chunk 0).
    ends: Vec<usize>,
}

/// The codes of vertices `v0..` and quads of slots `f0..` with records
/// `k0..` of `r` (to the deepest level, `st`) undone from `st`, ids below
/// `v0` / `f0` left out: a vertex or slot that existed at level `k0` gets
/// its value there; one made by record `k >= k0` its value as that record
/// made it (no earlier record touches it), what a replay appends. `r` must
/// have its logs from `k0` on.
fn unwound(r: &Records, st: &MeshState, v0: usize, f0: usize, k0: usize) -> Option<UnwoundIds> {
    let mut q = st.q.get(v0..)?.to_vec();
    let mut quads = st.quads.get(f0..)?.to_vec();
    for k in (k0..r.op.len()).rev() {
        for &(v, d) in r.moved_of(k).iter().rev() {
            if let Some(c) = (v as usize).checked_sub(v0).and_then(|i| q.get_mut(i)) {
                *c = codec::xor3(*c, d);
            }
        }
        for &(s, d) in r.rw_of(k).iter().rev() {
            if let Some(c) = (s as usize).checked_sub(f0).and_then(|i| quads.get_mut(i)) {
                *c = codec::xor4(*c, d);
            }
        }
    }
    Some((q, quads))
}

/// The push decoder (see the module docs).
pub struct Decoder {
    limits: Limits,
    buf: Vec<u8>,
    start: usize,
    consumed: u64,
    stage: Stage,
    failed: Option<FormatError>,
    failed_other: Option<String>,
    header: Option<Header>,
    quant: Option<Quantizer>,
    chunks: Vec<ChunkInfo>,
    chunks_ready: u32,
    /// Level reached after each ready chunk (cumulative records).
    chunk_levels: Vec<usize>,
    /// Uncompressed bytes of the base and all chunks (from the table).
    payload_total: u64,
    frontier: Option<MeshState>,
    recs: Records,
    /// The record being decoded, reused by every record.
    rec: codec::QRecord,
    /// The codec's per-record buffers.
    buffers: codec::DecodeScratch,
    /// Decompressed payload of the chunk being decoded (reused).
    zbuf: Vec<u8>,
    /// The vertex-order section as it arrived, checked only as far as is
    /// cheap (CRC, flags, one section, length and memory bounds): decoding
    /// it costs as much as a large part of the levels and only exporters
    /// need it, so [`Decoder::vertex_order`] decodes it on first use.
    vertex_order_section: Option<PendingOrder>,
    /// The decoded order (or why the section is bad), once asked for.
    vertex_order: OnceLock<Result<Vec<u32>, DecodeError>>,
    zstd: Option<zstd::bulk::Decompressor<'static>>,
    // Current level.
    level: usize,
    q: HugeVec<[u32; 3]>,
    pos: HugeVec<[f32; 3]>,
    quads: HugeVec<[u32; 4]>,
    /// The current level is the frontier's (the deepest decoded level) and
    /// its codes and quads are read from the frontier: `q` and `quads` are
    /// stale. A refinement to the deepest level sets it instead of copying
    /// the frontier's arrays (on bunny 5.8 MB written and faulted in);
    /// [`Decoder::unshare`] makes the copy when the frontier is about to
    /// change (the next chunk) or the level moves away from it, so a
    /// client that does that pays what every refinement paid before.
    shared: bool,
    /// When a refinement copies the frontier instead of replaying records.
    copy_policy: CopyPolicy,
    /// Keeps no undo data past a chunk ([`Decoder::forward_only`]).
    forward_only: bool,
    /// How the base section was coded (spec §6), once it is decoded.
    base_layout: Option<crate::base::BaseLayout>,
    /// The undo logs (`Records::moved`, `rw` and their offsets) cover
    /// every record. A general decoder starts without them and decodes as
    /// a forward-only one does (each chunk's log dropped at its commit),
    /// keeping the compressed chunks instead (`replay`): the logs are
    /// rebuilt from those by decoding the chunks again, once, when a move
    /// to a level other than the deepest first needs them
    /// ([`Decoder::ensure_logs`]); from then on every chunk's log is kept.
    /// On the bunny the logs are 7.8 MB written per decode, and their page
    /// faults (glibc returns the freed heap top to the kernel) made the
    /// general decoder 25–30 % slower than the forward-only one in a
    /// process decoding repeatedly (session 13, docs/figures-history.md).
    /// A refinement to the deepest level needs no logs: it takes the
    /// pending ids' values from the frontier, or shares the frontier.
    logs: bool,
    /// What rebuilds the logs while `logs` is false (general decoders).
    replay: Option<Replay>,
    /// Without logs (`logs`): moved vertices below the current level's count and
    /// rewritten slots below its face count, since the last move (what the
    /// next [`Change`] reports; the logs they come from are dropped).
    pending_moved: Vec<u32>,
    pending_rw: Vec<u32>,
    /// Allocations of the previous file's frontier and replay, handed on
    /// by [`Decoder::reset`] for the next base mesh to reuse.
    spare: Spare,
    /// Whether dropping this decoder leaves its allocations to the next
    /// new one ([`RECYCLED`]); false for the husks that `reset` and the
    /// recycling itself leave behind.
    recycle: bool,
}

/// What [`Decoder::reset`] keeps of the previous file for the next one's
/// base mesh (`Decoder::on_base`), emptied: the frontier's arrays and the
/// replay's buffers.
#[derive(Default)]
struct Spare {
    state: Option<MeshState>,
    replay_base: Vec<u8>,
    replay_bytes: Vec<u8>,
    replay_ends: Vec<usize>,
}

/// Most bytes of allocations a dropped decoder leaves for the next new one
/// ([`RECYCLED`]): as much as [`crate::huge_pages`] keeps of freed arrays.
/// A larger decoder frees its memory when dropped.
const RECYCLE_MAX_BYTES: usize = 64 << 20;

/// The allocations of the last decoder dropped in this process (emptied,
/// up to [`RECYCLE_MAX_BYTES`]), which the next [`Decoder::new`] or
/// [`Decoder::forward_only`] takes over.
///
/// Why: a new decoder's arrays are new memory, and glibc returns the freed
/// heap top to the kernel, so a client making a decoder per file faults
/// every page in again (loki: ≈ 550 faults of ≈ 1.2 µs each, a fifth of
/// its decode; session 20). A decoder reused with [`Decoder::reset`]
/// avoids that, and this gives a new decoder the same. One slot, not one
/// per thread: a pool of threads keeps one decoder's memory, not one per
/// thread. [`release_recycled`] frees it.
static RECYCLED: Mutex<Option<Box<Decoder>>> = Mutex::new(None);

/// The decoder in `slot`, if any (also after a panic elsewhere: what the
/// slot holds is only capacity).
fn take_from(slot: &Mutex<Option<Box<Decoder>>>) -> Option<Decoder> {
    let taken = slot.lock().unwrap_or_else(|e| e.into_inner()).take();
    taken.map(|d| *d)
}

/// Puts `husk` (not recycled itself when dropped) into `slot` if it holds
/// at most `max_bytes`, in place of the one there (dropped, outside the
/// lock); otherwise drops it.
fn put_into(slot: &Mutex<Option<Box<Decoder>>>, mut husk: Decoder, max_bytes: usize) {
    husk.recycle = false;
    if husk.retained_bytes() > max_bytes {
        return;
    }
    let displaced = slot
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .replace(Box::new(husk));
    drop(displaced);
}

/// Frees the allocations a dropped decoder left for the next new one (see
/// [`Decoder::new`]), and the freed arrays [`crate::huge_pages`] keeps;
/// returns about how many bytes that was. For a long-running process that
/// decoded a large file and will not decode another soon. Decoders in use
/// are not touched.
pub fn release_recycled() -> usize {
    let old = take_from(&RECYCLED);
    let bytes = old.as_ref().map_or(0, |d| d.retained_bytes());
    // `recycle` is off in the slot: the drop frees, and the mapped arrays
    // go to the huge-page cache, released next.
    drop(old);
    bytes + crate::huge_pages::release_cached()
}

impl Drop for Decoder {
    /// Leaves this decoder's allocations to the next new one
    /// ([`Decoder::new`]) when they are at most 64 MiB.
    fn drop(&mut self) {
        if !self.recycle || std::thread::panicking() {
            return;
        }
        let husk = std::mem::replace(self, Decoder::empty(self.limits, false));
        // What is left in `self` owns nothing.
        self.recycle = false;
        put_into(&RECYCLED, husk, RECYCLE_MAX_BYTES);
    }
}

/// Whether [`Decoder::go_to`] refines to the deepest level by copying the
/// frontier (`Auto`: when that writes less than the replay would; the other
/// two force one way, for the tests that check both agree).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CopyPolicy {
    Auto,
    #[cfg_attr(not(test), allow(dead_code))]
    Never,
    #[cfg_attr(not(test), allow(dead_code))]
    Always,
}

impl CopyPolicy {
    /// Copy for `entries` logged moves and rewrites to replay onto a level
    /// of `size` vertices and faces?
    fn copies(self, entries: usize, size: usize) -> bool {
        match self {
            CopyPolicy::Auto => entries.saturating_mul(16) > size,
            CopyPolicy::Never => false,
            CopyPolicy::Always => true,
        }
    }
}

impl Decoder {
    /// A decoder with the given budget.
    ///
    /// It starts with the allocations the last dropped decoder of this
    /// process left, if any, and if they fit in `limits.max_memory_bytes`
    /// (see [`release_recycled`]): a new decoder per file then finds its
    /// arrays' pages mapped, as a reset one does ([`Decoder::reset`]),
    /// instead of faulting them in again. Nothing of that decoder's file is
    /// kept but capacity.
    pub fn new(limits: Limits) -> Self {
        Decoder::recycled_or_empty(limits, false)
    }

    /// A decoder for one-way decoding: it keeps the undo data of a chunk
    /// only until the chunk is committed, so it moves only *to the deepest
    /// decoded level* ([`Decoder::refine_to`] / [`Decoder::set_level`] with
    /// a target that resolves to it; any other level is a
    /// [`DecodeError::Parameter`]), and
    /// [`Decoder::to_progressive_mesh`] gives `None`. Everything else — the
    /// push API, the checks, [`Limits`], the events, the levels it reaches
    /// and the [`Change`]s it reports — is the same as [`Decoder::new`]'s;
    /// it needs less memory (neither undo data nor the compressed chunks to
    /// rebuild it), though, like [`Decoder::new`], it starts with what the
    /// last dropped decoder left, a general one's buffers included.
    pub fn forward_only(limits: Limits) -> Self {
        Decoder::recycled_or_empty(limits, true)
    }

    /// A decoder that owns no allocation yet.
    fn empty(limits: Limits, forward_only: bool) -> Self {
        Decoder {
            limits,
            buf: Vec::new(),
            start: 0,
            consumed: 0,
            stage: Stage::Prefix,
            failed: None,
            failed_other: None,
            header: None,
            quant: None,
            chunks: Vec::new(),
            chunks_ready: 0,
            chunk_levels: Vec::new(),
            payload_total: 0,
            frontier: None,
            recs: Records::default(),
            rec: codec::QRecord::default(),
            buffers: codec::DecodeScratch::default(),
            zbuf: Vec::new(),
            vertex_order_section: None,
            vertex_order: OnceLock::new(),
            zstd: None,
            level: 0,
            q: HugeVec::new(),
            pos: HugeVec::new(),
            quads: HugeVec::new(),
            shared: false,
            copy_policy: CopyPolicy::Auto,
            forward_only,
            base_layout: None,
            logs: false,
            replay: None,
            pending_moved: Vec::new(),
            pending_rw: Vec::new(),
            spare: Spare::default(),
            recycle: true,
        }
    }

    /// An empty decoder that takes over the allocations in [`RECYCLED`].
    fn recycled_or_empty(limits: Limits, forward_only: bool) -> Self {
        let mut d = Decoder::empty(limits, forward_only);
        if let Some(old) = take_from(&RECYCLED) {
            // Never more than the budget allows, even as mere capacity.
            if old.retained_bytes() as u64 <= limits.max_memory_bytes {
                d.adopt(old);
            } else {
                put_into(&RECYCLED, old, RECYCLE_MAX_BYTES);
            }
        }
        d
    }

    /// Makes this decoder a new one for the next file — as
    /// [`Decoder::new`] (or [`Decoder::forward_only`], if this one is)
    /// with `limits` makes one — keeping the memory it allocated: the
    /// mesh arrays, the undo lists, the input and payload buffers and the
    /// zstd context. Nothing of the previous file is kept but capacity:
    /// every decode after a reset gives what a fresh decoder gives (test
    /// `reset_decoder_equals_fresh`).
    ///
    /// For a client that decodes file after file (a game streaming its
    /// assets): a decoder's arrays as new memory are mapped by the system
    /// page by page as they are first written (on loki ≈ 530 page faults,
    /// 2.1 MB); a reused decoder decoded spot, makehuman and loki 10–29 %
    /// faster than one on new memory (`decode_loop … reuse`, session 18).
    /// A new decoder that takes over a dropped one's allocations
    /// ([`Decoder::new`]) gets the same, as long as no other decoder was
    /// dropped in between; a reset one keeps its own whatever other
    /// decoders do. The previous file's mesh is gone after the call: take
    /// what you need from it first.
    pub fn reset(&mut self, limits: Limits) {
        // Everything not handed on by `adopt` starts as a fresh decoder's:
        // no state of the previous file can leak into the next.
        let old = std::mem::replace(self, Decoder::empty(limits, self.forward_only));
        self.adopt(old);
    }

    /// Takes over `old`'s allocations, emptied, into this empty decoder
    /// (what [`Decoder::reset`] and a recycled [`Decoder::new`] keep).
    fn adopt(&mut self, mut old: Decoder) {
        // The husk left in `old` is dropped, not recycled.
        old.recycle = false;
        // Emptied, their capacity kept.
        macro_rules! emptied {
            ($($f:ident),*) => {$(
                old.$f.clear();
                self.$f = std::mem::take(&mut old.$f);
            )*};
        }
        emptied!(
            buf,
            chunks,
            chunk_levels,
            recs,
            zbuf,
            q,
            pos,
            quads,
            pending_moved,
            pending_rw
        );
        // Per-record buffers, sized to the largest record seen; their
        // marks are generation stamps, never reset between records or files.
        self.rec = std::mem::take(&mut old.rec);
        self.buffers = std::mem::take(&mut old.buffers);
        // zstd resets its context at every frame.
        self.zstd = old.zstd.take();
        self.spare = std::mem::take(&mut old.spare);
        if let Some(st) = old.frontier.take() {
            self.spare.state = Some(st);
        }
        if let Some(r) = old.replay.take() {
            self.spare.replay_base = r.base;
            self.spare.replay_bytes = r.bytes;
            self.spare.replay_ends = r.ends;
        }
    }

    /// About how many bytes of allocations this decoder holds (the arrays
    /// that grow with the mesh; a few small ones are left out).
    fn retained_bytes(&self) -> usize {
        fn b<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        fn h<T: Copy>(v: &HugeVec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let r = &self.recs;
        let states = self.frontier.iter().chain(self.spare.state.iter());
        let replay = self
            .replay
            .iter()
            .map(|r| b(&r.base) + b(&r.bytes) + b(&r.ends));
        b(&self.buf)
            + b(&self.zbuf)
            + b(&self.chunks)
            + b(&self.chunk_levels)
            + h(&self.q)
            + h(&self.pos)
            + h(&self.quads)
            + b(&self.pending_moved)
            + b(&self.pending_rw)
            + b(&r.op)
            + b(&r.v_at)
            + b(&r.f_at)
            + b(&r.moved_at)
            + b(&r.rw_at)
            + b(&r.moved)
            + b(&r.rw)
            + b(&r.new_pos)
            + b(&r.appended)
            + states.map(MeshState::capacity_bytes).sum::<usize>()
            + replay.sum::<usize>()
            + b(&self.spare.replay_base)
            + b(&self.spare.replay_bytes)
            + b(&self.spare.replay_ends)
    }

    /// Makes a general decoder keep its undo logs for every record from now
    /// on, so that no later move pays for them. By default a general decoder
    /// keeps none until a move below the deepest level first needs them, and
    /// that move decodes the committed chunks again (on the bunny 46 ms for
    /// the first move to level 0 and back, against 31 ms for a whole decode
    /// and 3 ms for later moves): a client that will coarsen and cannot take
    /// that pause in a frame calls this — before the base mesh arrives (the
    /// logs are then written while decoding: no pause later, but one-shot
    /// decodes 6–9 % slower, their pages being fresh), or at a moment of its
    /// choosing (the chunks so far are decoded again then).
    ///
    /// A forward-only decoder keeps no undo data: [`DecodeError::Parameter`].
    pub fn keep_undo_logs(&mut self) -> Result<(), DecodeError> {
        if self.forward_only {
            return Err(DecodeError::Parameter(
                "a forward-only decoder keeps no undo logs".into(),
            ));
        }
        if self.frontier.is_none() {
            // Before the base mesh: every record gets its log as it is
            // decoded, and no compressed chunk is kept to rebuild them.
            self.logs = true;
            return Ok(());
        }
        self.ensure_logs()
    }

    /// Feeds the next bytes of the file; returns the events they completed,
    /// in file order. After an error the decoder is failed and every further
    /// call returns an error; the events of the failing call are not
    /// returned, but every level decoded before the error stays usable
    /// ([`Decoder::status`], [`Decoder::deepest_level`]).
    pub fn push(&mut self, data: &[u8]) -> Result<Vec<Event>, DecodeError> {
        if let Some(e) = &self.failed {
            return Err(DecodeError::Format(e.clone()));
        }
        if let Some(e) = &self.failed_other {
            return Err(DecodeError::Parameter(format!(
                "the decoder failed earlier: {e}"
            )));
        }
        let mut events = Vec::new();
        let r = if self.start == self.buf.len() {
            // Nothing buffered: sections are parsed straight from `data`
            // and only its unparsed tail is kept (a whole file pushed at
            // once is not copied: on bunny 1.4 MB written and faulted in,
            // and again for each section's own copy).
            self.buf.clear();
            self.start = 0;
            let mut pos = 0;
            let r = self.run(data, &mut pos, &mut events);
            self.buf.extend_from_slice(&data[pos..]);
            r
        } else {
            self.buf.extend_from_slice(data);
            let buf = std::mem::take(&mut self.buf);
            let mut pos = self.start;
            let r = self.run(&buf, &mut pos, &mut events);
            (self.buf, self.start) = (buf, pos);
            r
        };
        if self.start > 0 && (self.start >= self.buf.len() / 2 || self.start > 1 << 20) {
            self.buf.drain(..self.start);
            self.start = 0;
        }
        match r {
            Ok(()) => Ok(events),
            Err(e) => {
                match &e {
                    DecodeError::Format(f) => self.failed = Some(f.clone()),
                    other => self.failed_other = Some(other.to_string()),
                }
                Err(e)
            }
        }
    }

    /// Reads `r` to the end, pushing everything (a convenience for files and
    /// sockets; I/O errors are `DecodeError::Io`).
    pub fn push_reader(&mut self, mut r: impl std::io::Read) -> Result<Vec<Event>, DecodeError> {
        let mut events = Vec::new();
        let mut chunk = vec![0u8; 64 * 1024];
        loop {
            let n = match r.read(&mut chunk) {
                Ok(0) => return Ok(events),
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            };
            events.extend(self.push(&chunk[..n])?);
        }
    }

    fn avail(&self) -> &[u8] {
        &self.buf[self.start..]
    }

    /// The next `n` bytes of `src` from `*pos` (which the caller checked
    /// are there), consumed.
    fn take<'s>(&mut self, src: &'s [u8], pos: &mut usize, n: usize) -> &'s [u8] {
        let b = &src[*pos..*pos + n];
        *pos += n;
        self.consumed += n as u64;
        b
    }

    /// Bytes the current stage needs (None when done).
    fn need(&self) -> Option<usize> {
        let h = self.header.as_ref();
        match self.stage {
            Stage::Prefix => Some(HEADER_PREFIX),
            Stage::Header(len) => Some(len as usize),
            Stage::Table => h.map(|h| h.chunk_count as usize * h.chunk_entry_len as usize + 4),
            Stage::Base => h.map(|h| h.base_compressed_len as usize),
            Stage::Chunk(i) => self
                .chunks
                .get(i as usize)
                .map(|c| c.compressed_len as usize),
            Stage::SectionHead(_) => Some(SECTION_HEADER_LEN),
            Stage::SectionBody(_, _, clen, _, _) => Some(clen as usize),
            Stage::Done => None,
        }
    }

    /// Parses `src` from `*pos` as far as whole sections go (`*pos`
    /// advances past what was consumed).
    fn run(
        &mut self,
        src: &[u8],
        pos: &mut usize,
        events: &mut Vec<Event>,
    ) -> Result<(), DecodeError> {
        loop {
            let avail = src.len() - *pos;
            let Some(need) = self.need() else {
                if avail != 0 {
                    return Err(DecodeError::invalid(
                        Section::Trailer,
                        format!("{avail} bytes after the end of the file"),
                    ));
                }
                return Ok(());
            };
            if avail < need {
                return Ok(());
            }
            match self.stage {
                Stage::Prefix => self.on_prefix(&src[*pos..])?,
                Stage::Header(len) => {
                    let b = self.take(src, pos, len as usize);
                    self.on_header(b)?;
                }
                Stage::Table => {
                    let b = self.take(src, pos, need);
                    self.on_table(b)?;
                    events.push(Event::HeaderReady);
                }
                Stage::Base => {
                    let b = self.take(src, pos, need);
                    self.on_base(b)?;
                    events.push(Event::BaseMeshReady);
                    self.after_chunks(0, events)?;
                }
                Stage::Chunk(i) => {
                    let b = self.take(src, pos, need);
                    self.on_chunk(i, b)?;
                    events.push(Event::ChunkReady(i));
                    self.after_chunks(i + 1, events)?;
                }
                Stage::SectionHead(i) => {
                    let b = self.take(src, pos, need);
                    let tag = [b[0], b[1], b[2], b[3]];
                    self.stage = Stage::SectionBody(
                        i,
                        tag,
                        LE::read_u32(&b[4..]),
                        LE::read_u32(&b[8..]),
                        LE::read_u32(&b[12..]),
                    );
                }
                Stage::SectionBody(i, tag, _, ulen, crc) => {
                    let b = self.take(src, pos, need);
                    self.on_section(i, tag, ulen, crc, b)?;
                    events.push(Event::SectionReady(tag));
                    let n = self.header.as_ref().map_or(0, |h| h.section_count);
                    self.stage = if i + 1 < n {
                        Stage::SectionHead(i + 1)
                    } else {
                        Stage::Done
                    };
                    if self.stage == Stage::Done {
                        self.check_vord_flag()?;
                        events.push(Event::Finished);
                    }
                }
                Stage::Done => return Ok(()),
            }
        }
    }

    /// Moves to chunk `next`, or to the sections / the end.
    fn after_chunks(&mut self, next: u32, events: &mut Vec<Event>) -> Result<(), DecodeError> {
        let (chunks, sections) = self
            .header
            .as_ref()
            .map_or((0, 0), |h| (h.chunk_count, h.section_count));
        self.stage = if next < chunks {
            Stage::Chunk(next)
        } else if sections > 0 {
            Stage::SectionHead(0)
        } else {
            self.check_vord_flag()?;
            events.push(Event::Finished);
            Stage::Done
        };
        Ok(())
    }

    /// At the end of the file: header flag bits 0 and 1 must agree with
    /// the presence of a `VORD` or `VNBR` section (spec §3, §8).
    fn check_vord_flag(&self) -> Result<(), DecodeError> {
        let flags = self.header.as_ref().map_or(0, |h| h.flags);
        for (flag, tag) in [
            (FLAG_VERTEX_ORDER, TAG_VORD),
            (FLAG_VERTEX_NEIGHBOURS, TAG_VNBR),
        ] {
            let present = self.vertex_order_section.as_ref().map(|p| {
                if p.neighbours {
                    TAG_VNBR
                } else {
                    TAG_VORD
                }
            });
            if flags & flag != 0 && present != Some(tag) {
                return Err(DecodeError::invalid(
                    Section::Trailer,
                    format!(
                        "header flag bit {} announces a {} section but the file has none",
                        flag.trailing_zeros(),
                        String::from_utf8_lossy(&tag)
                    ),
                ));
            }
        }
        Ok(())
    }

    fn on_prefix(&mut self, b: &[u8]) -> Result<(), DecodeError> {
        if b[..8] != MAGIC {
            return Err(FormatError::BadMagic.into());
        }
        let major = LE::read_u16(&b[8..]);
        let minor = LE::read_u16(&b[10..]);
        if !(MIN_VERSION_MAJOR..=VERSION_MAJOR).contains(&major) {
            return Err(FormatError::UnsupportedVersion {
                major,
                minor,
                supported: VERSION_MAJOR,
            }
            .into());
        }
        let len = LE::read_u32(&b[12..]);
        if !(HEADER_LEN..=MAX_HEADER_LEN).contains(&len) {
            return Err(DecodeError::invalid(
                Section::Header,
                format!("header_len {len} outside {HEADER_LEN}..={MAX_HEADER_LEN}"),
            ));
        }
        self.stage = Stage::Header(len);
        Ok(())
    }

    fn on_header(&mut self, b: &[u8]) -> Result<(), DecodeError> {
        let len = b.len();
        let stored = LE::read_u32(&b[len - 4..]);
        let computed = crc32(&b[..len - 4]);
        if stored != computed {
            return Err(FormatError::CrcMismatch {
                section: Section::Header,
                stored,
                computed,
            }
            .into());
        }
        let h = Header::parse(b);
        let bad = |m: String| Err(DecodeError::invalid(Section::Header, m));
        if !(8..=24).contains(&h.quant_bits) {
            return bad(format!("quantization bits {} outside 8..=24", h.quant_bits));
        }
        if h.chunk_entry_len < CHUNK_ENTRY_LEN || h.chunk_entry_len > 4096 {
            return bad(format!(
                "chunk entry length {} outside {CHUNK_ENTRY_LEN}..=4096",
                h.chunk_entry_len
            ));
        }
        for k in 0..3 {
            let (lo, hi) = (h.bbox_min[k], h.bbox_max[k]);
            if !lo.is_finite() || !hi.is_finite() || lo > hi || !(hi - lo).is_finite() {
                return bad(format!("bounding box axis {k} is [{lo}, {hi}]"));
            }
        }
        if h.flags & FLAG_BOUNDS != 0 {
            let Some([lo, hi]) = h.bounds else {
                return bad(format!(
                    "flag bit 2 (bounds) set but header_len {len} < {HEADER_LEN_BOUNDS}"
                ));
            };
            for k in 0..3 {
                if !lo[k].is_finite() || !hi[k].is_finite() || lo[k] > hi[k] {
                    return bad(format!("bounds axis {k} is [{}, {}]", lo[k], hi[k]));
                }
            }
        }
        if h.base_vertex_count > h.final_vertex_count || h.base_face_count > h.final_face_count {
            return bad("base counts exceed final counts".into());
        }
        if h.chunk_count > h.record_count || (h.record_count > 0 && h.chunk_count == 0) {
            return bad(format!(
                "{} chunks cannot hold {} records",
                h.chunk_count, h.record_count
            ));
        }
        if h.base_error.is_nan() || h.base_error < 0.0 {
            return bad(format!(
                "base error {} is not a non-negative number",
                h.base_error
            ));
        }
        if h.final_vertex_count > self.limits.max_vertices {
            return Err(DecodeError::LimitsExceeded(format!(
                "{} vertices > max_vertices {}",
                h.final_vertex_count, self.limits.max_vertices
            )));
        }
        if h.final_face_count > codec::MAX_FACES {
            return Err(DecodeError::LimitsExceeded(format!(
                "{} faces > {} (this decoder's corner ids are 32-bit)",
                h.final_face_count,
                codec::MAX_FACES
            )));
        }
        if h.final_face_count > self.limits.max_faces {
            return Err(DecodeError::LimitsExceeded(format!(
                "{} faces > max_faces {}",
                h.final_face_count, self.limits.max_faces
            )));
        }
        let est = Limits::estimate(
            h.final_vertex_count as u64,
            h.final_face_count as u64,
            h.record_count as u64,
            h.base_uncompressed_len as u64,
        );
        if est > self.limits.max_memory_bytes {
            return Err(DecodeError::LimitsExceeded(format!(
                "estimated memory {est} bytes > max_memory_bytes {}",
                self.limits.max_memory_bytes
            )));
        }
        self.quant = Some(Quantizer::new(h.bbox_min, h.bbox_max, h.quant_bits));
        self.header = Some(h);
        self.stage = Stage::Table;
        Ok(())
    }

    fn on_table(&mut self, b: &[u8]) -> Result<(), DecodeError> {
        let h = self
            .header
            .clone()
            .ok_or_else(|| DecodeError::Internal("table before header".into()))?;
        let n = b.len() - 4;
        let stored = LE::read_u32(&b[n..]);
        let computed = crc32(&b[..n]);
        if stored != computed {
            return Err(FormatError::CrcMismatch {
                section: Section::ChunkTable,
                stored,
                computed,
            }
            .into());
        }
        let bad = |m: String| Err(DecodeError::invalid(Section::ChunkTable, m));
        let mut offset = h.header_len as u64 + n as u64 + 4 + h.base_compressed_len as u64;
        let (mut records, mut v, mut f, mut err) =
            (0u64, h.base_vertex_count, h.base_face_count, h.base_error);
        let mut payload = h.base_uncompressed_len as u64;
        let mut chunks = Vec::with_capacity(h.chunk_count as usize);
        for i in 0..h.chunk_count as usize {
            let e = ChunkInfo::parse(&b[i * h.chunk_entry_len as usize..]);
            if e.offset != offset {
                return bad(format!(
                    "chunk {i} offset {} != expected {offset}",
                    e.offset
                ));
            }
            if e.record_count == 0 {
                return bad(format!("chunk {i} has no records"));
            }
            if e.vertex_count < v || e.face_count < f {
                return bad(format!("chunk {i} vertex/face counts decrease"));
            }
            if e.error.is_nan() || e.error < 0.0 || e.error > err {
                return bad(format!("chunk {i} error {} is not in [0, {err}]", e.error));
            }
            offset += e.compressed_len as u64;
            records += e.record_count as u64;
            payload += e.uncompressed_len as u64;
            (v, f, err) = (e.vertex_count, e.face_count, e.error);
            chunks.push(e);
        }
        if records != h.record_count as u64 {
            return bad(format!(
                "chunks hold {records} records, header says {}",
                h.record_count
            ));
        }
        if v != h.final_vertex_count || f != h.final_face_count {
            return bad(format!(
                "chunks end at {v} vertices and {f} faces, header says {} and {}",
                h.final_vertex_count, h.final_face_count
            ));
        }
        let est = Limits::estimate(
            h.final_vertex_count as u64,
            h.final_face_count as u64,
            h.record_count as u64,
            payload,
        );
        if est > self.limits.max_memory_bytes {
            return Err(DecodeError::LimitsExceeded(format!(
                "estimated memory {est} bytes > max_memory_bytes {}",
                self.limits.max_memory_bytes
            )));
        }
        self.chunks = chunks;
        self.payload_total = payload;
        self.stage = Stage::Base;
        Ok(())
    }

    fn decompress(
        &mut self,
        section: Section,
        data: &[u8],
        ulen: u32,
    ) -> Result<Vec<u8>, DecodeError> {
        let mut out = Vec::new();
        self.decompress_into(section, data, ulen, &mut out)?;
        Ok(out)
    }

    /// Decompresses the single frame `data` of `ulen` bytes into `out`
    /// (cleared first; its buffer is reused).
    fn decompress_into(
        &mut self,
        section: Section,
        data: &[u8],
        ulen: u32,
        out: &mut Vec<u8>,
    ) -> Result<(), DecodeError> {
        if self.zstd.is_none() {
            self.zstd = Some(new_zstd()?);
        }
        let d = self
            .zstd
            .as_mut()
            .ok_or_else(|| DecodeError::Internal("no zstd context".into()))?;
        decompress_frame(d, section, data, ulen, out)
    }

    fn check_crc(section: Section, data: &[u8], stored: u32) -> Result<(), DecodeError> {
        let computed = crc32(data);
        if computed != stored {
            return Err(FormatError::CrcMismatch {
                section,
                stored,
                computed,
            }
            .into());
        }
        Ok(())
    }

    fn on_base(&mut self, b: &[u8]) -> Result<(), DecodeError> {
        let h = self
            .header
            .clone()
            .ok_or_else(|| DecodeError::Internal("base before header".into()))?;
        Self::check_crc(Section::BaseMesh, b, h.base_crc32)?;
        let payload = self.decompress(Section::BaseMesh, b, h.base_uncompressed_len)?;
        let qmax = self.quant.map_or(0, |q| q.qmax());
        self.base_layout = Some(crate::base::layout_of(&payload, h.version_major));
        let base = crate::base::decode(
            &payload,
            h.base_vertex_count,
            h.base_face_count,
            qmax,
            h.version_major,
        )
        .map_err(|m| DecodeError::invalid(Section::BaseMesh, m))?;
        // A reset decoder's previous frontier takes the base (its arrays
        // already have room, and their pages are mapped).
        let mut st = match self.spare.state.take() {
            Some(mut st) => {
                st.reset_to(&base);
                st
            }
            None => base,
        };
        if !self.forward_only && !self.logs {
            // Room for the chunks as the table states them (growing the
            // list copied it ~log2(chunks) times), never past the
            // uncompressed payload counted in `Limits::estimate`.
            let claimed: u64 = self.chunks.iter().map(|c| c.compressed_len as u64).sum();
            let room = claimed.min(self.payload_total) as usize;
            let sp = &mut self.spare;
            let (mut base, mut bytes, mut ends) = (
                std::mem::take(&mut sp.replay_base),
                std::mem::take(&mut sp.replay_bytes),
                std::mem::take(&mut sp.replay_ends),
            );
            base.clear();
            base.extend_from_slice(b);
            bytes.clear();
            bytes.reserve(room);
            ends.clear();
            self.replay = Some(Replay { base, bytes, ends });
        }
        // Room for the finest level up front: the header's counts were
        // checked against the limits, and what is reserved here (68 bytes
        // per vertex — 44 of them the frontier's codes and corner block —,
        // 32 per face, 17 per record; the frontier's overflow lists add at
        // most 4 per vertex and 32 per face, their page directories 1/4
        // and 2) stays within
        // `Limits::estimate`. Growing these lists chunk by chunk copied them
        // ~log2(final / base) times. Untouched capacity is address space,
        // not memory: a client that stops early does not pay for it.
        let (nv, nf) = (
            (h.final_vertex_count - h.base_vertex_count) as usize,
            (h.final_face_count - h.base_face_count) as usize,
        );
        st.reserve(nv, nf);
        // The log offsets cover one chunk at a time until a general
        // decoder needs its logs (`logs`).
        let n_rec = h.record_count as usize + 1;
        self.recs.reserve(n_rec, if self.logs { n_rec } else { 0 });
        // Empty here (a new decoder's, or emptied by `reset`).
        self.q.clear();
        self.q.reserve(st.q.len() + nv);
        self.q.extend_from_slice(&st.q);
        self.pos.clear();
        self.pos.reserve(st.q.len() + nv);
        extend_f32(&mut self.pos, &st.q, self.quant.as_ref());
        self.quads.clear();
        self.quads.reserve(st.quads.len() + nf);
        self.quads.extend_from_slice(&st.quads);
        self.level = 0;
        self.recs.v_at.push(st.q.len() as u32);
        self.recs.f_at.push(st.quads.len() as u32);
        self.recs.moved_at.push(0);
        self.recs.rw_at.push(0);
        self.frontier = Some(st);
        Ok(())
    }

    fn on_chunk(&mut self, i: u32, b: &[u8]) -> Result<(), DecodeError> {
        let info = self
            .chunks
            .get(i as usize)
            .cloned()
            .ok_or_else(|| DecodeError::Internal("chunk index".into()))?;
        let h = self
            .header
            .clone()
            .ok_or_else(|| DecodeError::Internal("chunk before header".into()))?;
        Self::check_crc(Section::Chunk(i), b, info.crc32)?;
        self.unshare();
        // The payload goes into one buffer reused by every chunk (no fresh
        // pages to fault in per chunk).
        let mut payload = std::mem::take(&mut self.zbuf);
        let result = self.decode_chunk(i, &info, &h, b, &mut payload);
        self.zbuf = payload;
        result?;
        self.chunks_ready = i + 1;
        self.chunk_levels.push(self.recs.op.len());
        if !self.logs {
            if let Some(src) = &mut self.replay {
                src.bytes.extend_from_slice(b);
                src.ends.push(src.bytes.len());
            }
            self.drop_chunk_log();
        }
        Ok(())
    }

    /// Without logs (`logs`): keeps of the committed chunk's log only the ids the
    /// next [`Change`] reports (below the current level's counts), then
    /// empties the log — its buffers are reused by the next chunk, so the
    /// decoder's memory does not grow with the records.
    fn drop_chunk_log(&mut self) {
        let r = &mut self.recs;
        let (vl, fl) = (r.v_at[self.level], r.f_at[self.level]);
        self.pending_moved
            .extend(r.moved.iter().map(|m| m.0).filter(|&v| v < vl));
        self.pending_rw
            .extend(r.rw.iter().map(|w| w.0).filter(|&s| s < fl));
        // Distinct ids stay below the level's counts: dedup when the lists
        // outgrow them, so a client that never refines keeps O(level) —
        // through a bit set, linear (a sort here was 4 % of loki's
        // forward-only decode).
        for (ids, n) in [(&mut self.pending_moved, vl), (&mut self.pending_rw, fl)] {
            if ids.len() > 2 * n as usize + 1024 {
                sorted_distinct_below(ids, n);
            }
        }
        r.moved.clear();
        r.rw.clear();
        // The log offsets restart at the committed level: no level before
        // it has entries now.
        r.at0 = r.op.len();
        for at in [&mut r.moved_at, &mut r.rw_at] {
            at.clear();
            at.push(0);
        }
    }

    /// Decompresses chunk `i` into `payload` and decodes its records
    /// straight into the committed lists. Records become available only
    /// when the whole chunk checked out (spec §7.2): on failure the frontier
    /// is rolled back with the chunk's own undo data and the lists are
    /// truncated to the last good chunk.
    fn decode_chunk(
        &mut self,
        i: u32,
        info: &ChunkInfo,
        h: &Header,
        b: &[u8],
        payload: &mut Vec<u8>,
    ) -> Result<(), DecodeError> {
        self.decompress_into(Section::Chunk(i), b, info.uncompressed_len, payload)?;
        let mut rd = codec::split_streams(payload)
            .map_err(|m| DecodeError::invalid(Section::Chunk(i), m))?;
        let mut st = self
            .frontier
            .take()
            .ok_or_else(|| DecodeError::Internal("no frontier".into()))?;
        let r = &mut self.recs;
        let k0 = r.op.len();
        let lens = (r.moved.len(), r.rw.len());
        // Room for the chunk as the table states it, but never more than its
        // payload could hold (every record, new vertex and appended face
        // takes at least one byte): a hostile table cannot make this
        // allocate beyond the payload size counted in the memory estimate.
        let cap = payload.len();
        let n_rec = (info.record_count as usize).min(cap);
        let n_v = (info.vertex_count as usize)
            .saturating_sub(st.q.len())
            .min(cap);
        let n_f = (info.face_count as usize)
            .saturating_sub(st.quads.len())
            .min(cap);
        let logs = self.logs;
        r.reserve(n_rec, if logs { n_rec } else { 0 });
        st.reserve(n_v, n_f);
        let decode = if logs {
            Self::decode_chunk_records::<true>
        } else {
            Self::decode_chunk_records::<false>
        };
        let result = decode(
            i,
            info,
            h,
            k0 as u32,
            &mut st,
            &mut rd,
            r,
            &mut self.rec,
            &mut self.buffers,
        );
        if result.is_err() {
            if logs {
                for k in (k0..r.op.len()).rev() {
                    st.undo_deltas(
                        r.v_at[k] as usize,
                        r.f_at[k] as usize,
                        r.moved_of(k),
                        r.rw_of(k),
                    );
                }
            } else {
                // No per-record offsets: the chunk's records undone at
                // once (the log holds only this chunk's entries).
                st.undo_deltas(
                    r.v_at[k0] as usize,
                    r.f_at[k0] as usize,
                    &r.moved[lens.0..],
                    &r.rw[lens.1..],
                );
            }
            r.op.truncate(k0);
            for at in [&mut r.v_at, &mut r.f_at] {
                at.truncate(k0 + 1);
            }
            // `at0 <= k0`: the chunk's levels are covered.
            for at in [&mut r.moved_at, &mut r.rw_at] {
                at.truncate(k0 + 1 - r.at0);
            }
            r.moved.truncate(lens.0);
            r.rw.truncate(lens.1);
        }
        self.frontier = Some(st);
        Ok(result?)
    }

    /// Decodes and applies the records of chunk `i` to `st`, appending them
    /// to `r` (whose last level is `st`'s); then checks that every stream is
    /// consumed and the counts match the chunk table. On error `r` holds the
    /// records applied so far. `rec` and `buffers` are reused per record.
    /// With `LOGS` each level gets its log offsets too
    /// ([`Records::push_level`]), else only its counts.
    #[allow(clippy::too_many_arguments)]
    fn decode_chunk_records<const LOGS: bool>(
        i: u32,
        info: &ChunkInfo,
        h: &Header,
        first_record: u32,
        st: &mut MeshState,
        rd: &mut [Reader<'_>; 5],
        r: &mut Records,
        rec: &mut codec::QRecord,
        buffers: &mut codec::DecodeScratch,
    ) -> Result<(), FormatError> {
        let mut cur = Cursors::default();
        // On a large mesh, the lines the next records' levels go to
        // (`prefetch_tail`). (Small meshes measured even, as for
        // `MeshState`'s look-ahead.) Every 16th record: each list grows
        // by one entry of at most 4 bytes a record, so a hint per 16
        // records still reaches every new 64-byte line, where one per
        // record repeated each hint 16 to 64 times.
        let big = st.q.len() >= codec::PREFETCH_MIN_VERTICES;
        for t in 0..info.record_count {
            if big && t % 16 == 0 {
                r.prefetch_tail::<LOGS>();
            }
            // Decoded and applied (the compact forms fused, without the
            // explicit rewritten list); on error `st` is as before.
            codec::decode_apply_record(
                st,
                rd,
                &mut cur,
                h.final_vertex_count,
                h.final_face_count,
                h.version_major,
                rec,
                buffers,
                &mut r.moved,
                &mut r.rw,
                // The explicit new vertices and quads serve only a replay
                // below the deepest level: unwound from the frontier when
                // one first needs them (`Records::new_pos`).
                None,
            )
            .map_err(|message| FormatError::BadRecord {
                chunk: i,
                record: first_record + t,
                message,
            })?;
            if !LOGS {
                r.push_counts(rec.op, st);
            } else if !r.push_level(rec.op, st) {
                // A log past 4 G entries: this record is undone here (it
                // has no level; the caller rolls back the others).
                let k = r.op.len();
                let (m0, w0) = (r.moved_at(k), r.rw_at(k));
                st.undo_deltas(
                    r.v_at[k] as usize,
                    r.f_at[k] as usize,
                    &r.moved[m0..],
                    &r.rw[w0..],
                );
                return Err(FormatError::BadRecord {
                    chunk: i,
                    record: first_record + t,
                    message: "the undo log exceeds 2^32 entries".into(),
                });
            }
        }
        for s in rd.iter() {
            if s.remaining() != 0 {
                return Err(FormatError::Invalid {
                    section: Section::Chunk(i),
                    message: format!("{} unused bytes in stream {}", s.remaining(), s.name),
                });
            }
        }
        if st.q.len() as u32 != info.vertex_count || st.quads.len() as u32 != info.face_count {
            return Err(FormatError::Invalid {
                section: Section::Chunk(i),
                message: format!(
                    "records reach {} vertices and {} faces, the table says {} and {}",
                    st.q.len(),
                    st.quads.len(),
                    info.vertex_count,
                    info.face_count
                ),
            });
        }
        Ok(())
    }

    fn on_section(
        &mut self,
        i: u32,
        tag: [u8; 4],
        ulen: u32,
        crc: u32,
        b: &[u8],
    ) -> Result<(), DecodeError> {
        Self::check_crc(Section::Optional(i), b, crc)?;
        let neighbours = match tag {
            TAG_VORD => false,
            TAG_VNBR => true,
            _ => return Ok(()), // unknown optional section: skipped (spec §8)
        };
        let name = if neighbours { "VNBR" } else { "VORD" };
        let bad = |m: String| DecodeError::invalid(Section::Optional(i), m);
        let h = self
            .header
            .as_ref()
            .ok_or_else(|| DecodeError::Internal("section before header".into()))?;
        let n = h.final_vertex_count;
        let flag = if neighbours {
            FLAG_VERTEX_NEIGHBOURS
        } else {
            FLAG_VERTEX_ORDER
        };
        if h.flags & flag == 0 {
            return Err(bad(format!(
                "a {name} section is present but header flag bit {} is clear",
                flag.trailing_zeros()
            )));
        }
        if self.vertex_order_section.is_some() {
            return Err(bad(format!(
                "a second vertex-order section ({name}; a file holds at most one VORD or VNBR)"
            )));
        }
        // VORD: every entry is one varint of 1 to 10 bytes; VNBR: one
        // symbol byte per vertex plus at most one rank varint per vertex
        // (spec §8). Bound the stated length before it sizes a buffer, then
        // count the buffer and the decoder's arrays in the memory budget,
        // which the header and table checks did not cover: VORD 5 bytes per
        // vertex (permutation, seen-set); VNBR at most 48 per vertex and 64
        // per quad (permutation, walk state, corner lists, capped
        // neighbour lists).
        let (n64, ulen64) = (n as u64, ulen as u64);
        let max = if neighbours { 11 * n64 } else { 10 * n64 };
        if ulen64 < n64 || ulen64 > max {
            return Err(bad(format!(
                "{name} uncompressed length {ulen} outside {n}..={max} for {n} vertices"
            )));
        }
        let state = if neighbours {
            48 * n64 + 64 * h.final_face_count as u64
        } else {
            5 * n64
        };
        let est = Limits::estimate(
            h.final_vertex_count as u64,
            h.final_face_count as u64,
            h.record_count as u64,
            self.payload_total + ulen64,
        )
        .saturating_add(state);
        if est > self.limits.max_memory_bytes {
            return Err(DecodeError::LimitsExceeded(format!(
                "{name} section: estimated memory {est} bytes > max_memory_bytes {}",
                self.limits.max_memory_bytes
            )));
        }
        // The frame's structure is cheap to check now; decompressing and
        // the permutation wait until the order is first asked for (spec §8:
        // a reader may defer them).
        check_single_frame(b, ulen).map_err(bad)?;
        self.vertex_order_section = Some(PendingOrder {
            index: i,
            neighbours,
            compressed: b.to_vec(),
            uncompressed_len: ulen,
        });
        Ok(())
    }

    /// Decodes the kept vertex-order section (see [`Decoder::vertex_order`]).
    fn decode_vertex_order(&self, p: &PendingOrder) -> Result<Vec<u32>, DecodeError> {
        let section = Section::Optional(p.index);
        let bad = |m: String| DecodeError::invalid(section, m);
        let h = self
            .header
            .as_ref()
            .ok_or_else(|| DecodeError::Internal("section before header".into()))?;
        let n = h.final_vertex_count;
        let mut zstd = new_zstd()?;
        let mut payload = Vec::new();
        decompress_frame(
            &mut zstd,
            section,
            &p.compressed,
            p.uncompressed_len,
            &mut payload,
        )?;
        if p.neighbours {
            // Sections come after the last chunk and nothing changes the
            // frontier after it, so the frontier is the finest level
            // whatever level the caller is at.
            let st = self
                .frontier
                .as_ref()
                .filter(|st| st.q.len() == n as usize)
                .ok_or_else(|| DecodeError::Internal("VNBR before the finest level".into()))?;
            crate::vorder::decode(
                &payload,
                n as usize,
                &st.quads,
                h.base_vertex_count as usize,
            )
            .map_err(bad)
        } else {
            Self::decode_vord(&payload, n).map_err(bad)
        }
    }

    /// The `VORD` permutation: `n` svarint deltas (spec §8.1).
    fn decode_vord(payload: &[u8], n: u32) -> Result<Vec<u32>, String> {
        let mut r = Reader::new(payload, "VORD");
        let mut order = Vec::with_capacity(n as usize);
        let mut seen = vec![false; n as usize];
        let mut prev = 0i64;
        for k in 0..n {
            let v = prev.saturating_add(r.s()?);
            match usize::try_from(v).ok().and_then(|u| seen.get_mut(u)) {
                Some(s) if !*s => *s = true,
                _ => return Err(format!("VORD entry {k} = {v} is out of range or repeated")),
            }
            order.push(v as u32);
            prev = v;
        }
        if r.remaining() != 0 {
            return Err("unused bytes in VORD".into());
        }
        Ok(order)
    }

    // ---- navigation -------------------------------------------------------

    /// The current level.
    pub fn level(&self) -> usize {
        self.level
    }

    /// Deepest level reachable now (`None` before the base mesh).
    pub fn deepest_level(&self) -> Option<usize> {
        (!self.recs.v_at.is_empty()).then_some(self.recs.op.len())
    }

    /// Resolves `t` to a level among the decoded ones.
    pub fn resolve(&self, t: Target) -> Result<usize, DecodeError> {
        let deepest = self.deepest_level().ok_or_else(|| {
            DecodeError::Parameter("no level is available before the base mesh is decoded".into())
        })?;
        Ok(match t {
            Target::Level(k) => k.min(deepest),
            Target::Faces(n) => {
                let f_at = &self.recs.f_at[..=deepest];
                f_at.partition_point(|&f| f as usize <= n).saturating_sub(1)
            }
            Target::Error(e) => {
                let h = self.header.as_ref().map_or(0.0, |h| h.base_error);
                if h as f64 <= e {
                    0
                } else {
                    (0..self.chunks_ready as usize)
                        .find(|&c| self.chunks[c].error as f64 <= e)
                        .map_or(deepest, |c| self.chunk_levels[c])
                }
            }
        })
    }

    /// Goes to `t` if that is finer than the current level (else no change).
    pub fn refine_to(&mut self, t: Target) -> Result<Change, DecodeError> {
        let k = self.resolve(t)?;
        self.go_to(k.max(self.level))
    }

    /// Goes to `t` if that is coarser than the current level (else no change).
    pub fn coarsen_to(&mut self, t: Target) -> Result<Change, DecodeError> {
        let k = self.resolve(t)?;
        self.go_to(k.min(self.level))
    }

    /// Goes to `t`, refining or coarsening.
    pub fn set_level(&mut self, t: Target) -> Result<Change, DecodeError> {
        let k = self.resolve(t)?;
        self.go_to(k)
    }

    /// Gives the current level its own codes and quads again (a copy of
    /// the frontier's) if it shares the frontier's (see `shared`).
    fn unshare(&mut self) {
        if !self.shared {
            return;
        }
        if let Some(st) = &self.frontier {
            self.q.clear();
            self.q.extend_from_slice(&st.q);
            self.quads.clear();
            self.quads.extend_from_slice(&st.quads);
        }
        self.shared = false;
    }

    /// Every record decoded so far, its undo logs included, decoded again
    /// from the base mesh and the kept compressed chunks (`replay`), with
    /// a copy of the base mesh as the frontier.
    fn rebuilt_logs(&self) -> Result<Records, DecodeError> {
        let mut st = self.kept_base()?;
        self.decode_logs(&mut st)
    }

    /// The base mesh decoded again from `replay`.
    fn kept_base(&self) -> Result<MeshState, DecodeError> {
        let (Some(src), Some(h)) = (&self.replay, &self.header) else {
            return Err(DecodeError::Internal("no base mesh kept".into()));
        };
        let mut payload = Vec::new();
        decompress_frame(
            &mut new_zstd()?,
            Section::BaseMesh,
            &src.base,
            h.base_uncompressed_len,
            &mut payload,
        )?;
        let qmax = self.quant.map_or(0, |q| q.qmax());
        crate::base::decode(
            &payload,
            h.base_vertex_count,
            h.base_face_count,
            qmax,
            h.version_major,
        )
        .map_err(|m| DecodeError::invalid(Section::BaseMesh, m))
    }

    /// Every record decoded so far, its undo logs included, decoded again
    /// from the kept compressed chunks (`replay`) onto `st`, which holds
    /// the base mesh: `st` ends at the deepest level. The decoding is
    /// deterministic: the levels are the ones decoded on arrival (checked:
    /// counts of every level).
    fn decode_logs(&self, st: &mut MeshState) -> Result<Records, DecodeError> {
        let src = self
            .replay
            .as_ref()
            .ok_or_else(|| DecodeError::Internal("no chunks kept for the undo logs".into()))?;
        let h = self
            .header
            .as_ref()
            .ok_or_else(|| DecodeError::Internal("no header".into()))?;
        let n = self.recs.v_at.len();
        let mut r = Records::default();
        r.reserve(n, n);
        r.v_at.push(st.q.len() as u32);
        r.f_at.push(st.quads.len() as u32);
        r.moved_at.push(0);
        r.rw_at.push(0);
        if let (Some(&v), Some(&f)) = (self.recs.v_at.last(), self.recs.f_at.last()) {
            st.reserve(
                (v as usize).saturating_sub(st.q.len()),
                (f as usize).saturating_sub(st.quads.len()),
            );
        }
        let mut zstd = new_zstd()?;
        let mut payload = Vec::new();
        let mut rec = codec::QRecord::default();
        let mut buffers = codec::DecodeScratch::default();
        let mut start = 0;
        for (i, &end) in src.ends.iter().enumerate() {
            let info = self
                .chunks
                .get(i)
                .ok_or_else(|| DecodeError::Internal("chunk index".into()))?;
            let section = Section::Chunk(i as u32);
            let b = &src.bytes[start..end];
            start = end;
            decompress_frame(&mut zstd, section, b, info.uncompressed_len, &mut payload)?;
            let mut rd =
                codec::split_streams(&payload).map_err(|m| DecodeError::invalid(section, m))?;
            let k0 = r.op.len() as u32;
            Self::decode_chunk_records::<true>(
                i as u32,
                info,
                h,
                k0,
                st,
                &mut rd,
                &mut r,
                &mut rec,
                &mut buffers,
            )?;
        }
        if r.v_at != self.recs.v_at || r.f_at != self.recs.f_at {
            return Err(DecodeError::Internal(
                "the undo logs decoded again reach other levels".into(),
            ));
        }
        Ok(r)
    }

    /// Gives a general decoder its undo logs for every record decoded so
    /// far (see `logs`), once: the chunks are decoded again, on the
    /// frontier itself set back to the base mesh (its arrays reused: no
    /// second frontier beside it, so the memory stays within
    /// [`Limits::estimate`]). Keeps them for every later chunk.
    fn ensure_logs(&mut self) -> Result<(), DecodeError> {
        if self.logs || self.forward_only {
            return Ok(());
        }
        let base = self.kept_base()?;
        let Some(mut st) = self.frontier.take() else {
            return Err(DecodeError::Internal("no frontier".into()));
        };
        st.reset_to(&base);
        drop(base);
        let full = self.decode_logs(&mut st);
        self.frontier = Some(st);
        let full = match full {
            Ok(full) => full,
            Err(e) => {
                // Only a bug gets here (the chunks decoded before): the
                // frontier is not the deepest level any more.
                self.failed_other = Some(e.to_string());
                return Err(e);
            }
        };
        let r = &mut self.recs;
        (r.moved, r.rw, r.moved_at, r.rw_at) = (full.moved, full.rw, full.moved_at, full.rw_at);
        r.at0 = 0;
        // The logs from the current level on name these ids.
        self.pending_moved = Vec::new();
        self.pending_rw = Vec::new();
        self.replay = None;
        self.logs = true;
        Ok(())
    }

    /// Appends the new codes and quads of records `kept..` (to the deepest
    /// level) to `recs.new_pos` / `recs.appended`, unwound from the
    /// frontier: once for the records decoded so far, on the first replay
    /// that needs them.
    fn keep_records(&mut self) -> Result<(), DecodeError> {
        let r = &self.recs;
        let k0 = r.kept;
        let (v0, f0) = (r.v_at[k0] as usize, r.f_at[k0] as usize);
        let (q, quads) = self
            .frontier
            .as_ref()
            .and_then(|st| unwound(r, st, v0, f0, k0))
            .ok_or_else(|| DecodeError::Internal("no frontier to unwind".into()))?;
        let r = &mut self.recs;
        r.new_pos.extend_from_slice(&q);
        r.appended.extend_from_slice(&quads);
        r.kept = r.op.len();
        Ok(())
    }

    fn go_to(&mut self, to: usize) -> Result<Change, DecodeError> {
        if to != self.level {
            // Only a move away from the deepest level reaches here while
            // shared (a refinement needs a new chunk, which unshared).
            self.unshare();
        }
        let from = self.level;
        if to >= self.recs.v_at.len() {
            return Err(DecodeError::Internal(format!("level {to} not decoded")));
        }
        let to_frontier = frontier_at(&self.frontier, &self.recs, to).is_some();
        if to != from && !(to > from && to_frontier) && !self.forward_only {
            // Anything but a refinement to the deepest level replays the
            // logs.
            self.ensure_logs()?;
        }
        if to > from && to > self.recs.kept && !to_frontier && !self.forward_only {
            // A replay below the deepest level needs the new codes and
            // quads of its records.
            self.keep_records()?;
        }
        let r = &self.recs;
        let (v_from, v_to) = (r.v_at[from], r.v_at[to]);
        let (f_from, f_to) = (r.f_at[from], r.f_at[to]);
        let (bv, bf) = (r.v_at[0], r.f_at[0]);
        let mut moved = Vec::new();
        let mut rewritten = Vec::new();
        let quant = self.quant;
        let f32_of = |c: [u32; 3]| quant.map_or([0.0; 3], |q| q.dequantize(c).map(|x| x as f32));
        // The frontier *is* the deepest decoded level: a long refinement to
        // it copies the frontier's arrays in order instead of replaying each
        // record's writes at scattered slots (on bunny the replay's cache
        // misses were a third of the decoder's). The logs are still read,
        // in order, for the ids the `Change` reports. Both ways give the
        // same level and the same `Change` (test `frontier_copy_equals_replay`);
        // the copy is taken when the records to replay write more entries
        // than a sixteenth of the level holds.
        let at_to = frontier_at(&self.frontier, r, to);
        // Without logs the ids to update are the pending ones. Counted only
        // when `to` is the deepest level (`at_to`), so `to >= from` and the
        // log offsets do not run backwards.
        let frontier = at_to.filter(|_| {
            let entries = if self.logs {
                (r.rw_at(to) - r.rw_at(from)) + (r.moved_at(to) - r.moved_at(from))
            } else {
                self.pending_moved.len() + self.pending_rw.len()
            };
            self.copy_policy.copies(entries, (v_from + f_from) as usize)
        });
        if self.forward_only && to != from && (to < from || at_to.is_none()) {
            return Err(DecodeError::Parameter(format!(
                "a forward-only decoder moves only to the deepest decoded level ({}), not from level {from} to {to}",
                r.v_at.len() - 1
            )));
        }
        if let (true, Some(st)) = (to > from, frontier) {
            // Without logs: the dropped logs' ids, kept per chunk.
            moved.append(&mut self.pending_moved);
            rewritten.append(&mut self.pending_rw);
            for &(v, _) in &r.moved[r.moved_at(from)..r.moved_at(to)] {
                if v < v_from {
                    moved.push(v);
                }
            }
            for &(s, _) in &r.rw[r.rw_at(from)..r.rw_at(to)] {
                if s < f_from {
                    rewritten.push(s);
                }
            }
            for &v in &moved {
                self.pos[v as usize] = f32_of(st.q[v as usize]);
            }
            extend_f32(&mut self.pos, &st.q[v_from as usize..], quant.as_ref());
            // The codes and quads are the frontier's (see `shared`).
            self.shared = true;
        } else if let (true, Some(st)) = (to > from, at_to) {
            // A short refinement to the deepest level: the records' writes
            // to what the caller has, replayed; the new vertices and quads
            // are the frontier's (their values at this level).
            self.q.extend_from_slice(&st.q[v_from as usize..]);
            extend_f32(&mut self.pos, &st.q[v_from as usize..], quant.as_ref());
            self.quads.extend_from_slice(&st.quads[f_from as usize..]);
            // Without logs (dropped at each chunk's commit): the ids they
            // named, kept per chunk, get the frontier's values.
            for v in self.pending_moved.drain(..) {
                let p = st.q[v as usize];
                self.q[v as usize] = p;
                self.pos[v as usize] = f32_of(p);
                moved.push(v);
            }
            for s in self.pending_rw.drain(..) {
                self.quads[s as usize] = st.quads[s as usize];
                rewritten.push(s);
            }
            for k in from..to {
                for &(v, d) in r.moved_of(k) {
                    if v < v_from {
                        let p = codec::xor3(self.q[v as usize], d);
                        self.q[v as usize] = p;
                        self.pos[v as usize] = f32_of(p);
                        moved.push(v);
                    }
                }
                for &(s, d) in r.rw_of(k) {
                    if s < f_from {
                        let q = &mut self.quads[s as usize];
                        *q = codec::xor4(*q, d);
                        rewritten.push(s);
                    }
                }
            }
        } else if to > from {
            let nv = (v_to - bv) as usize;
            let new = r
                .new_pos
                .get((v_from - bv) as usize..nv)
                .ok_or_else(|| DecodeError::Internal("replay past the kept records".into()))?;
            self.q.extend_from_slice(new);
            extend_f32(&mut self.pos, new, quant.as_ref());
            for k in from..to {
                // Only changes to what the caller already has are reported
                // (ids below `v_from` / `f_from`): collecting the others
                // only to drop them below cost a sort of every rewrite of a
                // long refinement.
                // The level holds each entry's old value: the delta gives
                // the new one.
                for &(v, d) in r.moved_of(k) {
                    let p = codec::xor3(self.q[v as usize], d);
                    self.q[v as usize] = p;
                    self.pos[v as usize] = f32_of(p);
                    if v < v_from {
                        moved.push(v);
                    }
                }
                for &(s, d) in r.rw_of(k) {
                    let q = &mut self.quads[s as usize];
                    *q = codec::xor4(*q, d);
                    if s < f_from {
                        rewritten.push(s);
                    }
                }
                let app = (r.f_at[k] - bf) as usize..(r.f_at[k + 1] - bf) as usize;
                self.quads.extend_from_slice(
                    r.appended.get(app).ok_or_else(|| {
                        DecodeError::Internal("replay past the kept records".into())
                    })?,
                );
            }
        } else if to < from {
            for k in (to..from).rev() {
                self.q.truncate(r.v_at[k] as usize);
                self.pos.truncate(r.v_at[k] as usize);
                self.quads.truncate(r.f_at[k] as usize);
                // The level holds each entry's new value: the delta gives
                // the old one.
                for &(v, d) in r.moved_of(k).iter().rev() {
                    let o = codec::xor3(self.q[v as usize], d);
                    self.q[v as usize] = o;
                    self.pos[v as usize] = f32_of(o);
                    if v < v_to {
                        moved.push(v);
                    }
                }
                for &(s, d) in r.rw_of(k).iter().rev() {
                    let q = &mut self.quads[s as usize];
                    *q = codec::xor4(*q, d);
                    if s < f_to {
                        rewritten.push(s);
                    }
                }
            }
        }
        self.level = to;
        let (vmin, fmin) = (v_from.min(v_to), f_from.min(f_to));
        sorted_distinct_below(&mut moved, vmin);
        sorted_distinct_below(&mut rewritten, fmin);
        Ok(Change {
            from_level: from,
            to_level: to,
            vertices_appended: v_from.min(v_to)..v_to,
            vertices_removed: v_to..v_from.max(v_to),
            vertices_moved: moved,
            faces_rewritten: rewritten,
            faces_appended: f_from.min(f_to)..f_to,
            faces_truncated: f_to..f_from.max(f_to),
        })
    }

    /// A change that uploads the whole current level into empty buffers
    /// (every vertex and face appended): what a renderer applies once, when
    /// [`Event::BaseMeshReady`] arrives or after it recreates its buffers.
    pub fn full_upload(&self) -> Change {
        Change {
            from_level: self.level,
            to_level: self.level,
            vertices_appended: 0..self.position_codes().len() as u32,
            faces_appended: 0..self.quads().len() as u32,
            ..Change::default()
        }
    }

    // ---- access -----------------------------------------------------------

    /// The header (after [`Event::HeaderReady`]).
    pub fn header(&self) -> Option<&Header> {
        self.header.as_ref()
    }

    /// The chunk table (empty before [`Event::HeaderReady`]).
    pub fn chunks(&self) -> &[ChunkInfo] {
        &self.chunks
    }

    /// The quantization grid (after the header).
    pub fn quantizer(&self) -> Option<Quantizer> {
        self.quant
    }

    /// How the file's base section is coded (spec §6): the traversal
    /// layout (4.0 files whose base the writer could number in the walk's
    /// order) or the corner deltas; `None` until the base is decoded.
    pub fn base_layout(&self) -> Option<crate::base::BaseLayout> {
        self.base_layout
    }

    /// A bounding box `[min, max]` of every level's positions (after the
    /// header): the header's exact bounds when it has them (version 3.2,
    /// spec §3), else the grid, which holds every position too (tight for
    /// files with the box grid, §5, up to the rounding of `min + q × step`,
    /// which can pass the grid's maximum by an ulp).
    pub fn bounds(&self) -> Option<[[f64; 3]; 2]> {
        let h = self.header.as_ref()?;
        Some(h.bounds.unwrap_or([h.bbox_min, h.bbox_max]))
    }

    /// Positions of the current level as f32 (dequantized in f64, then
    /// rounded to f32), ready for a vertex buffer.
    pub fn positions(&self) -> &[[f32; 3]] {
        &self.pos
    }

    /// Quantization codes of the current level's vertices.
    pub fn position_codes(&self) -> &[[u32; 3]] {
        match &self.frontier {
            Some(st) if self.shared => &st.q,
            _ => &self.q,
        }
    }

    /// Positions of the current level in f64, exactly as the spec dequantizes.
    pub fn positions_f64(&self) -> Vec<DVec3> {
        match &self.quant {
            Some(q) => self
                .position_codes()
                .iter()
                .map(|&c| q.dequantize_vec(c))
                .collect(),
            None => Vec::new(),
        }
    }

    /// Quads of the current level, by slot (counter-clockwise).
    pub fn quads(&self) -> &[[u32; 4]] {
        match &self.frontier {
            Some(st) if self.shared => &st.quads,
            _ => &self.quads,
        }
    }

    /// Triangle index buffer of the current level: quad `f` becomes
    /// triangles `2f = (v0, v1, v2)` and `2f + 1 = (v0, v2, v3)`.
    pub fn triangle_indices(&self) -> Vec<u32> {
        self.quads()
            .iter()
            .flat_map(|q| quad_triangles(*q))
            .collect()
    }

    /// The current level as an [`IndexedMesh`] (f64 positions).
    pub fn to_indexed_mesh(&self) -> IndexedMesh {
        IndexedMesh::from_faces(self.positions_f64(), self.quads().iter())
    }

    /// Vertex count and face count of level `k`, if decoded.
    pub fn level_counts(&self, k: usize) -> Option<(u32, u32)> {
        Some((*self.recs.v_at.get(k)?, *self.recs.f_at.get(k)?))
    }

    /// The input vertex order (canonical id → input vertex index at the
    /// finest level); `Ok(None)` until a `VORD` or `VNBR` section has
    /// arrived (and for files without one).
    ///
    /// The section is decoded here, on the first call, not when it arrives
    /// (only exporters need the order, and decoding it costs a large part
    /// of a whole-file decode); later calls return the cached result. A bad
    /// section is then a [`DecodeError::Format`] naming it, returned by
    /// every call; it affects only the order, never the levels (spec §8).
    pub fn vertex_order(&self) -> Result<Option<&[u32]>, DecodeError> {
        let Some(p) = &self.vertex_order_section else {
            return Ok(None);
        };
        match self
            .vertex_order
            .get_or_init(|| self.decode_vertex_order(p))
        {
            Ok(order) => Ok(Some(order)),
            Err(e) => Err(e.duplicate()),
        }
    }

    /// Progress: what is decoded, what is missing.
    pub fn status(&self) -> Status {
        let h = self.header.as_ref();
        let waiting_for = match self.stage {
            _ if self.failed.is_some() || self.failed_other.is_some() => None,
            Stage::Prefix | Stage::Header(_) => Some(Section::Header),
            Stage::Table => Some(Section::ChunkTable),
            Stage::Base => Some(Section::BaseMesh),
            Stage::Chunk(i) => Some(Section::Chunk(i)),
            Stage::SectionHead(i) | Stage::SectionBody(i, ..) => Some(Section::Optional(i)),
            Stage::Done => None,
        };
        let bytes_needed = match self.stage {
            Stage::Prefix => None,
            _ => self
                .need()
                .map(|n| n.saturating_sub(self.avail().len()) as u64),
        };
        Status {
            bytes_consumed: self.consumed,
            bytes_buffered: self.avail().len() as u64,
            header_ready: !self.chunks.is_empty()
                || !matches!(self.stage, Stage::Prefix | Stage::Header(_) | Stage::Table),
            base_ready: !self.recs.v_at.is_empty(),
            chunks_ready: self.chunks_ready,
            chunk_count: h.map(|h| h.chunk_count),
            deepest_level: self.deepest_level(),
            final_level: h.map(|h| h.record_count as usize),
            waiting_for,
            bytes_needed: if waiting_for.is_some() {
                bytes_needed
            } else {
                None
            },
            bytes_to_last_chunk: self
                .chunks
                .last()
                .map(|c| c.offset + c.compressed_len as u64)
                .or_else(|| {
                    h.filter(|_| {
                        !matches!(self.stage, Stage::Prefix | Stage::Header(_) | Stage::Table)
                    })
                    .map(|h| h.header_len as u64 + 4 + h.base_compressed_len as u64)
                }),
            finished: self.stage == Stage::Done && self.failed.is_none(),
            failed: self.failed.is_some() || self.failed_other.is_some(),
        }
    }

    /// Rebuilds a [`ProgressiveMesh`] from everything decoded so far
    /// (dequantized positions). `level_error[k]` is the error of the last
    /// chunk boundary at or before `k` — an upper bound, since the file
    /// stores errors per chunk only. `None` before the base mesh and for a
    /// [`Decoder::forward_only`] decoder (it keeps no records). Its
    /// `vertex_order` is the file's once every level is decoded (this
    /// decodes the section if [`Decoder::vertex_order`] has not), and empty
    /// before, without a section, or when the section is bad (call
    /// [`Decoder::vertex_order`] for the error).
    pub fn to_progressive_mesh(&self) -> Option<ProgressiveMesh> {
        if self.forward_only {
            return None;
        }
        let quant = self.quant?;
        // A general decoder without its logs yet decodes them again here
        // (without keeping them: this takes `&self`).
        let rebuilt;
        let r = if self.logs {
            &self.recs
        } else {
            rebuilt = self.rebuilt_logs().ok()?;
            &rebuilt
        };
        let (bv, bf) = (*r.v_at.first()? as usize, *r.f_at.first()? as usize);
        let dq = |c: [u32; 3]| quant.dequantize_vec(c);
        // Every record undone from the frontier: level 0's codes and quads,
        // then each record's new ones as it made them.
        let (all_q, all_quads) = unwound(r, self.frontier.as_ref()?, 0, 0, 0)?;
        let mut q = all_q[..bv].to_vec();
        let mut quads = all_quads[..bf].to_vec();
        let base = IndexedMesh::from_faces(q.iter().map(|&c| dq(c)).collect(), quads.iter());
        // The records' explicit new codes and quads: a replay from level 0.
        let mut records = Vec::with_capacity(r.op.len());
        for k in 0..r.op.len() {
            let new_pos = &all_q[r.v_at[k] as usize..r.v_at[k + 1] as usize];
            let appended = &all_quads[r.f_at[k] as usize..r.f_at[k + 1] as usize];
            q.extend_from_slice(new_pos);
            let moved = r
                .moved_of(k)
                .iter()
                .map(|&(v, d)| {
                    let p = codec::xor3(q[v as usize], d);
                    q[v as usize] = p;
                    (v, dq(p))
                })
                .collect();
            let mut rewritten: Vec<(u32, [u32; 4])> = r
                .rw_of(k)
                .iter()
                .map(|&(s, d)| {
                    let n = codec::xor4(quads[s as usize], d);
                    quads[s as usize] = n;
                    (s, n)
                })
                .collect();
            // The log of a fused record is in star order; a record lists
            // its slots ascending.
            rewritten.sort_unstable_by_key(|w| w.0);
            quads.extend_from_slice(appended);
            records.push(SplitRecord {
                op: r.op[k],
                new_vertices: new_pos.iter().map(|&c| dq(c)).collect(),
                moved,
                rewritten,
                appended_faces: appended.to_vec(),
            });
        }
        let base_error = self.header.as_ref().map_or(0.0, |h| h.base_error as f64);
        let mut level_error = vec![base_error; r.op.len() + 1];
        for (c, &l) in self.chunk_levels.iter().enumerate() {
            for e in level_error.iter_mut().skip(l) {
                *e = self.chunks[c].error as f64;
            }
        }
        let vertex_order =
            if self.deepest_level() == self.header.as_ref().map(|h| h.record_count as usize) {
                // An undecodable order is left out, as if the file had
                // none ([`Decoder::vertex_order`] says why).
                self.vertex_order()
                    .ok()
                    .flatten()
                    .map(<[u32]>::to_vec)
                    .unwrap_or_default()
            } else {
                Vec::new()
            };
        Some(ProgressiveMesh {
            base,
            records,
            vertex_order,
            level_error,
        })
    }
}

/// The two triangles of a quad: `(v0, v1, v2)` and `(v0, v2, v3)`.
pub fn quad_triangles(q: [u32; 4]) -> [u32; 6] {
    [q[0], q[1], q[2], q[0], q[2], q[3]]
}

/// The two triangles of a quad split along its shorter diagonal, as
/// modelling tools draw quads: `(v1, v2, v3)` and `(v1, v3, v0)` where
/// `v1–v3` is strictly shorter, else [`quad_triangles`]. Lengths are
/// measured on the quantization codes `codes` (the decoder's
/// [`Decoder::position_codes`]) scaled by the grid's `step` per axis
/// ([`crate::Quantizer::step`]); on the cube grid (one step) in exact
/// integers. The rule of `pqm_core::io::quad_split_diagonal` and of
/// pqm-three's `quadSplit: 'shorter'`.
///
/// For a renderer that picks the split when it writes a slot: files that
/// keep each quad's meant diagonal ([`crate::Header::finest_diagonals`],
/// a paired triangle mesh) are better drawn with [`quad_triangles`].
pub fn quad_triangles_shorter(q: [u32; 4], codes: &[[u32; 3]], step: [f64; 3]) -> [u32; 6] {
    let cube = step[0] == step[1] && step[1] == step[2];
    let d2 = |u: u32, v: u32| {
        let (a, b) = (codes[u as usize], codes[v as usize]);
        (0..3)
            .map(|k| {
                let t = a[k] as f64 - b[k] as f64;
                let t = if cube { t } else { t * step[k] };
                t * t
            })
            .sum::<f64>()
    };
    if d2(q[1], q[3]) < d2(q[0], q[2]) {
        [q[1], q[2], q[3], q[1], q[3], q[0]]
    } else {
        quad_triangles(q)
    }
}

/// Checks that `data` is exactly one Zstandard frame (no skippable frame, no
/// trailing frame or bytes) whose header states the content size `ulen`
/// (spec §1). zstd itself would decode concatenated frames as one payload,
/// which small JavaScript decoders do not: refusing them keeps every reader
/// in agreement.
/// Spec §1: a block holds at most `min(window, 128 KiB)` bytes (RFC 8878's
/// Block_Maximum_Size). libzstd accepts larger blocks in some frames, small
/// decoders do not, so every reader rejects them (walks the 3-byte block
/// headers without decoding: raw and compressed blocks carry `size` bytes,
/// an RLE block one). Called after the magic and checksum flag are checked;
/// anything malformed in the header is left to libzstd's own checks.
fn check_block_sizes(data: &[u8]) -> Result<(), String> {
    let Some(&fhd) = data.get(4) else {
        return Ok(());
    };
    let single = (fhd >> 5) & 1 == 1;
    let mut p = 5usize;
    let mut window: u64 = 0;
    if !single {
        let Some(&wd) = data.get(p) else {
            return Ok(());
        };
        p += 1;
        let base = 1u64 << (10 + (wd >> 3));
        window = base + (base / 8) * u64::from(wd & 7);
    }
    p += [0, 1, 2, 4][usize::from(fhd & 3)];
    let fcs_len = match fhd >> 6 {
        0 => usize::from(single),
        f => 1 << f,
    };
    let Some(fcs_bytes) = data.get(p..p + fcs_len) else {
        return Ok(());
    };
    let mut fcs = fcs_bytes
        .iter()
        .rev()
        .fold(0u64, |a, &b| (a << 8) | u64::from(b));
    if fcs_len == 2 {
        fcs += 256;
    }
    p += fcs_len;
    if single {
        window = fcs;
    }
    let block_max = window.min(128 * 1024);
    while let Some(h) = data.get(p..p + 3) {
        let bh = u32::from(h[0]) | u32::from(h[1]) << 8 | u32::from(h[2]) << 16;
        let (last, kind, size) = (bh & 1 == 1, (bh >> 1) & 3, bh >> 3);
        if kind != 3 && u64::from(size) > block_max {
            return Err(format!(
                "zstd block of {size} bytes exceeds the frame's maximum block size {block_max} (window or 128 KiB)"
            ));
        }
        p += 3 + if kind == 1 { 1 } else { size as usize };
        if last {
            break;
        }
    }
    Ok(())
}

/// A zstd context that refuses windows beyond [`MAX_WINDOW_LOG`].
fn new_zstd() -> Result<zstd::bulk::Decompressor<'static>, DecodeError> {
    let mut d =
        zstd::bulk::Decompressor::new().map_err(|e| DecodeError::Internal(e.to_string()))?;
    d.set_parameter(zstd::zstd_safe::DParameter::WindowLogMax(MAX_WINDOW_LOG))
        .map_err(|e| DecodeError::Internal(e.to_string()))?;
    Ok(d)
}

/// Decompresses the single frame `data` of `ulen` bytes into `out`
/// (cleared first; its buffer is reused).
fn decompress_frame(
    d: &mut zstd::bulk::Decompressor<'static>,
    section: Section,
    data: &[u8],
    ulen: u32,
    out: &mut Vec<u8>,
) -> Result<(), DecodeError> {
    check_single_frame(data, ulen).map_err(|m| DecodeError::invalid(section, m))?;
    // `ulen` was counted in the memory estimate (chunk table check).
    out.clear();
    out.reserve(ulen as usize);
    let n = d
        .decompress_to_buffer(data, out)
        .map_err(|e| DecodeError::invalid(section, format!("zstd: {e}")))?;
    if n != ulen as usize || out.len() != n {
        return Err(DecodeError::invalid(
            section,
            format!("decompressed to {n} bytes, expected {ulen}"),
        ));
    }
    Ok(())
}

fn check_single_frame(data: &[u8], ulen: u32) -> Result<(), String> {
    const ZSTD_MAGIC: u32 = 0xFD2F_B528;
    if data.len() < 4 || LE::read_u32(data) != ZSTD_MAGIC {
        return Err("not a Zstandard frame (bad frame magic)".into());
    }
    // Frame_Header_Descriptor bit 2: Content_Checksum_flag (spec §1 forbids it)
    if data.get(4).is_some_and(|fhd| fhd & 0x04 != 0) {
        return Err(
            "zstd frame carries a content checksum (not allowed: the section CRC covers it)".into(),
        );
    }
    check_block_sizes(data)?;
    let len = zstd::zstd_safe::find_frame_compressed_size(data)
        .map_err(|_| "zstd: cannot find the end of the frame".to_string())?;
    if len != data.len() {
        return Err(format!(
            "{} bytes after the zstd frame (a section holds exactly one frame)",
            data.len().saturating_sub(len)
        ));
    }
    match zstd::zstd_safe::get_frame_content_size(data) {
        Ok(Some(n)) if n == ulen as u64 => Ok(()),
        Ok(Some(n)) => Err(format!(
            "zstd frame holds {n} bytes, the file states {ulen}"
        )),
        Ok(None) => Err("zstd frame header lacks the content size".into()),
        Err(_) => Err("zstd: bad frame header".into()),
    }
}

/// Decodes a complete file held in memory (all levels available, current
/// level 0). A file that ends early is `FormatError::Truncated`.
pub fn decode_all(bytes: &[u8], limits: Limits) -> Result<Decoder, DecodeError> {
    let mut d = Decoder::new(limits);
    d.push(bytes)?;
    let s = d.status();
    if !s.finished {
        return Err(FormatError::Truncated(format!(
            "input ends after {} bytes while waiting for the {}",
            bytes.len(),
            s.waiting_for.map_or("rest".to_string(), |w| w.to_string())
        ))
        .into());
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::{
        check_block_sizes, put_into, sorted_distinct_below, take_from, CopyPolicy, Decoder, Limits,
        Target,
    };
    use crate::{write_to_vec, EncodeOptions};
    use pqm_core::progressive::testgen;
    use proptest::prelude::*;
    use std::sync::Mutex;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// Refining to the deepest level by copying the frontier gives the
        /// same level (codes, f32 positions, quads) and the same `Change`
        /// as replaying the records, on random walks that often end at the
        /// deepest level, over whole files and over prefixes (the deepest
        /// level then is a chunk boundary before the end), with moved
        /// vertices, face splits and edge splits.
        #[test]
        fn frontier_copy_equals_replay(
            seed in any::<u64>(),
            walk in proptest::collection::vec(prop_oneof![0usize..200, Just(usize::MAX)], 1..10),
            cut in 0.3f64..1.0,
            version_major in 1u16..=4,
        ) {
            let mut pm = testgen::generate(seed, 120);
            crate::vectors::add_face_splits(&mut pm, 30, seed);
            crate::vectors::add_edge_splits(&mut pm, 10, seed);
            let opts = EncodeOptions { chunk_records: Some(13), version_major, ..EncodeOptions::default() };
            let bytes = write_to_vec(&pm, &opts).expect("encode").0;
            let cut = if cut > 0.9 { bytes.len() } else { (bytes.len() as f64 * cut) as usize };
            let mut dec = [CopyPolicy::Never, CopyPolicy::Always].map(|policy| {
                let mut d = Decoder::new(Limits::default());
                d.copy_policy = policy;
                // A prefix may end inside a chunk: that is no error.
                let _ = d.push(&bytes[..cut]);
                d
            });
            prop_assume!(dec[0].deepest_level().is_some());
            for &t in &walk {
                let [a, b] = &mut dec;
                let ca = a.set_level(Target::Level(t)).unwrap();
                let cb = b.set_level(Target::Level(t)).unwrap();
                prop_assert_eq!(&ca, &cb);
                prop_assert_eq!(a.quads(), b.quads());
                prop_assert_eq!(a.position_codes(), b.position_codes());
                prop_assert_eq!(a.positions(), b.positions());
            }
        }
    }

    /// A file of a generated mesh of 120 faces, default options.
    fn small_file(seed: u64) -> Vec<u8> {
        let pm = testgen::generate(seed, 120);
        write_to_vec(&pm, &EncodeOptions::default())
            .expect("encode")
            .0
    }

    /// The recycling slot keeps the last decoder put into it, only within
    /// the byte budget, and a decoder that took one over leaves the slot
    /// empty; dropping a decoder that does not recycle leaves it alone.
    #[test]
    fn recycling_slot_keeps_the_last_decoder_within_budget() {
        let bytes = small_file(7);
        let decoded = || {
            let mut d = Decoder::empty(Limits::default(), false);
            d.push(&bytes).expect("decode");
            d
        };
        let slot = Mutex::new(None);
        let d = decoded();
        let held = d.retained_bytes();
        assert!(
            held > bytes.len(),
            "a decoded file holds its arrays: {held}"
        );
        put_into(&slot, decoded(), held - 1);
        assert!(slot.lock().unwrap().is_none(), "over the budget: freed");
        put_into(&slot, d, held);
        assert!(slot.lock().unwrap().is_some());
        put_into(&slot, Decoder::empty(Limits::default(), true), usize::MAX);
        let taken = take_from(&slot).expect("the last one put");
        assert!(taken.forward_only && taken.retained_bytes() == 0);
        assert!(!taken.recycle, "a husk is freed when dropped");
        assert!(take_from(&slot).is_none());
        let mut fresh = Decoder::empty(Limits::default(), false);
        let before = fresh.retained_bytes();
        fresh.adopt(decoded());
        assert!(fresh.retained_bytes() > before, "adopted the allocations");
        let again = fresh.push(&bytes).expect("decode after adopting");
        let want = Decoder::empty(Limits::default(), false)
            .push(&bytes)
            .expect("decode");
        assert_eq!(again, want);
    }

    /// A new decoder never takes over more than its memory limit: with a
    /// limit of 0 it owns nothing, whatever the process's slot holds (a
    /// decoder dropped here is put there first).
    #[test]
    fn new_decoder_takes_over_nothing_above_its_limit() {
        let bytes = small_file(11);
        let mut d = Decoder::new(Limits::default());
        d.push(&bytes).expect("decode");
        assert!(d.retained_bytes() > 0);
        drop(d);
        let tight = Limits {
            max_memory_bytes: 0,
            ..Limits::default()
        };
        assert_eq!(Decoder::new(tight).retained_bytes(), 0);
        assert_eq!(Decoder::forward_only(tight).retained_bytes(), 0);
    }

    /// Pushes `bytes` in pieces of `piece` bytes; the events, or the
    /// first error as text, and the status after.
    fn push_pieces(
        d: &mut Decoder,
        bytes: &[u8],
        piece: usize,
    ) -> (Result<Vec<super::Event>, String>, super::Status) {
        let mut events = Vec::new();
        for p in bytes.chunks(piece.max(1)) {
            match d.push(p) {
                Ok(e) => events.extend(e),
                Err(e) => return (Err(e.to_string()), d.status()),
            }
        }
        (Ok(events), d.status())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(40))]
        /// A decoder reset after any first file — decoded whole, cut
        /// short, failed on a corrupted byte, or moved below its deepest
        /// level (its undo logs rebuilt) — decodes the next file exactly
        /// as a fresh decoder of its kind does: the same events, status
        /// and errors, the same levels and changes on a walk over them.
        /// So does a new decoder that took over a dropped one's
        /// allocations (`recycled`), of either kind.
        #[test]
        fn reset_decoder_equals_fresh(
            seed_a in any::<u64>(),
            seed_b in any::<u64>(),
            first in 0u8..4,
            cut in 0.0f64..1.0,
            flip in any::<prop::sample::Index>(),
            forward in any::<bool>(),
            recycled in any::<bool>(),
            forward_first in any::<bool>(),
            majors in (1u16..=4, 1u16..=4),
            piece in 1usize..400,
            walk in proptest::collection::vec(prop_oneof![0usize..200, Just(usize::MAX)], 1..6),
        ) {
            let file = |seed: u64, n: usize, version_major: u16, chunk: usize| {
                let mut pm = testgen::generate(seed, n);
                crate::vectors::add_face_splits(&mut pm, 20, seed);
                crate::vectors::add_edge_splits(&mut pm, 8, seed);
                let opts = EncodeOptions {
                    chunk_records: Some(chunk),
                    version_major,
                    ..EncodeOptions::default()
                };
                write_to_vec(&pm, &opts).expect("encode").0
            };
            let a = file(seed_a, 150, majors.0, 11);
            let b = file(seed_b, 90, majors.1, 7);
            let new = || if forward {
                Decoder::forward_only(Limits::default())
            } else {
                Decoder::new(Limits::default())
            };
            // A recycled decoder may have been of the other kind.
            let mut used = if recycled {
                Decoder::empty(Limits::default(), forward_first)
            } else {
                new()
            };
            match first {
                0 => { let _ = used.push(&a); }
                1 => { let _ = used.push(&a[..(a.len() as f64 * cut) as usize]); }
                2 => {
                    let mut bad = a.clone();
                    let i = flip.index(bad.len());
                    bad[i] ^= 0x5a;
                    let _ = used.push(&bad);
                }
                _ => {
                    let _ = used.push(&a);
                    if !used.forward_only {
                        let _ = used.set_level(Target::Level(0));
                        let _ = used.set_level(Target::Level(usize::MAX));
                    }
                }
            }
            if recycled {
                // Dropped into a slot and taken out by a new decoder, as
                // `Decoder::drop` and `Decoder::new` do with `RECYCLED`.
                let slot = Mutex::new(None);
                put_into(&slot, used, usize::MAX);
                used = Decoder::empty(Limits::default(), forward);
                used.adopt(take_from(&slot).expect("kept"));
            } else {
                used.reset(Limits::default());
            }
            // Owns no allocation (`new` may take another test's).
            let mut fresh = Decoder::empty(Limits::default(), forward);
            let got = push_pieces(&mut used, &b, piece);
            let want = push_pieces(&mut fresh, &b, piece);
            prop_assert_eq!(&got, &want);
            prop_assert_eq!(used.base_layout(), fresh.base_layout());
            for &t in &walk {
                let t = if forward { usize::MAX } else { t };
                let cu = used.set_level(Target::Level(t)).map_err(|e| e.to_string());
                let cf = fresh.set_level(Target::Level(t)).map_err(|e| e.to_string());
                prop_assert_eq!(&cu, &cf);
                prop_assert_eq!(used.level(), fresh.level());
                prop_assert_eq!(used.quads(), fresh.quads());
                prop_assert_eq!(used.position_codes(), fresh.position_codes());
                prop_assert_eq!(used.positions(), fresh.positions());
            }
            if !forward {
                prop_assert_eq!(used.to_progressive_mesh(), fresh.to_progressive_mesh());
            }
        }
    }

    proptest! {
        /// The bit-set path and the sort path of `sorted_distinct_below`
        /// both give the distinct ids below the bound, ascending: few ids
        /// or many, with repeats, over small and large bounds.
        #[test]
        fn distinct_below_equals_sort_dedup(
            ids in proptest::collection::vec(0u32..5000, 0..3000),
            bound in 0u32..6000,
        ) {
            let mut want: Vec<u32> = ids.iter().copied().filter(|&v| v < bound).collect();
            want.sort_unstable();
            want.dedup();
            let mut got = ids.clone();
            sorted_distinct_below(&mut got, bound);
            prop_assert_eq!(got, want);
        }
    }

    /// Streaming with a refinement to the deepest level after every chunk
    /// (the level then shares the frontier's arrays, and the next chunk
    /// must give it its own copy first) ends at the same mesh as a
    /// whole-file decode, and a move back to level 0 gives the base mesh.
    #[test]
    fn refining_after_every_chunk_equals_decode_all() {
        let mut pm = testgen::generate(7, 150);
        crate::vectors::add_face_splits(&mut pm, 20, 7);
        let opts = EncodeOptions {
            chunk_records: Some(9),
            ..EncodeOptions::default()
        };
        let bytes = write_to_vec(&pm, &opts).expect("encode").0;
        let mut all = super::decode_all(&bytes, Limits::default()).unwrap();
        let base_quads = all.quads().to_vec();
        let base_codes = all.position_codes().to_vec();
        all.set_level(Target::Level(usize::MAX)).unwrap();
        for forward in [false, true] {
            let mut d = if forward {
                Decoder::forward_only(Limits::default())
            } else {
                Decoder::new(Limits::default())
            };
            for piece in bytes.chunks(37) {
                d.push(piece).unwrap();
                // A chunk that arrived does not change the current level.
                if let Some((v, f)) = d.level_counts(d.level()) {
                    assert_eq!(d.quads().len(), f as usize);
                    assert_eq!(d.position_codes().len(), v as usize);
                    assert_eq!(d.positions().len(), v as usize);
                }
                if d.deepest_level().is_some() {
                    d.set_level(Target::Level(usize::MAX)).unwrap();
                }
            }
            assert_eq!(d.quads(), all.quads());
            assert_eq!(d.position_codes(), all.position_codes());
            assert_eq!(d.positions(), all.positions());
            if !forward {
                d.set_level(Target::Level(0)).unwrap();
                assert_eq!(d.quads(), &base_quads[..]);
                assert_eq!(d.position_codes(), &base_codes[..]);
            }
        }
    }

    /// Undo logs asked for before the base mesh are written while decoding:
    /// no compressed chunk is kept to rebuild them, and the first move below
    /// the deepest level decodes nothing again (the levels are checked in
    /// `tests/roundtrip.rs`); a default general decoder keeps the chunks
    /// until that move and drops them after it.
    #[test]
    fn undo_logs_asked_for_up_front_keep_no_chunks() {
        let mut pm = testgen::generate(7, 120);
        crate::vectors::add_edge_splits(&mut pm, 10, 7);
        let opts = EncodeOptions {
            chunk_records: Some(11),
            ..EncodeOptions::default()
        };
        let bytes = write_to_vec(&pm, &opts).expect("encode").0;
        let mut eager = Decoder::new(Limits::default());
        eager.keep_undo_logs().unwrap();
        eager.push(&bytes).unwrap();
        assert!(eager.logs && eager.replay.is_none());
        let mut lazy = Decoder::new(Limits::default());
        lazy.push(&bytes).unwrap();
        assert!(!lazy.logs && lazy.replay.as_ref().is_some_and(|r| !r.ends.is_empty()));
        for d in [&mut eager, &mut lazy] {
            d.set_level(Target::Level(usize::MAX)).unwrap();
            d.set_level(Target::Level(0)).unwrap();
            assert!(d.logs && d.replay.is_none());
        }
        assert_eq!(eager.quads(), lazy.quads());
        assert_eq!(eager.position_codes(), lazy.position_codes());
    }

    /// A single-segment frame of content size `fcs` whose only block is raw
    /// and `size` bytes long.
    fn frame(fcs: u8, size: u32) -> Vec<u8> {
        let mut f = vec![0x28, 0xB5, 0x2F, 0xFD, 0x20, fcs];
        let bh = 1 | (size << 3);
        f.extend_from_slice(&bh.to_le_bytes()[..3]);
        f.extend(std::iter::repeat_n(7u8, size as usize));
        f
    }

    #[test]
    fn blocks_larger_than_the_window_are_rejected() {
        assert!(check_block_sizes(&frame(10, 10)).is_ok());
        let e = check_block_sizes(&frame(10, 16)).expect_err("block of 16 > window 10");
        assert!(
            e.contains("16 bytes") && e.contains("maximum block size 10"),
            "{e}"
        );
    }
}
