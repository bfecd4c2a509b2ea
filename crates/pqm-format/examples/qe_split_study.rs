//! Design study for issue 4: a compact "edge split" record form for qeMerge
//! inverses. No format, spec or encoder change — this example only derives
//! parameters from real records, rebuilds the records from them and prices
//! them.
//!
//! `cargo run --release -p pqm-format --example qe_split_study -- FILE.pqm...`
//!
//! For every qeMerge record (op code 1) of each file it replays the records
//! on a [`MeshState`] (public API, as `entropy_study`), and on the state
//! before the record:
//!
//! 1. **derives** the parameter set below from the coarse state + the
//!    explicit record (`derive`: a search over the few sector/fan splits
//!    the stars allow, then reading the vertex/face orders and rotations
//!    off the record);
//! 2. **rebuilds** the explicit record from the coarse state + parameters
//!    alone (`reconstruct`, which never sees the record) and compares it
//!    exactly — rewritten slots and quads, appended quads in order with
//!    their rotation, new-vertex ids;
//! 3. **prices** the parameters with ideal adaptive models (entropy_study's
//!    `Small` model: KT order-0 table per field and context, escape to an
//!    adaptive gamma bucket) and today's local form (§7.7) of the same
//!    records with entropy_study's field models (counts, slot gaps, masks,
//!    corner codes, corner indices; fed with qeMerge records only).
//!
//! Derivation and rebuild share the geometric core (`canon`); what the
//! comparison proves is that the coarse state plus this parameter set
//! determine the record, bit for bit. As a control, every single-field
//! change of a derived set (`r`, `n1`, `m` ± 1, two vertices or two
//! appended quads swapped, a rotation + 1) must rebuild something else or
//! be rejected (the example fails otherwise): 0 of 46 618 (loki), 23 141
//! (makehuman_base), 4 770 (spot) did not.
//!
//! # Design: the edge-split form (inverse of qeMerge)
//!
//! Notation as in `pqm-core/src/ops/qe_merge.rs`: fine quads
//! `q1 = (a, b, c, d)`, `q2 = (a, d, e, f)`; coarsening collapses b, f → A
//! and c, e → D and re-fans each endpoint over the non-crossing side.
//! Stars are the canonical stars of spec §7.5 (faces `F_i`, link `l_i`,
//! `l_i` = the vertex after the centre in `F_i`, `F_{i+1}` follows `F_i`
//! counter-clockwise).
//!
//! **Shape observed in every record.** Around an endpoint `X` with other
//! endpoint `Y`, let `ρ` be the index with `l_ρ = Y`. Reading `X`'s star
//! from `ρ`, the faces are: `F_ρ` (the face on X–Y whose next vertex is Y),
//! then `n1 ≥ 0` more faces of the *first sector*, then the `m = k + 1 ≥ 1`
//! fan quads, then the *second sector* (`≥ 1` faces, ending with
//! `F_{ρ−1}`, the other face on X–Y). With `u1`, `u2` the new vertices of
//! the first and second sector (at `A`: `u1 = f`, `u2 = b`; at `D`:
//! `u1 = c`, `u2 = e`):
//!
//! * every sector face keeps its slot and its rotation, with `X` replaced
//!   by `u1` (first sector, including `F_ρ`) or `u2` (second sector,
//!   including `F_{ρ−1}`); a face in both endpoints' sectors (the two faces
//!   on A–D) gets both replacements;
//! * the fan path: fan quad `j` (`j = 0 … m−1`, star order) reads
//!   `(X, P_2j, P_2j+1, P_2j+2)` from `X`, giving `P_0 … P_2m`; fan slot
//!   `j < m−1` becomes `(X, P_2j+1, P_2j+2, P_2j+3)`, slot `m−1` becomes
//!   `(X, P_2m−1, P_2m, u2)`, and the first-sector triangle
//!   `(X, u1, P_0, P_1)` is appended (the coarsener's fan keeps the old ids
//!   in walk order, which always runs from the second-sector triangle, so
//!   the first-sector one is the deleted face);
//! * appended also: `q1 = (A, u2(A), u1(D), D)` and `q2 = (A, D, u2(D), u1(A))`.
//!
//! **Parameters** (anchor excluded — named as today by a cursor delta):
//! `r` = index of `D` in `A`'s link (alphabet `K_A`); per endpoint the
//! first-sector count `n1` and fan length `m − 1` (alphabets given by `K`);
//! then, as today's recorder emits them, the order of the four new vertices
//! (a permutation of 4), the order of the four appended quads (a
//! permutation of 4) and a 2-bit rotation per appended and per fan quad.
//! The operator is symmetric in A and D, so the encoder anchors the
//! endpoint nearer to the cursor at no cost.
//!
//! **Decoding** (given anchor `A`): build `A`'s star; `D = l_r`; build `D`'s
//! star; for each endpoint apply the three rules above with placeholder
//! vertices; map placeholders to ids `V + π_v(i)`; rotate fan and appended
//! quads; write appended quads at slots `NF + π_f(i)`. Reject when
//! `1 + n1 + m ≥ K`, a star is open (boundary) or not a fan, a fan face
//! does not hold `X` followed by its link vertex, or a slot is both
//! re-fanned and substituted.
//!
//! **Canonical rules and deviations.** Canonical = identity orders
//! (`[u1(A), u2(A), u1(D), u2(D)]`, appended `[q1, q2, tri(A), tri(D)]`)
//! and rotation 0 (quads as written above, starting at the endpoint). Real
//! records deviate almost always (92–97 % of vertex and appended orders,
//! ~75 % of rotations: the orders come from the coarsener's ids, the
//! rotations from the input's corner order) and the deviations are
//! incompressible (4.3–4.5 bits per permutation ≈ log2 24; 2 bits per
//! rotation; contexts tried — smallest / largest id corner, the untouched
//! neighbour's edge index — gain at most 1.1 bits per record, listed as
//! `(alt)` rows). Recommendation: **make the recorder canonical**
//! (`coarsen/record.rs`: emit a qeMerge's new vertices and appended quads
//! in the canonical order, defined relative to the smaller endpoint id so
//! the encoder's anchor choice does not interact). Free for the appended
//! order (the format keeps no input face order: slots are canonical) and
//! for vertices without `VORD` (`--no-vertex-order`); with `VORD`, the
//! order moves there — today a record's new vertices are ascending in input
//! index, which an ideal `VORD` coder would exploit, so up to log2 24 ≈ 4.6
//! bits per record may reappear in `VORD` (not measured; `VORD` is
//! zstd-coded deltas, far from ideal today). The rotations carry
//! the input's corner order ("faces keep their corner order"), so dropping
//! them (≈ 12 bits per record) is an encoder option like
//! `--no-vertex-order`, not a free change.
//!
//! **Not covered** (none occurred on these files): an endpoint on the
//! boundary (open star, or no triangle → no re-fan) and crossing-side fans
//! (`qe_merge_patch_with`'s `cross`); both would need a case bit and their
//! own rule.
//!
//! # Figures (14-bit positions; files by the `pqm encode` binary built from main at 07:50 UTC, 2026-11-22)
//!
//! `cargo run --release -p pqm-format --example qe_split_study --
//! /tmp/qed/{loki,makehuman_base,spot_quadrangulated}.pqm` (0.4 s for all).
//! Rebuilt exactly: **4115 / 4115 (loki), 2036 / 2036 (makehuman_base),
//! 422 / 422 (spot) — 100 %**, no failure kind. One loki record is in the
//! general form today and is left out of the prices.
//!
//! Ideal adaptive bits per qeMerge record:
//!
//! | file | today local form conn+slots | edge split, today's recorder | canonical orders, rotations kept | fully canonical | anchor today → edge split |
//! |---|---:|---:|---:|---:|---:|
//! | loki | 151.5 | 24.5 | 15.6 | 3.5 | 10.6 → 12.4 |
//! | makehuman_base | 152.5 | 24.7 | 16.0 | 3.7 | 10.2 → 11.8 |
//! | spot_quadrangulated | 153.0 | 26.6 | 17.8 | 4.8 | 9.7 → 10.6 |
//!
//! Of the 24.5 (loki): shape 3.5 (`r` 2.2, `n1` 1.1, `m` 0.2), vertex
//! order 4.4, appended order 4.5, appended rotations 8.1, fan rotations
//! 4.0. (Anchor: today's local form may anchor any vertex near the record
//! and picks the cheapest; the edge split must name an endpoint, +0.9–1.8
//! bits; priced against today's cursor, an approximation.)
//!
//! Saving, anchor included, bits per refined / per final vertex (today's
//! recorder → fully canonical): loki 20.2 / 18.7 → 23.6 / 21.9;
//! makehuman_base 17.9 / 13.4 → 20.9 / 15.6; spot 19.8 / 18.1 → 23.3 /
//! 21.2 — in line with entropy_study's estimate (−20.9 / −14.9 / −20.2
//! per final vertex), now measured on rebuilt records.

