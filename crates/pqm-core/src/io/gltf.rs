//! glTF 2.0 / GLB reading (via `gltf`) and writing (via `gltf-json`).
//!
//! # Reading
//!
//! All primitives of mode TRIANGLES of all meshes, in document order, become
//! one [`IndexedMesh`]: each primitive's POSITION values are appended
//! (vertices are not shared between primitives) and its triangles are offset
//! accordingly; other modes (points, lines, strips, fans) are skipped.
//! Non-indexed primitives use consecutive vertex triples. A mesh instanced
//! by a node gets the world transform of its first instance (depth first:
//! default scene, other scenes, then root nodes in no scene, such as the
//! coarser `MSFT_lod` levels); meshes no node instances are read as stored.
//! Several instances of one mesh are read once.
//!
//! When `FB_ngon_encoding` is listed in `extensionsUsed`, polygons are
//! recovered: consecutive triangles with the same first index that form a
//! fan (each triangle's second vertex is the previous one's third) are one
//! polygon. Without the extension triangles stay triangles.
//!
//! Buffers come from the GLB `BIN` chunk, from `data:` URIs (base64), or from
//! files relative to `base_dir` (`.bin` next to a `.gltf`); other URI schemes
//! are unsupported. Accessors are decoded here with explicit bounds checks
//! (VEC3 positions of float32 or, as `KHR_mesh_quantization` allows, of
//! (normalized) 8/16-bit integers; u8/u16/u32 SCALAR indices; sparse
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
//! apart. A quad is split along its shorter diagonal
//! ([`quad_split_diagonal`]): its fan starts at one end of it (the other
//! end when the first is the previous anchor), so it reads back as the
//! same quad, maybe starting at another corner. The extension is listed in `extensionsUsed`, not in
//! `extensionsRequired` (plain readers see a valid triangle mesh). Only
//! positions, optional normals and faces are written.
//!
//! [`GltfWriteOptions`] adds normals (smooth, or flat with per-face vertex
//! copies) and `KHR_mesh_quantization` (16-bit positions restored by the
//! node transform; see [`GltfWriteOptions::quantize`]);
//! [`write_glb_lod`] writes several levels of detail of one object linked
//! with `MSFT_lod`. Every combination passes the Khronos glTF-Validator
//! with zero errors (tests `io_gltf_validate` and `gltf_export_*`).
//!
//! `.gltf` output embeds the buffer as a base64 `data:` URI, so the file is
//! self-contained and the atomic single-file write of
//! [`super::write_mesh`] covers everything.

use super::{read_all, Element, Location, MeshIoError, MeshIoErrorKind};
use crate::IndexedMesh;
use base64::Engine;
use glam::{DMat4, DVec3};
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
/// Name of the glTF extension that allows integer vertex attributes.
pub const KHR_MESH_QUANTIZATION: &str = "KHR_mesh_quantization";
/// Name of the (Microsoft vendor) glTF extension for discrete levels of detail.
pub const MSFT_LOD: &str = "MSFT_lod";

/// Reads a glTF (JSON) or GLB file from `reader`. External buffer files are
/// resolved relative to `base_dir`; without it only GLB and `data:` URIs work.
pub fn read_gltf(reader: impl Read, base_dir: Option<&Path>) -> Result<IndexedMesh, MeshIoError> {
    read_gltf_bytes(&read_all(reader)?, base_dir)
}

fn gltf_err(message: impl Into<String>) -> MeshIoError {
    MeshIoError::parse(Location::Unknown, message)
}

