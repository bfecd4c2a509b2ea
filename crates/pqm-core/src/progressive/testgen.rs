//! Seeded generator of random, valid [`ProgressiveMesh`]es for tests,
//! benches and test vectors of other crates (not part of the stable API).
//!
//! It builds a small quad base mesh (an open grid or a closed subdivided box),
//! then *refines* it with random **quad vertex splits** — the inverse of the
//! paper's qvMerge — recording each step in canonical numbering:
//!
//! * pick a vertex `m` whose star is a single fan, with link ring
//!   `l_0 … l_{L-1}` in counter-clockwise order (face `f_t` lies between
//!   `l_t` and `l_{t+1}`);
//! * pick two wings `b = l_i`, `d = l_j` splitting the star into two sides of
//!   at least two faces each (one side for a boundary `m`, which becomes
//!   interior);
//! * faces `f_i … f_{j-1}` keep `m` (now called `a`, it moves), the other
//!   faces get the new vertex `c` (appended id) — those slots are *rewritten*;
//! * the quad `(a, d, c, b)` (counter-clockwise; appended in a random
//!   rotation) fills the gap.
//!
//! `m`'s old position is the midpoint of `a` and `c`, as a qvMerge that
//! places the merged vertex at the midpoint would produce. Sometimes two
//! splits are fused into one record (op `QeMerge`, two new vertices — this
//! exercises general record forms), and sometimes a `Smooth` record moves a
//! few vertices. Everything is deterministic in the seed.

use crate::indexed::IndexedMesh;
use crate::progressive::{OpKind, ProgressiveMesh, SplitRecord};
use glam::DVec3;
use std::collections::HashMap;

/// SplitMix64: a tiny, good-enough deterministic generator (no `rand` in core).
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform integer in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Uniform float in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform float in `[-1, 1)`.
    pub fn signed(&mut self) -> f64 {
        2.0 * self.unit() - 1.0
    }
}

/// Shape of the base (coarsest) mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BaseShape {
    /// Open `nx × ny` quad grid in the z≈0 plane (has a boundary loop).
    Grid { nx: u32, ny: u32 },
    /// Closed cube surface with `n × n` quads per side (genus 0); use `n ≥ 2`,
    /// the corners of `n = 1` have valence 3 and nothing can be split.
    Box { n: u32 },
}

/// Generator parameters.
#[derive(Clone, Debug)]
pub struct GenOptions {
    /// Seed of every random choice.
    pub seed: u64,
    /// Base mesh shape.
    pub base: BaseShape,
    /// Number of vertex splits to perform (the record count is a bit lower
    /// when splits are fused, a bit higher with smoothing records).
    pub splits: usize,
    /// Probability that a record is a `Smooth` record (moves only).
    pub smooth_prob: f64,
    /// Probability that two splits are fused into one `QeMerge` record.
    pub fuse_prob: f64,
    /// Fill `vertex_order` with a random permutation (else leave it empty).
    pub vertex_order: bool,
}

impl GenOptions {
    /// Defaults for `seed` with `splits` splits: base shape chosen by the
    /// seed (grid or box), 5 % smoothing, 5 % fused records, vertex order on.
    pub fn new(seed: u64, splits: usize) -> Self {
        let mut rng = Rng(seed ^ 0xA5A5_5A5A_0F0F_F0F0);
        let base = if rng.below(2) == 0 {
            BaseShape::Grid {
                nx: 2 + rng.below(3) as u32,
                ny: 2 + rng.below(3) as u32,
            }
        } else {
            BaseShape::Box {
                n: 2 + rng.below(2) as u32,
            }
        };
        GenOptions {
            seed,
            base,
            splits,
            smooth_prob: 0.05,
            fuse_prob: 0.05,
            vertex_order: true,
        }
    }
}

/// Random valid progressive mesh with `splits` splits, from `seed`
/// (shorthand for [`generate_with`]`(&GenOptions::new(seed, splits))`).
pub fn generate(seed: u64, splits: usize) -> ProgressiveMesh {
    generate_with(&GenOptions::new(seed, splits))
}