use pqm_format::codec::{self, Coding, Cursors, MeshState, QRecord, CONN, REFS, SLOTS};
use pqm_format::varint::Reader;
use std::collections::{BTreeMap, HashMap};

/// qeMerge's op code (spec §7.3).
const QE: u8 = 1;

#[path = "common/models.rs"]
mod models;
use models::Small;

/// Field prices (ideal adaptive bits), summed per field name.
#[derive(Default)]
struct Prices {
    models: HashMap<&'static str, Small>,
    sum: BTreeMap<&'static str, f64>,
}

impl Prices {
    fn add(&mut self, name: &'static str, ctx: u64, v: u64) -> f64 {
        let b = self.models.entry(name).or_default().cost(ctx, v);
        *self.sum.entry(name).or_default() += b;
        b
    }
}

/// Placeholder ids of the four new vertices before the permutation is
/// applied: `U[2 x + s]` is new vertex `s` (0: first sector, 1: second) of
/// endpoint `x`.
const U: [u32; 4] = [u32::MAX - 4, u32::MAX - 3, u32::MAX - 2, u32::MAX - 1];

/// Parameters of one endpoint `X` (the other one is `Y`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Side {
    /// Faces of the first sector after `F[r]` (`n1 ≥ 0`).
    n1: usize,
    /// Fan faces (`m = k + 1 ≥ 1`).
    m: usize,
}