/// gltf-json's validation indexes `accessors` with a primitive's POSITION
/// index unchecked (it panics on a hostile file), so every accessor a
/// primitive names is bounds-checked first.
fn check_accessor_indices(root: &gltf::json::Root) -> Result<(), MeshIoError> {
    let n = root.accessors.len();
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let named = prim.attributes.values().chain(prim.indices.iter());
            for a in named {
                if a.value() >= n {
                    return Err(gltf_err(format!(
                        "mesh {mi} primitive {pi} names accessor {} but the file has {n}",
                        a.value()
                    )));
                }
            }
        }
    }
    Ok(())
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
    let invalid = |e: gltf::Error| gltf_err(format!("invalid glTF: {e}"));
    let raw = gltf::Gltf::from_slice_without_validation(data).map_err(invalid)?;
    // The gltf crate refuses every required extension it does not implement;
    // KHR_mesh_quantization is implemented here (integer positions below).
    let mut root = raw.document.into_json();
    root.extensions_required
        .retain(|e| e != KHR_MESH_QUANTIZATION);
    check_accessor_indices(&root)?;
    let doc = gltf::Gltf {
        document: gltf::Document::from_json(root).map_err(invalid)?,
        blob: raw.blob,
    };
    let buffers = load_buffers(&doc, base_dir)?;
    let ngon = doc.extensions_used().any(|e| e == FB_NGON_ENCODING);

    let transforms = mesh_transforms(&doc);
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
            if pos.dimensions() != Dimensions::Vec3 {
                return Err(MeshIoError::unsupported(format!(
                    "{what}: POSITION must be VEC3"
                )));
            }
            let (bytes, stride) = accessor_bytes(&pos, &buffers, &what)?;
            let base = m.positions.len();
            let count = pos.count();
            m.positions.reserve(count);
            let component = component_reader(pos.data_type(), pos.normalized());
            for k in 0..count {
                let o = k * stride;
                let size = pos.data_type().size();
                let f = |i: usize| component(&bytes[o + size * i..o + size * (i + 1)]);
                m.positions.push(DVec3::new(f(0), f(1), f(2)));
            }
            if let Some(t) = transforms[mesh.index()].filter(|t| *t != DMat4::IDENTITY) {
                for p in &mut m.positions[base..] {
                    *p = t.transform_point3(*p);
                }
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

/// Decodes one vertex attribute component of type `t` (little endian) to
/// f64: float32 as is, integers as their value, or mapped to `[-1, 1]` /
/// `[0, 1]` when `normalized` (glTF 2.0 §3.11, as KHR_mesh_quantization
/// uses them). The slice has exactly `t.size()` bytes.
fn component_reader(t: DataType, normalized: bool) -> impl Fn(&[u8]) -> f64 {
    move |b: &[u8]| {
        let (v, scale) = match t {
            DataType::F32 => (f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])), 0.0),
            DataType::I8 => (f64::from(b[0] as i8), 127.0),
            DataType::U8 => (f64::from(b[0]), 255.0),
            DataType::I16 => (f64::from(i16::from_le_bytes([b[0], b[1]])), 32767.0),
            DataType::U16 => (f64::from(u16::from_le_bytes([b[0], b[1]])), 65535.0),
            DataType::U32 => (f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])), 0.0),
        };
        if normalized && scale > 0.0 {
            (v / scale).max(-1.0)
        } else {
            v
        }
    }
}

/// The world transform of the first node instancing each mesh, in a
/// depth-first walk of the default scene, then of the other scenes, then of
/// the root nodes outside every scene; `None` for meshes no node instances. The walk is iterative and
/// visits each node once, so hostile hierarchies (cycles, deep chains)
/// neither loop nor overflow the stack.
fn mesh_transforms(doc: &gltf::Document) -> Vec<Option<DMat4>> {
    let mut out = vec![None; doc.meshes().len()];
    let mut seen = vec![false; doc.nodes().len()];
    let mut has_parent = vec![false; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            has_parent[c.index()] = true;
        }
    }
    // Root nodes outside every scene come last: MSFT_lod keeps its coarser
    // levels there.
    let roots = doc
        .default_scene()
        .into_iter()
        .chain(doc.scenes())
        .map(|s| s.nodes().collect::<Vec<_>>())
        .chain(std::iter::once(
            doc.nodes().filter(|n| !has_parent[n.index()]).collect(),
        ));
    let mut stack = Vec::new();
    for nodes in roots {
        stack.extend(nodes.into_iter().rev().map(|n| (n, DMat4::IDENTITY)));
        while let Some((node, parent)) = stack.pop() {
            if std::mem::replace(&mut seen[node.index()], true) {
                continue;
            }
            let local = node.transform().matrix().map(|c| c.map(f64::from));
            let world = parent * DMat4::from_cols_array_2d(&local);
            if let Some(mesh) = node.mesh() {
                out[mesh.index()].get_or_insert(world);
            }
            stack.extend(node.children().map(|c| (c, world)));
        }
    }
    out
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

/// Which diagonal to split quad `q` along: 0 for `q[0]–q[2]`, 1 for
/// `q[1]–q[3]`, whichever is shorter in `positions` (0 on a tie).
///
/// Why the shorter one: of the two triangle pairs of a non-planar quad it
/// is the one that folds less along a short crease, the usual choice of
/// modelling tools (Blender's "shortest diagonal"), and it does not depend
/// on where the quad's corner list starts — which a `.pqm` writer chooses
/// for size (`pqm encode --corner-order`), so that the same quads export
/// the same triangles. It also compresses well: gltfpack's codecs
/// (meshoptimizer + zstd) took 129.4 KB for loki's finest level split this
/// way against 132.2 KB split as the input's corners start and 141.1 KB as
/// the canonical `.pqm` corners start (session 22).
pub fn quad_split_diagonal(positions: &[DVec3], q: [u32; 4]) -> usize {
    let d = |a: u32, b: u32| positions[a as usize].distance_squared(positions[b as usize]);
    usize::from(d(q[1], q[3]) < d(q[0], q[2]))
}

/// Which diagonal the glTF writers split each quad along.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum QuadSplit {
    /// The shorter one ([`quad_split_diagonal`]): what modelling tools do,
    /// whatever corner a quad's list starts at.
    #[default]
    Shorter,
    /// `q[0]–q[2]`, as the mesh lists each quad: for quads whose corner
    /// lists were started so that this diagonal is the meant one (a
    /// triangle mesh joined in pairs, whose `.pqm` file says so: then the
    /// finest level exports the input's own triangles).
    First,
}

