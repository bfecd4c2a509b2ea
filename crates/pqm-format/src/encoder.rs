//! The `.pqm` writer: [`write()`] a [`ProgressiveMesh`] in one pass to any
//! `Write` (chunks are buffered in memory because the chunk table, which
//! holds their offsets and lengths, comes first).
//!
//! Steps: validate the mesh; compute the bounding box of every position it
//! ever shows; quantize everything on that one grid; run the decoder's
//! [`MeshState`] alongside and code each record in the split form when that
//! reproduces it exactly, else in the face-split form likewise (version 2),
//! else in the edge-split form likewise (version 3), else in the local
//! form when its changes lie around one vertex (nearly
//! every other coarsener record), else in the general form; cut
//! chunks by record count or payload size; compress each chunk as an
//! independent zstd frame.

use crate::codec::{self, Coding, Cursors, MeshState, QRecord, CONN, OPS, POS, REFS, SLOTS};
use crate::error::EncodeError;
use crate::layout::*;
use crate::quant::{Grid, Quantizer};
use crate::varint::put_s;
use pqm_core::ProgressiveMesh;
use std::io::Write;

/// Encoder settings.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodeOptions {
    /// Quantization bits per axis, 8..=24 (default 14).
    pub bits: u8,
    /// Close a chunk after this many records (`None`: only `chunk_bytes` decides).
    pub chunk_records: Option<usize>,
    /// Close a chunk once its uncompressed payload reaches this many bytes
    /// (default 16 KiB: a few thousand splits, so a client can stop often),
    /// at the next step boundary (after a record that is not a doublet
    /// re-insertion; at most twice this size).
    pub chunk_bytes: usize,
    /// Let chunks grow with the file: a chunk closes once its payload
    /// reaches `chunk_bytes` *and* this fraction of the payload of all
    /// earlier chunks (default 0.1; 0: every chunk `chunk_bytes`). Each
    /// chunk then adds at most about a tenth of what came before it once
    /// the file is past ten chunks, so a client still gets small steps
    /// while the base and the first levels arrive, and the fine end, where
    /// a step changes little, is coded in fewer, larger frames that zstd
    /// compresses better (and a shorter chunk table: the base shows
    /// sooner). Measured: positions + connectivity 1.9 % smaller on the
    /// bunny, 2.6 % on amo (whole files 1.5 and 1.7 %).
    pub chunk_growth: f64,
    /// zstd compression level, 1..=22 (default 19).
    pub zstd_level: i32,
    /// zstd window log, 10..=25 (default 21; the spec caps it at 25 so that
    /// small pure-JavaScript decoders can read every frame).
    pub window_log: u32,
    /// Use the compact split form where it applies (default true; false
    /// codes every record in the general form, for measurement and tests).
    pub split_form: bool,
    /// Use the local form (spec §7.7) where it is smaller than the general
    /// form (default true).
    pub local_form: bool,
    /// Use the face-split form (spec §7.9) where it applies (default true;
    /// version 2 and later).
    pub face_split_form: bool,
    /// Use the edge-split form (spec §7.10) where it applies (default true;
    /// version 3 only).
    pub edge_split_form: bool,
    /// Major version to write (default 3): 2 writes a 2.0 file (no
    /// edge-split form) for readers that predate 3.0; 1 a 1.1 file with the
    /// version-1 prediction and no face-split form, for readers that
    /// predate 2.0 and to keep testing the 1.x rules.
    pub version_major: u16,
    /// Write the mesh's vertex order when it has one (default true), as
    /// `vertex_order_code` says; older majors than 3 always get `VORD`.
    pub vertex_order: bool,
    /// Which vertex-order section to write (default
    /// [`VertexOrderCode::Smaller`]).
    pub vertex_order_code: VertexOrderCode,
    /// Only the input indices below this mean something to the user
    /// (default `None`: all do). The writer may then give the others out
    /// anew, in the order the `VNBR` section codes in the fewest bits
    /// ([`crate::vorder::free_tail`]), and does where that section comes
    /// out smaller than the whole order's: `pqm encode` passes the input's
    /// vertex count when it split a triangle or mixed mesh into quads, whose
    /// edge and face points are its own. [`write_stored`] returns the
    /// order written.
    pub vertex_order_keep: Option<usize>,
    /// How the zstd frames of the base and the record chunks are cut into
    /// blocks (default [`ZstdBlocks::Auto`]). Every choice is one standard
    /// frame per section (spec §1); only size and decode time differ.
    pub zstd_blocks: ZstdBlocks,
    /// Where each stored quad's corner list starts (default
    /// [`CornerOrder::Input`]; `pqm encode` writes
    /// [`CornerOrder::Canonical`]).
    pub corner_order: CornerOrder,
    /// Set header flag bit 3 (default false; a 4.1 file): at the finest
    /// level every quad's `v0–v2` diagonal is the one its triangles meant
    /// — the caller's word, for a mesh whose finest quads are pairs of
    /// input triangles across their `q0–q2` diagonal (`pqm_core::pairing`).
    /// Only with a corner order that keeps the mesh's diagonals
    /// ([`CornerOrder::Input`] or [`CornerOrder::Diagonal`]) and major
    /// version 4.
    pub finest_diagonals: bool,
    /// The quantization grid (default [`Grid::Cube`], as Draco; spec §5).
    /// With `Cube` and major version 3 the header also carries the
    /// positions' exact bounds (a 3.2 file).
    pub grid: Grid,
    /// zstd's minimum match length for the base and chunk frames (default
    /// [`ZstdMinMatch::Auto`]). Every choice is a standard frame; only
    /// size and decode time differ.
    pub zstd_min_match: ZstdMinMatch,
}

