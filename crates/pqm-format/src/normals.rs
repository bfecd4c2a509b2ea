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
//! The sums are kept exactly, on the integer position codes (`i64`,
//! added and subtracted with wrapping arithmetic, which is exact whenever
//! the true sum fits: codes below 2^24 give products below 2^50, so a vertex
//! would need thousands of quads to overflow), so adding a quad and taking
//! it back leave no trace: whatever path reaches a
//! level — streamed, refined, coarsened and refined again — the normals are
//! the ones [`SmoothNormals::compute`] gives at that level. The JavaScript
//! binding keeps normals by the same rule (`normals: true` in
//! `web/pqm-three`).
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

/// Slots listed inline per vertex; the rest of a vertex's slots (valence
/// above this) go to an overflow list. 9 makes a vertex one 64-byte line.
const INLINE: usize = 9;
/// Bit of `Vert::len` marking a vertex touched by the change being applied.
const MARK: u32 = 1 << 31;

/// What is kept per vertex, in one cache line: the sum of its quads'
/// doubled vector areas (code units) and the slots of those quads.
#[derive(Clone, Copy, Debug, Default)]
#[repr(align(64))]
struct Vert {
    sum: [i64; 3],
    /// Number of slots (low 31 bits) and the touched mark ([`MARK`]).
    len: u32,
    slots: [u32; INLINE],
}

/// Smooth normals kept in step with a decoder's level (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct SmoothNormals {
    verts: Vec<Vert>,
    /// Slots past a vertex's first [`INLINE`], by vertex.
    overflow: std::collections::HashMap<u32, Vec<u32>>,
    /// Per slot: the quad it last added and the area it added (taken back
    /// exactly when the slot changes or goes), or none.
    slots: Vec<Option<([u32; 4], [i64; 3])>>,
    /// Unit normals (zero where a vertex's quads cancel), per vertex.
    normals: Vec<[f32; 3]>,
    /// Scratch: vertices touched by the change being applied, slots
    /// already redone, a moved vertex's slots.
    touched: Vec<u32>,
    slot_seen: Vec<bool>,
    seen: Vec<u32>,
    around: Vec<u32>,
}

impl SmoothNormals {
    /// The normals of the decoder's current level, vertex by vertex, from
    /// scratch: what [`SmoothNormals::apply`] keeps up to date.
    pub fn compute(dec: &Decoder) -> Vec<[f32; 3]> {
        let codes = dec.position_codes();
        let mut sums = vec![[0i64; 3]; codes.len()];
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
            self.verts.clear();
            self.overflow.clear();
            self.slots.clear();
        }
        if self.verts.len() < nv {
            self.verts.resize(nv, Vert::default());
        }
        let flen = nf.max(change.faces_truncated.end as usize);
        if self.slots.len() < flen {
            self.slots.resize(flen, None);
            self.slot_seen.resize(flen, false);
        }