/// Builds the base mesh of `shape` as positions and CCW quads.
pub fn base_mesh(shape: BaseShape, rng: &mut Rng) -> (Vec<DVec3>, Vec<[u32; 4]>) {
    let mut pos = Vec::new();
    let mut quads = Vec::new();
    match shape {
        BaseShape::Grid { nx, ny } => {
            let id = |i: u32, j: u32| j * (nx + 1) + i;
            for j in 0..=ny {
                for i in 0..=nx {
                    pos.push(DVec3::new(i as f64, j as f64, 0.1 * rng.signed()));
                }
            }
            for j in 0..ny {
                for i in 0..nx {
                    quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        BaseShape::Box { n } => {
            // (corner, u, v) per side with u × v pointing outward, so the
            // quads (p(i,j), p(i+1,j), p(i+1,j+1), p(i,j+1)) are CCW outside.
            let sides: [([i32; 3], [i32; 3], [i32; 3]); 6] = [
                ([0, 0, 0], [0, 0, 1], [0, 1, 0]),
                ([1, 0, 0], [0, 1, 0], [0, 0, 1]),
                ([0, 0, 0], [1, 0, 0], [0, 0, 1]),
                ([0, 1, 0], [0, 0, 1], [1, 0, 0]),
                ([0, 0, 0], [0, 1, 0], [1, 0, 0]),
                ([0, 0, 1], [1, 0, 0], [0, 1, 0]),
            ];
            let n = n as i32;
            let mut ids: HashMap<[i32; 3], u32> = HashMap::new();
            let mut vid = |p: [i32; 3], pos: &mut Vec<DVec3>, rng: &mut Rng| -> u32 {
                *ids.entry(p).or_insert_with(|| {
                    pos.push(
                        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * (2.0 / n as f64)
                            - DVec3::ONE
                            + DVec3::new(rng.signed(), rng.signed(), rng.signed()) * 0.02,
                    );
                    (pos.len() - 1) as u32
                })
            };
            for (c, u, v) in sides {
                let at = |i: i32, j: i32| -> [i32; 3] {
                    [0, 1, 2].map(|k| c[k] * n + i * u[k] + j * v[k])
                };
                for j in 0..n {
                    for i in 0..n {
                        let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
                            .map(|p| vid(p, &mut pos, rng));
                        quads.push(q);
                    }
                }
            }
        }
    }
    (pos, quads)
}

/// The refining mesh plus a per-record change log (old slot contents and old
/// positions) so that a record is the diff of one or more operations.
struct State {
    pos: Vec<DVec3>,
    quads: Vec<[u32; 4]>,
    vf: Vec<Vec<u32>>,
    v0: usize,
    f0: usize,
    old_quads: HashMap<u32, [u32; 4]>,
    old_pos: HashMap<u32, DVec3>,
}

impl State {
    fn set_quad(&mut self, s: u32, q: [u32; 4]) {
        let old = self.quads[s as usize];
        if (s as usize) < self.f0 {
            self.old_quads.entry(s).or_insert(old);
        }
        for v in old {
            self.vf[v as usize].retain(|&f| f != s);
        }
        for v in q {
            self.vf[v as usize].push(s);
        }
        self.quads[s as usize] = q;
    }
    fn push_quad(&mut self, q: [u32; 4]) {
        let s = self.quads.len() as u32;
        for v in q {
            self.vf[v as usize].push(s);
        }
        self.quads.push(q);
    }
    fn set_pos(&mut self, v: u32, p: DVec3) {
        if (v as usize) < self.v0 {
            let old = self.pos[v as usize];
            self.old_pos.entry(v).or_insert(old);
        }
        self.pos[v as usize] = p;
    }
    fn begin(&mut self) {
        self.v0 = self.pos.len();
        self.f0 = self.quads.len();
        self.old_quads.clear();
        self.old_pos.clear();
    }
    fn finish(&mut self, op: OpKind) -> SplitRecord {
        let mut rewritten: Vec<(u32, [u32; 4])> = self
            .old_quads
            .iter()
            .filter(|(&s, &old)| self.quads[s as usize] != old)
            .map(|(&s, _)| (s, self.quads[s as usize]))
            .collect();
        rewritten.sort_by_key(|r| r.0);
        let mut moved: Vec<(u32, DVec3)> = self
            .old_pos
            .iter()
            .filter(|(&v, &old)| self.pos[v as usize] != old)
            .map(|(&v, _)| (v, self.pos[v as usize]))
            .collect();
        moved.sort_by_key(|m| m.0);
        SplitRecord {
            op,
            new_vertices: self.pos[self.v0..].to_vec(),
            moved,
            rewritten,
            appended_faces: self.quads[self.f0..].to_vec(),
        }
    }

    /// Star of `m` as (faces in CCW order, link ring, is_boundary), or None
    /// when the star is not a single fan with a duplicate-free link.
    fn star(&self, m: u32) -> Option<(Vec<u32>, Vec<u32>, bool)> {
        let fs = &self.vf[m as usize];
        let first = *fs.first()?;
        let corner = |f: u32| self.quads[f as usize].iter().position(|&x| x == m);
        // Next face CCW around m from face f: the one containing edge (m, prev(f)).
        let next = |f: u32| -> Option<u32> {
            let q = self.quads[f as usize];
            let p = q[(corner(f)? + 3) % 4];
            fs.iter().copied().find(|&g| {
                g != f && {
                    let gq = self.quads[g as usize];
                    corner(g).is_some_and(|k| gq[(k + 1) % 4] == p)
                }
            })
        };
        let prev = |f: u32| -> Option<u32> {
            let q = self.quads[f as usize];
            let n = q[(corner(f)? + 1) % 4];
            fs.iter().copied().find(|&g| {
                g != f && {
                    let gq = self.quads[g as usize];
                    corner(g).is_some_and(|k| gq[(k + 3) % 4] == n)
                }
            })
        };
        // Rewind to the boundary start (if any).
        let mut start = first;
        let mut boundary = false;
        for _ in 0..fs.len() {
            match prev(start) {
                Some(g) if g == first => break,
                Some(g) => start = g,
                None => {
                    boundary = true;
                    break;
                }
            }
        }
        let mut faces = vec![start];
        let mut f = start;
        loop {
            match next(f) {
                Some(g) if g == start => break,
                Some(g) => {
                    if faces.len() > fs.len() {
                        return None;
                    }
                    faces.push(g);
                    f = g;
                }
                None => {
                    if !boundary {
                        return None;
                    }
                    break;
                }
            }
        }
        if faces.len() != fs.len() {
            return None;
        }
        let mut link: Vec<u32> = faces
            .iter()
            .map(|&f| self.quads[f as usize][(corner(f).unwrap_or(0) + 1) % 4])
            .collect();
        if boundary {
            let f = *faces.last()?;
            link.push(self.quads[f as usize][(corner(f)? + 3) % 4]);
        }
        let mut sorted = link.clone();
        sorted.sort_unstable();
        sorted.dedup();
        if sorted.len() != link.len() {
            return None;
        }
        Some((faces, link, boundary))
    }

    /// One random quad vertex split; false when the picked vertex is unsuitable.
    fn try_split(&mut self, rng: &mut Rng) -> bool {
        let m = rng.below(self.pos.len()) as u32;
        let Some((faces, link, boundary)) = self.star(m) else {
            return false;
        };
        let k = faces.len();
        let (i, j) = if boundary {
            if k < 2 {
                return false;
            }
            let i = rng.below(k - 1);
            let j = i + 2 + rng.below(k - 1 - i);
            (i, j)
        } else {
            if k < 4 {
                return false;
            }
            let i = rng.below(k);
            (i, (i + 2 + rng.below(k - 3)) % k)
        };
        let side_a: Vec<u32> = if i < j {
            faces[i..j].to_vec()
        } else {
            faces[i..].iter().chain(&faces[..j]).copied().collect()
        };
        let (b, d) = (link[i], link[j]);
        let centroid = |fs: &mut dyn Iterator<Item = &u32>, st: &State| -> Option<DVec3> {
            let mut s = DVec3::ZERO;
            let mut n = 0.0;
            for &f in fs {
                for v in st.quads[f as usize] {
                    s += st.pos[v as usize];
                    n += 1.0;
                }
            }
            (n > 0.0).then(|| s / n)
        };
        let p = self.pos[m as usize];
        let ca = centroid(&mut side_a.iter(), self).unwrap_or(p);
        let cc = centroid(&mut faces.iter().filter(|f| !side_a.contains(f)), self)
            .unwrap_or(2.0 * p - ca);
        let t = 0.2 + 0.2 * rng.unit();
        let half = (ca - cc) * t * 0.5;
        let noise = DVec3::new(rng.signed(), rng.signed(), rng.signed()) * half.length() * 0.1;
        let pa = p + half + noise;
        let pc = p - half - noise;
        let c = self.pos.len() as u32;
        self.pos.push(pc);
        self.vf.push(Vec::new());
        self.set_pos(m, pa);
        for &f in &faces {
            if !side_a.contains(&f) {
                let q = self.quads[f as usize].map(|x| if x == m { c } else { x });
                self.set_quad(f, q);
            }
        }
        let quad = [m, d, c, b];
        let r = rng.below(4);
        self.push_quad([0, 1, 2, 3].map(|t| quad[(t + r) % 4]));
        true
    }

    fn smooth(&mut self, rng: &mut Rng) {
        let n = 1 + rng.below(4);
        for _ in 0..n {
            let v = rng.below(self.pos.len()) as u32;
            let fs = self.vf[v as usize].clone();
            let mut s = DVec3::ZERO;
            let mut cnt = 0.0;
            for f in fs {
                for x in self.quads[f as usize] {
                    s += self.pos[x as usize];
                    cnt += 1.0;
                }
            }
            if cnt > 0.0 {
                let p = self.pos[v as usize];
                self.set_pos(v, p + (s / cnt - p) * 0.3);
            }
        }
    }
}

/// Random valid progressive mesh from `opts` (see the module docs).
pub fn generate_with(opts: &GenOptions) -> ProgressiveMesh {
    let mut rng = Rng(opts.seed);
    let (pos, quads) = base_mesh(opts.base, &mut rng);
    let base = IndexedMesh::from_faces(pos.clone(), quads.iter());
    let mut vf = vec![Vec::new(); pos.len()];
    for (f, q) in quads.iter().enumerate() {
        for &v in q {
            vf[v as usize].push(f as u32);
        }
    }
    let mut st = State {
        pos,
        quads,
        vf,
        v0: 0,
        f0: 0,
        old_quads: HashMap::new(),
        old_pos: HashMap::new(),
    };
    let mut records = Vec::new();
    let mut done = 0;
    let mut failures = 0;
    while done < opts.splits && failures < 10_000 {
        st.begin();
        if rng.unit() < opts.smooth_prob {
            failures += 1; // bounds the loop when nothing can be split
            st.smooth(&mut rng);
            let r = st.finish(OpKind::Smooth);
            if !r.moved.is_empty() {
                records.push(r);
            }
            continue;
        }
        let fuse = done + 1 < opts.splits && rng.unit() < opts.fuse_prob;
        if !st.try_split(&mut rng) {
            failures += 1;
            continue;
        }
        failures = 0; // bound consecutive failures only
        done += 1;
        let mut op = OpKind::QvMerge;
        if fuse {
            for _ in 0..100 {
                if st.try_split(&mut rng) {
                    done += 1;
                    op = OpKind::QeMerge;
                    break;
                }
            }
        }
        records.push(st.finish(op));
    }
    let n = records.len();
    let level_error = (0..=n)
        .map(|k| 0.05 * (n - k) as f64 / n.max(1) as f64)
        .collect();
    let mut vertex_order = Vec::new();
    if opts.vertex_order {
        vertex_order = (0..st.pos.len() as u32).collect();
        for i in (1..vertex_order.len()).rev() {
            vertex_order.swap(i, rng.below(i + 1));
        }
    }
    ProgressiveMesh {
        base,
        records,
        vertex_order,
        level_error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_meshes_validate_and_reach_their_counts() {
        for seed in 0..40 {
            let pm = generate(seed, 60);
            pm.validate().unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            let (p, q) = pm.level_quads(pm.records.len());
            assert_eq!(p.len(), pm.final_vertex_count());
            assert_eq!(q.len(), pm.final_face_count());
            // Each split adds one vertex and one face (Euler characteristic kept).
            assert_eq!(
                pm.final_vertex_count() - pm.base.vertex_count(),
                pm.final_face_count() - pm.base.face_count()
            );
        }
    }

    #[test]
    fn every_level_is_a_manifold_quad_mesh() {
        // Each undirected edge is used by at most two faces, once per direction.
        for seed in 0..10 {
            let pm = generate(seed, 80);
            for k in [0, pm.records.len() / 2, pm.records.len()] {
                let (_, quads) = pm.level_quads(k);
                let mut half: HashMap<(u32, u32), u32> = HashMap::new();
                for q in &quads {
                    for c in 0..4 {
                        *half.entry((q[c], q[(c + 1) % 4])).or_default() += 1;
                    }
                }
                assert!(
                    half.values().all(|&n| n == 1),
                    "seed {seed} level {k}: repeated half-edge"
                );
            }
        }
    }
}