/// The whole parameter set of one edge split.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Params {
    /// Anchor `A` (the endpoint nearer to the anchor cursor).
    a: u32,
    /// Index of `D` in `A`'s canonical link (§7.5).
    r: usize,
    /// Per endpoint `[A, D]`.
    side: [Side; 2],
    /// New vertex id offset (0..4) of each placeholder `U[i]`.
    perm_v: [u8; 4],
    /// Appended slot offset (0..4) of each canonical appended quad
    /// `[q1, q2, tri(A), tri(D)]`.
    perm_f: [u8; 4],
    /// Rotation of each rebuilt fan quad and appended quad (canonical quad
    /// rotated left by this), in rebuild order.
    rot_fan: Vec<u8>,
    rot_app: [u8; 4],
}

/// A canonical (unpermuted, unrotated) rebuild: rewritten (slot, quad,
/// is-fan) and the four appended quads `[q1, q2, tri(A), tri(D)]`.
struct Canon {
    rewritten: Vec<(u32, [u32; 4], bool)>,
    appended: [[u32; 4]; 4],
}

/// Rebuilds the fine neighbourhood from the coarse state (design steps 1–4
/// of the doc comment) in canonical form; `None` when the parameters do not
/// fit the star (the decoder would reject the record).
fn canon(st: &MeshState, a: u32, r: usize, side: [Side; 2]) -> Option<Canon> {
    let sa = st.star(a).ok()?;
    if sa.link.len() != sa.faces.len() {
        return None; // boundary star: not covered by this design
    }
    let d = *sa.link.get(r)?;
    let mut sub: BTreeMap<u32, [u32; 4]> = BTreeMap::new();
    let mut fan: BTreeMap<u32, [u32; 4]> = BTreeMap::new();
    let mut tri = [[0u32; 4]; 2];
    for (x, (xv, yv)) in [(a, d), (d, a)].into_iter().enumerate() {
        let s = st.star(xv).ok()?;
        let k = s.faces.len();
        if s.link.len() != k {
            return None;
        }
        let rx = s.link.iter().position(|&v| v == yv)?;
        let Side { n1, m } = side[x];
        if m == 0 || 1 + n1 + m >= k {
            return None;
        }
        let (u1, u2) = (U[2 * x], U[2 * x + 1]);
        let f = |i: usize| s.faces[(rx + i) % k];
        let l = |i: usize| s.link[(rx + i) % k];
        // Sectors: X → u1 on F[r] … F[r+n1], X → u2 after the fan.
        for i in 0..k {
            let u = if i <= n1 {
                u1
            } else if i > n1 + m {
                u2
            } else {
                continue;
            };
            let g = f(i);
            let q = sub.entry(g).or_insert(st.quads[g as usize]);
            for c in q.iter_mut() {
                if *c == xv {
                    *c = u;
                }
            }
        }
        // Fan path P0 … P2m in star order.
        let mut p = Vec::with_capacity(2 * m + 1);
        for j in 0..m {
            let g = f(n1 + 1 + j);
            let q = st.quads[g as usize];
            let c = q.iter().position(|&v| v == xv)?;
            if q[(c + 1) % 4] != l(n1 + 1 + j) {
                return None;
            }
            p.push(q[(c + 1) % 4]);
            p.push(q[(c + 2) % 4]);
        }
        p.push(l(n1 + 1 + m));
        for j in 0..m {
            let g = f(n1 + 1 + j);
            let q = if j + 1 < m {
                [xv, p[2 * j + 1], p[2 * j + 2], p[2 * j + 3]]
            } else {
                [xv, p[2 * m - 1], p[2 * m], u2]
            };
            if fan.insert(g, q).is_some() {
                return None;
            }
        }
        tri[x] = [xv, u1, p[0], p[1]];
    }
    // A face both re-fanned and substituted: not this operator's shape.
    if fan.keys().any(|g| sub.contains_key(g)) {
        return None;
    }
    let mut rewritten: Vec<(u32, [u32; 4], bool)> = sub
        .into_iter()
        .map(|(g, q)| (g, q, false))
        .chain(fan.into_iter().map(|(g, q)| (g, q, true)))
        .collect();
    rewritten.sort_by_key(|x| x.0);
    // q1 = (a, b, c, d), q2 = (a, d, e, f) with b = u2(A), f = u1(A),
    // c = u1(D), e = u2(D).
    let q1 = [a, U[1], U[2], d];
    let q2 = [a, d, U[3], U[0]];
    Some(Canon {
        rewritten,
        appended: [q1, q2, tri[0], tri[1]],
    })
}

