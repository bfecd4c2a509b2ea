//! OFF (Object File Format) reading and writing.
//!
//! Reading accepts
//! * ASCII OFF: a header line `OFF` (also `COFF`, `NOFF`, `CNOFF`, `STOFF`, ...:
//!   any keyword ending in `OFF`, whose extra per-vertex columns are ignored),
//!   the counts `nV nF nE` on the same or the next line, then one vertex per
//!   line (first three numbers used) and one face per line as
//!   `k i1 .. ik [colour ...]` (colour columns ignored). `#` starts a comment;
//!   blank lines and `\r\n` line ends are fine.
//! * pmp-library's binary layout (`/work/shared/meshes/large/amo.off`): the
//!   line `OFF BINARY\n`, then int32 `nV nF nE`, `nV x 3` float32
//!   coordinates, and per face an int32 count followed by int32 indices, all
//!   little endian. As in the reference `inspect.py`, big endian is tried when
//!   the little-endian counts cannot fit in the file.
//!
//! Counts are checked against the bytes that remain before any allocation,
//! and every index against `nV`.
//!
//! Writing produces ASCII OFF with shortest round-trip decimals.

use super::obj::parse_f64;
use super::{read_all, Element, MeshIoError};
use crate::IndexedMesh;
use glam::DVec3;
use std::io::{Read, Write};

/// Reads an ASCII or binary OFF file from `reader`.
pub fn read_off(reader: impl Read) -> Result<IndexedMesh, MeshIoError> {
    read_off_bytes(&read_all(reader)?)
}

/// Reads an ASCII or binary OFF file held in memory.
pub fn read_off_bytes(data: &[u8]) -> Result<IndexedMesh, MeshIoError> {
    let first_end = data.iter().position(|&b| b == b'\n').unwrap_or(data.len());
    let first = data[..first_end].trim_ascii();
    if first.starts_with(b"OFF") {
        let rest = first[3..].trim_ascii();
        if rest == b"BINARY" {
            return read_binary(data, (first_end + 1).min(data.len()));
        }
    }
    read_ascii(data)
}

/// Lines of an ASCII file with comments stripped, skipping blank lines;
/// yields `(line number, tokens)`.
struct Lines<'a> {
    data: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Lines<'a> {
    fn next_line(&mut self) -> Option<(u64, &'a [u8])> {
        while self.pos < self.data.len() {
            self.line += 1;
            let d = &self.data[self.pos..];
            let end = d.iter().position(|&b| b == b'\n').unwrap_or(d.len());
            self.pos += end + 1;
            let mut l = &d[..end];
            if let Some(h) = l.iter().position(|&b| b == b'#') {
                l = &l[..h];
            }
            let l = l.trim_ascii();
            if !l.is_empty() {
                return Some((self.line, l));
            }
        }
        None
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }
}

fn tokens(l: &[u8]) -> impl Iterator<Item = &[u8]> {
    l.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

fn parse_count(tok: Option<&[u8]>, line: u64, what: &str) -> Result<usize, MeshIoError> {
    let tok = tok.ok_or_else(|| MeshIoError::line(line, format!("missing {what} count")))?;
    std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse::<u32>().ok())
        .map(|n| n as usize)
        .ok_or_else(|| {
            MeshIoError::line(
                line,
                format!(
                    "{what} count '{}' is not a number",
                    String::from_utf8_lossy(tok)
                ),
            )
        })
}

fn read_ascii(data: &[u8]) -> Result<IndexedMesh, MeshIoError> {
    let mut lines = Lines {
        data,
        pos: 0,
        line: 0,
    };
    let (hl, header) = lines
        .next_line()
        .ok_or_else(|| MeshIoError::line(1, "empty file (expected 'OFF')"))?;
    let mut toks = tokens(header);
    let key = toks.next().unwrap_or(b"");
    if !key.ends_with(b"OFF") {
        return Err(MeshIoError::line(
            hl,
            "not an OFF file (the first word must end in 'OFF')",
        ));
    }
    if key.len() > 3 && key[..key.len() - 3].contains(&b'n') {
        return Err(MeshIoError::unsupported(
            "nOFF (vertex dimension other than 3)",
        ));
    }
    let mut counts: Vec<&[u8]> = toks.collect();
    let mut cl = hl;
    if counts.is_empty() {
        let (l, c) = lines
            .next_line()
            .ok_or_else(|| MeshIoError::line(hl + 1, "missing counts"))?;
        counts = tokens(c).collect();
        cl = l;
    }
    let nv = parse_count(counts.first().copied(), cl, "vertex")?;
    let nf = parse_count(counts.get(1).copied(), cl, "face")?;
    // A vertex line is at least "0 0 0" (5 bytes) and a face line "1 0" (3).
    let need = nv.saturating_mul(5).saturating_add(nf.saturating_mul(3));
    if need > lines.remaining() + 1 {
        return Err(MeshIoError::line(
            cl,
            format!(
                "header declares {nv} vertices and {nf} faces, more than the {} remaining bytes can hold",
                lines.remaining()
            ),
        ));
    }
    let mut m = IndexedMesh::new();
    m.positions.reserve(nv);
    m.face_starts.reserve(nf);
    for k in 0..nv {
        let (l, text) = lines.next_line().ok_or_else(|| {
            MeshIoError::line(
                lines.line + 1,
                format!("file ends after {k} of {nv} vertices"),
            )
        })?;
        let mut p = [0.0; 3];
        let mut t = tokens(text);
        for (c, o) in p.iter_mut().enumerate() {
            let tok = t.next().ok_or_else(|| {
                MeshIoError::line(l, format!("vertex {k} has {c} coordinates, expected 3"))
            })?;
            *o = parse_f64(tok).ok_or_else(|| {
                MeshIoError::line(
                    l,
                    format!(
                        "vertex {k}: '{}' is not a number",
                        String::from_utf8_lossy(tok)
                    ),
                )
            })?;
        }
        m.positions.push(DVec3::from_array(p));
    }
    for f in 0..nf {
        let (l, text) = lines.next_line().ok_or_else(|| {
            MeshIoError::line(lines.line + 1, format!("file ends after {f} of {nf} faces"))
        })?;
        let mut t = tokens(text);
        let k = parse_count(t.next(), l, "face vertex")?;
        for _ in 0..k {
            let tok = t.next().ok_or_else(|| {
                MeshIoError::line(l, format!("face {f} lists fewer than its {k} vertices"))
            })?;
            let i = std::str::from_utf8(tok)
                .ok()
                .and_then(|s| s.parse::<u32>().ok())
                .ok_or_else(|| {
                    MeshIoError::line(
                        l,
                        format!(
                            "face {f}: bad vertex index '{}'",
                            String::from_utf8_lossy(tok)
                        ),
                    )
                })?;
            if i as usize >= nv {
                return Err(MeshIoError::invalid(
                    Element::Face(f as u32),
                    format!("references vertex {i} but the file has {nv} vertices"),
                ));
            }
            m.indices.push(i);
        }
        push_start(&mut m)?;
    }
    Ok(m)
}

