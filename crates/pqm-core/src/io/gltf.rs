//! glTF 2.0 / GLB reading (via `gltf`) and writing (via `gltf-json`).
//!
//! # Reading
//!
//! All primitives of mode TRIANGLES of all meshes, in document order, become
//! one [`IndexedMesh`]: each primitive's POSITION values are appended as
//! stored (node transforms are not applied, vertices are not shared between
//! primitives) and its triangles are offset accordingly; other modes (points,
//! lines, strips, fans) are skipped. Non-indexed primitives use consecutive
//! vertex triples.
//!
//! When `FB_ngon_encoding` is listed in `extensionsUsed`, polygons are
//! recovered: consecutive triangles with the same first index that form a
//! fan (each triangle's second vertex is the previous one's third) are one
//! polygon. Without the extension triangles stay triangles.
//!
//! Buffers come from the GLB `BIN` chunk, from `data:` URIs (base64), or from
//! files relative to `base_dir` (`.bin` next to a `.gltf`); other URI schemes
//! are unsupported. Accessors are decoded here with explicit bounds checks
//! (only float32 VEC3 positions and u8/u16/u32 SCALAR indices; sparse
//! accessors are unsupported) so malformed files give errors, not panics.
//! Only the `gltf` crate's JSON model and validation are used, which is why
//! it is built without its `import` feature (that feature pulls in image
//! decoding we do not need).
//!
//! # Writing
//!
//! One buffer, one mesh with one TRIANGLES primitive, one node, one scene.
//! POSITION is float32 VEC3 with accessor min/max; indices are u16 when every
//! index is below 65535 (65535 is the primitive-restart value glTF forbids),
//! otherwise u32. Polygons with more than three vertices are written as
//! triangle fans in `FB_ngon_encoding` order: all triangles of a polygon
//! start at the same vertex (the anchor), and consecutive polygons get
//! different anchors — the polygon is rotated by one when its first vertex
//! equals the previous polygon's anchor — so that a reader can tell polygons
//! apart. The extension is listed in `extensionsUsed`, not in
//! `extensionsRequired` (plain readers see a valid triangle mesh). Only
//! positions and faces are written.
//!
//! `.gltf` output embeds the buffer as a base64 `data:` URI, so the file is
//! self-contained and the atomic single-file write of
//! [`super::write_mesh`] covers everything.

use super::{read_all, Element, Location, MeshIoError};
use crate::IndexedMesh;
use base64::Engine;
use glam::DVec3;
use gltf::accessor::{DataType, Dimensions};
use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::Path;

/// Name of the glTF extension whose triangle order encodes polygons.
pub const FB_NGON_ENCODING: &str = "FB_ngon_encoding";

/// Reads a glTF (JSON) or GLB file from `reader`. External buffer files are
/// resolved relative to `base_dir`; without it only GLB and `data:` URIs work.
pub fn read_gltf(reader: impl Read, base_dir: Option<&Path>) -> Result<IndexedMesh, MeshIoError> {
    read_gltf_bytes(&read_all(reader)?, base_dir)
}

fn gltf_err(message: impl Into<String>) -> MeshIoError {
    MeshIoError::parse(Location::Unknown, message)
}