impl QuadSplit {
    /// The corner of `face` the split starts at: the quad's diagonal runs
    /// from it to the corner two on (0 for anything but a quad, and for a
    /// quad naming a vertex `positions` does not have, which a checked mesh
    /// never holds: fanned as listed rather than measured).
    fn start(self, positions: &[DVec3], face: &[u32]) -> usize {
        match (self, face) {
            (QuadSplit::Shorter, &[a, b, c, d])
                if face.iter().all(|&v| (v as usize) < positions.len()) =>
            {
                quad_split_diagonal(positions, [a, b, c, d])
            }
            _ => 0,
        }
    }
}

/// `mesh` with each quad split into two triangles along the diagonal
/// `split` picks (`(v0, v1, v2)`, `(v0, v2, v3)` from the corner that
/// starts it) and every other polygon of five or more corners into a fan
/// from its first corner; triangles stay. Any mesh is taken: faces of
/// fewer than three corners are left out, and corner tables whose length
/// is not the corners' are dropped. Vertices, their tables and
/// properties are kept; each corner keeps its texture coordinate and
/// normal, each face its group (a polygon's triangles take its place).
///
/// For the full level of a `.pqm` file whose header says its diagonals are
/// meant (format 4.1, flag bit 3: a triangle mesh paired into quads),
/// [`QuadSplit::First`] gives back exactly the input's triangles.
pub fn triangulate(mesh: &IndexedMesh, split: QuadSplit) -> IndexedMesh {
    let mut out = IndexedMesh {
        positions: mesh.positions.clone(),
        texcoords: mesh.texcoords.clone(),
        normals: mesh.normals.clone(),
        vertex_scalars: mesh.vertex_scalars.clone(),
        ..IndexedMesh::new()
    };
    let mut group = mesh.groups.iter().peekable();
    for (f, face) in mesh.faces().enumerate() {
        while let Some((name, _)) = group.next_if(|g| g.1 as usize <= f) {
            out.groups.push((name.clone(), out.face_count() as u32));
        }
        let n = face.len();
        let r = split.start(&mesh.positions, face);
        let at = mesh.face_starts[f] as usize;
        let corner = |k: usize| at + (r + k) % n;
        for k in 1..n.saturating_sub(1) {
            let tri = [corner(0), corner(k), corner(k + 1)];
            out.push_face(&tri.map(|c| mesh.indices[c]));
            for (table, corners) in [
                (&mesh.corner_texcoords, &mut out.corner_texcoords),
                (&mesh.corner_normals, &mut out.corner_normals),
            ] {
                if table.len() == mesh.indices.len() {
                    corners.extend(tri.map(|c| table[c]));
                }
            }
        }
    }
    // Groups that start past the last face (none in a valid mesh) stay.
    let end = out.face_count() as u32;
    out.groups
        .extend(group.map(|(name, _)| (name.clone(), end)));
    out
}

/// Triangle fans in FB_ngon_encoding order (see the module docs); quads
/// along the diagonal `split` picks.
fn ngon_triangles(mesh: &IndexedMesh, split: QuadSplit) -> Result<Vec<u32>, MeshIoError> {
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
        // first vertex is the previous anchor, so rotating by one suffices;
        // a quad's fan from either end of its diagonal (a rotation by 2)
        // draws the same two triangles.
        let r = if n == 4 {
            let r = split.start(&mesh.positions, face);
            if face[r] == prev_anchor {
                r + 2
            } else {
                r
            }
        } else {
            usize::from(face[0] == prev_anchor)
        };
        let v = |k: usize| face[(r + k) % n];
        for k in 1..n - 1 {
            out.extend_from_slice(&[v(0), v(k), v(k + 1)]);
        }
        prev_anchor = v(0);
    }
    Ok(out)
}

/// Which normals the glTF writers emit (`--normals none|smooth|flat`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Normals {
    /// No NORMAL attribute; viewers then shade flat (glTF 2.0 §3.7.2.1).
    #[default]
    None,
    /// One normal per vertex: the sum of the adjacent polygons' area vectors
    /// (Newell normals, so larger faces weigh more), normalized. Vertices stay
    /// shared, so the vertex count is the mesh's.
    Smooth,
    /// One normal per polygon (its Newell normal, normalized): every polygon
    /// gets its own copies of its vertices, so the vertex count becomes the
    /// number of face corners. Polygons then share no vertex, which keeps the
    /// `FB_ngon_encoding` anchors of consecutive polygons distinct for free.
    Flat,
}