fn push_start(m: &mut IndexedMesh) -> Result<(), MeshIoError> {
    let n = u32::try_from(m.indices.len())
        .map_err(|_| MeshIoError::unsupported("more than 2^32 face corners"))?;
    m.face_starts.push(n);
    Ok(())
}

/// Bounds-checked little/big-endian reader over a byte slice.
struct Bin<'a> {
    d: &'a [u8],
    pos: usize,
    big: bool,
}

impl Bin<'_> {
    fn i32(&mut self, what: &str) -> Result<i32, MeshIoError> {
        let b = self
            .d
            .get(self.pos..self.pos + 4)
            .ok_or_else(|| MeshIoError::offset(self.pos, format!("file ends inside {what}")))?;
        let b = [b[0], b[1], b[2], b[3]];
        self.pos += 4;
        Ok(if self.big {
            i32::from_be_bytes(b)
        } else {
            i32::from_le_bytes(b)
        })
    }

    fn f32(&mut self, what: &str) -> Result<f32, MeshIoError> {
        self.i32(what).map(|i| f32::from_bits(i as u32))
    }

    fn remaining(&self) -> usize {
        self.d.len().saturating_sub(self.pos)
    }
}

fn read_binary(data: &[u8], start: usize) -> Result<IndexedMesh, MeshIoError> {
    // Counts that fit: nV x 12 bytes of coordinates plus at least 4 bytes per face.
    let fits = |nv: i32, nf: i32, rem: usize| {
        nv >= 0 && nf >= 0 && (nv as u64) * 12 + (nf as u64) * 4 <= rem as u64
    };
    let mut r = Bin {
        d: data,
        pos: start,
        big: false,
    };
    let (mut nv, mut nf) = (r.i32("the counts")?, r.i32("the counts")?);
    r.i32("the counts")?;
    if !fits(nv, nf, r.remaining()) {
        let mut b = Bin {
            d: data,
            pos: start,
            big: true,
        };
        let (bv, bf) = (b.i32("the counts")?, b.i32("the counts")?);
        b.i32("the counts")?;
        if !fits(bv, bf, b.remaining()) {
            return Err(MeshIoError::offset(
                start,
                format!(
                    "binary OFF header declares {nv} vertices and {nf} faces, which do not fit in the {} remaining bytes",
                    r.remaining()
                ),
            ));
        }
        (r, nv, nf) = (b, bv, bf);
    }
    let (nv, nf) = (nv as usize, nf as usize);
    let mut m = IndexedMesh::new();
    m.positions.reserve(nv);
    m.face_starts.reserve(nf);
    for _ in 0..nv {
        let x = r.f32("the vertex coordinates")?;
        let y = r.f32("the vertex coordinates")?;
        let z = r.f32("the vertex coordinates")?;
        m.positions.push(DVec3::new(x.into(), y.into(), z.into()));
    }
    for f in 0..nf {
        let at = r.pos;
        let k = r.i32("a face")?;
        if k < 0 || (k as u64) * 4 > r.remaining() as u64 {
            return Err(MeshIoError::offset(
                at,
                format!("face {f} declares {k} vertices, which do not fit in the file"),
            ));
        }
        for _ in 0..k {
            let i = r.i32("a face")?;
            if i < 0 || i as usize >= nv {
                return Err(MeshIoError::invalid(
                    Element::Face(f as u32),
                    format!("references vertex {i} but the file has {nv} vertices"),
                ));
            }
            m.indices.push(i as u32);
        }
        push_start(&mut m)?;
    }
    Ok(m)
}

/// Writes `mesh` as ASCII OFF (`OFF`, `nV nF 0`, vertices with shortest
/// round-trip decimals, faces as `k i1 .. ik`). Only positions and faces are
/// written.
pub fn write_off(w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    super::check_writable(mesh)?;
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 16);
    writeln!(buf, "OFF\n{} {} 0", mesh.vertex_count(), mesh.face_count())?;
    super::write_ascii_rows(w, buf, mesh, &[])
}