/// Reads a glTF (JSON) or GLB file held in memory (see [`read_gltf`]).
pub fn read_gltf_bytes(data: &[u8], base_dir: Option<&Path>) -> Result<IndexedMesh, MeshIoError> {
    let data = if data.starts_with(b"glTF") {
        // The gltf crate subtracts 12 from the declared length unchecked.
        if data.len() < 12 {
            return Err(MeshIoError::offset(
                data.len(),
                "GLB file ends inside its header",
            ));
        }
        let len = u32::from_le_bytes([data[8], data[9], data[10], data[11]]) as usize;
        if len < 12 || len > data.len() {
            return Err(MeshIoError::offset(
                8,
                format!(
                    "GLB header declares {len} bytes but the file has {}",
                    data.len()
                ),
            ));
        }
        &data[..len]
    } else {
        data
    };
    let doc = gltf::Gltf::from_slice(data).map_err(|e| gltf_err(format!("invalid glTF: {e}")))?;
    let buffers = load_buffers(&doc, base_dir)?;
    let ngon = doc.extensions_used().any(|e| e == FB_NGON_ENCODING);

    let mut m = IndexedMesh::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let pos = prim
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| gltf_err(format!("{what} has no POSITION attribute")))?;
            if pos.data_type() != DataType::F32 || pos.dimensions() != Dimensions::Vec3 {
                return Err(MeshIoError::unsupported(format!(
                    "{what}: POSITION must be float32 VEC3"
                )));
            }
            let (bytes, stride) = accessor_bytes(&pos, &buffers, &what)?;
            let base = m.positions.len();
            let count = pos.count();
            m.positions.reserve(count);
            for k in 0..count {
                let o = k * stride;
                let f = |i: usize| {
                    let b = &bytes[o + 4 * i..o + 4 * i + 4];
                    f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                };
                m.positions.push(DVec3::new(f(0), f(1), f(2)));
            }
            let tris: Vec<u32> = match prim.indices() {
                Some(acc) => read_indices(&acc, &buffers, &what)?,
                None => (0..count as u32).collect(),
            };
            if !tris.chunks_exact(3).remainder().is_empty() {
                return Err(gltf_err(format!(
                    "{what} has {} indices, not a multiple of 3",
                    tris.len()
                )));
            }
            if let Some(&i) = tris.iter().find(|&&i| i as usize >= count) {
                return Err(MeshIoError::invalid(
                    Element::Face(m.face_count() as u32),
                    format!(
                        "({what}) references vertex {i} but the primitive has {count} vertices"
                    ),
                ));
            }
            let base = u32::try_from(base)
                .map_err(|_| MeshIoError::unsupported("more than 2^32 vertices"))?;
            append_triangles(&mut m, &tris, base, ngon)?;
        }
    }
    Ok(m)
}

/// Appends triangles (indices relative to `base`), merging FB_ngon_encoding
/// fans into polygons when `ngon` is set.
fn append_triangles(
    m: &mut IndexedMesh,
    tris: &[u32],
    base: u32,
    ngon: bool,
) -> Result<(), MeshIoError> {
    let push = |m: &mut IndexedMesh, poly: &[u32]| -> Result<(), MeshIoError> {
        m.indices.extend(poly.iter().map(|&i| i + base));
        let n = u32::try_from(m.indices.len())
            .map_err(|_| MeshIoError::unsupported("more than 2^32 face corners"))?;
        m.face_starts.push(n);
        Ok(())
    };
    let t: Vec<[u32; 3]> = tris.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut k = 0;
    let mut poly = Vec::new();
    while k < t.len() {
        poly.clear();
        poly.extend_from_slice(&t[k]);
        k += 1;
        if ngon {
            // Consecutive triangles with the same anchor that continue the fan.
            while k < t.len() && t[k][0] == poly[0] && t[k][1] == *poly.last().unwrap_or(&u32::MAX)
            {
                poly.push(t[k][2]);
                k += 1;
            }
        }
        push(m, &poly)?;
    }
    Ok(())
}

/// Loads the bytes of every buffer.
fn load_buffers(
    doc: &gltf::Gltf,
    base_dir: Option<&Path>,
) -> Result<Vec<Cow<'static, [u8]>>, MeshIoError> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let data: Vec<u8> = match b.source() {
            gltf::buffer::Source::Bin => doc.blob.clone().ok_or_else(|| {
                gltf_err(format!(
                    "buffer {} refers to a missing GLB BIN chunk",
                    b.index()
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest.split_once(";base64,").ok_or_else(|| {
                        MeshIoError::unsupported(format!(
                            "buffer {}: data URI is not base64",
                            b.index()
                        ))
                    })?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| {
                            gltf_err(format!("buffer {}: bad base64 data: {e}", b.index()))
                        })?
                } else if uri.contains(':') || uri.starts_with('/') || uri.starts_with('\\') {
                    return Err(MeshIoError::unsupported(format!(
                        "buffer {}: only relative file URIs and data URIs are supported, not '{uri}'",
                        b.index()
                    )));
                } else {
                    let dir = base_dir.ok_or_else(|| {
                        MeshIoError::unsupported(format!(
                            "buffer {} is in external file '{uri}' but no base directory is known",
                            b.index()
                        ))
                    })?;
                    let path = dir.join(percent_decode(uri));
                    std::fs::read(&path).map_err(|e| {
                        gltf_err(format!(
                            "buffer {}: cannot read '{}': {e}",
                            b.index(),
                            path.display()
                        ))
                    })?
                }
            }
        };
        if data.len() < b.length() {
            return Err(gltf_err(format!(
                "buffer {} declares {} bytes but has {}",
                b.index(),
                b.length(),
                data.len()
            )));
        }
        out.push(Cow::Owned(data));
    }
    Ok(out)
}