/// Options of [`write_gltf_with`], [`write_glb_with`] and [`write_glb_lod`].
/// The default (no normals, float positions) is what [`write_gltf`] and
/// [`write_glb`] write.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct GltfWriteOptions {
    /// Normals to write (default none).
    pub normals: Normals,
    /// Store positions (and normals) as 16-bit integers with
    /// `KHR_mesh_quantization`: positions as unnormalized SHORT on a uniform
    /// grid (step = largest bounding-box half extent / 32767, so the error is
    /// at most a quarter of 1/32767 of the largest extent per axis), restored
    /// by the node's `scale` and `translation`; normals as normalized SHORT.
    /// The extension is listed in `extensionsUsed` and `extensionsRequired`,
    /// as it requires. Halves the vertex data (8 bytes per position or
    /// normal, padded for the 4-byte alignment glTF asks of attributes).
    pub quantize: bool,
    /// The diagonal each quad is split along (default the shorter).
    pub quad_split: QuadSplit,
}

/// A unit normal from an area vector; `+Z` when the polygon is degenerate
/// (the validator rejects non-unit normals, so some unit vector must be
/// written, and a degenerate polygon has no better one).
fn unit_or_z(n: DVec3) -> DVec3 {
    let u = n.normalize_or_zero();
    if u == DVec3::ZERO {
        DVec3::Z
    } else {
        u
    }
}

/// Newell's area vector of a polygon (twice the area times the normal for a
/// planar one; a stable average normal for a non-planar quad). Taken
/// relative to the first corner to limit cancellation far from the origin.
fn newell(positions: &[DVec3], face: &[u32]) -> DVec3 {
    let p0 = positions[face[0] as usize];
    let mut n = DVec3::ZERO;
    for k in 1..face.len().saturating_sub(1) {
        let a = positions[face[k] as usize] - p0;
        let b = positions[face[k + 1] as usize] - p0;
        n += a.cross(b);
    }
    n
}

/// Vertex data and `FB_ngon_encoding` triangles of one mesh, ready to encode.
struct Prepared<'a> {
    positions: Cow<'a, [DVec3]>,
    normals: Option<Vec<DVec3>>,
    tris: Vec<u32>,
}

/// Checks `mesh` and lays out its vertices for `normals` (see [`Normals`]).
fn prepare(
    mesh: &IndexedMesh,
    normals: Normals,
    split: QuadSplit,
) -> Result<Prepared<'_>, MeshIoError> {
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
    // Also rejects faces with fewer than three vertices, before the normal
    // code below indexes their corners.
    let tris = ngon_triangles(mesh, split)?;
    Ok(match normals {
        Normals::None => Prepared {
            positions: Cow::Borrowed(&mesh.positions),
            normals: None,
            tris,
        },
        Normals::Smooth => {
            let mut acc = vec![DVec3::ZERO; mesh.positions.len()];
            for face in mesh.faces() {
                let n = newell(&mesh.positions, face);
                for &v in face {
                    acc[v as usize] += n;
                }
            }
            Prepared {
                positions: Cow::Borrowed(&mesh.positions),
                normals: Some(acc.into_iter().map(unit_or_z).collect()),
                tris,
            }
        }
        Normals::Flat => {
            // Corner k of the mesh becomes vertex k; the faces keep their
            // sizes and order, so the fan order (and any error message
            // about a face) is the same as for the shared layout.
            let flat = IndexedMesh {
                positions: mesh
                    .indices
                    .iter()
                    .map(|&i| mesh.positions[i as usize])
                    .collect(),
                face_starts: mesh.face_starts.clone(),
                indices: (0..mesh.indices.len() as u32).collect(),
                ..IndexedMesh::default()
            };
            let mut nrm = Vec::with_capacity(mesh.indices.len());
            for face in mesh.faces() {
                let n = unit_or_z(newell(&mesh.positions, face));
                nrm.resize(nrm.len() + face.len(), n);
            }
            Prepared {
                tris: ngon_triangles(&flat, split)?,
                positions: Cow::Owned(flat.positions),
                normals: Some(nrm),
            }
        }
    })
}

/// The KHR_mesh_quantization grid: a position `p` is stored as the integer
/// vector `q = round((p - center) / step)` and restored by the node transform
/// `center + step * q`. `center` and `step` are f32 values (what the node
/// stores), so the rounding is computed against exactly what a reader uses.
#[derive(Clone, Copy, Debug)]
struct QuantFrame {
    center: [f32; 3],
    step: f32,
}

impl QuantFrame {
    /// The grid covering the box `lo..hi` with 16-bit signed integers.
    fn covering(lo: DVec3, hi: DVec3) -> QuantFrame {
        let c = ((lo + hi) * 0.5).as_vec3();
        let cd = c.as_dvec3();
        let half = (hi - cd).max(cd - lo).max_element();
        // A hair above half/32767 so that the extreme points round inside
        // the i16 range despite the f32 rounding of `step`; the clamp in
        // `quantize` catches anything left.
        let step = (half / 32767.0 * (1.0 + 1e-6)) as f32;
        let step = if step.is_finite() && step > 0.0 {
            step
        } else {
            1.0
        };
        QuantFrame {
            center: c.to_array(),
            step,
        }
    }