        let written = || {
            change
                .faces_rewritten
                .iter()
                .copied()
                .chain(change.faces_appended.clone())
        };
        // take back what the old quads put in
        for f in change.faces_truncated.clone().chain(written()) {
            self.unadd(f);
        }
        let codes = dec.position_codes();
        let mut seen = std::mem::take(&mut self.seen);
        for f in written() {
            if (f as usize) < nf {
                self.add(f, quads[f as usize], codes);
                self.slot_seen[f as usize] = true;
                seen.push(f);
            }
        }
        // the other quads around a moved vertex: same corners, new area
        let mut around = std::mem::take(&mut self.around);
        for &v in &change.vertices_moved {
            around.clear();
            self.slots_of(v, &mut around);
            for &f in &around {
                if std::mem::replace(&mut self.slot_seen[f as usize], true) {
                    continue;
                }
                seen.push(f);
                self.unadd(f);
                self.add(f, quads[f as usize], codes);
            }
        }
        for &f in &seen {
            self.slot_seen[f as usize] = false;
        }
        seen.clear();
        self.seen = seen;
        self.around = around;
        // normalize the touched vertices, report them as runs
        self.normals.resize(nv, [0.0; 3]);
        let k = axis_scale(dec);
        let mut touched = std::mem::take(&mut self.touched);
        touched.sort_unstable();
        let mut runs: Vec<Range<u32>> = Vec::new();
        for &v in &touched {
            let vert = &mut self.verts[v as usize];
            vert.len &= !MARK;
            if v as usize >= nv {
                continue;
            }
            self.normals[v as usize] = unit(vert.sum, k);
            match runs.last_mut() {
                Some(r) if r.end == v => r.end = v + 1,
                _ => runs.push(v..v + 1),
            }
        }
        touched.clear();
        self.touched = touched;
        runs
    }

    /// Adds vertex `v`'s slots to `out`.
    fn slots_of(&self, v: u32, out: &mut Vec<u32>) {
        let vert = &self.verts[v as usize];
        let n = (vert.len & !MARK) as usize;
        out.extend_from_slice(&vert.slots[..n.min(INLINE)]);
        if n > INLINE {
            out.extend_from_slice(&self.overflow[&v]);
        }
    }

    /// Adds `area × sign` to vertex `v`'s sum, lists or unlists slot `f`
    /// there, and marks `v` touched.
    fn corner(&mut self, v: u32, f: u32, n: [i64; 3], sign: i64) {
        let vert = &mut self.verts[v as usize];
        add(&mut vert.sum, n, sign);
        if vert.len & MARK == 0 {
            vert.len |= MARK;
            self.touched.push(v);
        }
        let len = (vert.len & !MARK) as usize;
        if sign > 0 {
            if len < INLINE {
                vert.slots[len] = f;
            } else {
                self.overflow.entry(v).or_default().push(f);
            }
            vert.len += 1;
            return;
        }
        // unlist: the last slot takes the place of `f`
        let last = if len > INLINE {
            let list = self.overflow.get_mut(&v).expect("overflow list");
            if let Some(i) = list.iter().position(|&g| g == f) {
                list.swap_remove(i);
                if list.is_empty() {
                    self.overflow.remove(&v);
                }
                vert.len -= 1;
                return;
            }
            let last = list.pop().expect("overflow slot");
            if list.is_empty() {
                self.overflow.remove(&v);
            }
            last
        } else {
            vert.slots[len - 1]
        };
        let i = vert.slots[..len.min(INLINE)]
            .iter()
            .position(|&g| g == f)
            .expect("a listed slot");
        vert.slots[i] = last;
        vert.len -= 1;
    }

    fn add(&mut self, f: u32, q: [u32; 4], codes: &[[u32; 3]]) {
        let n = area(&q, codes);
        self.slots[f as usize] = Some((q, n));
        for v in q {
            self.corner(v, f, n, 1);
        }
    }

    fn unadd(&mut self, f: u32) {
        let Some(Some((q, n))) = self.slots.get_mut(f as usize).map(Option::take) else {
            return; // never written, or already taken back
        };
        for v in q {
            self.corner(v, f, n, -1);
        }
    }
}

/// Doubled vector area `(p2 − p0) × (p3 − p1)` of a quad, in code units.
fn area(q: &[u32; 4], codes: &[[u32; 3]]) -> [i64; 3] {
    let c = |v: u32| codes[v as usize].map(i64::from);
    // differences below 2^24 in magnitude: the products fit
    let (p0, p1, p2, p3) = (c(q[0]), c(q[1]), c(q[2]), c(q[3]));
    let u = [p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]];
    let w = [p3[0] - p1[0], p3[1] - p1[1], p3[2] - p1[2]];
    [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ]
}

fn add(s: &mut [i64; 3], n: [i64; 3], sign: i64) {
    for k in 0..3 {
        s[k] = s[k].wrapping_add(sign.wrapping_mul(n[k]));
    }
}

/// The code grid's step per axis scales a normal by `(sy sz, sx sz, sx sy)`
/// (files before 3.1's cube grid have a step per axis).
fn axis_scale(dec: &Decoder) -> [f64; 3] {
    let [sx, sy, sz] = dec.quantizer().map_or([1.0; 3], |q| q.step());
    [sy * sz, sx * sz, sx * sy]
}

fn unit(s: [i64; 3], k: [f64; 3]) -> [f32; 3] {
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
