//! Wavefront OBJ reading and writing.
//!
//! # Why a hand-written parser (and not tobj)
//!
//! tobj 4 with `triangulate: false, single_index: false` keeps polygons, but
//! it splits the file into one model per `o`/`g` and re-numbers the vertices
//! of each model in order of first use, so the file's vertex order (which the
//! progressive stream and the tests rely on) is lost and has to be rebuilt
//! from per-model index maps. This parser is one pass over the bytes in
//! memory: no per-line allocation, Clinger's exact fast path for plain
//! decimals (std's parser otherwise) and an integer parser for indices. It
//! keeps the file's vertex order and reads loki.obj at 166–221 MiB/s on the
//! shared 2-core machine under load (`benches/io_read.rs`; target 100 MB/s).
//!
//! # What is read
//!
//! * `v x y z [w | r g b]` (extra columns ignored), `vt u [v [w]]`, `vn x y z`;
//! * `f` with `v`, `v/vt`, `v//vn`, `v/vt/vn` corners; negative indices count
//!   back from the last element defined so far; positive ones may refer to
//!   elements defined later in the file (checked at the end);
//! * `g` / `o` start a named group at the next face (a group that gets no face
//!   is replaced by the next group name);
//! * `#` comments, blank lines, `\r\n` line ends; `mtllib`, `usemtl`, `s`, `l`,
//!   `p` and unknown statements are ignored.
//!
//! Texture coordinates (normals) are kept only when every face corner has
//! one; a file that gives them for some corners only is read without them,
//! since [`IndexedMesh`] stores them per corner for all corners or none.

use super::{fmt_f64, read_all, Element, MeshIoError};
use crate::IndexedMesh;
use glam::DVec3;
use std::io::{Read, Write};

/// Reads an OBJ file from `reader` (see the module docs for what is kept).
pub fn read_obj(reader: impl Read) -> Result<IndexedMesh, MeshIoError> {
    read_obj_bytes(&read_all(reader)?)
}

/// Reads an OBJ file held in memory.
pub fn read_obj_bytes(data: &[u8]) -> Result<IndexedMesh, MeshIoError> {
    let mut m = IndexedMesh::new();
    // Corners with / without a texcoord (normal), to decide whether to keep them.
    let (mut with_vt, mut with_vn) = (0usize, 0usize);
    let mut pos = 0usize;
    let mut line_no = 0u64;
    while pos < data.len() {
        line_no += 1;
        let end = data[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |k| pos + k);
        let line = &data[pos..end];
        pos = end + 1;
        let mut t = Tokens { s: line, i: 0 };
        let Some(key) = t.next() else { continue };
        match key {
            b"v" => {
                let p = parse_floats::<3>(&mut t, 3, line_no, "vertex")?;
                m.positions.push(DVec3::from_array(p));
            }
            b"vt" => {
                let p = parse_floats::<2>(&mut t, 1, line_no, "texture coordinate")?;
                m.texcoords.push(p);
            }
            b"vn" => {
                let p = parse_floats::<3>(&mut t, 3, line_no, "normal")?;
                m.normals.push(DVec3::from_array(p));
            }
            b"f" | b"fo" => {
                let start = m.indices.len();
                while let Some(tok) = t.next() {
                    let mut parts = tok.splitn(3, |&b| b == b'/');
                    let v = parts.next().unwrap_or(b"");
                    let vt = parts.next().unwrap_or(b"");
                    let vn = parts.next().unwrap_or(b"");
                    m.indices
                        .push(resolve(v, m.positions.len(), line_no, "vertex")?);
                    if !vt.is_empty() {
                        m.corner_texcoords
                            .push(resolve(vt, m.texcoords.len(), line_no, "vt")?);
                        with_vt += 1;
                    } else {
                        // Placeholder keeps the per-corner arrays aligned; the
                        // whole array is dropped at the end unless every corner
                        // had a texcoord.
                        m.corner_texcoords.push(0);
                    }
                    if !vn.is_empty() {
                        m.corner_normals
                            .push(resolve(vn, m.normals.len(), line_no, "vn")?);
                        with_vn += 1;
                    } else {
                        m.corner_normals.push(0);
                    }
                }
                if m.indices.len() == start {
                    return Err(MeshIoError::line(line_no, "face with no vertices"));
                }
                let n = u32::try_from(m.indices.len())
                    .map_err(|_| MeshIoError::line(line_no, "more than 2^32 face corners"))?;
                m.face_starts.push(n);
            }
            b"g" | b"o" => {
                let name = t.rest();
                let name = String::from_utf8_lossy(name).into_owned();
                let first = m.face_count() as u32;
                match m.groups.last_mut() {
                    Some(last) if last.1 == first => last.0 = name,
                    _ => m.groups.push((name, first)),
                }
            }
            _ => {} // comments, mtllib, usemtl, s, l, p, unknown statements
        }
    }
    // Drop a trailing group that got no face.
    if m.groups
        .last()
        .is_some_and(|g| g.1 as usize == m.face_count())
    {
        m.groups.pop();
    }
    let corners = m.indices.len();
    if with_vt < corners || corners == 0 {
        m.corner_texcoords.clear();
    }
    if with_vn < corners || corners == 0 {
        m.corner_normals.clear();
    }
    check_ranges(&m)?;
    Ok(m)
}