/// zstd's minimum match length (its `ZSTD_c_minMatch` parameter) for the
/// frames of the base and the record chunks.
///
/// Level 19 looks for matches from 3 bytes on. In the record streams (mostly
/// varints of near-random residuals) those short matches are rarely worth
/// their sequence codes, and each costs the decoder a sequence to execute;
/// from 5 or 6 bytes on, zstd codes more bytes as Huffman literals, which
/// is smaller on most sections and faster to decode (session 18, `Auto`
/// against `Level`: spot −0.4 %, makehuman −1.1 %, loki −1.6 %, the split
/// bunny −2.4 %; zstd's decode instructions −17 to −23 %; `pqm encode`
/// 10 % longer on the bunny).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ZstdMinMatch {
    /// Per section and block layout, the level's own minimum, 5 and 6
    /// (three compressions where there was one), the cheapest frame kept
    /// (bytes plus [`BLOCK_PENALTY_BYTES`] per extra block); on a tie
    /// within a layout the longer minimum, whose frame decodes in fewer
    /// sequences.
    #[default]
    Auto,
    /// The compression level's own minimum (3 at level 19): the frames
    /// written before this option.
    Level,
    /// This minimum, 3..=7 (zstd clamps it to what the level's strategy
    /// supports: 6 at level 19).
    Fixed(u32),
}

impl ZstdMinMatch {
    /// The minimum match lengths to try, 0 standing for the level's own.
    fn candidates(self) -> Vec<u32> {
        match self {
            ZstdMinMatch::Auto => vec![0, 5, 6],
            ZstdMinMatch::Level => vec![0],
            ZstdMinMatch::Fixed(n) => vec![n],
        }
    }
}

/// Where each stored quad's corner list starts.
///
/// Every compact record form stores a 2-bit rotation for each quad it
/// builds (spec §7.5, §7.9, §7.10), which is what keeps the input's first
/// corner of every quad. Only the rotation's parity matters to a renderer:
/// it picks the diagonal that splits the quad into two triangles
/// ([`crate::quad_triangles`]: `(v0, v1, v2)` and `(v0, v2, v3)`), and a
/// rotation by 2 keeps it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CornerOrder {
    /// Each quad starts where the progressive mesh's quad starts: the
    /// finest level lists every input quad's corners as the input did.
    #[default]
    Input,
    /// A quad a record builds may start at its opposite corner instead (a
    /// rotation by 2), whichever makes its rotation field 0 or 1, and keeps
    /// that start until a later record builds the slot again. Every quad
    /// keeps its diagonal, so every level splits into exactly the same
    /// triangles as with `Input`; the file is 2.2–2.5 % smaller (session
    /// 15: spot, makehuman, loki, the split bunny). The finest level equals
    /// the input up to where each quad's corner list starts;
    /// [`write_stored`] returns the progressive mesh the file holds. Under
    /// both turning orders a record keeps the form it has under `Input` (a
    /// face split whose quads turn stays a face split).
    Diagonal,
    /// A quad a record builds starts where the record's form builds it
    /// (every rotation field 0), and keeps that start until a later record
    /// builds the slot again. Every quad keeps its corners in their cyclic
    /// order, not always its diagonal: a renderer may split some quads
    /// along the other one. (The input's diagonals carry nothing on the
    /// bench meshes: 39–52 % of their quads are split along the shorter
    /// one, 50–57 % here, and the mean angle between a quad's two
    /// triangles moves by −0.05° to +0.10°.) Under `Diagonal` the fields
    /// still cost ≈ 1 bit per refined vertex; all 0, which every reader
    /// already decodes (no format change), they leave the geometry 2.5–3.5 %
    /// smaller than with `Diagonal` (the files 2.2–3.1 %), and decoding
    /// takes 0.5–1.2 % fewer instructions (session 22: the six bench
    /// meshes).
    /// [`write_stored`] returns the progressive mesh the file holds.
    Canonical,
}

/// How the vertex order is written (spec §8). Both sections give the same
/// permutation; they differ in size and in which readers understand them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum VertexOrderCode {
    /// Whichever of `VNBR` and `VORD` compresses smaller, `VORD` on a tie
    /// (a 3.0 reader can read it too). `VNBR` wins on nearly every real
    /// mesh (3.3–14.5 against 4.7–22 bits per vertex), but where the
    /// coarsener renumbered long strips at once (fandisk's chord collapses)
    /// the plain deltas can be a few bytes smaller.
    #[default]
    Smaller,
    /// Always the 3.1 `VNBR` section (spec §8.2).
    Neighbours,
    /// Always the 3.0 `VORD` section (deltas, spec §8.1), for readers that
    /// predate 3.1 (they skip `VNBR`).
    Deltas,
}

