//! Smooth vertex normals that follow a decoder from level to level, for a
//! renderer that shades smoothly: each vertex's normal is the normalized sum
//! of its quads' vector areas `(p2 − p0) × (p3 − p1)` (twice the area times
//! the normal for a planar quad; a stable mean normal for a bent one).
//!
//! [`SmoothNormals::apply`] takes each [`Change`] the decoder returns and
//! updates only what it touched: the corners of the quads the change adds,
//! removes or rewrites, and the quads around a moved vertex. It returns the
//! vertex ranges whose normals changed, so a renderer writes just those
//! sub-ranges of its normal buffer, as it does for positions.
//!
//! The sums are kept exactly, on the integer position codes (`i128`), so
//! adding a quad and taking it back leave no trace: whatever path reaches a
//! level — streamed, refined, coarsened and refined again — the normals are
//! the ones [`SmoothNormals::compute`] gives at that level. The JavaScript
//! binding keeps the same normals (`normals: true` in `web/pqm-three`).
//!
//! ```
//! use pqm_format::normals::SmoothNormals;
//! # use pqm_format::{write_to_vec, Decoder, EncodeOptions, Limits, Target};
//! # use pqm_core::progressive::testgen::{self, GenOptions};
//! # let file = write_to_vec(&testgen::generate_with(&GenOptions::new(1, 300)), &EncodeOptions::default()).unwrap().0;
//! let mut dec = Decoder::new(Limits::default());
//! dec.push(&file)?;
//! let mut normals = SmoothNormals::default();
//! normals.apply(&dec, &dec.full_upload()); // after the base mesh, or any level
//! let change = dec.set_level(Target::Level(0))?;
//! for r in normals.apply(&dec, &change) {
//!     // upload normals.normals()[r.start as usize..r.end as usize]
//!     # let _ = r;
//! }
//! assert_eq!(normals.normals(), SmoothNormals::compute(&dec).as_slice());
//! # Ok::<(), pqm_format::DecodeError>(())
//! ```

use crate::{Change, Decoder};
use std::ops::Range;

/// Smooth normals kept in step with a decoder's level (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct SmoothNormals {
    /// Per vertex, the sum of its quads' doubled vector areas in code units.
    sums: Vec<[i128; 3]>,
    /// Per slot, the quad it last added and the area it added (taken back
    /// exactly when the slot changes or goes).
    slot_quad: Vec<[u32; 4]>,
    slot_area: Vec<[i128; 3]>,
    slot_live: Vec<bool>,
    /// Per vertex, the slots of the quads around it.
    slots_of: Vec<Vec<u32>>,
    /// Unit normals (zero where a vertex's quads cancel), per vertex.
    normals: Vec<[f32; 3]>,
    /// Scratch: vertices touched by the change being applied, and marks.
    touched: Vec<u32>,
    marked: Vec<bool>,
    slot_seen: Vec<bool>,
}

impl SmoothNormals {
    /// The normals of the decoder's current level, vertex by vertex, from
    /// scratch: what [`SmoothNormals::apply`] keeps up to date.
    pub fn compute(dec: &Decoder) -> Vec<[f32; 3]> {
        let codes = dec.position_codes();
        let mut sums = vec![[0i128; 3]; codes.len()];
        for q in dec.quads() {
            let n = area(q, codes);
            for &v in q {
                add(&mut sums[v as usize], n, 1);
            }
        }
        let k = axis_scale(dec);
        sums.iter().map(|s| unit(*s, k)).collect()
    }

    /// The normals of vertices `0..n`, `n` the vertex count of the last
    /// level applied.
    pub fn normals(&self) -> &[[f32; 3]] {
        &self.normals
    }

