//! Progressive quad mesh in canonical numbering: a base (coarsest) mesh plus
//! split records in refinement order (coarse → fine), Hoppe-style.
//!
//! # Canonical numbering (what every decoder reproduces, id for id)
//! * **Vertices**: the base mesh has vertices `0..base.vertex_count()`. Each
//!   record appends its `new_vertices` at the end, in order, so vertex ids are
//!   never reused and the vertex array only grows while refining.
//! * **Face slots**: the base mesh has faces `0..base.face_count()`. A record
//!   first *rewrites* the slots it names (`rewritten`, new vertex lists), then
//!   *appends* `appended_faces` at the end. Coarsening back undoes exactly that
//!   (truncate, restore the old contents). A quad keeps its slot for as long as
//!   it exists, which is what lets a renderer update sub-ranges of its buffers.
//! * **Positions**: a record may move existing vertices (`moved`), for example
//!   the merged vertex of a qvMerge going back to where one of its parents was.
//!
//! Applying records `0..k` to the base gives level `k`; level `records.len()`
//! is the finest mesh (the coarsener's input, vertices permuted by
//! `vertex_order`).

use crate::indexed::IndexedMesh;
use glam::DVec3;

/// Which coarsening step a record undoes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OpKind {
    /// Inverse of a quad-vertex merge (a quad vertex split).
    QvMerge = 0,
    /// Inverse of a quad-edge merge with 1-ring re-meshing.
    QeMerge = 1,
    /// Inverse of a doublet removal.
    Doublet = 2,
    /// Inverse of smoothing: moves vertices only.
    Smooth = 3,
}

/// One refinement step in canonical numbering (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SplitRecord {
    /// The coarsening operator this record undoes.
    pub op: OpKind,
    /// Positions of the vertices this record appends (ids `n, n+1, …` where
    /// `n` is the vertex count before the record).
    pub new_vertices: Vec<DVec3>,
    /// Existing vertices that move: `(vertex id, position after refinement)`.
    pub moved: Vec<(u32, DVec3)>,
    /// Face slots whose vertex list changes: `(slot, new quad)`; slots ascending.
    pub rewritten: Vec<(u32, [u32; 4])>,
    /// Quads appended at the end of the face array.
    pub appended_faces: Vec<[u32; 4]>,
}

/// A base mesh plus refinement records (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProgressiveMesh {
    /// The coarsest level, quad-only, in canonical numbering.
    pub base: IndexedMesh,
    /// Refinement records, coarse → fine.
    pub records: Vec<SplitRecord>,
    /// Canonical vertex id → vertex index in the coarsener's input, for the
    /// finest level (lets a writer restore the input's vertex order).
    pub vertex_order: Vec<u32>,
    /// Geometric error bound of each level, `records.len() + 1` entries
    /// (index k = level k), non-increasing with k, in units of the input's
    /// bounding-box diagonal. Level `records.len()` has error 0.
    pub level_error: Vec<f64>,
}

impl OpKind {
    /// The operator with code `code` (the `repr` value), if any.
    pub fn from_code(code: u8) -> Option<OpKind> {
        match code {
            0 => Some(OpKind::QvMerge),
            1 => Some(OpKind::QeMerge),
            2 => Some(OpKind::Doublet),
            3 => Some(OpKind::Smooth),
            _ => None,
        }
    }
}

impl ProgressiveMesh {
    /// Number of levels, `records.len() + 1` (level 0 is the base mesh).
    pub fn level_count(&self) -> usize {
        self.records.len() + 1
    }

    /// Vertex count of the finest level (base plus every appended vertex).
    pub fn final_vertex_count(&self) -> usize {
        self.base.vertex_count()
            + self
                .records
                .iter()
                .map(|r| r.new_vertices.len())
                .sum::<usize>()
    }

    /// Face count of the finest level (base plus every appended quad).
    pub fn final_face_count(&self) -> usize {
        self.base.face_count()
            + self
                .records
                .iter()
                .map(|r| r.appended_faces.len())
                .sum::<usize>()
    }