    fn quantize(&self, p: DVec3) -> [i16; 3] {
        let s = f64::from(self.step);
        let q = |k: usize| {
            ((p[k] - f64::from(self.center[k])) / s)
                .round()
                .clamp(-32767.0, 32767.0) as i16
        };
        [q(0), q(1), q(2)]
    }
}

/// Accumulates the JSON document and its single binary buffer.
struct DocBuilder {
    root: json::Root,
    bin: Vec<u8>,
    buffer: json::Index<json::Buffer>,
}

impl DocBuilder {
    fn new(opts: &GltfWriteOptions) -> Self {
        let mut root = json::Root::default();
        root.asset.generator = Some("pqm".into());
        root.extensions_used.push(FB_NGON_ENCODING.into());
        if opts.quantize {
            root.extensions_used.push(KHR_MESH_QUANTIZATION.into());
            root.extensions_required.push(KHR_MESH_QUANTIZATION.into());
        }
        // The length and the URI are filled in by `finish`.
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        DocBuilder {
            root,
            bin: Vec::new(),
            buffer,
        }
    }

    /// Appends `bytes` as a buffer view, 4-byte aligned (glTF requires it
    /// for vertex attributes and the validator for every accessor).
    fn view(
        &mut self,
        bytes: &[u8],
        stride: Option<usize>,
        target: json::buffer::Target,
    ) -> json::Index<json::buffer::View> {
        while self.bin.len() & 3 != 0 {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: self.buffer,
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: stride.map(json::buffer::Stride),
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: Default::default(),
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        ct: json::accessor::ComponentType,
        ty: json::accessor::Type,
        normalized: bool,
        min: Option<json::Value>,
        max: Option<json::Value>,
    ) -> json::Index<json::Accessor> {
        self.root.push(json::Accessor {
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
            normalized,
            sparse: None,
        })
    }

    /// Encodes one mesh (positions, optional normals, triangles) and returns
    /// a node instancing it (with the quantization transform when `frame`).
    fn add_mesh(
        &mut self,
        p: &Prepared<'_>,
        frame: Option<&QuantFrame>,
    ) -> json::Index<json::Node> {
        use json::accessor::{ComponentType as C, Type as T};
        use json::buffer::Target;
        let nv = p.positions.len();
        let pos_acc = match frame {
            None => {
                let mut bytes = Vec::with_capacity(12 * nv);
                let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
                for q in p.positions.iter() {
                    let q = q.as_vec3().to_array();
                    for k in 0..3 {
                        lo[k] = lo[k].min(q[k]);
                        hi[k] = hi[k].max(q[k]);
                        bytes.extend_from_slice(&q[k].to_le_bytes());
                    }
                }
                let view = self.view(&bytes, None, Target::ArrayBuffer);
                self.accessor(
                    view,
                    nv,
                    C::F32,
                    T::Vec3,
                    false,
                    Some(json::Value::from(lo.to_vec())),
                    Some(json::Value::from(hi.to_vec())),
                )
            }
            Some(frame) => {
                let mut bytes = Vec::with_capacity(8 * nv);
                let (mut lo, mut hi) = ([i16::MAX; 3], [i16::MIN; 3]);
                for &q in p.positions.iter() {
                    let q = frame.quantize(q);
                    for k in 0..3 {
                        lo[k] = lo[k].min(q[k]);
                        hi[k] = hi[k].max(q[k]);
                        bytes.extend_from_slice(&q[k].to_le_bytes());
                    }
                    bytes.extend_from_slice(&[0, 0]);
                }
                let view = self.view(&bytes, Some(8), Target::ArrayBuffer);
                self.accessor(
                    view,
                    nv,
                    C::I16,
                    T::Vec3,
                    false,
                    Some(json::Value::from(lo.to_vec())),
                    Some(json::Value::from(hi.to_vec())),
                )
            }
        };
        let nrm_acc = p.normals.as_ref().map(|normals| {
            if frame.is_none() {
                let mut bytes = Vec::with_capacity(12 * nv);
                for n in normals {
                    for c in n.as_vec3().to_array() {
                        bytes.extend_from_slice(&c.to_le_bytes());
                    }
                }
                let view = self.view(&bytes, None, Target::ArrayBuffer);
                self.accessor(view, nv, C::F32, T::Vec3, false, None, None)
            } else {
                // Normalized SHORT: the rounding moves a unit vector's length
                // by at most ~3e-5, well inside the validator's unit-length
                // tolerance (normalized BYTE would not be).
                let mut bytes = Vec::with_capacity(8 * nv);
                for n in normals {
                    for c in n.to_array() {
                        let q = (c * 32767.0).round().clamp(-32767.0, 32767.0) as i16;
                        bytes.extend_from_slice(&q.to_le_bytes());
                    }
                    bytes.extend_from_slice(&[0, 0]);
                }
                let view = self.view(&bytes, Some(8), Target::ArrayBuffer);
                self.accessor(view, nv, C::I16, T::Vec3, true, None, None)
            }
        });
        // 65535 is the primitive-restart value glTF forbids as an index.
        let small = nv < 65535;
        let mut bytes = Vec::with_capacity(if small { 2 } else { 4 } * p.tris.len());
        for &i in &p.tris {
            if small {
                bytes.extend_from_slice(&(i as u16).to_le_bytes());
            } else {
                bytes.extend_from_slice(&i.to_le_bytes());
            }
        }
        let idx_view = self.view(&bytes, None, Target::ElementArrayBuffer);
        let idx_acc = self.accessor(
            idx_view,
            p.tris.len(),
            if small { C::U16 } else { C::U32 },
            T::Scalar,
            false,
            None,
            None,
        );
        let mut attributes = BTreeMap::from([(Valid(json::mesh::Semantic::Positions), pos_acc)]);
        if let Some(n) = nrm_acc {
            attributes.insert(Valid(json::mesh::Semantic::Normals), n);
        }
        let primitive = json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(idx_acc),
            material: None,
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        };
        let gmesh = self.root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: None,
            primitives: vec![primitive],
            weights: None,
        });
        self.root.push(json::Node {
            mesh: Some(gmesh),
            translation: frame.map(|f| f.center),
            scale: frame.map(|f| [f.step; 3]),
            ..Default::default()
        })
    }

    /// Adds the scene showing `nodes`, pads the buffer and fills in its
    /// length (and its base64 data URI when `embed`).
    fn finish(mut self, nodes: Vec<json::Index<json::Node>>, embed: bool) -> (json::Root, Vec<u8>) {
        while self.bin.len() & 3 != 0 {
            self.bin.push(0);
        }
        let scene = self.root.push(json::Scene {
            extensions: None,
            extras: Default::default(),
            name: None,
            nodes,
        });
        self.root.scene = Some(scene);
        let buf = &mut self.root.buffers[self.buffer.value()];
        buf.byte_length = USize64::from(self.bin.len());
        if embed {
            buf.uri = Some(format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&self.bin)
            ));
        }
        (self.root, self.bin)
    }
}

