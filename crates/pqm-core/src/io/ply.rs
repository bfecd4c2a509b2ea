//! Stanford PLY reading (via `ply-rs-bw`) and writing.
//!
//! Reading accepts ASCII, binary little endian and binary big endian files.
//! The `vertex` element must have `x`, `y`, `z` (any scalar type); every other
//! scalar vertex property (`quality`, `importance`, `nx`, `red`, ...) is kept
//! in [`IndexedMesh::vertex_scalars`] under its name, converted to f64. The
//! `face` element's `vertex_indices` (or `vertex_index`) list gives the
//! polygons, of any size, with any integer count and index types. Other
//! elements (`edge`, `material`, ...) and other face properties are skipped.
//! Elements may come in any order.
//!
//! Hostile input: the header is pre-scanned (ply-rs-bw panics on numbers that
//! overflow u64), and the element counts are checked against the bytes that
//! remain (each element needs at least one byte per property, or the binary
//! size of its scalars and list counts) before ply-rs-bw reads anything, so a
//! header cannot make the reader allocate or loop beyond the file's size.
//!
//! Rows are decoded into small typed structs implementing ply-rs-bw's
//! `PropertyAccess` rather than its `DefaultElement` hash maps, which keeps
//! binary reading fast (see `benches/io_read.rs`).
//!
//! Writing: [`write_ply`] writes binary little endian with `double` positions
//! and vertex scalars (exact round trips) and `list uchar int vertex_indices`
//! faces (`list int int` when a face has more than 255 vertices);
//! [`write_ply_ascii`] writes the same layout as ASCII with shortest
//! round-trip decimals. Texture coordinates and normals are not written.

use super::{read_all, Element, MeshIoError};
use crate::IndexedMesh;
use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    ElementDef, Encoding, Header, Property, PropertyAccess, PropertyType, ScalarType,
};
use std::io::{Cursor, Read, Write};

/// Reads an ASCII or binary PLY file from `reader`.
pub fn read_ply(reader: impl Read) -> Result<IndexedMesh, MeshIoError> {
    read_ply_bytes(&read_all(reader)?)
}

/// One vertex row: the position and the other scalar properties in header order.
struct VertexRow {
    p: [f64; 3],
    extras: Vec<f64>,
}

impl PropertyAccess for VertexRow {
    fn new() -> Self {
        VertexRow {
            p: [0.0; 3],
            extras: Vec::new(),
        }
    }

    fn set_property(&mut self, name: String, property: Property) {
        let Some(v) = scalar(&property) else { return };
        match name.as_str() {
            "x" => self.p[0] = v,
            "y" => self.p[1] = v,
            "z" => self.p[2] = v,
            _ => self.extras.push(v),
        }
    }
}

/// One face row: the raw index list (converted when flattening, which saves
/// a second allocation per face).
struct FaceRow {
    list: Option<Property>,
}

impl PropertyAccess for FaceRow {
    fn new() -> Self {
        FaceRow { list: None }
    }

    fn set_property(&mut self, name: String, property: Property) {
        if name == "vertex_indices" || name == "vertex_index" {
            self.list = Some(property);
        }
    }
}

/// Row of an element we do not use (still parsed, to advance the reader).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v.into(),
        Property::UChar(v) => v.into(),
        Property::Short(v) => v.into(),
        Property::UShort(v) => v.into(),
        Property::Int(v) => v.into(),
        Property::UInt(v) => v.into(),
        Property::Float(v) => v.into(),
        Property::Double(v) => v,
        _ => return None,
    })
}

/// Appends the list in `p` to `out` as u32 vertex indices; `Err(value)` on a
/// value that cannot be a vertex index.
fn push_indices(p: &Property, out: &mut Vec<u32>) -> Result<(), f64> {
    fn ints<T: Copy + TryInto<u32> + Into<f64>>(v: &[T], out: &mut Vec<u32>) -> Result<(), f64> {
        for &x in v {
            out.push(x.try_into().map_err(|_| x.into())?);
        }
        Ok(())
    }
    match p {
        Property::ListChar(v) => ints(v, out),
        Property::ListUChar(v) => ints(v, out),
        Property::ListShort(v) => ints(v, out),
        Property::ListUShort(v) => ints(v, out),
        Property::ListInt(v) => ints(v, out),
        Property::ListUInt(v) => ints(v, out),
        Property::ListFloat(v) => v.first().map_or(Ok(()), |&x| Err(x.into())),
        Property::ListDouble(v) => v.first().map_or(Ok(()), |&x| Err(x)),
        _ => Ok(()),
    }
}

fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Finds the end of the header (just after the `end_header` line) and
/// rejects what would make ply-rs-bw panic: digit runs too long for a u64.
fn scan_header(data: &[u8]) -> Result<usize, MeshIoError> {
    if !data.starts_with(b"ply") {
        return Err(MeshIoError::line(
            1,
            "not a PLY file (must start with 'ply')",
        ));
    }
    let mut pos = 0;
    let mut line = 0u64;
    while pos < data.len() {
        line += 1;
        let end = data[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |k| pos + k);
        let text = data[pos..end].trim_ascii();
        pos = end + 1;
        if text == b"end_header" {
            return Ok(pos.min(data.len()));
        }
        if text.starts_with(b"comment") || text.starts_with(b"obj_info") {
            continue;
        }
        let too_long = text.split(|b| !b.is_ascii_digit()).any(|run| {
            !run.is_empty()
                && std::str::from_utf8(run)
                    .ok()
                    .and_then(|s| s.parse::<u64>().ok())
                    .is_none()
        });
        if too_long {
            return Err(MeshIoError::line(line, "number too large in the header"));
        }
    }
    Err(MeshIoError::line(line, "header has no 'end_header' line"))
}

/// Smallest number of bytes one element of `e` can take.
fn min_element_bytes(e: &ElementDef, encoding: Encoding) -> usize {
    match encoding {
        // A token and a separator per property (the last one a newline).
        Encoding::Ascii => 2 * e.properties.len(),
        _ => e
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) => scalar_size(t),
                PropertyType::List(count, _) => scalar_size(count),
            })
            .sum(),
    }
}

/// Reads an ASCII or binary PLY file held in memory.
pub fn read_ply_bytes(data: &[u8]) -> Result<IndexedMesh, MeshIoError> {
    let header_end = scan_header(data)?;
    let mut cur = Cursor::new(data);
    let header: Header = Parser::<Skip>::new().read_header(&mut cur).map_err(|e| {
        MeshIoError::parse(super::Location::Unknown, format!("bad PLY header: {e}"))
    })?;
    let body_start = (cur.position() as usize).max(header_end.min(data.len()));
    cur.set_position(body_start as u64);
    let remaining = data.len() - body_start;

    // Bound the work before reading anything.
    let mut need: u128 = 0;
    for e in header.elements.values() {
        let min = min_element_bytes(e, header.encoding);
        if min == 0 && e.count > 0 {
            return Err(MeshIoError::unsupported(format!(
                "PLY element '{}' has no properties but a count of {}",
                e.name, e.count
            )));
        }
        need += (min as u128) * (e.count as u128);
    }
    // The last ASCII line may lack its newline.
    if need > remaining as u128 + 1 {
        return Err(MeshIoError::offset(
            body_start,
            format!("header declares elements needing at least {need} bytes but only {remaining} remain"),
        ));
    }
    let vdef = header.elements.get("vertex");
    if vdef.is_none() {
        return Err(MeshIoError::parse(
            super::Location::Unknown,
            "PLY file has no 'vertex' element",
        ));
    }
    if header.elements.contains_key("tristrips") && !header.elements.contains_key("face") {
        return Err(MeshIoError::unsupported(
            "PLY triangle strips ('tristrips') are not supported",
        ));
    }

    let mut m = IndexedMesh::new();
    let mut faces: Option<Vec<FaceRow>> = None;
    let body_err = |e: std::io::Error, what: &str| {
        MeshIoError::parse(super::Location::Unknown, format!("{what}: {e}"))
    };
    for (name, e) in &header.elements {
        match name.as_str() {
            "vertex" => {
                for axis in ["x", "y", "z"] {
                    match e.properties.get(axis).map(|p| &p.data_type) {
                        Some(PropertyType::Scalar(_)) => {}
                        _ => {
                            return Err(MeshIoError::parse(
                                super::Location::Unknown,
                                format!("PLY vertex element has no scalar '{axis}' property"),
                            ))
                        }
                    }
                }
                let extra_names: Vec<String> = e
                    .properties
                    .values()
                    .filter(|p| !["x", "y", "z"].contains(&p.name.as_str()))
                    .filter(|p| matches!(p.data_type, PropertyType::Scalar(_)))
                    .map(|p| p.name.clone())
                    .collect();
                let rows = Parser::<VertexRow>::new()
                    .read_payload_for_element(&mut cur, e, &header)
                    .map_err(|err| body_err(err, "reading PLY vertices"))?;
                m.positions = rows.iter().map(|r| DVec3::from_array(r.p)).collect();
                for (k, n) in extra_names.into_iter().enumerate() {
                    let vals = rows
                        .iter()
                        .map(|r| r.extras.get(k).copied().unwrap_or(0.0))
                        .collect();
                    m.vertex_scalars.insert(n, vals);
                }
            }
            "face" => {
                let has_list = ["vertex_indices", "vertex_index"].iter().any(|n| {
                    matches!(
                        e.properties.get(*n).map(|p| &p.data_type),
                        Some(PropertyType::List(..))
                    )
                });
                if !has_list {
                    return Err(MeshIoError::parse(
                        super::Location::Unknown,
                        "PLY face element has no 'vertex_indices' list",
                    ));
                }
                faces = Some(
                    Parser::<FaceRow>::new()
                        .read_payload_for_element(&mut cur, e, &header)
                        .map_err(|err| body_err(err, "reading PLY faces"))?,
                );
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut cur, e, &header)
                    .map_err(|err| body_err(err, &format!("reading PLY element '{name}'")))?;
            }
        }
    }
    let nv = m.positions.len();
    if let Some(rows) = faces {
        m.face_starts.reserve(rows.len());
        for (f, r) in rows.iter().enumerate() {
            if let Some(list) = &r.list {
                let start = m.indices.len();
                push_indices(list, &mut m.indices).map_err(|v| {
                    MeshIoError::invalid(Element::Face(f as u32), format!("has vertex index {v}"))
                })?;
                if let Some(&i) = m.indices[start..].iter().find(|&&i| i as usize >= nv) {
                    return Err(MeshIoError::invalid(
                        Element::Face(f as u32),
                        format!("references vertex {i} but the file has {nv} vertices"),
                    ));
                }
            }
            let n = u32::try_from(m.indices.len())
                .map_err(|_| MeshIoError::unsupported("more than 2^32 face corners"))?;
            m.face_starts.push(n);
        }
    }
    Ok(m)
}