fn rotl(q: [u32; 4], t: u8) -> [u32; 4] {
    let t = t as usize;
    [q[t % 4], q[(t + 1) % 4], q[(t + 2) % 4], q[(t + 3) % 4]]
}

/// Explicit connectivity of a record: rewritten (slot, quad), appended quads.
type Explicit = (Vec<(u32, [u32; 4])>, Vec<[u32; 4]>);

/// The independent reconstruction (decoding steps of the doc comment):
/// explicit rewritten and appended quads from the coarse state and a full
/// parameter set. It shares only [`canon`] with [`derive`]; the comparison
/// against the real record is what checks both.
fn reconstruct(st: &MeshState, p: &Params) -> Option<Explicit> {
    let c = canon(st, p.a, p.r, p.side)?;
    let v0 = st.q.len() as u32;
    let map = |q: [u32; 4]| {
        q.map(|v| match U.iter().position(|&u| u == v) {
            Some(i) => v0 + p.perm_v[i] as u32,
            None => v,
        })
    };
    let mut fi = 0;
    let mut rw = Vec::with_capacity(c.rewritten.len());
    for (g, q, is_fan) in c.rewritten {
        let q = if is_fan {
            fi += 1;
            rotl(q, *p.rot_fan.get(fi - 1)?)
        } else {
            q
        };
        rw.push((g, map(q)));
    }
    let mut app = vec![[0u32; 4]; 4];
    for (i, q) in c.appended.into_iter().enumerate() {
        app[p.perm_f[i] as usize] = map(rotl(q, p.rot_app[i]));
    }
    Some((rw, app))
}

/// Rotation `t` with `rotl(q, t) == target`, if any.
fn rotation(q: [u32; 4], target: [u32; 4]) -> Option<u8> {
    (0..4u8).find(|&t| rotl(q, t) == target)
}

/// Why a record's parameters could not be derived.
fn derive(st: &MeshState, r: &QRecord, cursor: u32) -> Result<Params, &'static str> {
    if r.new_pos.len() != 4 || r.appended.len() != 4 {
        return Err("not 4 new / 4 appended");
    }
    // A and D: the old vertices in at least two appended quads (q1 and q2
    // hold both; placement may leave them unmoved, so `moved` is no guide).
    let v0 = st.q.len() as u32;
    let mut cand: Vec<u32> = Vec::new();
    for q in &r.appended {
        for &v in q {
            if v < v0
                && !cand.contains(&v)
                && r.appended.iter().filter(|p| p.contains(&v)).count() >= 2
            {
                cand.push(v);
            }
        }
    }
    cand.sort_unstable();
    let mut last = Err("no pair of old vertices shared by appended quads");
    for (i, &a) in cand.iter().enumerate() {
        for &d in &cand[i + 1..] {
            // The operator is symmetric in its endpoints: anchor the one
            // nearer to the cursor (cheaper delta), no bit needed.
            let dist = |v: u32| (v as i64 - cursor as i64).unsigned_abs();
            let (a, d) = if dist(d) < dist(a) { (d, a) } else { (a, d) };
            match derive_ad(st, r, a, d) {
                Ok(p) => return Ok(p),
                Err(e) => last = Err(e),
            }
        }
    }
    last
}