/// Builds the glTF JSON and the binary buffer of one mesh.
fn build(
    mesh: &IndexedMesh,
    opts: &GltfWriteOptions,
    embed: bool,
) -> Result<(json::Root, Vec<u8>), MeshIoError> {
    let prepared = prepare(mesh, opts.normals, opts.quad_split)?;
    let frame = if opts.quantize {
        let (lo, hi) = mesh.bounding_box().unwrap_or((DVec3::ZERO, DVec3::ZERO));
        Some(QuantFrame::covering(lo, hi))
    } else {
        None
    };
    let mut doc = DocBuilder::new(opts);
    let node = doc.add_mesh(&prepared, frame.as_ref());
    Ok(doc.finish(vec![node], embed))
}

fn json_bytes<T: serde::Serialize>(value: &T) -> Result<Vec<u8>, MeshIoError> {
    json::serialize::to_vec(value)
        .map_err(|e| MeshIoError::from(std::io::Error::other(e.to_string())))
}

fn write_glb_parts(mut w: impl Write, text: Vec<u8>, bin: Vec<u8>) -> Result<(), MeshIoError> {
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

/// Writes `mesh` as glTF JSON with the buffer embedded as a base64 data URI
/// (see the module docs for the layout and the polygon encoding). Same as
/// [`write_gltf_with`] with default options.
pub fn write_gltf(w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    write_gltf_with(w, mesh, &GltfWriteOptions::default())
}

/// Writes `mesh` as binary glTF (GLB) with the buffer in the BIN chunk. Same
/// as [`write_glb_with`] with default options.
pub fn write_glb(w: impl Write, mesh: &IndexedMesh) -> Result<(), MeshIoError> {
    write_glb_with(w, mesh, &GltfWriteOptions::default())
}

/// Writes `mesh` as glTF JSON (buffer embedded as a base64 data URI) with
/// the normals and quantization of `opts`.
pub fn write_gltf_with(
    mut w: impl Write,
    mesh: &IndexedMesh,
    opts: &GltfWriteOptions,
) -> Result<(), MeshIoError> {
    let (root, _) = build(mesh, opts, true)?;
    w.write_all(&json_bytes(&root)?)?;
    w.flush()?;
    Ok(())
}

/// Writes `mesh` as GLB with the normals and quantization of `opts`.
pub fn write_glb_with(
    w: impl Write,
    mesh: &IndexedMesh,
    opts: &GltfWriteOptions,
) -> Result<(), MeshIoError> {
    let (root, bin) = build(mesh, opts, false)?;
    write_glb_parts(w, json_bytes(&root)?, bin)
}

/// Screen-coverage hints for levels of detail with these face counts
/// (finest first), as [`write_glb_lod`] takes them.
///
/// A hint is the smallest fraction of the screen the object must cover for
/// its level to be shown (Babylon.js's reading of `MSFT_screencoverage`).
/// The rule keeps the number of faces per unit of covered screen the same
/// at every switch: the finest level is shown from half the screen up
/// (Microsoft's recommended LOD 0 threshold), and level `i` from
/// `0.5 · faces[i] / faces[0]`, so at its threshold each level puts
/// `2 · faces[0]` faces per full screen, just as the finest level does at
/// its own. The coarsest level gets 0, so the object never disappears.
/// With one level the result is `[0.0]`. Face counts of zero count as one.
pub fn lod_screen_coverage(face_counts: &[usize]) -> Vec<f64> {
    let n = face_counts.len();
    let finest = face_counts.first().copied().unwrap_or(1).max(1) as f64;
    face_counts
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            if i + 1 == n {
                0.0
            } else {
                (0.5 * f.max(1) as f64 / finest).min(1.0)
            }
        })
        .collect()
}