    /// Positions and quads of level `k` (records `0..k` applied to the base),
    /// in canonical numbering.
    ///
    /// # Panics
    /// When `k > records.len()` or when the mesh does not pass
    /// [`ProgressiveMesh::validate`] (an index out of range).
    pub fn level_quads(&self, k: usize) -> (Vec<DVec3>, Vec<[u32; 4]>) {
        assert!(
            k <= self.records.len(),
            "level {k} > record count {}",
            self.records.len()
        );
        let mut positions = self.base.positions.clone();
        let mut quads: Vec<[u32; 4]> = self
            .base
            .faces()
            .map(|f| {
                assert!(f.len() == 4, "base mesh is not quad-only");
                [f[0], f[1], f[2], f[3]]
            })
            .collect();
        for r in &self.records[..k] {
            positions.extend_from_slice(&r.new_vertices);
            for &(v, p) in &r.moved {
                positions[v as usize] = p;
            }
            for &(s, q) in &r.rewritten {
                quads[s as usize] = q;
            }
            quads.extend_from_slice(&r.appended_faces);
        }
        (positions, quads)
    }

    /// Level `k` as an [`IndexedMesh`] (positions and quads only); see
    /// [`ProgressiveMesh::level_quads`] for the panics.
    pub fn level(&self, k: usize) -> IndexedMesh {
        let (positions, quads) = self.level_quads(k);
        IndexedMesh::from_faces(positions, quads)
    }

    /// Checks that the records can be applied in order: the base is quad-only
    /// with indices in range; every record moves only existing vertices (each
    /// at most once), rewrites existing slots in strictly ascending order,
    /// uses only vertices that exist once its own vertices are appended,
    /// writes quads with four distinct vertices and finite positions, and a
    /// `Smooth` record only moves vertices. `vertex_order` is empty or a
    /// permutation of the final vertex ids; `level_error` is empty or has
    /// `records.len() + 1` finite, non-negative, non-increasing entries.
    /// The error message names the element (`record 12 rewrites slot 90 but
    /// only 88 faces exist`).
    pub fn validate(&self) -> Result<(), String> {
        let base = &self.base;
        if base.face_starts.first().copied().unwrap_or(0) != 0
            || base.face_starts.last().map(|&e| e as usize).unwrap_or(0) != base.indices.len()
            || base.face_starts.windows(2).any(|w| w[0] > w[1])
        {
            return Err("base mesh: face_starts is not a valid prefix-sum of indices".into());
        }
        let mut nv = base.vertex_count();
        for (i, p) in base.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(format!("base vertex {i} has a non-finite position"));
            }
        }
        let check_quad = |what: &str, q: &[u32], nv: usize| -> Result<(), String> {
            if q.len() != 4 {
                return Err(format!("{what} has {} vertices, expected 4", q.len()));
            }
            for (c, &v) in q.iter().enumerate() {
                if v as usize >= nv {
                    return Err(format!(
                        "{what} uses vertex {v} but only {nv} vertices exist"
                    ));
                }
                if q[..c].contains(&v) {
                    return Err(format!("{what} repeats vertex {v}"));
                }
            }
            Ok(())
        };
        for (f, q) in base.faces().enumerate() {
            check_quad(&format!("base face {f}"), q, nv)?;
        }
        let mut nf = base.face_count();
        for (r, rec) in self.records.iter().enumerate() {
            if rec.op == OpKind::Smooth
                && (!rec.new_vertices.is_empty()
                    || !rec.rewritten.is_empty()
                    || !rec.appended_faces.is_empty())
            {
                return Err(format!("record {r} (Smooth) changes connectivity"));
            }
            let mut seen = std::collections::HashSet::new();
            for &(v, p) in &rec.moved {
                if v as usize >= nv {
                    return Err(format!(
                        "record {r} moves vertex {v} but only {nv} vertices exist"
                    ));
                }
                if !seen.insert(v) {
                    return Err(format!("record {r} moves vertex {v} twice"));
                }
                if !p.is_finite() {
                    return Err(format!(
                        "record {r} moves vertex {v} to a non-finite position"
                    ));
                }
            }
            if rec.new_vertices.iter().any(|p| !p.is_finite()) {
                return Err(format!("record {r} appends a non-finite position"));
            }
            let nv_after = nv + rec.new_vertices.len();
            let mut prev: Option<u32> = None;
            for &(s, q) in &rec.rewritten {
                if s as usize >= nf {
                    return Err(format!(
                        "record {r} rewrites slot {s} but only {nf} faces exist"
                    ));
                }
                if prev.is_some_and(|p| p >= s) {
                    return Err(format!(
                        "record {r} rewritten slots are not strictly ascending at {s}"
                    ));
                }
                prev = Some(s);
                check_quad(&format!("record {r} rewritten slot {s}"), &q, nv_after)?;
            }
            for (i, q) in rec.appended_faces.iter().enumerate() {
                check_quad(&format!("record {r} appended face {i}"), q, nv_after)?;
            }
            nv = nv_after;
            nf += rec.appended_faces.len();
        }
        if !self.vertex_order.is_empty() {
            if self.vertex_order.len() != nv {
                return Err(format!(
                    "vertex_order has {} entries, the finest level has {nv} vertices",
                    self.vertex_order.len()
                ));
            }
            let mut seen = vec![false; nv];
            for (i, &o) in self.vertex_order.iter().enumerate() {
                match seen.get_mut(o as usize) {
                    Some(s) if !*s => *s = true,
                    _ => {
                        return Err(format!(
                            "vertex_order[{i}] = {o} is out of range or repeated"
                        ))
                    }
                }
            }
        }
        if !self.level_error.is_empty() {
            if self.level_error.len() != self.records.len() + 1 {
                return Err(format!(
                    "level_error has {} entries, expected {}",
                    self.level_error.len(),
                    self.records.len() + 1
                ));
            }
            for (k, &e) in self.level_error.iter().enumerate() {
                if !e.is_finite() || e < 0.0 {
                    return Err(format!(
                        "level_error[{k}] = {e} is not finite and non-negative"
                    ));
                }
                if k > 0 && e > self.level_error[k - 1] {
                    return Err(format!("level_error increases at level {k}"));
                }
            }
        }
        Ok(())
    }
}