/// [`derive`] for a given anchor `a` and other endpoint `d`.
fn derive_ad(st: &MeshState, r: &QRecord, a: u32, d: u32) -> Result<Params, &'static str> {
    let sa = st.star(a).map_err(|_| "star of A not a fan")?;
    let sd = st.star(d).map_err(|_| "star of D not a fan")?;
    if sa.link.len() != sa.faces.len() || sd.link.len() != sd.faces.len() {
        return Err("boundary endpoint");
    }
    let rr = sa
        .link
        .iter()
        .position(|&v| v == d)
        .ok_or("A and D not adjacent")?;
    let v0 = st.q.len() as u32;
    let (ka, kd) = (sa.faces.len(), sd.faces.len());
    let mut shape_fit = false;
    for m0 in 1..ka {
        for n0 in 0..ka {
            for m1 in 1..kd {
                for n1 in 0..kd {
                    let side = [Side { n1: n0, m: m0 }, Side { n1, m: m1 }];
                    let Some(c) = canon(st, a, rr, side) else {
                        continue;
                    };
                    if c.rewritten.len() != r.rewritten.len()
                        || c.rewritten
                            .iter()
                            .zip(&r.rewritten)
                            .any(|(x, y)| x.0 != y.0)
                    {
                        continue;
                    }
                    shape_fit = true;
                    // Vertex permutation: read it off the substituted
                    // (unrotated) faces and the fans.
                    let mut perm_v = [u8::MAX; 4];
                    let mut ok = true;
                    let mut rot_fan = Vec::new();
                    let bind = |cq: [u32; 4], rq: [u32; 4], perm_v: &mut [u8; 4]| {
                        for (x, y) in cq.iter().zip(rq) {
                            if let Some(i) = U.iter().position(|u| u == x) {
                                if y < v0 || y >= v0 + 4 {
                                    return false;
                                }
                                let o = (y - v0) as u8;
                                if perm_v[i] != u8::MAX && perm_v[i] != o {
                                    return false;
                                }
                                perm_v[i] = o;
                            } else if *x != y {
                                return false;
                            }
                        }
                        true
                    };
                    for (cw, rw) in c.rewritten.iter().zip(&r.rewritten) {
                        if cw.2 {
                            // fans: any rotation that binds
                            let t = (0..4u8).find(|&t| {
                                let mut pv = perm_v;
                                bind(rotl(cw.1, t), rw.1, &mut pv)
                            });
                            match t {
                                Some(t) => {
                                    bind(rotl(cw.1, t), rw.1, &mut perm_v);
                                    rot_fan.push(t);
                                }
                                None => ok = false,
                            }
                        } else if !bind(cw.1, rw.1, &mut perm_v) {
                            ok = false;
                        }
                    }
                    if !ok {
                        continue;
                    }
                    // Unbound new vertices (only in appended quads): try
                    // all completions with the appended quads.
                    let mut best = None;
                    'perm: for p in perms4() {
                        if (0..4).any(|i| perm_v[i] != u8::MAX && perm_v[i] != p[i]) {
                            continue;
                        }
                        let map = |q: [u32; 4]| {
                            q.map(|v| match U.iter().position(|&u| u == v) {
                                Some(i) => v0 + p[i] as u32,
                                None => v,
                            })
                        };
                        let mut perm_f = [0u8; 4];
                        let mut rot_app = [0u8; 4];
                        let mut used = [false; 4];
                        for (i, q) in c.appended.iter().enumerate() {
                            let q = map(*q);
                            let hit = (0..4).find_map(|j| {
                                (!used[j])
                                    .then(|| rotation(q, r.appended[j]).map(|t| (j, t)))
                                    .flatten()
                            });
                            let Some((j, t)) = hit else { continue 'perm };
                            used[j] = true;
                            perm_f[i] = j as u8;
                            rot_app[i] = t;
                        }
                        best = Some((p, perm_f, rot_app));
                        break;
                    }
                    if let Some((perm_v, perm_f, rot_app)) = best {
                        return Ok(Params {
                            a,
                            r: rr,
                            side,
                            perm_v,
                            perm_f,
                            rot_fan,
                            rot_app,
                        });
                    }
                }
            }
        }
    }
    Err(if shape_fit {
        "slots fit, contents differ"
    } else {
        "no sector/fan split fits the rewritten slots"
    })
}

fn perms4() -> Vec<[u8; 4]> {
    let mut out = Vec::with_capacity(24);
    for a in 0..4u8 {
        for b in 0..4u8 {
            for c in 0..4u8 {
                for d in 0..4u8 {
                    let p = [a, b, c, d];
                    if (0..4).all(|i| (0..i).all(|j| p[i] != p[j])) {
                        out.push(p);
                    }
                }
            }
        }
    }
    out
}

/// Index of a permutation of 0..4 in [`perms4`] order.
fn perm_index(p: [u8; 4]) -> u64 {
    perms4().iter().position(|&q| q == p).unwrap_or(0) as u64
}