/// Adds "LOD level k: " to an error about one level's mesh.
fn in_level(k: usize, e: MeshIoError) -> MeshIoError {
    match e.kind {
        MeshIoErrorKind::Invalid { element, message } => {
            MeshIoError::invalid(element, format!("{message} (LOD level {k})"))
        }
        MeshIoErrorKind::Unsupported(m) => MeshIoError::unsupported(format!("LOD level {k}: {m}")),
        MeshIoErrorKind::Parse { location, message } => {
            MeshIoError::parse(location, format!("LOD level {k}: {message}"))
        }
        kind => MeshIoError::from(kind),
    }
}

/// Writes several levels of detail of one object as one GLB linked with
/// `MSFT_lod`.
///
/// * `levels`: the meshes, **finest first**; face counts must not increase.
/// * `coverage`: one screen-coverage hint per level (fractions of the
///   screen in `[0, 1]`, not increasing; [`lod_screen_coverage`] computes
///   the default rule), written as the finest node's
///   `extras.MSFT_screencoverage`.
/// * `opts`: normals and quantization, as for [`write_glb_with`]. With
///   quantization all levels share one grid (over the union of their
///   bounding boxes), so every level's node has the same transform and a
///   renderer may swap meshes without caring whose transform it keeps.
///
/// Layout: node `i` instances the mesh of level `i`; node 0 carries
/// `extensions.MSFT_lod.ids = [1, …, n-1]` and is the only node in the
/// scene, so a viewer without `MSFT_lod` shows the finest level alone.
/// `MSFT_lod` is listed in `extensionsUsed` only (it is optional by
/// design). With a single level the extension and the hints are omitted
/// and the file is what [`write_glb_with`] writes.
pub fn write_glb_lod(
    w: impl Write,
    levels: &[IndexedMesh],
    coverage: &[f64],
    opts: &GltfWriteOptions,
) -> Result<(), MeshIoError> {
    if levels.is_empty() {
        return Err(MeshIoError::unsupported("no levels of detail to write"));
    }
    if coverage.len() != levels.len() {
        return Err(MeshIoError::unsupported(format!(
            "{} levels of detail but {} screen-coverage values",
            levels.len(),
            coverage.len()
        )));
    }
    if let Some(k) = coverage
        .iter()
        .position(|c| !(c.is_finite() && (0.0..=1.0).contains(c)))
    {
        return Err(MeshIoError::unsupported(format!(
            "screen coverage {} of LOD level {k} is not a fraction in [0, 1]",
            coverage[k]
        )));
    }
    if let Some(k) = coverage.windows(2).position(|w| w[1] > w[0]) {
        return Err(MeshIoError::unsupported(format!(
            "screen coverage increases from LOD level {k} to {} (levels go finest first)",
            k + 1
        )));
    }
    if let Some(k) = levels
        .windows(2)
        .position(|w| w[1].face_count() > w[0].face_count())
    {
        return Err(MeshIoError::unsupported(format!(
            "LOD level {} has more faces ({}) than level {k} ({}); levels go finest first",
            k + 1,
            levels[k + 1].face_count(),
            levels[k].face_count()
        )));
    }
    let prepared = levels
        .iter()
        .enumerate()
        .map(|(k, m)| prepare(m, opts.normals, opts.quad_split).map_err(|e| in_level(k, e)))
        .collect::<Result<Vec<_>, _>>()?;
    let frame = if opts.quantize {
        let boxes = levels.iter().filter_map(IndexedMesh::bounding_box);
        let (lo, hi) = boxes
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
            .unwrap_or((DVec3::ZERO, DVec3::ZERO));
        Some(QuantFrame::covering(lo, hi))
    } else {
        None
    };
    let mut doc = DocBuilder::new(opts);
    if levels.len() > 1 {
        doc.root.extensions_used.push(MSFT_LOD.into());
    }
    let nodes: Vec<_> = prepared
        .iter()
        .map(|p| doc.add_mesh(p, frame.as_ref()))
        .collect();
    let (root, bin) = doc.finish(vec![nodes[0]], false);
    if levels.len() == 1 {
        return write_glb_parts(w, json_bytes(&root)?, bin);
    }
    // gltf-json is built without its open `extensions`/`extras` maps, so the
    // two node members are added on the JSON value.
    let mut value = json::serialize::to_value(&root)
        .map_err(|e| MeshIoError::from(std::io::Error::other(e.to_string())))?;
    let node0 = &mut value["nodes"][0];
    // (Indexing a missing member of a JSON object inserts it.)
    node0["extensions"][MSFT_LOD]["ids"] = json::Value::from((1..levels.len()).collect::<Vec<_>>());
    node0["extras"]["MSFT_screencoverage"] = json::Value::from(coverage.to_vec());
    write_glb_parts(w, json_bytes(&value)?, bin)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two triangles' shared edge, as a sorted pair.
    fn shared_edge(t: &[u32]) -> [u32; 2] {
        let mut e: Vec<u32> = t[..3]
            .iter()
            .filter(|v| t[3..].contains(v))
            .copied()
            .collect();
        e.sort();
        [e[0], e[1]]
    }

    /// Each quad is split along its shorter diagonal, whatever corner its
    /// list starts at, and consecutive fans keep distinct anchors.
    #[test]
    fn quads_split_along_the_shorter_diagonal() {
        // A strip of two non-planar quads: 1–3 is the shorter diagonal of
        // the first (2.25 against 3.38, squared), 1–5 (corners 0–2) of the
        // second (2 against 2.43).
        let p = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.3, 1.3, 0.0),
            DVec3::new(0.0, 1.0, 0.5),
            DVec3::new(2.0, 0.0, 0.5),
            DVec3::new(2.0, 1.0, 0.0),
        ];
        for turn in 0..4 {
            let q0 = [0u32, 1, 2, 3];
            let q0: Vec<u32> = (0..4).map(|k| q0[(k + turn) % 4]).collect();
            let mesh = IndexedMesh::from_faces(p.clone(), &[q0, vec![1, 4, 5, 2]]);
            let t = ngon_triangles(&mesh, QuadSplit::Shorter).unwrap();
            assert_eq!(t.len(), 12);
            assert_eq!(shared_edge(&t[..6]), [1, 3], "turn {turn}");
            assert_eq!(shared_edge(&t[6..]), [1, 5], "turn {turn}");
            // fans: each starts at its anchor, and the anchors differ
            assert_eq!(t[0], t[3]);
            assert_eq!(t[6], t[9]);
            assert_ne!(t[0], t[6], "turn {turn}");
            // `First` splits along corners 0–2 as listed: the turn decides
            let t = ngon_triangles(&mesh, QuadSplit::First).unwrap();
            let first = if turn % 2 == 0 { [0, 2] } else { [1, 3] };
            assert_eq!(shared_edge(&t[..6]), first, "turn {turn}");
            assert_eq!(shared_edge(&t[6..]), [1, 5], "turn {turn}");
            assert_ne!(t[0], t[6], "turn {turn}");
            // `triangulate` splits along the same diagonals, as faces.
            for split in [QuadSplit::Shorter, QuadSplit::First] {
                let tri = triangulate(&mesh, split);
                assert_eq!(tri.face_size_counts(), (0, 4, 0));
                let flat: Vec<u32> = tri.indices.clone();
                let want = ngon_triangles(&mesh, split).unwrap();
                assert_eq!(shared_edge(&flat[..6]), shared_edge(&want[..6]));
                assert_eq!(shared_edge(&flat[6..]), shared_edge(&want[6..]));
            }
        }
    }

    /// Corners keep their texture coordinates and normals, faces their
    /// groups, and a pentagon becomes a fan of three.
    #[test]
    fn triangulate_keeps_corner_attributes_and_groups() {
        let p = (0..7)
            .map(|i| DVec3::new((i % 4) as f64, (i / 4) as f64, 0.0))
            .collect();
        let mut m = IndexedMesh::from_faces(p, [vec![0u32, 1, 5, 4], vec![1, 2, 3, 6, 5]]);
        m.texcoords = (0..9).map(|i| [i as f64, 0.0]).collect();
        m.corner_texcoords = (0..9).collect();
        m.groups = vec![("a".into(), 0), ("b".into(), 1)];
        let t = triangulate(&m, QuadSplit::First);
        assert_eq!(t.face_count(), 5);
        assert_eq!(t.groups, vec![("a".into(), 0), ("b".into(), 2)]);
        for (c, &v) in t.indices.iter().enumerate() {
            // corner texture coordinate k sits at input corner k
            let k = t.corner_texcoords[c] as usize;
            assert_eq!(m.indices[k], v);
        }
        assert_eq!(t.face(2), &[1, 2, 3]);
        assert_eq!(t.face(4), &[1, 6, 5]);
    }
}