/// Checks every index against the final element counts (positive OBJ indices
/// may point forward, so this can only happen at the end).
fn check_ranges(m: &IndexedMesh) -> Result<(), MeshIoError> {
    let checks: [(&[u32], usize, &str); 3] = [
        (&m.indices, m.positions.len(), "vertex"),
        (&m.corner_texcoords, m.texcoords.len(), "texture coordinate"),
        (&m.corner_normals, m.normals.len(), "normal"),
    ];
    for (idx, n, what) in checks {
        if let Some(c) = idx.iter().position(|&i| i as usize >= n) {
            let f = super::check::face_of_corner(m, c as u32);
            return Err(MeshIoError::invalid(
                Element::Face(f),
                format!(
                    "references {what} {} but the file has {n}",
                    idx[c] as u64 + 1
                ),
            ));
        }
    }
    Ok(())
}

/// Whitespace tokenizer over one line (also strips a trailing `\r` and
/// treats `#` as the start of a comment).
struct Tokens<'a> {
    s: &'a [u8],
    i: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self) -> Option<&'a [u8]> {
        let s = self.s;
        while self.i < s.len() && s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
        if self.i >= s.len() || s[self.i] == b'#' {
            return None;
        }
        let b = self.i;
        while self.i < s.len() && !s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
        Some(&s[b..self.i])
    }

    /// The rest of the line, trimmed (for group names).
    fn rest(&mut self) -> &'a [u8] {
        let r = self.s[self.i..].trim_ascii();
        self.i = self.s.len();
        r
    }
}

/// Parses up to `N` floats (at least `min`); missing optional ones are 0 and
/// extra columns are ignored.
fn parse_floats<const N: usize>(
    t: &mut Tokens<'_>,
    min: usize,
    line: u64,
    what: &str,
) -> Result<[f64; N], MeshIoError> {
    let mut out = [0.0; N];
    for (k, o) in out.iter_mut().enumerate() {
        match t.next() {
            Some(tok) => *o = parse_f64(tok).ok_or_else(|| bad_number(line, what, tok))?,
            None if k >= min => break,
            None => {
                return Err(MeshIoError::line(
                    line,
                    format!("{what} has {k} coordinates, expected {min}"),
                ))
            }
        }
    }
    Ok(out)
}

/// Parses a decimal number. Plain decimals with at most 2^53 as mantissa and
/// at most 22 fraction digits (nearly every coordinate in real files) take
/// Clinger's fast path — both the mantissa and the power of ten are exact in
/// f64, so the single division is correctly rounded and the result equals
/// std's. Everything else (exponents, long mantissas, `inf`, `nan`) goes to
/// std's parser.
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    fast_f64(tok).or_else(|| std::str::from_utf8(tok).ok()?.parse().ok())
}

fn fast_f64(t: &[u8]) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (neg, digits) = match t.first()? {
        b'-' => (true, &t[1..]),
        b'+' => (false, &t[1..]),
        _ => (false, t),
    };
    let mut mant: u64 = 0;
    let mut frac: usize = 0;
    let mut dot = false;
    let mut any = false;
    for &c in digits {
        if c.is_ascii_digit() {
            // 10 * mant + 9 cannot overflow while mant < 2^60.
            if mant >= 1 << 60 {
                return None;
            }
            mant = mant * 10 + u64::from(c - b'0');
            frac += usize::from(dot);
            any = true;
        } else if c == b'.' && !dot {
            dot = true;
        } else {
            return None;
        }
    }
    if !any || mant > 1 << 53 || frac >= POW10.len() {
        return None;
    }
    let v = mant as f64 / POW10[frac];
    Some(if neg { -v } else { v })
}

fn bad_number(line: u64, what: &str, tok: &[u8]) -> MeshIoError {
    MeshIoError::line(
        line,
        format!(
            "{what}: '{}' is not a number",
            String::from_utf8_lossy(&tok[..tok.len().min(40)])
        ),
    )
}