/// The order of the `.pqm` base section's traversal walk (spec §6.1) over
/// `faces` (with `vertex_count` vertices): returns the faces in walk order
/// and the vertices by first appearance in it, then the vertices in no
/// face, in id order. A mesh numbered this way (`faces[i]` becomes slot
/// `i`, vertex `order[j]` becomes id `j`) is one a 4.0 writer can code in
/// a few bits per face.
///
/// The walk: start at the lowest face not yet reached (a *component
/// start*, corners numbered in order); visiting face `f`, for each corner
/// `k`, with `a = f[k]`, `b = f[k + 1]`, the face holding the half-edge
/// `b → a` (the first such face, if a non-manifold mesh has several) is
/// queued if it is not yet, its corners after `a` numbered in order
/// (`b` at its corner `r`: corners `r + 2`, `r + 3`, …). Deterministic.
pub fn walk_order(faces: &[&[u32]], vertex_count: usize) -> (Vec<u32>, Vec<u32>) {
    let mut across: std::collections::HashMap<(u32, u32), u32> = Default::default();
    for (i, f) in faces.iter().enumerate() {
        for k in 0..f.len() {
            across
                .entry((f[k], f[(k + 1) % f.len()]))
                .or_insert(i as u32);
        }
    }
    let mut queued = vec![false; faces.len()];
    let mut numbered = vec![false; vertex_count];
    let mut order: Vec<u32> = Vec::with_capacity(faces.len());
    let mut vertices: Vec<u32> = Vec::with_capacity(vertex_count);
    let mut number = |v: u32, vertices: &mut Vec<u32>| {
        if let Some(n) = numbered.get_mut(v as usize) {
            if !*n {
                *n = true;
                vertices.push(v);
            }
        }
    };
    let mut head = 0;
    for start in 0..faces.len() {
        if queued[start] {
            continue;
        }
        queued[start] = true;
        order.push(start as u32);
        for &v in faces[start] {
            number(v, &mut vertices);
        }
        while head < order.len() {
            let f = faces[order[head] as usize];
            head += 1;
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                let Some(&g) = across.get(&(b, a)) else {
                    continue;
                };
                if queued[g as usize] {
                    continue;
                }
                queued[g as usize] = true;
                order.push(g);
                let gv = faces[g as usize];
                let r = gv.iter().position(|&v| v == b).unwrap_or(0);
                for t in 2..gv.len() {
                    number(gv[(r + t) % gv.len()], &mut vertices);
                }
            }
        }
    }
    for v in 0..vertex_count as u32 {
        number(v, &mut vertices);
    }
    (order, vertices)
}

impl ProgressiveMesh {
    /// Renumbers the base's faces and vertices in [`walk_order`], and the
    /// records and vertex order with them: the same levels under other ids
    /// and slots (records' own vertices and quads keep theirs).
    pub fn renumber_base_in_walk_order(&mut self) {
        let faces: Vec<Vec<u32>> = self.base.faces().map(|f| f.to_vec()).collect();
        let refs: Vec<&[u32]> = faces.iter().map(|f| &f[..]).collect();
        let (face_order, vertex_order) = walk_order(&refs, self.base.vertex_count());
        self.renumber_base(&face_order, &vertex_order);
    }