fn write_header(w: &mut Vec<u8>, mesh: &IndexedMesh, format: &str) -> Result<bool, MeshIoError> {
    for name in mesh.vertex_scalars.keys() {
        let ok = !name.is_empty()
            && !["x", "y", "z"].contains(&name.as_str())
            && name.bytes().all(|b| b.is_ascii_graphic());
        if !ok {
            return Err(MeshIoError::invalid(
                Element::Mesh,
                format!("vertex property name '{name}' cannot be written to PLY"),
            ));
        }
    }
    if mesh.vertex_count() > i32::MAX as usize {
        return Err(MeshIoError::unsupported(
            "more than 2^31 - 1 vertices for PLY int indices",
        ));
    }
    let small = mesh.faces().all(|f| f.len() <= 255);
    writeln!(w, "ply\nformat {format} 1.0\ncomment written by pqm")?;
    writeln!(w, "element vertex {}", mesh.vertex_count())?;
    w.extend_from_slice(b"property double x\nproperty double y\nproperty double z\n");
    for name in mesh.vertex_scalars.keys() {
        writeln!(w, "property double {name}")?;
    }
    writeln!(w, "element face {}", mesh.face_count())?;
    writeln!(
        w,
        "property list {} int vertex_indices",
        if small { "uchar" } else { "int" }
    )?;
    w.extend_from_slice(b"end_header\n");
    Ok(small)
}

/// Writes `mesh` as binary little-endian PLY (see the module docs).
pub fn write_ply(mut w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    super::check_writable(mesh)?;
    let mut buf = Vec::with_capacity(1 << 16);
    let small = write_header(&mut buf, mesh, "binary_little_endian")?;
    let scalars: Vec<&Vec<f64>> = mesh.vertex_scalars.values().collect();
    for (v, p) in mesh.positions.iter().enumerate() {
        for x in p.to_array() {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        for s in &scalars {
            buf.extend_from_slice(&s[v].to_le_bytes());
        }
        if buf.len() >= 1 << 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    for f in mesh.faces() {
        if small {
            buf.push(f.len() as u8);
        } else {
            buf.extend_from_slice(&(f.len() as i32).to_le_bytes());
        }
        for &i in f {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
        if buf.len() >= 1 << 16 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)?;
    w.flush()?;
    Ok(())
}

/// Writes `mesh` as ASCII PLY (same layout as [`write_ply`]).
pub fn write_ply_ascii(w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    super::check_writable(mesh)?;
    let mut buf = Vec::with_capacity(1 << 16);
    write_header(&mut buf, mesh, "ascii")?;
    let scalars: Vec<&Vec<f64>> = mesh.vertex_scalars.values().collect();
    super::write_ascii_rows(w, buf, mesh, &scalars)
}