/// Today's local-form (§7.7) connectivity + slots bits of one record,
/// priced with entropy_study's models (fields and contexts the same, models
/// fed with qeMerge records only).
fn price_today(s: &[Vec<u8>; 5], y: &mut Prices) -> Result<(u8, f64, f64), String> {
    let mut rd = [0, 1, 2, 3, 4].map(|t| Reader::new(&s[t], codec::STREAM_NAMES[t]));
    let sym = rd[0].byte()?;
    let form = (sym >> 2) & 3;
    let opf = (sym & 3) as u64 | (form as u64) << 2;
    if form != 2 {
        return Ok((form, 0.0, 0.0));
    }
    let mut b = 0.0;
    let anchor = y.add("today anchor delta (zigzag)", 0, zigzag(rd[REFS].s()?));
    let mut c = [0u64; 4];
    for x in c.iter_mut() {
        *x = rd[CONN].u()?;
    }
    let [_nn, nm, nr, na] = c;
    b += y.add("today count new", opf, c[0]);
    b += y.add("today count moved", opf, nm);
    b += y.add("today count rewritten", opf, nr);
    b += y.add("today count appended", opf, na);
    for t in 0..nr {
        let v = rd[SLOTS].u()?;
        b += y.add(
            if t == 0 {
                "today rw first"
            } else {
                "today rw gap"
            },
            0,
            v,
        );
    }
    for t in 0..nm {
        let v = rd[SLOTS].u()?;
        b += y.add(
            if t == 0 {
                "today moved first"
            } else {
                "today moved gap"
            },
            0,
            v,
        );
    }
    let corner = |y: &mut Prices, rd: &mut [Reader; 5]| -> Result<f64, String> {
        let x = rd[CONN].u()?;
        let mut b = y.add("today corner code", 2, x);
        if x == 0 {
            let i = rd[SLOTS].u()?;
            b += y.add("today corner index", 0, i);
        }
        Ok(b)
    };
    for _ in 0..nr {
        let mask = rd[CONN].u()?;
        b += y.add("today mask", 2, mask);
        for k in 0..4 {
            if mask & (1 << k) != 0 {
                b += corner(y, &mut rd)?;
            }
        }
    }
    for _ in 0..4 * na {
        b += corner(y, &mut rd)?;
    }
    Ok((form, b, anchor))
}

fn main() {
    models::study_files("qe_split_study", study);
}

