//! Fixed byte layout of the header and the chunk table (spec §3–§4).

use byteorder::{ByteOrder, LittleEndian as LE};

/// File signature: `\x89 P Q M \r \n \x1a \n` (PNG-style: catches 7-bit and
/// newline-mangling transfers).
pub const MAGIC: [u8; 8] = [0x89, b'P', b'Q', b'M', 0x0D, 0x0A, 0x1A, 0x0A];
/// Major version this crate writes by default, and the newest it reads.
pub const VERSION_MAJOR: u16 = 4;
/// Minor version this crate writes with major version 3 when the file
/// holds a `VNBR` section but no header bounds (3.1, spec §8.2); files
/// with neither are 3.0. (Every 4.x file so far is 4.0.)
pub const VERSION_MINOR: u16 = 1;
/// Minor version this crate writes with major version 3 when the header
/// holds the positions' bounds (3.2, spec §3: flag bit 2).
pub const VERSION_MINOR_BOUNDS: u16 = 2;
/// Oldest major version this crate reads (and can write, for tests and old
/// readers: 1.1, spec §9).
pub const MIN_VERSION_MAJOR: u16 = 1;
/// Minor version this crate writes with major version 1.
pub const VERSION_1_MINOR: u16 = 1;
/// Header length written by v1.0 (readers accept longer headers).
pub const HEADER_LEN: u32 = 120;
/// Header length written with the 3.2 bounds (flag bit 2).
pub const HEADER_LEN_BOUNDS: u32 = 168;
/// Header flag: the header holds `bounds_min` / `bounds_max` (version 3.2).
pub const FLAG_BOUNDS: u32 = 4;
/// Header flag: at the finest level each quad's `v0–v2` diagonal splits it
/// into the two triangles the writer's input had there, as a triangle mesh
/// joined in pairs (version 4.1).
pub const FLAG_FINEST_DIAGONALS: u32 = 8;
/// Minor version this crate writes with major version 4 when it sets
/// [`FLAG_FINEST_DIAGONALS`] (4.1); other 4.x files are 4.0.
pub const VERSION_4_MINOR_DIAGONALS: u16 = 1;
/// Bytes of the header needed to learn `header_len`.
pub const HEADER_PREFIX: usize = 16;
/// Chunk table entry length written by v1.0 (readers accept longer entries).
pub const CHUNK_ENTRY_LEN: u16 = 36;
/// Header flag: a `VORD` section is present.
pub const FLAG_VERTEX_ORDER: u32 = 1;
/// Tag of the vertex-order section.
pub const TAG_VORD: [u8; 4] = *b"VORD";
/// Header flag: a `VNBR` section is present (version 3.1).
pub const FLAG_VERTEX_NEIGHBOURS: u32 = 2;
/// Tag of the vertex-order section coded against the mesh (version 3.1).
pub const TAG_VNBR: [u8; 4] = *b"VNBR";
/// Optional section header length (tag, compressed length, uncompressed length, CRC).
pub const SECTION_HEADER_LEN: usize = 16;
/// Largest header a reader accepts (sanity bound against hostile input).
pub const MAX_HEADER_LEN: u32 = 1 << 16;
/// Largest zstd window (log2) a writer may use and a reader accepts.
pub const MAX_WINDOW_LOG: u32 = 25;

/// The file header (spec §3).
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Major version (incompatible changes).
    pub version_major: u16,
    /// Minor version (compatible additions).
    pub version_minor: u16,
    /// Header length in bytes, magic and trailing CRC included.
    pub header_len: u32,
    /// Flags (`FLAG_*`).
    pub flags: u32,
    /// Quantization bits per axis, 8..=24.
    pub quant_bits: u8,
    /// Bytes per chunk table entry.
    pub chunk_entry_len: u16,
    /// Base (level 0) vertex count.
    pub base_vertex_count: u32,
    /// Base (level 0) face count.
    pub base_face_count: u32,
    /// Finest-level vertex count.
    pub final_vertex_count: u32,
    /// Finest-level face count.
    pub final_face_count: u32,
    /// Number of records (levels − 1).
    pub record_count: u32,
    /// Number of record chunks.
    pub chunk_count: u32,
    /// Number of optional sections after the last chunk.
    pub section_count: u32,
    /// Compressed length of the base section.
    pub base_compressed_len: u32,
    /// Uncompressed length of the base payload.
    pub base_uncompressed_len: u32,
    /// CRC-32 of the base section's compressed bytes.
    pub base_crc32: u32,
    /// Quantization grid minimum.
    pub bbox_min: [f64; 3],
    /// Quantization grid maximum.
    pub bbox_max: [f64; 3],
    /// Geometric error of level 0.
    pub base_error: f32,
    /// The positions' exact bounds `[min, max]` (flag bit 2, version 3.2):
    /// per axis the smallest and largest §5 coordinate any level shows.
    /// `None` when the header has no bounds (the grid is then the bounding
    /// volume).
    pub bounds: Option<[[f64; 3]; 2]>,
}

/// One chunk table entry (spec §4).
#[derive(Clone, Debug, PartialEq)]
pub struct ChunkInfo {
    /// Absolute file offset of the chunk's compressed bytes.
    pub offset: u64,
    /// Compressed length.
    pub compressed_len: u32,
    /// Uncompressed payload length.
    pub uncompressed_len: u32,
    /// Records in the chunk.
    pub record_count: u32,
    /// Vertex count after the chunk's last record.
    pub vertex_count: u32,
    /// Face count after the chunk's last record.
    pub face_count: u32,
    /// Geometric error of the level reached after the chunk.
    pub error: f32,
    /// CRC-32 of the compressed bytes.
    pub crc32: u32,
}