/// Block layout of a section's zstd frame. A zstd block carries its own
/// literal Huffman and sequence tables; a chunk's streams (operation
/// symbols, connectivity varints, vertex-cursor deltas, position
/// residuals) and the base's two parts (corner deltas, code deltas) have
/// statistics of their own, so a block each codes them as if compressed
/// alone, in the same frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ZstdBlocks {
    /// One block per frame (up to zstd's 128 KiB block size): the smallest
    /// work for a decoder. Files before this option were written so.
    Single,
    /// Per section, whichever layout (a chunk: one block; ops + conn + refs
    /// | slots + pos; ops | conn + refs | slots + pos; ops | conn | refs |
    /// slots + pos; the base: one block or corners | codes) is smallest once each extra block is
    /// charged [`BLOCK_PENALTY_BYTES`] (what it costs a JavaScript decoder).
    #[default]
    Auto,
    /// Always a block per part: ops | conn | refs | slots + pos, and
    /// corners | codes for the base.
    PerPart,
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            bits: 14,
            chunk_records: None,
            chunk_bytes: 16 * 1024,
            chunk_growth: 0.1,
            zstd_level: 19,
            window_log: 21,
            split_form: true,
            local_form: true,
            face_split_form: true,
            edge_split_form: true,
            version_major: VERSION_MAJOR,
            vertex_order: true,
            vertex_order_code: VertexOrderCode::Smaller,
            vertex_order_keep: None,
            zstd_blocks: ZstdBlocks::Auto,
            corner_order: CornerOrder::Input,
            finest_diagonals: false,
            grid: Grid::Cube,
            zstd_min_match: ZstdMinMatch::Auto,
        }
    }
}

/// Bits per vertex of the refinement records, split by content.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BitsPerVertex {
    /// Connectivity (symbols, counts, wings, vertex references, slots).
    pub connectivity: f64,
    /// Position residuals.
    pub positions: f64,
    /// Both (all record chunk bytes).
    pub total: f64,
}

/// What [`write()`] produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EncodeReport {
    /// Header bytes.
    pub header_bytes: u64,
    /// Chunk table bytes (entries + CRC).
    pub table_bytes: u64,
    /// Base mesh section bytes (compressed).
    pub base_bytes: u64,
    /// All record chunks (compressed).
    pub chunk_bytes: u64,
    /// Optional sections, headers included.
    pub section_bytes: u64,
    /// Whole file.
    pub total_bytes: u64,
    /// Number of chunks.
    pub chunk_count: usize,
    /// Records coded in the split form.
    pub split_records: usize,
    /// Records coded in the general form.
    pub general_records: usize,
    /// Records coded in the local form.
    pub local_records: usize,
    /// Records coded in the face-split form.
    pub face_split_records: usize,
    /// Records coded in the edge-split form.
    pub edge_split_records: usize,
    /// Uncompressed bytes per stream (ops, conn, refs, slots, pos), all chunks.
    pub stream_raw_bytes: [u64; 5],
    /// Compressed chunk bytes attributed to each stream: every stream is also
    /// compressed alone and the chunk's real size is shared in proportion.
    pub stream_bytes: [f64; 5],
    /// Vertices added by the records (final − base).
    pub refined_vertices: u64,
    /// Record chunk bits per refined vertex.
    pub bits_per_vertex: BitsPerVertex,
    /// Whole-file bits per final vertex (base, table and sections included).
    pub file_bits_per_vertex: f64,
    /// Per operator kind (index = `OpKind as usize`): what its records hold
    /// and which share of each stream they take (see [`OpStats`]).
    pub per_op: [OpStats; 4],
}

/// What the records of one operator kind hold and cost (a measuring aid:
/// find where the bits go).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OpStats {
    /// Records of this kind.
    pub records: usize,
    /// Of them, coded in each form (index = form number, spec §7.3).
    pub forms: [usize; 5],
    /// Sums over the records of new vertices, moved vertices, rewritten
    /// slots and appended quads (divide by `records` for the average).
    pub new: u64,
    /// See `new`.
    pub moved: u64,
    /// See `new`.
    pub rewritten: u64,
    /// See `new`.
    pub appended: u64,
    /// Uncompressed bytes this kind wrote into each stream.
    pub raw_bytes: [u64; 5],
    /// Compressed bytes attributed to this kind per stream: each stream's
    /// compressed share ([`EncodeReport::stream_bytes`]) split in proportion
    /// to the raw bytes each kind wrote into it within the chunk.
    pub bytes: [f64; 5],
}

/// One zstd frame of `data` (frame content size recorded, no checksum, the
/// window of `opts`) in which a block ends at each offset of `cuts`
/// (ascending, inside `data`); returns the frame and the frame's length
/// after each part (the last entry is the frame's length).
///
/// Why blocks: a zstd block carries its own literal Huffman table and
/// sequence tables, and a chunk's five streams have very different byte
/// statistics (operation symbols, small connectivity varints, vertex-cursor
/// deltas, position residuals). One block per stream codes each with its own
/// tables, as if compressed alone, while staying one standard frame that
/// every zstd decoder reads (the format is unchanged: spec §1 asks for one
/// frame, not one block). Matches may still reach into earlier streams.
fn compress_parts(
    data: &[u8],
    cuts: &[usize],
    opts: &EncodeOptions,
    min_match: u32,
) -> Result<(Vec<u8>, Vec<usize>), EncodeError> {
    use zstd::zstd_safe::{
        self, zstd_sys::ZSTD_EndDirective, CCtx, CParameter, InBuffer, OutBuffer,
    };
    let zerr =
        |code: usize| EncodeError::Io(std::io::Error::other(zstd_safe::get_error_name(code)));
    let mut c = CCtx::try_create()
        .ok_or_else(|| EncodeError::Io(std::io::Error::other("cannot allocate a zstd context")))?;
    c.set_parameter(CParameter::CompressionLevel(opts.zstd_level))
        .map_err(zerr)?;
    c.set_parameter(CParameter::WindowLog(opts.window_log))
        .map_err(zerr)?;
    c.set_parameter(CParameter::ContentSizeFlag(true))
        .map_err(zerr)?;
    c.set_parameter(CParameter::ChecksumFlag(false))
        .map_err(zerr)?;
    // 0 keeps the level's own.
    c.set_parameter(CParameter::MinMatch(min_match))
        .map_err(zerr)?;
    c.set_pledged_src_size(Some(data.len() as u64))
        .map_err(zerr)?;
    let mut out: Vec<u8> =
        Vec::with_capacity(zstd_safe::compress_bound(data.len()) + 16 * cuts.len() + 64);
    let mut ends = Vec::with_capacity(cuts.len() + 1);
    let mut from = 0;
    for (i, &to) in cuts.iter().chain(std::iter::once(&data.len())).enumerate() {
        let last = i == cuts.len();
        let directive = if last {
            ZSTD_EndDirective::ZSTD_e_end
        } else {
            ZSTD_EndDirective::ZSTD_e_flush
        };
        let mut input = InBuffer::around(&data[from..to]);
        loop {
            if out.capacity() - out.len() < 4096 {
                out.reserve(64 * 1024);
            }
            let pos = out.len();
            let mut output = OutBuffer::around_pos(&mut out, pos);
            let left = c
                .compress_stream2(&mut output, &mut input, directive)
                .map_err(zerr)?;
            if left == 0 && input.pos() == to - from {
                break;
            }
        }
        from = to;
        ends.push(out.len());
    }
    Ok((out, ends))
}