fn percent_decode(s: &str) -> String {
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push(h * 16 + l);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The bytes of an accessor, starting at its first element, and the stride.
/// Guarantees that `count` elements of `accessor.size()` bytes at `stride`
/// are in range.
fn accessor_bytes<'b>(
    acc: &gltf::Accessor<'_>,
    buffers: &'b [Cow<'static, [u8]>],
    what: &str,
) -> Result<(&'b [u8], usize), MeshIoError> {
    if acc.sparse().is_some() {
        return Err(MeshIoError::unsupported(format!(
            "{what}: sparse accessors are not supported"
        )));
    }
    let view = acc.view().ok_or_else(|| {
        MeshIoError::unsupported(format!("{what}: accessor without a buffer view"))
    })?;
    let buf = buffers
        .get(view.buffer().index())
        .ok_or_else(|| gltf_err("missing buffer"))?;
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(gltf_err(format!(
            "{what}: byte stride {stride} is below the element size {elem}"
        )));
    }
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&e| e <= buf.len())
        .ok_or_else(|| {
            gltf_err(format!(
                "{what}: buffer view {} exceeds its buffer",
                view.index()
            ))
        })?;
    let view_bytes = &buf[view.offset()..view_end];
    let count = acc.count();
    if count == 0 {
        return Ok((&[], stride));
    }
    let need = stride
        .checked_mul(count - 1)
        .and_then(|n| n.checked_add(elem))
        .and_then(|n| n.checked_add(acc.offset()))
        .filter(|&n| n <= view_bytes.len())
        .ok_or_else(|| {
            gltf_err(format!(
                "{what}: accessor {} exceeds its buffer view",
                acc.index()
            ))
        })?;
    Ok((&view_bytes[acc.offset()..need], stride))
}

fn read_indices(
    acc: &gltf::Accessor<'_>,
    buffers: &[Cow<'static, [u8]>],
    what: &str,
) -> Result<Vec<u32>, MeshIoError> {
    if acc.dimensions() != Dimensions::Scalar {
        return Err(gltf_err(format!("{what}: indices must be SCALAR")));
    }
    let (bytes, stride) = accessor_bytes(acc, buffers, what)?;
    let n = acc.count();
    let at = |k: usize| k * stride;
    Ok(match acc.data_type() {
        DataType::U8 => (0..n).map(|k| u32::from(bytes[at(k)])).collect(),
        DataType::U16 => (0..n)
            .map(|k| u32::from(u16::from_le_bytes([bytes[at(k)], bytes[at(k) + 1]])))
            .collect(),
        DataType::U32 => (0..n)
            .map(|k| {
                let o = at(k);
                u32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]])
            })
            .collect(),
        t => {
            return Err(gltf_err(format!(
                "{what}: index component type {t:?} is not unsigned"
            )))
        }
    })
}

/// Triangle fans in FB_ngon_encoding order (see the module docs).
fn ngon_triangles(mesh: &IndexedMesh) -> Result<Vec<u32>, MeshIoError> {
    let mut out = Vec::with_capacity(3 * mesh.indices.len());
    let mut prev_anchor = u32::MAX;
    for (f, face) in mesh.faces().enumerate() {
        let n = face.len();
        if n < 3 {
            return Err(MeshIoError::invalid(
                Element::Face(f as u32),
                format!("has {n} vertices; glTF needs polygons of 3 or more"),
            ));
        }
        // A polygon with distinct vertices has at most one rotation whose
        // first vertex is the previous anchor, so rotating by one suffices.
        let r = usize::from(face[0] == prev_anchor);
        let v = |k: usize| face[(r + k) % n];
        for k in 1..n - 1 {
            out.extend_from_slice(&[v(0), v(k), v(k + 1)]);
        }
        prev_anchor = v(0);
    }
    Ok(out)
}