/// CRC-32 (ISO-HDLC, as zlib and PNG) of `data`.
pub fn crc32(data: &[u8]) -> u32 {
    crc32fast::hash(data)
}

impl Header {
    /// Flag bit 3 (version 4.1): whether an exporter or renderer of the
    /// finest level should split each quad along its `v0–v2` diagonal,
    /// where it would otherwise choose one (spec §3).
    pub fn finest_diagonals(&self) -> bool {
        self.flags & FLAG_FINEST_DIAGONALS != 0
    }

    /// Serializes the header: [`HEADER_LEN`] bytes, CRC included, or
    /// [`HEADER_LEN_BOUNDS`] with `bounds` (and then flag bit 2 set,
    /// whatever `flags` says; `header_len` is likewise written from
    /// `bounds`).
    pub fn to_bytes(&self) -> Vec<u8> {
        let len = self.bounds.map_or(HEADER_LEN, |_| HEADER_LEN_BOUNDS);
        let flags = match self.bounds {
            Some(_) => self.flags | FLAG_BOUNDS,
            None => self.flags & !FLAG_BOUNDS,
        };
        let mut b = vec![0u8; len as usize];
        b[..8].copy_from_slice(&MAGIC);
        LE::write_u16(&mut b[8..], self.version_major);
        LE::write_u16(&mut b[10..], self.version_minor);
        LE::write_u32(&mut b[12..], len);
        LE::write_u32(&mut b[16..], flags);
        b[20] = self.quant_bits;
        b[21] = 0;
        LE::write_u16(&mut b[22..], self.chunk_entry_len);
        let words = [
            self.base_vertex_count,
            self.base_face_count,
            self.final_vertex_count,
            self.final_face_count,
            self.record_count,
            self.chunk_count,
            self.section_count,
            self.base_compressed_len,
            self.base_uncompressed_len,
            self.base_crc32,
        ];
        for (i, w) in words.iter().enumerate() {
            LE::write_u32(&mut b[24 + 4 * i..], *w);
        }
        for k in 0..3 {
            LE::write_f64(&mut b[64 + 8 * k..], self.bbox_min[k]);
            LE::write_f64(&mut b[88 + 8 * k..], self.bbox_max[k]);
        }
        LE::write_f32(&mut b[112..], self.base_error);
        if let Some([lo, hi]) = self.bounds {
            for k in 0..3 {
                LE::write_f64(&mut b[116 + 8 * k..], lo[k]);
                LE::write_f64(&mut b[140 + 8 * k..], hi[k]);
            }
        }
        let n = len as usize - 4;
        let crc = crc32(&b[..n]);
        LE::write_u32(&mut b[n..], crc);
        b
    }

    /// Parses the fields of a full header `b` (`b.len() == header_len >= 120`,
    /// magic, version and CRC already checked by the caller). The bounds
    /// are read when flag bit 2 is set and `b` is long enough for them (a
    /// shorter header with the flag is the caller's error to report).
    pub fn parse(b: &[u8]) -> Header {
        let w = |i: usize| LE::read_u32(&b[24 + 4 * i..]);
        let flags = LE::read_u32(&b[16..]);
        let bounds = (flags & FLAG_BOUNDS != 0 && b.len() >= HEADER_LEN_BOUNDS as usize)
            .then(|| [116, 140].map(|at| [0, 1, 2].map(|k| LE::read_f64(&b[at + 8 * k..]))));
        Header {
            version_major: LE::read_u16(&b[8..]),
            version_minor: LE::read_u16(&b[10..]),
            header_len: LE::read_u32(&b[12..]),
            flags,
            quant_bits: b[20],
            chunk_entry_len: LE::read_u16(&b[22..]),
            base_vertex_count: w(0),
            base_face_count: w(1),
            final_vertex_count: w(2),
            final_face_count: w(3),
            record_count: w(4),
            chunk_count: w(5),
            section_count: w(6),
            base_compressed_len: w(7),
            base_uncompressed_len: w(8),
            base_crc32: w(9),
            bbox_min: [0, 1, 2].map(|k| LE::read_f64(&b[64 + 8 * k..])),
            bbox_max: [0, 1, 2].map(|k| LE::read_f64(&b[88 + 8 * k..])),
            base_error: LE::read_f32(&b[112..]),
            bounds,
        }
    }
}

impl ChunkInfo {
    /// Serializes a v1.0 entry (`CHUNK_ENTRY_LEN` bytes).
    pub fn to_bytes(&self) -> [u8; CHUNK_ENTRY_LEN as usize] {
        let mut b = [0u8; CHUNK_ENTRY_LEN as usize];
        LE::write_u64(&mut b[0..], self.offset);
        LE::write_u32(&mut b[8..], self.compressed_len);
        LE::write_u32(&mut b[12..], self.uncompressed_len);
        LE::write_u32(&mut b[16..], self.record_count);
        LE::write_u32(&mut b[20..], self.vertex_count);
        LE::write_u32(&mut b[24..], self.face_count);
        LE::write_f32(&mut b[28..], self.error);
        LE::write_u32(&mut b[32..], self.crc32);
        b
    }

    /// Parses the first `CHUNK_ENTRY_LEN` bytes of `b` (longer entries of
    /// newer minors carry extra fields that are ignored).
    pub fn parse(b: &[u8]) -> ChunkInfo {
        ChunkInfo {
            offset: LE::read_u64(&b[0..]),
            compressed_len: LE::read_u32(&b[8..]),
            uncompressed_len: LE::read_u32(&b[12..]),
            record_count: LE::read_u32(&b[16..]),
            vertex_count: LE::read_u32(&b[20..]),
            face_count: LE::read_u32(&b[24..]),
            error: LE::read_f32(&b[28..]),
            crc32: LE::read_u32(&b[32..]),
        }
    }
}