/// Bytes an extra zstd block must save to be chosen under
/// [`ZstdBlocks::Auto`].
/// A block costs a JavaScript decoder (fzstd) about 20 µs — mostly building
/// its literal Huffman table — which is what ≈ 30 bytes take to arrive at
/// 10 Mbit/s; native zstd hardly notices. Measured on the split bunny
/// (97 chunks): fzstd 19.9 ms with one block per chunk, 25.8 ms with four.
pub const BLOCK_PENALTY_BYTES: usize = 32;

/// A compressed section: the zstd frame, the frame's length after each
/// part, and the block-end offsets it was cut at.
struct Framed {
    frame: Vec<u8>,
    ends: Vec<usize>,
    cuts: Vec<usize>,
}

/// Whichever of `candidates` (block-end offset lists for
/// [`compress_parts`], each ascending and inside `data`), each under every
/// minimum match of `opts.zstd_min_match`, gives the smallest frame once
/// each block past the first is charged [`BLOCK_PENALTY_BYTES`]; ties go
/// to the earlier candidate (list them with fewer blocks first) and,
/// within one, to the later minimum match.
fn compress_best(
    data: &[u8],
    candidates: Vec<Vec<usize>>,
    opts: &EncodeOptions,
) -> Result<Framed, EncodeError> {
    let min_matches = opts.zstd_min_match.candidates();
    let mut best: Option<(usize, Framed)> = None;
    for cuts in candidates {
        for &mm in &min_matches {
            let (frame, ends) = compress_parts(data, &cuts, opts, mm)?;
            let cost = frame.len() + BLOCK_PENALTY_BYTES * cuts.len();
            // `<=` across minimum matches of one layout: on a tie the
            // longer minimum (listed later), fewer sequences to decode.
            let better = match &best {
                Some((c, f)) if f.cuts == cuts => cost <= *c,
                Some((c, _)) => cost < *c,
                None => true,
            };
            if better {
                best = Some((
                    cost,
                    Framed {
                        frame,
                        ends,
                        cuts: cuts.clone(),
                    },
                ));
            }
        }
    }
    best.map(|(_, f)| f)
        .ok_or_else(|| EncodeError::InvalidOptions("no block layout".into()))
}

/// The layouts of `all` (one block first, the most blocks last) that
/// `mode` allows.
fn select_layouts(mut all: Vec<Vec<usize>>, mode: ZstdBlocks) -> Vec<Vec<usize>> {
    match mode {
        ZstdBlocks::Single => all.truncate(1),
        ZstdBlocks::Auto => {}
        ZstdBlocks::PerPart => {
            let last = all.pop().unwrap_or_default();
            all = vec![last];
        }
    }
    all
}

/// The block layouts tried for a chunk payload whose streams start at
/// `starts[0..5]` (`starts[5]` = its length): one block; ops + conn + refs
/// | slots + pos; ops | conn + refs | slots + pos; ops | conn | refs |
/// slots + pos (the slots stream is empty in files of records that need no
/// local or general form). On the meshes of the encode table the last two
/// save 1–3 % of the chunk bytes against one block — the operation symbols
/// above all have statistics of their own.
fn chunk_block_layouts(starts: &[usize; 6]) -> Vec<Vec<usize>> {
    let inside = |c: &[usize]| -> Vec<usize> {
        let mut v: Vec<usize> = c
            .iter()
            .copied()
            .filter(|&x| x > 0 && x < starts[5])
            .collect();
        v.dedup();
        v
    };
    let mut out: Vec<Vec<usize>> = vec![Vec::new()];
    for c in [
        vec![starts[3]],
        vec![starts[1], starts[3]],
        vec![starts[1], starts[2], starts[3]],
    ] {
        let c = inside(&c);
        if !out.contains(&c) {
            out.push(c);
        }
    }
    out
}

struct Chunk {
    info: ChunkInfo,
    bytes: Vec<u8>,
}

/// Encodes `mesh` as a `.pqm` file into `w` (see the module docs and
/// `spec/pqm.md`). Decoding the result gives, at every level `k`, exactly
/// `mesh.level(k)` with positions snapped to the file's grid.
pub fn write(
    mesh: &ProgressiveMesh,
    opts: &EncodeOptions,
    w: impl Write,
) -> Result<EncodeReport, EncodeError> {
    write_impl(mesh, opts, w, None)
}