    /// Takes `change`, which `dec` has just made (a `set_level` /
    /// `refine_to` / `coarsen_to` result, or [`Decoder::full_upload`] for a
    /// first level or to start over), and returns the sorted, disjoint
    /// vertex ranges whose normals changed (vertices below the new vertex
    /// count only). Changes must be applied in the order the decoder made
    /// them; several moves may be applied one after the other.
    pub fn apply(&mut self, dec: &Decoder, change: &Change) -> Vec<Range<u32>> {
        let nv = dec.position_codes().len();
        let quads = dec.quads();
        let nf = quads.len();
        let full = change.from_level == change.to_level
            && change.faces_appended.start == 0
            && change.faces_appended.end as usize == nf;
        if full {
            // `full_upload`: start over from the level as it is
            self.sums.clear();
            self.slot_live.clear();
            self.slot_quad.clear();
            self.slot_area.clear();
            self.slots_of.clear();
        }
        let grow = |len: usize, n: usize| len.max(n);
        let vlen = grow(self.sums.len(), nv);
        self.sums.resize(vlen, [0; 3]);
        self.slots_of.resize_with(vlen, Vec::new);
        self.marked.resize(vlen, false);
        self.normals.resize(vlen, [0.0; 3]);
        let flen = grow(
            self.slot_live.len(),
            nf.max(change.faces_truncated.end as usize),
        );
        self.slot_live.resize(flen, false);
        self.slot_quad.resize(flen, [0; 4]);
        self.slot_area.resize(flen, [0; 3]);
        self.slot_seen.resize(flen, false);

        let mut slots: Vec<u32> = change.faces_rewritten.clone();
        slots.extend(change.faces_appended.clone());
        // take back what the old quads put in
        for f in change.faces_truncated.clone().chain(slots.iter().copied()) {
            self.unadd(f);
        }
        let codes = dec.position_codes();
        for &f in &slots {
            if (f as usize) < nf {
                self.add(f, quads[f as usize], codes);
                self.slot_seen[f as usize] = true;
            }
        }
        // the other quads around a moved vertex: same corners, new area
        let mut seen: Vec<u32> = slots.clone();
        for &v in &change.vertices_moved {
            let around = self.slots_of[v as usize].clone();
            for f in around {
                if std::mem::replace(&mut self.slot_seen[f as usize], true) {
                    continue;
                }
                seen.push(f);
                self.unadd(f);
                self.add(f, quads[f as usize], codes);
            }
        }
        for f in seen {
            if let Some(s) = self.slot_seen.get_mut(f as usize) {
                *s = false;
            }
        }
        // normalize the touched vertices, report them as runs
        let k = axis_scale(dec);
        let mut touched = std::mem::take(&mut self.touched);
        touched.sort_unstable();
        let mut runs: Vec<Range<u32>> = Vec::new();
        for &v in &touched {
            self.marked[v as usize] = false;
            if v as usize >= nv {
                continue;
            }
            self.normals[v as usize] = unit(self.sums[v as usize], k);
            match runs.last_mut() {
                Some(r) if r.end == v => r.end = v + 1,
                _ => runs.push(v..v + 1),
            }
        }
        touched.clear();
        self.touched = touched;
        self.normals.truncate(nv);
        runs
    }

    fn touch(&mut self, v: u32) {
        if !std::mem::replace(&mut self.marked[v as usize], true) {
            self.touched.push(v);
        }
    }

    fn add(&mut self, f: u32, q: [u32; 4], codes: &[[u32; 3]]) {
        let n = area(&q, codes);
        let fi = f as usize;
        self.slot_quad[fi] = q;
        self.slot_area[fi] = n;
        self.slot_live[fi] = true;
        for v in q {
            add(&mut self.sums[v as usize], n, 1);
            self.slots_of[v as usize].push(f);
            self.touch(v);
        }
    }

    fn unadd(&mut self, f: u32) {
        let fi = f as usize;
        if fi >= self.slot_live.len() || !std::mem::replace(&mut self.slot_live[fi], false) {
            return; // never written, or already taken back
        }
        let n = self.slot_area[fi];
        for v in self.slot_quad[fi] {
            add(&mut self.sums[v as usize], n, -1);
            let list = &mut self.slots_of[v as usize];
            if let Some(i) = list.iter().position(|&g| g == f) {
                list.swap_remove(i);
            }
            self.touch(v);
        }
    }
}

/// Doubled vector area `(p2 − p0) × (p3 − p1)` of a quad, in code units.
fn area(q: &[u32; 4], codes: &[[u32; 3]]) -> [i128; 3] {
    let c = |v: u32| codes[v as usize].map(i128::from);
    let (p0, p1, p2, p3) = (c(q[0]), c(q[1]), c(q[2]), c(q[3]));
    let u = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
    let w = [p3[0] - p1[0], p3[1] - p1[1], p3[2] - p1[2]];
    [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ]
}

fn add(s: &mut [i128; 3], n: [i128; 3], sign: i128) {
    for k in 0..3 {
        s[k] += sign * n[k];
    }
}

/// The code grid's step per axis scales a normal by `(sy sz, sx sz, sx sy)`
/// (files before 3.1's cube grid have a step per axis).
fn axis_scale(dec: &Decoder) -> [f64; 3] {
    let [sx, sy, sz] = dec.quantizer().map_or([1.0; 3], |q| q.step());
    [sy * sz, sx * sz, sx * sy]
}

fn unit(s: [i128; 3], k: [f64; 3]) -> [f32; 3] {
    let v = [s[0] as f64 * k[0], s[1] as f64 * k[1], s[2] as f64 * k[2]];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        [
            (v[0] / len) as f32,
            (v[1] / len) as f32,
            (v[2] / len) as f32,
        ]
    } else {
        [0.0; 3]
    }
}