/// Turns a 1-based (or negative, relative) OBJ index into a 0-based one.
/// `count` is the number of elements defined so far.
fn resolve(tok: &[u8], count: usize, line: u64, what: &str) -> Result<u32, MeshIoError> {
    let (neg, digits) = match tok.first() {
        Some(b'-') => (true, &tok[1..]),
        Some(b'+') => (false, &tok[1..]),
        _ => (false, tok),
    };
    if digits.is_empty() || digits.len() > 12 || !digits.iter().all(u8::is_ascii_digit) {
        return Err(MeshIoError::line(
            line,
            format!(
                "bad {what} index '{}'",
                String::from_utf8_lossy(&tok[..tok.len().min(40)])
            ),
        ));
    }
    let v = digits
        .iter()
        .fold(0u64, |a, &d| a * 10 + u64::from(d - b'0'));
    let r = if v == 0 {
        None
    } else if neg {
        (count as u64).checked_sub(v)
    } else {
        Some(v - 1)
    };
    match r.and_then(|r| u32::try_from(r).ok()) {
        Some(r) => Ok(r),
        None => Err(MeshIoError::line(
            line,
            format!(
                "{what} index {}{v} does not name one of the {count} defined so far",
                if neg { "-" } else { "" }
            ),
        )),
    }
}

/// Writes `mesh` as OBJ: `v` lines (shortest round-trip decimals, so f64
/// positions read back exactly), `vt`/`vn` lines when the mesh has per-corner
/// texture coordinates / normals, `g` lines at group starts, and one `f` line
/// per polygon (no triangulation). Vertex scalar properties are not written
/// (OBJ has no place for them).
pub fn write_obj(mut w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    super::check_writable(mesh)?;
    let mut buf: Vec<u8> = Vec::with_capacity(1 << 16);
    buf.extend_from_slice(b"# written by pqm\n");
    let flush = |buf: &mut Vec<u8>, w: &mut dyn Write| -> std::io::Result<()> {
        if buf.len() >= 1 << 16 {
            w.write_all(buf)?;
            buf.clear();
        }
        Ok(())
    };
    for p in &mesh.positions {
        buf.extend_from_slice(b"v ");
        fmt_vec(&mut buf, &p.to_array());
        flush(&mut buf, &mut w)?;
    }
    let has_vt = !mesh.corner_texcoords.is_empty();
    let has_vn = !mesh.corner_normals.is_empty();
    if has_vt {
        for t in &mesh.texcoords {
            buf.extend_from_slice(b"vt ");
            fmt_vec(&mut buf, t);
            flush(&mut buf, &mut w)?;
        }
    }
    if has_vn {
        for n in &mesh.normals {
            buf.extend_from_slice(b"vn ");
            fmt_vec(&mut buf, &n.to_array());
            flush(&mut buf, &mut w)?;
        }
    }
    let mut groups = mesh.groups.iter().peekable();
    for f in 0..mesh.face_count() {
        while let Some((name, _)) = groups.next_if(|g| g.1 as usize <= f) {
            buf.extend_from_slice(b"g ");
            buf.extend_from_slice(name.as_bytes());
            buf.push(b'\n');
        }
        buf.push(b'f');
        let (s, e) = (
            mesh.face_starts[f] as usize,
            mesh.face_starts[f + 1] as usize,
        );
        for c in s..e {
            write!(buf, " {}", mesh.indices[c] as u64 + 1)?;
            if has_vt || has_vn {
                buf.push(b'/');
                if has_vt {
                    write!(buf, "{}", mesh.corner_texcoords[c] as u64 + 1)?;
                }
                if has_vn {
                    write!(buf, "/{}", mesh.corner_normals[c] as u64 + 1)?;
                }
            }
        }
        buf.push(b'\n');
        flush(&mut buf, &mut w)?;
    }
    w.write_all(&buf)?;
    w.flush()?;
    Ok(())
}

fn fmt_vec(buf: &mut Vec<u8>, v: &[f64]) {
    for (k, &x) in v.iter().enumerate() {
        if k > 0 {
            buf.push(b' ');
        }
        fmt_f64(buf, x);
    }
    buf.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::parse_f64;

    #[test]
    fn fast_float_path_agrees_with_std() {
        let cases = [
            "0",
            "-0.0",
            "1",
            "0.1",
            "74.6019",
            "-82.5656",
            "123456789012345.6",
            "0.000001",
            "9007199254740993",
            "0.30000000000000004",
            "1e-7",
            "-2.5E3",
            "inf",
            "NaN",
            ".5",
            "5.",
            "1.0000000000000000000001",
            "4503599627370497.5",
        ];
        for c in cases {
            let want: f64 = c.parse().unwrap();
            let got = parse_f64(c.as_bytes()).unwrap();
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{c}"
            );
        }
        for bad in ["", "-", ".", "1.2.3", "1x", "--1"] {
            assert!(parse_f64(bad.as_bytes()).is_none(), "{bad}");
        }
    }
}