fn study(f: &str) -> Result<(), String> {
    let models::Opened {
        pm,
        quant,
        state: mut st,
        ..
    } = models::open(f)?;
    let mut cur = Cursors::default();
    // The 2.0 coding this study measured (it parses forms 0-3 only; format
    // 3.0's edge-split form is what it led to).
    let coding = Coding {
        major: 2,
        edge_split: false,
        ..Coding::default()
    };
    let mut today = Prices::default();
    let mut new = Prices::default();
    let (mut n_qe, mut n_exact, mut n_new_all) = (0usize, 0usize, 0usize);
    let mut fails: BTreeMap<&'static str, usize> = BTreeMap::new();
    let mut forms = [0usize; 4];
    let (mut n_ctrl, mut n_ctrl_same) = (0usize, 0usize);
    let (mut today_bits, mut new_bits, mut new_canon, mut new_rot) = (0.0, 0.0, 0.0, 0.0);
    let (mut today_anchor, mut new_anchor, mut n_priced) = (0.0, 0.0, 0usize);
    // Deviations from the canonical rule (identity / rotation 0).
    let (mut dev_v, mut dev_f, mut dev_rf, mut dev_ra, mut n_fan) = (0, 0, 0, 0, 0);
    for rec in &pm.records {
        let r = QRecord::quantized(rec, &quant);
        n_new_all += r.new_pos.len();
        let mut s: [Vec<u8>; 5] = Default::default();
        let cursor = cur.vref;
        codec::encode_record(&st, &r, &mut cur, &mut s, coding);
        if r.op as u8 == QE {
            n_qe += 1;
            match derive(&st, &r, cursor) {
                Err(why) => *fails.entry(why).or_default() += 1,
                Ok(p) => match reconstruct(&st, &p) {
                    Some((rw, app)) if rw == r.rewritten && app == r.appended => {
                        n_exact += 1;
                        // Control: every single-parameter change must
                        // rebuild something else (or be rejected), or the
                        // comparison would prove nothing.
                        for q in perturbations(&p) {
                            n_ctrl += 1;
                            let same = reconstruct(&st, &q)
                                .is_some_and(|(rw, app)| rw == r.rewritten && app == r.appended);
                            n_ctrl_same += same as usize;
                        }
                        let (form, tb, ta) = price_today(&s, &mut today)?;
                        forms[form as usize] += 1;
                        // (priced only where today's form is the local one)
                        if form == 2 {
                            n_priced += 1;
                            today_bits += tb;
                            today_anchor += ta;
                            let (nb, canon_b, rot_b) = price_new(&st, &p, &mut new);
                            new_bits += nb;
                            new_canon += canon_b;
                            new_rot += rot_b;
                            new_anchor += new.add(
                                "new: anchor A delta (zigzag)",
                                0,
                                zigzag(p.a as i64 - cursor as i64),
                            );
                            // Alternative: always the smaller endpoint id
                            // (a recorder-side canonical anchor).
                            let d = st.star(p.a).ok().and_then(|s| s.link.get(p.r).copied());
                            let lo = d.map_or(p.a, |d| d.min(p.a));
                            new.add(
                                "(alt) anchor = smaller endpoint id (zigzag)",
                                0,
                                zigzag(lo as i64 - cursor as i64),
                            );
                        }
                        dev_v += (p.perm_v != [0, 1, 2, 3]) as usize;
                        dev_f += (p.perm_f != [0, 1, 2, 3]) as usize;
                        dev_ra += p.rot_app.iter().filter(|&&t| t != 0).count();
                        dev_rf += p.rot_fan.iter().filter(|&&t| t != 0).count();
                        n_fan += p.rot_fan.len();
                    }
                    _ => *fails.entry("rebuild differs from the record").or_default() += 1,
                },
            }
        }
        st.apply(&r);
    }
    let n = n_exact.max(1) as f64;
    let nfinal = st.q.len() as f64;
    println!(
        "## {f}: {} records, {n_qe} qeMerge, {n_new_all} refined vertices, {} final vertices",
        pm.records.len(),
        st.q.len()
    );
    println!(
        "reproduced exactly: {n_exact} / {n_qe} ({:.1} %); failures: {fails:?}",
        100.0 * n_exact as f64 / n_qe.max(1) as f64
    );
    println!(
        "control: {n_ctrl_same} of {n_ctrl} single-parameter perturbations still rebuild the record (must be 0)"
    );
    if n_ctrl_same != 0 {
        return Err(
            "a perturbed parameter set rebuilds the same record: the parameters are not all used"
                .into(),
        );
    }
    println!(
        "deviations from the canonical rule on reproduced records: vertex order {dev_v} ({:.1} %), appended order {dev_f} ({:.1} %), appended rotation {dev_ra} of {} quads, fan rotation {dev_rf} of {n_fan} quads",
        100.0 * dev_v as f64 / n,
        100.0 * dev_f as f64 / n,
        4 * n_exact,
    );
    println!(
        "today's forms of the reproduced records (general/split/local/face-split): {forms:?}; {n_priced} local-form records priced below"
    );
    let np = n_priced.max(1) as f64;
    println!("\n| field | bits/priced qe record |\n|---|---:|");
    for (k, v) in today.sum.iter().chain(new.sum.iter()) {
        println!("| {k} | {:.2} |", v / np);
    }
    let nv = n_new_all.max(1) as f64;
    println!("\n| per priced qe record | today (local form) | edge split, today's recorder | canonical orders, input rotations kept | fully canonical |");
    println!("|---|---:|---:|---:|---:|");
    let new_keep = new_canon + new_rot;
    println!(
        "| conn + slots bits | {:.1} | {:.1} | {:.1} | {:.1} |",
        today_bits / np,
        new_bits / np,
        new_keep / np,
        new_canon / np
    );
    println!(
        "| anchor bits | {:.1} | {:.1} | {:.1} | {:.1} |",
        today_anchor / np,
        new_anchor / np,
        new_anchor / np,
        new_anchor / np
    );
    for (name, div) in [("refined", nv), ("final", nfinal)] {
        let save = |x: f64| (today_bits + today_anchor - x - new_anchor) / div;
        println!(
            "| saving, bits per {name} vertex of the file | | {:.2} | {:.2} | {:.2} |",
            save(new_bits),
            save(new_keep),
            save(new_canon)
        );
    }
    println!();
    Ok(())
}