/// [`write()`], also returning the progressive mesh the file holds: `mesh`
/// itself with [`CornerOrder::Input`]; with [`CornerOrder::Diagonal`],
/// `mesh` with some quads starting at their opposite corner; with
/// [`CornerOrder::Canonical`], at any corner. Decoding the
/// file gives this mesh's level `k` exactly, id for id (positions snapped
/// to the file's grid).
pub fn write_stored(
    mesh: &ProgressiveMesh,
    opts: &EncodeOptions,
    w: impl Write,
) -> Result<(EncodeReport, ProgressiveMesh), EncodeError> {
    let mut records = Vec::with_capacity(mesh.records.len());
    let mut vertex_order = mesh.vertex_order.clone();
    let report = write_impl(mesh, opts, w, Some((&mut records, &mut vertex_order)))?;
    let stored = ProgressiveMesh {
        base: mesh.base.clone(),
        records,
        vertex_order,
        level_error: mesh.level_error.clone(),
    };
    Ok((report, stored))
}

/// [`write()`]; with `stored`, each record as the file holds it (see
/// [`write_stored`]) is pushed there, and the vertex order written (the
/// same unless `vertex_order_keep`) replaces the second.
fn write_impl(
    mesh: &ProgressiveMesh,
    opts: &EncodeOptions,
    mut w: impl Write,
    stored: Option<(&mut Vec<pqm_core::SplitRecord>, &mut Vec<u32>)>,
) -> Result<EncodeReport, EncodeError> {
    let (mut stored, stored_order) = stored.unzip();
    if !(8..=24).contains(&opts.bits) {
        return Err(EncodeError::InvalidOptions(format!(
            "bits = {} (allowed 8..=24)",
            opts.bits
        )));
    }
    if !(10..=MAX_WINDOW_LOG).contains(&opts.window_log) {
        return Err(EncodeError::InvalidOptions(format!(
            "window_log = {} (allowed 10..={MAX_WINDOW_LOG})",
            opts.window_log
        )));
    }
    if !(MIN_VERSION_MAJOR..=VERSION_MAJOR).contains(&opts.version_major) {
        return Err(EncodeError::InvalidOptions(format!(
            "version_major = {} (allowed {MIN_VERSION_MAJOR}..={VERSION_MAJOR})",
            opts.version_major
        )));
    }
    let coding = Coding {
        major: opts.version_major,
        split: opts.split_form,
        face_split: opts.face_split_form,
        local: opts.local_form,
        edge_split: opts.edge_split_form,
        // With the corner orders that turn quads (below), whose files
        // have no earlier bytes to keep.
        face_split_first: opts.corner_order != CornerOrder::Input,
    };
    if opts.finest_diagonals
        && (opts.corner_order == CornerOrder::Canonical || opts.version_major < 4)
    {
        return Err(EncodeError::InvalidOptions(format!(
            "finest_diagonals needs a corner order that keeps the diagonals (input or \
             diagonal, not {:?}) and major version 4 (not {})",
            opts.corner_order, opts.version_major
        )));
    }
    if opts.chunk_records == Some(0) || opts.chunk_bytes == 0 {
        return Err(EncodeError::InvalidOptions(
            "chunk size must be positive".into(),
        ));
    }
    if !(0.0..=16.0).contains(&opts.chunk_growth) {
        return Err(EncodeError::InvalidOptions(format!(
            "chunk growth = {} is not in 0..=16",
            opts.chunk_growth
        )));
    }
    mesh.validate().map_err(EncodeError::InvalidMesh)?;
    let too_big = |n: usize, what: &str| {
        if n > u32::MAX as usize - 1 {
            Err(EncodeError::InvalidMesh(format!(
                "{what} = {n} does not fit the format"
            )))
        } else {
            Ok(n as u32)
        }
    };
    let final_v = too_big(mesh.final_vertex_count(), "final vertex count")?;
    let final_f = too_big(mesh.final_face_count(), "final face count")?;
    if final_f > codec::MAX_FACES {
        return Err(EncodeError::InvalidMesh(format!(
            "final face count {final_f} exceeds {} (32-bit corner ids)",
            codec::MAX_FACES
        )));
    }
    let record_count = too_big(mesh.records.len(), "record count")?;

    // One grid over every position any level shows.
    let all = mesh.base.positions.iter().chain(
        mesh.records
            .iter()
            .flat_map(|r| r.new_vertices.iter().chain(r.moved.iter().map(|m| &m.1))),
    );
    let (mut lo, mut hi) = ([0.0f64; 3], [0.0f64; 3]);
    let mut any_position = false;
    for (i, p) in all.enumerate() {
        any_position = true;
        let p = p.to_array();
        for k in 0..3 {
            if i == 0 || p[k] < lo[k] {
                lo[k] = p[k];
            }
            if i == 0 || p[k] > hi[k] {
                hi[k] = p[k];
            }
        }
    }
    let (grid_lo, grid_hi) = opts.grid.over(lo, hi);
    if (0..3).any(|k| !(grid_hi[k] - grid_lo[k]).is_finite()) {
        return Err(EncodeError::InvalidMesh(
            "bounding box extent is not finite".into(),
        ));
    }
    let quant = Quantizer::new(grid_lo, grid_hi, opts.bits);
    let qp = |p: &glam::DVec3| quant.quantize(*p);
    // The header's bounds (3.2): what a decoder's positions span, so the
    // dequantized codes, not the input. Quantizing and dequantizing are
    // monotone per axis, so those of the input's box are the box of every
    // dequantized code. A mesh without positions has none to give.
    let bounds = (opts.grid == Grid::Cube && opts.version_major >= 3 && any_position)
        .then(|| [lo, hi].map(|p| quant.dequantize(qp(&glam::DVec3::from_array(p)))));

    let base_q: Vec<[u32; 3]> = mesh.base.positions.iter().map(qp).collect();
    let base_quads: Vec<[u32; 4]> = mesh
        .base
        .faces()
        .map(|f| [f[0], f[1], f[2], f[3]])
        .collect();
    // The base section (spec §6): from version 4 the traversal layout when
    // the base can be written in it and it is the smaller, else the deltas.
    let mut base_frames = Vec::with_capacity(2);
    for candidate in [
        Some(crate::base::encode_delta(
            &base_q,
            &base_quads,
            opts.version_major,
        )),
        (opts.version_major >= 4)
            .then(|| crate::base::encode_traversal(&base_q, &base_quads, quant.qmax()))
            .flatten(),
    ]
    .into_iter()
    .flatten()
    {
        let mut layouts = vec![Vec::new()];
        if !candidate.cuts.is_empty() {
            layouts.push(candidate.cuts.clone());
        }
        let layouts = select_layouts(layouts, opts.zstd_blocks);
        let frame = compress_best(&candidate.payload, layouts, opts)?.frame;
        base_frames.push((frame, candidate.payload.len()));
    }
    // the smaller; on a tie the later (the traversal layout)
    let (base_bytes, base_payload_len) = base_frames
        .into_iter()
        .rev()
        .min_by_key(|f| f.0.len())
        .expect("the delta layout is always a candidate");
    let mut state = MeshState::new(quant.qmax(), base_q, base_quads);

    let error_at = |k: usize| -> f32 {
        match mesh.level_error.get(k) {
            Some(&e) => e as f32,
            None if k == mesh.records.len() => 0.0,
            None => f32::INFINITY,
        }
    };

    let mut report = EncodeReport::default();
    let mut chunks: Vec<Chunk> = Vec::new();
    let mut streams: [Vec<u8>; 5] = Default::default();
    let mut cursors = Cursors::default();
    let mut in_chunk = 0u32;
    // Uncompressed payload bytes of the chunks closed so far.
    let mut done_payload = 0usize;
    let mut op_raw = [[0u64; 5]; 4];
    let mut close = |streams: &mut [Vec<u8>; 5],
                     op_raw: &mut [[u64; 5]; 4],
                     in_chunk: &mut u32,
                     cursors: &mut Cursors,
                     state: &MeshState,
                     k: usize,
                     report: &mut EncodeReport|
     -> Result<(), EncodeError> {
        // where each stream (with its length varint) starts in the payload
        let (payload, starts) = codec::join_streams_at(streams);
        let layouts = select_layouts(chunk_block_layouts(&starts), opts.zstd_blocks);
        let Framed {
            frame: bytes,
            ends,
            cuts,
        } = compress_best(&payload, layouts, opts)?;
        // each stream's share of the frame: its block's bytes (the frame
        // header with the first) split by the block's raw bytes
        let mut alone = [0f64; 5];
        let mut prev = 0;
        let mut from = 0;
        for (&to, &end) in cuts
            .iter()
            .chain(std::iter::once(&payload.len()))
            .zip(&ends)
        {
            for t in 0..5 {
                let (lo, hi) = (starts[t].max(from), starts[t + 1].min(to));
                if hi > lo {
                    alone[t] += (end - prev) as f64 * (hi - lo) as f64 / (to - from) as f64;
                }
            }
            prev = end;
            from = to;
        }
        for t in 0..5 {
            report.stream_raw_bytes[t] += streams[t].len() as u64;
            let share = alone[t];
            report.stream_bytes[t] += share;
            for (o, raw) in op_raw.iter().enumerate() {
                if !streams[t].is_empty() {
                    report.per_op[o].bytes[t] += share * raw[t] as f64 / streams[t].len() as f64;
                }
            }
        }
        *op_raw = [[0; 5]; 4];
        chunks.push(Chunk {
            info: ChunkInfo {
                offset: 0,
                compressed_len: bytes.len() as u32,
                uncompressed_len: payload.len() as u32,
                record_count: *in_chunk,
                vertex_count: state.q.len() as u32,
                face_count: state.quads.len() as u32,
                error: error_at(k),
                crc32: crc32(&bytes),
            },
            bytes,
        });
        *streams = Default::default();
        *cursors = Cursors::default();
        *in_chunk = 0;
        Ok(())
    };

    // CornerOrder::Diagonal and Canonical: per face slot, how far the
    // stored quad is rotated from `mesh`'s (`rotl` by 0 or 2; by 0..=3). A
    // slot keeps its turn while records only replace its corners in place,
    // and gets a new one when a record builds it again.
    let canonical = opts.corner_order == CornerOrder::Canonical;
    let turning = canonical || opts.corner_order == CornerOrder::Diagonal;
    // The part of a rotation field the corner order removes.
    let excess = |r: u8| if canonical { r & 3 } else { r & 2 };
    let mut turn: Vec<u8> = if turning {
        vec![0; final_f as usize]
    } else {
        Vec::new()
    };
    let mut built: Vec<(u32, u8)> = Vec::new();
    for (k, rec) in mesh.records.iter().enumerate() {
        let mut q = QRecord::quantized(rec, &quant);
        let before = [0, 1, 2, 3, 4].map(|t| streams[t].len());
        if turning {
            for (slot, quad) in &mut q.rewritten {
                *quad = codec::rotl(*quad, turn[*slot as usize]);
            }
        }
        // With CornerOrder::Diagonal, a quad the record's form builds with
        // a rotation field of 2 or 3 is started at its opposite corner and
        // the record encoded again: its field changes by 2, to 0 or 1
        // (with Canonical, any nonzero field `r`: the quad turned by
        // `4 - r`, its field to 0). A turn changes no other field, but a
        // face split's turned quads can fit the split form too, which
        // codes the same record larger (+4.5 % on the split bunny under
        // Canonical): these orders set `Coding::face_split_first`, so a
        // face split stays one. A few rounds settle it, and any turn is a
        // valid file (only smaller or not).
        let cursors_before = cursors;
        let mut rounds = 0;
        let form = loop {
            let form = codec::encode_record_rotations(
                &state,
                &q,
                &mut cursors,
                &mut streams,
                coding,
                &mut built,
            );
            if !turning || rounds == 4 || built.iter().all(|&(_, r)| excess(r) == 0) {
                break form;
            }
            rounds += 1;
            let f0 = state.quads.len() as u32;
            for &(slot, r) in &built {
                if excess(r) == 0 {
                    continue;
                }
                // The field says the stored quad is the form's `rotl(B, r)`;
                // turned by `x`, it is `rotl(B, r + x)`.
                let x = (4 - excess(r)) & 3;
                let quad = if slot >= f0 {
                    q.appended.get_mut((slot - f0) as usize)
                } else {
                    q.rewritten
                        .binary_search_by_key(&slot, |w| w.0)
                        .ok()
                        .map(|i| &mut q.rewritten[i].1)
                };
                let Some(quad) = quad else {
                    return Err(EncodeError::Internal(format!(
                        "record {k}: its form built slot {slot}, which it does not write"
                    )));
                };
                *quad = codec::rotl(*quad, x);
                turn[slot as usize] = (turn[slot as usize] + x) & 3;
            }
            for (t, s) in streams.iter_mut().enumerate() {
                s.truncate(before[t]);
            }
            cursors = cursors_before;
        };
        if let Some(out) = stored.as_deref_mut() {
            let mut r = rec.clone();
            for (dst, src) in r.rewritten.iter_mut().zip(&q.rewritten) {
                dst.1 = src.1;
            }
            r.appended_faces.clone_from(&q.appended);
            out.push(r);
        }
        match form {
            0 => report.general_records += 1,
            1 => report.split_records += 1,
            2 => report.local_records += 1,
            3 => report.face_split_records += 1,
            _ => report.edge_split_records += 1,
        }
        let st = &mut report.per_op[q.op as usize];
        st.records += 1;
        st.forms[form as usize] += 1;
        st.new += q.new_pos.len() as u64;
        st.moved += q.moved.len() as u64;
        st.rewritten += q.rewritten.len() as u64;
        st.appended += q.appended.len() as u64;
        for t in 0..5 {
            let n = (streams[t].len() - before[t]) as u64;
            st.raw_bytes[t] += n;
            op_raw[q.op as usize][t] += n;
        }
        state.apply(&q);
        in_chunk += 1;
        let size: usize = streams.iter().map(|s| s.len()).sum();
        // A coarsening step is logged as its doublet removals' records and
        // then its operator's (refinement order): a size-triggered chunk
        // ends after a record that is not a doublet re-insertion, so a
        // client stopping at a chunk never shows the doublets in the middle
        // of a step (their quads can fold); a run of doublets longer than
        // the chunk (the input's own doublets) closes at twice the size.
        let ends_step = rec.op != pqm_core::OpKind::Doublet;
        // The budget grows with what the earlier chunks hold
        // (`chunk_growth`); a run of doublets closes at twice the budget.
        let budget = opts
            .chunk_bytes
            .max((opts.chunk_growth * done_payload as f64) as usize);
        let by_size = size >= budget && (ends_step || size >= 2 * budget);
        if opts.chunk_records.is_some_and(|n| in_chunk as usize >= n) || by_size {
            done_payload += size;
            close(
                &mut streams,
                &mut op_raw,
                &mut in_chunk,
                &mut cursors,
                &state,
                k + 1,
                &mut report,
            )?;
        }
    }
    if in_chunk > 0 {
        close(
            &mut streams,
            &mut op_raw,
            &mut in_chunk,
            &mut cursors,
            &state,
            mesh.records.len(),
            &mut report,
        )?;
    }

    // Optional sections.
    let mut sections: Vec<u8> = Vec::new();
    let mut section_count = 0u32;
    let mut flags = 0u32;
    let mut minor = if opts.version_major == 1 {
        VERSION_1_MINOR
    } else {
        0
    };
    if opts.vertex_order && !mesh.vertex_order.is_empty() {
        // The mesh's whole order and, with `vertex_order_keep`, the order
        // with the free indices given out anew: the greedy walk nearly
        // always codes far smaller, but is not sure to (a few free
        // indices whose given order happens to compress well), so both
        // are priced and the smaller written — on a tie the whole order.
        let mut orders = vec![std::borrow::Cow::Borrowed(&mesh.vertex_order)];
        if let Some(keep) = opts
            .vertex_order_keep
            .filter(|&k| k < mesh.vertex_order.len())
        {
            let o = crate::vorder::free_tail(
                &mesh.vertex_order,
                &state.quads,
                mesh.base.vertex_count(),
                keep,
            )
            .map_err(EncodeError::InvalidMesh)?;
            orders.push(std::borrow::Cow::Owned(o));
        }
        let deltas = |order: &[u32]| {
            let mut payload = Vec::new();
            let mut prev = 0i64;
            for &o in order {
                put_s(&mut payload, o as i64 - prev);
                prev = o as i64;
            }
            payload
        };
        let code = if opts.version_major >= 3 {
            opts.vertex_order_code
        } else {
            VertexOrderCode::Deltas
        };
        let mut candidates = Vec::with_capacity(2 * orders.len());
        for (i, order) in orders.iter().enumerate() {
            if code != VertexOrderCode::Deltas {
                let payload = crate::vorder::encode(order, &state.quads, mesh.base.vertex_count())
                    .map_err(EncodeError::InvalidMesh)?;
                let (c, _) = compress_parts(&payload, &[], opts, 0)?;
                candidates.push((i, true, payload, c));
            }
            if code != VertexOrderCode::Neighbours {
                let payload = deltas(order);
                let (c, _) = compress_parts(&payload, &[], opts, 0)?;
                candidates.push((i, false, payload, c));
            }
        }
        // The smaller compressed section; on a tie the whole order, then
        // `VORD`, which 3.0 readers read too.
        let (i, neighbours, payload, c) = candidates
            .into_iter()
            .min_by_key(|(i, neighbours, _, c)| (c.len(), *i, *neighbours))
            .expect("at least one vertex-order candidate");
        if let Some(out) = stored_order {
            out.clone_from(&orders[i]);
        }
        sections.extend_from_slice(if neighbours { &TAG_VNBR } else { &TAG_VORD });
        sections.extend_from_slice(&(c.len() as u32).to_le_bytes());
        sections.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        sections.extend_from_slice(&crc32(&c).to_le_bytes());
        sections.extend_from_slice(&c);
        section_count += 1;
        if neighbours {
            flags |= FLAG_VERTEX_NEIGHBOURS;
            if opts.version_major == 3 {
                minor = VERSION_MINOR;
            }
        } else {
            flags |= FLAG_VERTEX_ORDER;
        }
    }

    if opts.finest_diagonals {
        flags |= FLAG_FINEST_DIAGONALS;
        minor = minor.max(VERSION_4_MINOR_DIAGONALS);
    }
    let header_len = if bounds.is_some() {
        if opts.version_major == 3 {
            minor = VERSION_MINOR_BOUNDS;
        }
        HEADER_LEN_BOUNDS
    } else {
        HEADER_LEN
    };
    let table_len = chunks.len() as u64 * CHUNK_ENTRY_LEN as u64 + 4;
    let mut offset = header_len as u64 + table_len + base_bytes.len() as u64;
    let mut table = Vec::with_capacity(table_len as usize);
    for c in &mut chunks {
        c.info.offset = offset;
        offset += c.bytes.len() as u64;
        table.extend_from_slice(&c.info.to_bytes());
    }
    let table_crc = crc32(&table);
    table.extend_from_slice(&table_crc.to_le_bytes());

    let header = Header {
        version_major: opts.version_major,
        version_minor: minor,
        header_len,
        flags,
        quant_bits: opts.bits,
        chunk_entry_len: CHUNK_ENTRY_LEN,
        base_vertex_count: mesh.base.vertex_count() as u32,
        base_face_count: mesh.base.face_count() as u32,
        final_vertex_count: final_v,
        final_face_count: final_f,
        record_count,
        chunk_count: chunks.len() as u32,
        section_count,
        base_compressed_len: base_bytes.len() as u32,
        base_uncompressed_len: base_payload_len as u32,
        base_crc32: crc32(&base_bytes),
        bbox_min: grid_lo,
        bbox_max: grid_hi,
        base_error: error_at(0),
        bounds,
    };
    w.write_all(&header.to_bytes())?;
    w.write_all(&table)?;
    w.write_all(&base_bytes)?;
    for c in &chunks {
        w.write_all(&c.bytes)?;
    }
    w.write_all(&sections)?;
    w.flush()?;

    report.header_bytes = header_len as u64;
    report.table_bytes = table_len;
    report.base_bytes = base_bytes.len() as u64;
    report.chunk_bytes = chunks.iter().map(|c| c.bytes.len() as u64).sum();
    report.section_bytes = sections.len() as u64;
    report.total_bytes = offset + sections.len() as u64;
    report.chunk_count = chunks.len();
    report.refined_vertices = (final_v as u64).saturating_sub(mesh.base.vertex_count() as u64);
    let n = report.refined_vertices.max(1) as f64;
    let sb = report.stream_bytes;
    report.bits_per_vertex = BitsPerVertex {
        connectivity: 8.0 * (sb[OPS] + sb[CONN] + sb[REFS] + sb[SLOTS]) / n,
        positions: 8.0 * sb[POS] / n,
        total: 8.0 * report.chunk_bytes as f64 / n,
    };
    report.file_bits_per_vertex = 8.0 * report.total_bytes as f64 / (final_v.max(1) as f64);
    Ok(report)
}

/// [`write()`] into a new `Vec<u8>`.
pub fn write_to_vec(
    mesh: &ProgressiveMesh,
    opts: &EncodeOptions,
) -> Result<(Vec<u8>, EncodeReport), EncodeError> {
    let mut out = Vec::new();
    let report = write(mesh, opts, &mut out)?;
    Ok((out, report))
}