/// Builds the glTF JSON and the binary buffer.
fn build(mesh: &IndexedMesh, embed: bool) -> Result<(json::Root, Vec<u8>), MeshIoError> {
    super::check_writable(mesh)?;
    if mesh.face_count() == 0 {
        return Err(MeshIoError::invalid(
            Element::Mesh,
            "has no faces; glTF needs at least one",
        ));
    }
    if let Some(v) = mesh.positions.iter().position(|p| !p.as_vec3().is_finite()) {
        return Err(MeshIoError::invalid(
            Element::Vertex(v as u32),
            "has a coordinate that is not finite in float32",
        ));
    }
    let tris = ngon_triangles(mesh)?;
    let nv = mesh.positions.len();
    let mut bin = Vec::with_capacity(12 * nv + 4 * tris.len());
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in &mesh.positions {
        let p = p.as_vec3().to_array();
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
            bin.extend_from_slice(&p[k].to_le_bytes());
        }
    }
    let pos_len = bin.len();
    let small = nv < 65535;
    for &i in &tris {
        if small {
            bin.extend_from_slice(&(i as u16).to_le_bytes());
        } else {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let idx_len = bin.len() - pos_len;
    while bin.len() % 4 != 0 {
        bin.push(0);
    }

    let mut root = json::Root::default();
    root.asset.generator = Some("pqm".into());
    root.extensions_used.push(FB_NGON_ENCODING.into());
    let uri = embed.then(|| {
        format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        )
    });
    let buffer = root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        name: None,
        uri,
        extensions: None,
        extras: Default::default(),
    });
    let view = |offset: usize, len: usize, target| json::buffer::View {
        buffer,
        byte_length: USize64::from(len),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        name: None,
        target: Some(Valid(target)),
        extensions: None,
        extras: Default::default(),
    };
    let pos_view = root.push(view(0, pos_len, json::buffer::Target::ArrayBuffer));
    let idx_view = root.push(view(
        pos_len,
        idx_len,
        json::buffer::Target::ElementArrayBuffer,
    ));
    let accessor = |view, count: usize, ct, ty, min, max| json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(ct)),
        extensions: None,
        extras: Default::default(),
        type_: Valid(ty),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    };
    let pos_acc = root.push(accessor(
        pos_view,
        nv,
        json::accessor::ComponentType::F32,
        json::accessor::Type::Vec3,
        Some(json::Value::from(lo.to_vec())),
        Some(json::Value::from(hi.to_vec())),
    ));
    let idx_acc = root.push(accessor(
        idx_view,
        tris.len(),
        if small {
            json::accessor::ComponentType::U16
        } else {
            json::accessor::ComponentType::U32
        },
        json::accessor::Type::Scalar,
        None,
        None,
    ));
    let primitive = json::mesh::Primitive {
        attributes: BTreeMap::from([(Valid(json::mesh::Semantic::Positions), pos_acc)]),
        extensions: None,
        extras: Default::default(),
        indices: Some(idx_acc),
        material: None,
        mode: Valid(json::mesh::Mode::Triangles),
        targets: None,
    };
    let gmesh = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: None,
        primitives: vec![primitive],
        weights: None,
    });
    let node = root.push(json::Node {
        mesh: Some(gmesh),
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: None,
        nodes: vec![node],
    });
    root.scene = Some(scene);
    Ok((root, bin))
}

/// Writes `mesh` as glTF JSON with the buffer embedded as a base64 data URI
/// (see the module docs for the layout and the polygon encoding).
pub fn write_gltf(mut w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    let (root, _) = build(mesh, true)?;
    let text = root
        .to_vec()
        .map_err(|e| MeshIoError::from(std::io::Error::other(e.to_string())))?;
    w.write_all(&text)?;
    w.flush()?;
    Ok(())
}

/// Writes `mesh` as binary glTF (GLB) with the buffer in the BIN chunk.
pub fn write_glb(mut w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    let (root, bin) = build(mesh, false)?;
    let text = root
        .to_vec()
        .map_err(|e| MeshIoError::from(std::io::Error::other(e.to_string())))?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: Cow::Owned(text),
        bin: Some(Cow::Owned(bin)),
    };
    glb.to_writer(&mut w)
        .map_err(|e| MeshIoError::from(std::io::Error::other(e.to_string())))?;
    w.flush()?;
    Ok(())
}
