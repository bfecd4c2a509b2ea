//! `IndexedMesh`: the plain polygon soup that readers produce and writers
//! consume. It is the exchange type between file formats and the half-edge
//! [`crate::mesh::Mesh`]; it keeps whatever the file had (any polygon size,
//! texture coordinates, normals, groups, per-vertex scalar properties) and
//! checks nothing: [`Mesh::from_indexed`](crate::mesh::Mesh::from_indexed)
//! checks the structure when a soup becomes a half-edge mesh.

use glam::DVec3;
use std::collections::BTreeMap;

/// A polygon mesh as index lists.
///
/// Faces are stored flat: face `f` is `indices[face_starts[f]..face_starts[f + 1]]`
/// (so `face_starts.len() == face_count() + 1` and `face_starts[0] == 0`).
/// Vertex indices are 0-based into `positions`. Faces are counter-clockwise
/// seen from outside (the usual OBJ/OFF/PLY/glTF convention).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexedMesh {
    /// Vertex positions, in the file's units.
    pub positions: Vec<DVec3>,
    /// Start of each face in `indices`, plus one final entry equal to `indices.len()`.
    pub face_starts: Vec<u32>,
    /// Vertex indices of all faces, one after another.
    pub indices: Vec<u32>,
    /// Optional texture coordinates (OBJ `vt`), referenced per corner by `corner_texcoords`.
    pub texcoords: Vec<[f64; 2]>,
    /// Per-corner index into `texcoords`, aligned with `indices` (empty when absent).
    pub corner_texcoords: Vec<u32>,
    /// Optional normals (OBJ `vn`), referenced per corner by `corner_normals`.
    pub normals: Vec<DVec3>,
    /// Per-corner index into `normals`, aligned with `indices` (empty when absent).
    pub corner_normals: Vec<u32>,
    /// Named face groups (OBJ `g`/`o`): `(name, first face)`, sorted by first face.
    pub groups: Vec<(String, u32)>,
    /// Extra per-vertex scalar properties by name (for example a PLY `quality`
    /// or `importance` property); each vector has `positions.len()` entries.
    pub vertex_scalars: BTreeMap<String, Vec<f64>>,
}

impl IndexedMesh {
    /// An empty mesh (no vertices, no faces).
    pub fn new() -> Self {
        IndexedMesh {
            face_starts: vec![0],
            ..Default::default()
        }
    }

    /// Builds a mesh from positions and faces given as slices of vertex indices.
    pub fn from_faces<F: AsRef<[u32]>>(
        positions: Vec<DVec3>,
        faces: impl IntoIterator<Item = F>,
    ) -> Self {
        let mut m = IndexedMesh {
            positions,
            ..IndexedMesh::new()
        };
        for f in faces {
            m.push_face(f.as_ref());
        }
        m
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.face_starts.len().saturating_sub(1)
    }

    /// Vertex indices of face `f` (counter-clockwise).
    pub fn face(&self, f: usize) -> &[u32] {
        &self.indices[self.face_starts[f] as usize..self.face_starts[f + 1] as usize]
    }

    /// Iterates over all faces as slices of vertex indices.
    pub fn faces(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        (0..self.face_count()).map(move |f| self.face(f))
    }

    /// Appends a face, unchecked: the structure is checked when the soup
    /// becomes a half-edge mesh ([`Mesh::from_indexed`](crate::mesh::Mesh::from_indexed)).
    pub fn push_face(&mut self, face: &[u32]) {
        if self.face_starts.is_empty() {
            self.face_starts.push(0);
        }
        self.indices.extend_from_slice(face);
        self.face_starts.push(self.indices.len() as u32);
    }

    /// Counts faces by size: `(quads, triangles, other)`.
    pub fn face_size_counts(&self) -> (usize, usize, usize) {
        let (mut q, mut t, mut o) = (0, 0, 0);
        for f in self.faces() {
            match f.len() {
                4 => q += 1,
                3 => t += 1,
                _ => o += 1,
            }
        }
        (q, t, o)
    }

    /// True when every face has exactly four vertices.
    pub fn is_quad_only(&self) -> bool {
        self.faces().all(|f| f.len() == 4)
    }

    /// Axis-aligned bounding box `(min, max)` of the positions; `None` when empty.
    pub fn bounding_box(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }

    /// Length of the bounding-box diagonal (0 for an empty mesh).
    pub fn bbox_diagonal(&self) -> f64 {
        self.bounding_box()
            .map(|(lo, hi)| (hi - lo).length())
            .unwrap_or(0.0)
    }
}

/// Builds a mesh face by face, in order, from the faces of a `source`
/// mesh (pairing and bridging rebuild a mesh this way): each face with its
/// corners' texture coordinate and normal indices where the source has
/// them, and the source's group names over the runs of faces that come
/// from one group.
pub(crate) struct FaceWriter<'a> {
    out: IndexedMesh,
    groups: &'a [(String, u32)],
    /// `(group, first face)` of each run.
    runs: Vec<(usize, u32)>,
    texcoords: bool,
    normals: bool,
}

impl<'a> FaceWriter<'a> {
    /// A writer into `out` (its vertex and attribute tables; its faces are
    /// replaced) for faces of `source`.
    pub(crate) fn new(mut out: IndexedMesh, source: &'a IndexedMesh) -> Self {
        out.face_starts = vec![0];
        out.indices.clear();
        out.corner_texcoords.clear();
        out.corner_normals.clear();
        FaceWriter {
            out,
            groups: &source.groups,
            runs: Vec::new(),
            texcoords: !source.corner_texcoords.is_empty(),
            normals: !source.corner_normals.is_empty(),
        }
    }

    /// Appends face `v` of the source's group `group` (an index into its
    /// `groups`), with its corners' texture coordinate and normal indices
    /// (read only where the source has them).
    pub(crate) fn push(
        &mut self,
        group: usize,
        v: &[u32],
        texcoords: impl IntoIterator<Item = u32>,
        normals: impl IntoIterator<Item = u32>,
    ) {
        if !self.groups.is_empty() && self.runs.last().map(|r| r.0) != Some(group) {
            self.runs.push((group, self.out.face_count() as u32));
        }
        self.out.push_face(v);
        if self.texcoords {
            self.out.corner_texcoords.extend(texcoords);
        }
        if self.normals {
            self.out.corner_normals.extend(normals);
        }
    }

    /// Faces written so far.
    pub(crate) fn face_count(&self) -> usize {
        self.out.face_count()
    }

    /// The mesh written.
    pub(crate) fn finish(mut self) -> IndexedMesh {
        self.out.groups = self
            .runs
            .into_iter()
            .map(|(g, first)| (self.groups[g].0.clone(), first))
            .collect();
        self.out
    }
}