    /// Renumbers the base: `face_order[i]` becomes slot `i` and
    /// `vertex_order[j]` becomes vertex `j` (both permutations of the base's
    /// faces and vertices); the records and the vertex order follow, so
    /// every level is the same mesh under other ids (records' own vertices
    /// and quads keep theirs).
    pub fn renumber_base(&mut self, face_order: &[u32], vertex_order: &[u32]) {
        let nb = self.base.vertex_count();
        let nfb = self.base.face_count() as u32;
        let faces: Vec<Vec<u32>> = self.base.faces().map(|f| f.to_vec()).collect();
        let mut vmap = vec![0u32; nb];
        for (new, &old) in vertex_order.iter().enumerate() {
            vmap[old as usize] = new as u32;
        }
        let mut fmap = vec![0u32; faces.len()];
        for (new, &old) in face_order.iter().enumerate() {
            fmap[old as usize] = new as u32;
        }
        let v = |x: u32| {
            if (x as usize) < nb {
                vmap[x as usize]
            } else {
                x
            }
        };
        let mut base = IndexedMesh::new();
        base.positions = vertex_order
            .iter()
            .map(|&o| self.base.positions[o as usize])
            .collect();
        for &o in face_order {
            let f: Vec<u32> = faces[o as usize].iter().map(|&x| v(x)).collect();
            base.push_face(&f);
        }
        self.base = base;
        for r in &mut self.records {
            for m in &mut r.moved {
                m.0 = v(m.0);
            }
            r.moved.sort_by_key(|m| m.0);
            for (slot, q) in &mut r.rewritten {
                if *slot < nfb {
                    *slot = fmap[*slot as usize];
                }
                *q = q.map(v);
            }
            r.rewritten.sort_by_key(|x| x.0);
            for q in &mut r.appended_faces {
                *q = q.map(v);
            }
        }
        if self.vertex_order.len() >= nb {
            let old: Vec<u32> = self.vertex_order[..nb].to_vec();
            for (new, &o) in vertex_order.iter().enumerate() {
                self.vertex_order[new] = old[o as usize];
            }
        }
    }
}

#[doc(hidden)]
pub mod testgen;

#[cfg(test)]
mod tests {
    use super::*;

    /// A small generated mesh whose first two records are splits.
    fn tiny() -> ProgressiveMesh {
        let mut pm = testgen::generate(7, 10);
        pm.records.retain(|r| r.op != OpKind::Smooth);
        pm.level_error.truncate(pm.records.len() + 1);
        pm.validate().unwrap();
        pm
    }

    #[test]
    fn level_counts_follow_the_records() {
        let pm = tiny();
        let (mut nv, mut nf) = (pm.base.vertex_count(), pm.base.face_count());
        for k in 0..=pm.records.len() {
            let m = pm.level(k);
            assert_eq!((m.vertex_count(), m.face_count()), (nv, nf), "level {k}");
            assert!(m.is_quad_only());
            if let Some(r) = pm.records.get(k) {
                nv += r.new_vertices.len();
                nf += r.appended_faces.len();
            }
        }
        assert_eq!(
            pm.level(0),
            IndexedMesh::from_faces(pm.base.positions.clone(), pm.base.faces())
        );
    }

    #[test]
    fn validate_names_the_bad_element() {
        let mut pm = tiny();
        let nf = pm.base.face_count() as u32;
        pm.records[0].rewritten = vec![(nf + 5, [0, 1, 2, 3])];
        let e = pm.validate().unwrap_err();
        assert!(e.contains("record 0 rewrites slot"), "{e}");

        let mut pm = tiny();
        let nv = pm.base.vertex_count() as u32;
        pm.records[0].moved.push((nv + 100, DVec3::ZERO));
        assert!(pm.validate().unwrap_err().contains("record 0 moves vertex"));

        let mut pm = tiny();
        pm.records[1].appended_faces.push([0, 0, 1, 2]);
        assert!(pm.validate().unwrap_err().contains("repeats vertex 0"));

        let mut pm = tiny();
        pm.level_error[1] = 10.0;
        assert!(pm.validate().unwrap_err().contains("level_error increases"));

        let mut pm = tiny();
        pm.vertex_order[0] = pm.vertex_order[1];
        assert!(pm.validate().unwrap_err().contains("vertex_order"));
    }
}