/// Prices one parameter set without its anchor (priced by the caller):
/// (all fields, the shape fields alone — what is left when the recorder
/// emits the canonical order and rotations).
fn price_new(st: &MeshState, p: &Params, y: &mut Prices) -> (f64, f64, f64) {
    let ka = st.star(p.a).map_or(0, |s| s.faces.len()) as u64;
    let d = st.star(p.a).ok().and_then(|s| s.link.get(p.r).copied());
    let kd = d.and_then(|d| st.star(d).ok()).map_or(0, |s| s.faces.len()) as u64;
    let mut b = y.add("new: r (D in A's link)", ka.min(16), p.r as u64);
    for (x, k) in [ka, kd].into_iter().enumerate() {
        let s = p.side[x];
        b += y.add("new: fan length m", k.min(16), s.m as u64 - 1);
        b += y.add(
            "new: first sector n1",
            (k - 1 - s.m as u64).min(16),
            s.n1 as u64,
        );
    }
    let shape = b;
    let mut rots = 0.0;
    b += y.add("new: vertex order (perm)", 0, perm_index(p.perm_v));
    b += y.add("new: appended order (perm)", 0, perm_index(p.perm_f));
    for (i, &t) in p.rot_app.iter().enumerate() {
        rots += y.add("new: appended rotation", i as u64, t as u64);
    }
    for &t in &p.rot_fan {
        rots += y.add("new: fan rotation", 0, t as u64);
    }
    // Alternative rotation models (not in the totals): context = corner of
    // the smallest / largest vertex id in the canonical quad (new vertices
    // with their ids) — would the input's corner order follow the ids?
    if let Some(c) = canon(st, p.a, p.r, p.side) {
        let v0 = st.q.len() as u32;
        let map = |q: [u32; 4]| {
            q.map(|v| match U.iter().position(|&u| u == v) {
                Some(i) => v0 + p.perm_v[i] as u32,
                None => v,
            })
        };
        let rewritten: Vec<u32> = c.rewritten.iter().map(|x| x.0).collect();
        let fans = c.rewritten.iter().filter(|x| x.2).map(|x| x.1);
        let rots = p.rot_fan.iter().chain(p.rot_app.iter());
        for (q, &t) in fans.chain(c.appended).zip(rots) {
            let q = map(q);
            let lo = (0..4).min_by_key(|&i| q[i]).unwrap_or(0) as u64;
            let hi = (0..4).max_by_key(|&i| q[i]).unwrap_or(0) as u64;
            y.add("(alt) fan+appended rotation, no context", 0, t as u64);
            y.add(
                "(alt) fan+appended rotation given smallest-id corner",
                lo,
                t as u64,
            );
            y.add(
                "(alt) fan+appended rotation given largest-id corner",
                hi,
                t as u64,
            );
            // Context: across the first edge of the canonical quad with an
            // untouched neighbour, which edge of that neighbour it is (a
            // mesh whose quads start "in the same direction" would make
            // (edge here, edge there) predict the rotation).
            let nb = (0..4).find_map(|e| {
                let (u, w) = (q[e], q[(e + 1) % 4]);
                st.corners(w).find_map(|(g, k)| {
                    let gq = st.quads[g as usize];
                    (gq[(k + 1) % 4] == u && !rewritten.contains(&g))
                        .then_some((e as u64, k as u64))
                })
            });
            let ctx = nb.map_or(99, |(e, k)| (4 + k - e) % 4);
            y.add(
                "(alt) fan+appended rotation given neighbour edge index",
                ctx,
                t as u64,
            );
        }
    }
    (b + rots, shape, rots)
}

/// Parameter sets that differ from `p` in one field: `r` ± 1, each
/// endpoint's `n1` ± 1 and `m` ± 1, two new vertices or two appended quads
/// swapped, one rotation + 1.
fn perturbations(p: &Params) -> Vec<Params> {
    let mut out = Vec::new();
    let mut push = |f: &dyn Fn(&mut Params)| {
        let mut q = p.clone();
        f(&mut q);
        out.push(q);
    };
    push(&|q| q.r += 1);
    if p.r > 0 {
        push(&|q| q.r -= 1);
    }
    for x in 0..2 {
        push(&|q| q.side[x].n1 += 1);
        push(&|q| q.side[x].m += 1);
        if p.side[x].n1 > 0 {
            push(&|q| q.side[x].n1 -= 1);
        }
        if p.side[x].m > 1 {
            push(&|q| q.side[x].m -= 1);
        }
    }
    push(&|q| q.perm_v.swap(0, 3));
    push(&|q| q.perm_f.swap(1, 2));
    push(&|q| q.rot_app[0] = (q.rot_app[0] + 1) % 4);
    if !p.rot_fan.is_empty() {
        push(&|q| q.rot_fan[0] = (q.rot_fan[0] + 1) % 4);
    }
    out
}

/// Zigzag map of a signed delta (0, -1, 1, -2, … → 0, 1, 2, 3, …).
fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}
