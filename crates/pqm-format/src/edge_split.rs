//! The edge-split record form (spec §7.10, format 3): the inverse of a
//! qeMerge, named by its edge `A–D` and a few small parameters instead of
//! the local form's explicit slots and corners.
//!
//! [`build`] is the one place the explicit record is made from the
//! parameters: `decode_record` calls it, and the encoder calls it on the
//! parameters it derived ([`derive()`]) and uses the form only when the result
//! equals the record exactly — so whatever the derivation guesses, a file
//! never holds a form-4 record that decodes to something else. The
//! decoder's loop takes `build_fast` when both stars are on the fast
//! path: the same quads and predictions, applied without the explicit
//! record (tests `fused_edge_split_equals_build` and every real-mesh
//! level check the two against each other).

use crate::codec::{
    check_distinct, eq_mask4x4, eq_mask8, rotl, FastStar, MeshState, OnePass, QRecord, Star, NIL,
};

/// The 24 permutations of `0..4` in lexicographic order (spec §7.10 step 5:
/// permutation number `t` is `PERMS[t]`).
pub const PERMS: [[u8; 4]; 24] = perms();

const fn perms() -> [[u8; 4]; 24] {
    let mut out = [[0u8; 4]; 24];
    let mut n = 0;
    let mut x = 0u32;
    // Ascending x with base-4 digits (π(0), …, π(3)) is lexicographic order.
    while x < 256 {
        let p = [
            (x >> 6) as u8,
            (x >> 4) as u8 & 3,
            (x >> 2) as u8 & 3,
            x as u8 & 3,
        ];
        if p[0] != p[1]
            && p[0] != p[2]
            && p[0] != p[3]
            && p[1] != p[2]
            && p[1] != p[3]
            && p[2] != p[3]
        {
            out[n] = p;
            n += 1;
        }
        x += 1;
    }
    out
}

/// Largest value of the combined permutation field `p = 24 π_v + π_f`.
pub const MAX_P: u64 = 24 * 24 - 1;

/// The fields of one edge-split record (spec §7.10 steps 1–7), endpoint
/// arrays in the order `[X0, X1]` (smaller id first).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EdgeSplit {
    /// The anchor `A` (either endpoint).
    pub a: u32,
    /// Index of the other endpoint in `A`'s link.
    pub r: usize,
    /// First-sector length per endpoint.
    pub n1: [usize; 2],
    /// Fan length per endpoint (`m ≥ 1`).
    pub m: [usize; 2],
    /// `24 π_v + π_f`.
    pub p: usize,
    /// Rotations of the four canonical appended quads, 2 bits each.
    pub ra: u8,
    /// Fan-quad rotations, `m[0]` of `X0` then `m[1]` of `X1`.
    pub rots: Vec<u8>,
}

/// Reusable buffers of [`build`] (and of the encoder's derivation): the
/// stars of both endpoints, the slot list and the fan quads. One per
/// decoder, so a record allocates nothing once they have grown.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// Stars of `[X0, X1]`.
    pub stars: [Star; 2],
    /// `slot << 32 | tag`: tag `< 4` = sector face of canonical new vertex
    /// `U_tag`; `4 + i` = fan quad `i` of `fan`. Packed in one `u64` so that
    /// sorting by slot then tag is a sort of plain integers (a tuple sort
    /// was a quarter of the form's decode).
    entries: Vec<u64>,
    /// Fan quads, rotated, `X0`'s then `X1`'s.
    fan: Vec<[u32; 4]>,
    /// The predictions of the four new vertices (spec §7.6), gathered by
    /// [`build`] from the quads it makes (the decoder reads them).
    pub(crate) pred: OnePass,
    /// [`build_fast`]'s rewritten fan quads and faces of both endpoints,
    /// whole (here, not on the stack: 320 bytes that a stack array
    /// cleared with a `memset` call per record).
    pub(crate) rws: [(u32, [u32; 4]); FAST_REWRITES],
    /// [`build_fast`]'s sector faces of one endpoint, `(corner id of the
    /// endpoint, new vertex)`: the rest of its rewritten slots, each with
    /// one corner changed.
    pub(crate) sec: [(u32, u32); FAST_REWRITES],
    /// After [`derive()`]: the slot of each fan quad, in the order of
    /// [`EdgeSplit::rots`] (what an encoder that re-rotates the quads a
    /// record builds needs, `crate::encoder`'s corner order).
    pub fan_slots: Vec<u32>,
    /// [`build_fast`]'s corner blocks after the record's rewrites (before
    /// its appended quads), each `[n, c_1 … c_n, stale…]`: `X0`, `X1`,
    /// then the new vertices `V … V+3` by id.
    pub(crate) blocks: [[u32; 8]; 6],
    /// Per entry of `rws`: the changed corners that are neither an
    /// endpoint's nor a new vertex's (bits 0–3: to unlink from the old
    /// vertex, 4–7: to link to the new one; [`build_fast`]).
    pub(crate) masks: [u8; FAST_REWRITES],
}

/// The star of anchor `a` into `sc.stars[0]`; an error when §7.5 rejects
/// it or it is open (spec §7.10 step 2).
pub fn anchor_star(st: &MeshState, a: u32, sc: &mut Scratch) -> Result<usize, String> {
    let s0 = &mut sc.stars[0];
    st.star_into(a, s0)?;
    if s0.link.len() != s0.faces.len() {
        return Err(format!("edge split: anchor {a} is a boundary vertex"));
    }
    Ok(s0.faces.len())
}

/// After [`anchor_star`] of `a`: the star of the endpoint named by link
/// index `r`, both stars in `sc.stars` as `[X0, X1]`; returns `[X0, X1]`
/// and `ρ` per endpoint. Errors: `r` out of range, an open or rejected
/// star of `D`, `A` not in `D`'s link.
pub fn stars(
    st: &MeshState,
    a: u32,
    r: usize,
    sc: &mut Scratch,
) -> Result<([u32; 2], [usize; 2]), String> {
    let [s0, s1] = &mut sc.stars;
    let d = *s0.link.get(r).ok_or_else(|| {
        format!(
            "edge split: link index {r} outside the {} faces of vertex {a}",
            s0.faces.len()
        )
    })?;
    st.star_into(d, s1)?;
    if s1.link.len() != s1.faces.len() {
        return Err(format!("edge split: endpoint {d} is a boundary vertex"));
    }
    let rd = s1
        .link
        .iter()
        .position(|&v| v == a)
        .ok_or_else(|| format!("edge split: vertex {a} is not in the link of {d}"))?;
    if a < d {
        Ok(([a, d], [r, rd]))
    } else {
        sc.stars.swap(0, 1);
        Ok(([d, a], [rd, r]))
    }
}

/// Builds the explicit connectivity of an edge split (spec §7.10 steps 8–9)
/// into `out.rewritten` and `out.appended` (cleared first), the stars of
/// `ends = [X0, X1]` being in `sc.stars` ([`stars`]). `n1`, `m`, `rots` must
/// already be within the bounds of steps 4 and 7 (the decoder reads them
/// bounded); `p ≤ MAX_P`.
#[allow(clippy::too_many_arguments)]
pub fn build(
    st: &MeshState,
    ends: [u32; 2],
    rho: [usize; 2],
    n1: [usize; 2],
    m: [usize; 2],
    p: usize,
    ra: u8,
    rots: &[u8],
    sc: &mut Scratch,
    out: &mut QRecord,
) -> Result<(), String> {
    let v0 = st.q.len() as u32;
    let pv = PERMS[p / 24];
    let pf = PERMS[p % 24];
    let u = |i: usize| v0 + pv[i] as u32;
    let Scratch {
        stars,
        entries,
        fan,
        pred,
        ..
    } = sc;
    entries.clear();
    fan.clear();
    // Every quad of the record is fed to `pred` once, as it is made: a
    // sector face (old corners and one new one where X was) and the last
    // fan quad by their known corners, the rest whole.
    pred.clear();
    let q = &st.q;
    let mut tri = [[0u32; 4]; 2];
    let mut rot_i = 0usize;
    for x in 0..2 {
        let s = &stars[x];
        let k = s.faces.len();
        let (xv, rho, n1, m) = (ends[x], rho[x], n1[x], m[x]);
        if m == 0 || n1 + m + 2 > k {
            return Err(format!(
                "edge split: n1 = {n1}, m = {m} do not fit the {k} faces of vertex {xv}"
            ));
        }
        // `(rho + i) mod k` without a division (tens of cycles, ~20 per
        // record): `rho < k` and every `i` used here is `< k`.
        let wrap = |i: usize| {
            let w = rho + i;
            if w < k {
                w
            } else if w < 2 * k {
                w - k
            } else {
                w % k
            }
        };
        let g = |i: usize| s.faces[wrap(i)];
        let lam = |i: usize| s.link[wrap(i)];
        for i in (0..=n1).chain(n1 + m + 1..k) {
            let t = if i <= n1 { 2 * x } else { 2 * x + 1 };
            entries.push((g(i) as u64) << 32 | t as u64);
        }
        // Corner opposite X in fan face j (P_{2j+1}).
        let opp = |j: usize| -> Result<u32, String> {
            let q = st.quads[g(n1 + 1 + j) as usize];
            let c = q.iter().position(|&v| v == xv).ok_or_else(|| {
                format!("edge split: fan face {} lacks vertex {xv}", g(n1 + 1 + j))
            })?;
            Ok(q[(c + 2) % 4])
        };
        let mut o = opp(0)?;
        tri[x] = [xv, u(2 * x), lam(n1 + 1), o];
        for j in 0..m {
            let q = if j + 1 < m {
                let o2 = opp(j + 1)?;
                let q = [xv, o, lam(n1 + 2 + j), o2];
                o = o2;
                q
            } else {
                let l = lam(n1 + 1 + m);
                pred.add_single(q, pv[2 * x + 1] as usize, xv, o, l);
                [xv, o, l, u(2 * x + 1)]
            };
            let t = *rots.get(rot_i).ok_or("edge split: too few fan rotations")?;
            rot_i += 1;
            entries.push((g(n1 + 1 + j) as u64) << 32 | (4 + fan.len()) as u64);
            fan.push(rotl(q, t));
        }
    }
    entries.sort_unstable();
    out.rewritten.clear();
    let mut i = 0;
    while i < entries.len() {
        let (slot, tag) = ((entries[i] >> 32) as u32, entries[i] as u32);
        let twin = entries
            .get(i + 1)
            .filter(|&&e| (e >> 32) as u32 == slot)
            .map(|&e| e as u32);
        let q = if tag >= 4 || twin.is_some_and(|t| t >= 4) {
            if twin.is_some() {
                return Err(format!(
                    "edge split: slot {slot} is a fan face and a face of the other endpoint"
                ));
            }
            fan[(tag - 4) as usize]
        } else if twin.is_none() {
            // One new corner, where X was (a quad holds X once; were it
            // twice, `check_distinct` below rejects the record).
            let mut qd = st.quads[slot as usize];
            let xv = ends[(tag >> 1) as usize];
            for k in 0..4 {
                if qd[k] == xv {
                    qd[k] = u(tag as usize);
                    let (a, o, e) = (qd[(k + 1) & 3], qd[(k + 2) & 3], qd[(k + 3) & 3]);
                    pred.add_single(q, pv[tag as usize] as usize, a, o, e);
                }
            }
            qd
        } else {
            // A face of both endpoints: two new corners, its parallelogram
            // goes to the larger once the smaller is decoded.
            let mut qd = st.quads[slot as usize];
            // The corner and index of the larger new vertex so far.
            let (mut kb, mut best, mut found) = (0usize, 0u8, 0);
            for t in std::iter::once(tag).chain(twin) {
                let (xv, id) = (ends[(t >> 1) as usize], u(t as usize));
                for (k, c) in qd.iter_mut().enumerate() {
                    if *c == xv {
                        *c = id;
                        if found == 0 || pv[t as usize] > best {
                            (kb, best) = (k, pv[t as usize]);
                        }
                        found += 1;
                    }
                }
            }
            if found == 2 {
                pred.defer_at(&qd, kb, best as usize);
            } else {
                // Not one corner per endpoint (a state no decoder
                // reaches): the general rule.
                pred.add_quad(q, &qd, v0, 4);
            }
            qd
        };
        check_distinct(&q, || format!("edge split: rewritten slot {slot}"))?;
        out.rewritten.push((slot, q));
        i += 1 + twin.is_some() as usize;
    }
    let [x0, x1] = ends;
    let canon = [[x0, u(1), u(2), x1], [x0, x1, u(3), u(0)], tri[0], tri[1]];
    // Their parallelograms, from the canonical corners (a rotation keeps
    // each corner's neighbours): `C_0` and `C_1` hold two new vertices
    // each (the larger takes the quad), `T_x` one, `U_{2x}` after `X`.
    let later = |a: usize, b: usize| if pv[a] > pv[b] { (1, a) } else { (0, b) };
    let (d0, t0) = later(1, 2);
    pred.defer_at(&canon[0], 2 - d0, pv[t0] as usize);
    let (d1, t1) = later(3, 0);
    pred.defer_at(&canon[1], 3 - d1, pv[t1] as usize);
    for x in 0..2 {
        let [xv, _, l, o] = tri[x];
        pred.add_single(&st.q, pv[2 * x] as usize, l, o, xv);
    }
    // Placed in a stack array, then copied in one go (a `resize` of the
    // list cost more than the placement).
    let mut app = [[0u32; 4]; 4];
    for (i, q) in canon.into_iter().enumerate() {
        let q = rotl(q, (ra >> (2 * i)) & 3);
        check_distinct(&q, || format!("edge split: appended quad {i}"))?;
        app[pf[i] as usize] = q;
    }
    out.appended.clear();
    out.appended.extend_from_slice(&app);
    Ok(())
}

/// Room for [`build_fast`]'s rewritten slots (at most every face of both
/// stars, `2 INLINE = 14`), a power of two: an index masked with
/// `FAST_REWRITES - 1` needs no bounds check.
pub(crate) const FAST_REWRITES: usize = 16;
const _: () = assert!(2 * crate::codec::INLINE <= FAST_REWRITES);

/// [`build`] for the decoder when both stars came from
/// [`MeshState::star_fast`] (interior, at most [`crate::codec::INLINE`]
/// faces each: nearly every edge split), straight from the parameters —
/// no slot list to sort, the faces of both endpoints found by one vector
/// compare per face — in three parts: the sector faces of one endpoint
/// only into `sec` as `(corner id of X, new vertex)` (one corner changes:
/// the quad itself is never built), the fan quads and the faces of both
/// endpoints into `rw` whole, and the appended quads into `app`; the
/// predictions fed to `pred` as `build` feeds them. Returns the counts of
/// `rw` and `sec`. Same quads, same predictions, and the same records
/// rejected, in a decoder's state (every stored quad has four distinct
/// corners: each passed `check_distinct`), as `build` followed by sorting
/// by slot (test `fused_edge_split_equals_build`, and every real-mesh
/// level). Also the corner blocks of the six vertices whose every corner
/// the record decides, into `blocks` (`[X0, X1, V, V+1, V+2, V+3]`, each
/// `[n, corners…]`, as [`Scratch::blocks`]): an endpoint's corners in its
/// rewritten fan quads (its block held exactly its fast star: the sector
/// faces lose it, no other face has it), a new vertex's where its sector
/// faces had the endpoint (the same corner ids) and, for `u2`, in the last
/// fan quad. The decoder then applies the parts itself
/// ([`MeshState::apply_edge_split_parts`]): the explicit record is never
/// made.
///
/// The order of the checks is `build_fast`'s since it first had them: the
/// fields against each star, then a face of both endpoints that is a fan
/// face (in `X1`'s star order), then a fan quad repeating a corner (in
/// star order) — the same records refused, and the same message where a
/// record breaks one rule.
#[allow(clippy::too_many_arguments)]
pub(crate) fn build_fast(
    st: &MeshState,
    ends: [u32; 2],
    fs: [&FastStar; 2],
    rho: [usize; 2],
    n1: [usize; 2],
    m: [usize; 2],
    p: usize,
    ra: u8,
    rots: &[u8],
    pred: &mut OnePass,
    rw: &mut [(u32, [u32; 4]); FAST_REWRITES],
    sec: &mut [(u32, u32); FAST_REWRITES],
    app: &mut [[u32; 4]; 4],
    blocks: &mut [[u32; 8]; 6],
    masks: &mut [u8; FAST_REWRITES],
) -> Result<(usize, usize), String> {
    let v0 = st.q.len() as u32;
    let pv = PERMS[p / 24];
    let pf = PERMS[p % 24];
    let u = |i: usize| v0 + pv[i] as u32;
    pred.clear();
    let (q, quads) = (&st.q, &st.quads);
    // The faces of both endpoints first (the sector loops skip them): X1's
    // faces whose slot is in X0's star, as star positions — `shared[x]`
    // one bit per position, `pairs` the `(X0, X1)` positions in X1's star
    // order. (Slots are below `2^30`: the `NIL` padding matches none.)
    let mut slots0 = [NIL; 8];
    for (sl, &c) in slots0.iter_mut().zip(&fs[0].c[..fs[0].n]) {
        *sl = c >> 2;
    }
    let mut shared = [0u32; 2];
    let mut pairs = [(0u8, 0u8); 8];
    let mut np = 0usize;
    for (i1, &c1) in fs[1].c[..fs[1].n].iter().enumerate() {
        let hit = eq_mask8(&slots0, c1 >> 2);
        if hit != 0 {
            let i0 = hit.trailing_zeros();
            shared[0] |= 1 << i0;
            shared[1] |= 1 << i1;
            pairs[np & 7] = (i0 as u8, i1 as u8);
            np += 1;
        }
    }
    let mut n = 0usize;
    let mut ns = 0usize;
    // Per endpoint, the star positions of fan quads before the last that
    // repeat a corner (refused after the faces of both endpoints).
    let mut bad = [0u32; 2];
    let mut tri = [[0u32; 4]; 2];
    let mut rot_i = 0usize;
    for x in 0..2 {
        let s = fs[x];
        let k = s.n;
        let (xv, rho, n1, m) = (ends[x], rho[x], n1[x], m[x]);
        if m == 0 || n1 + m + 2 > k {
            return Err(format!(
                "edge split: n1 = {n1}, m = {m} do not fit the {k} faces of vertex {xv}"
            ));
        }
        // `(rho + i) mod k`: `rho < k`, `i < k`.
        let wrap = |i: usize| if rho + i < k { rho + i } else { rho + i - k };
        let sh = shared[x];
        // The new vertices' blocks: where the sector faces had `X` (at
        // most `k - 2 <= 5` and `k - 1 <= 6` corners, with `u2`'s in the
        // last fan quad below: within a block; the `& 7` only spare the
        // bounds checks).
        let (b1, b2) = (
            2 + (pv[2 * x] & 3) as usize,
            2 + (pv[2 * x + 1] & 3) as usize,
        );
        for i in 0..=n1 {
            let w = wrap(i) & 7;
            blocks[b1][(1 + i) & 7] = s.c[w];
            if sh & (1 << w) == 0 {
                sector_face(st, s, w, pv[2 * x], pred, sec, &mut ns);
            }
        }
        blocks[b1][0] = n1 as u32 + 1;
        let mut nb2 = 0usize;
        for i in n1 + m + 1..k {
            let w = wrap(i) & 7;
            nb2 += 1;
            blocks[b2][nb2 & 7] = s.c[w];
            if sh & (1 << w) == 0 {
                sector_face(st, s, w, pv[2 * x + 1], pred, sec, &mut ns);
            }
        }
        let lam = |i: usize| s.nx[wrap(i)];
        // Corner opposite X in fan face j (P_{2j+1}): the corner id gives
        // X's place in the quad.
        let opp = |j: usize| {
            let c = s.c[wrap(n1 + 1 + j)];
            quads[(c >> 2) as usize][(c as usize + 2) & 3]
        };
        let mut o = opp(0);
        tri[x] = [xv, u(2 * x), lam(n1 + 1), o];
        for j in 0..m {
            let w = wrap(n1 + 1 + j) & 7;
            let fq = if j + 1 < m {
                let o2 = opp(j + 1);
                // Only a fan quad before the last can repeat a corner: its
                // `o` and `o2` are the far corners of two faces, which may
                // be one vertex. Every other pair of its corners, and of
                // the last fan quad's `[X, o, l, u2]`, is two corners of
                // one stored quad (`lam(n1 + 2 + j)`, the next face's
                // `nx`, is this face's `pv`), `X` and a corner of a quad
                // of `X`, or a new vertex: distinct.
                bad[x] |= ((o == o2) as u32) << w;
                let fq = [xv, o, lam(n1 + 2 + j), o2];
                o = o2;
                fq
            } else {
                let l = lam(n1 + 1 + m);
                pred.add_single(q, pv[2 * x + 1] as usize, xv, o, l);
                [xv, o, l, u(2 * x + 1)]
            };
            let t = *rots.get(rot_i).ok_or("edge split: too few fan rotations")?;
            rot_i += 1;
            let fq = rotl(fq, t);
            // `X` is corner 0 of the fan quad before its rotation (`u2`
            // corner 3 of the last): after it, corner `-t` (`3 - t`).
            let c = s.c[w];
            let kx = 0u32.wrapping_sub(t as u32) & 3;
            blocks[x][(1 + j) & 7] = c & !3 | kx;
            // The other changed corners: the fan's far vertices, linked
            // and unlinked one by one (`apply_edge_split_parts`).
            let changed = !eq_mask4x4(&quads[(c >> 2) as usize], &fq) & 15;
            let mut keep_new = 1 << kx;
            if j + 1 == m {
                let ku = 3u32.wrapping_sub(t as u32) & 3;
                nb2 += 1;
                blocks[b2][nb2 & 7] = c & !3 | ku;
                keep_new |= 1 << ku;
            }
            rw[n & (FAST_REWRITES - 1)] = (c >> 2, fq);
            masks[n & (FAST_REWRITES - 1)] =
                (changed & !(1 << (c & 3)) | (changed & !keep_new) << 4) as u8;
            n += 1;
        }
        blocks[x][0] = m as u32;
        blocks[b2][0] = nb2 as u32;
    }
    // The faces of both endpoints: refused where either has it as a fan
    // face; else two new corners, one per endpoint, and the parallelogram
    // goes to the larger once the smaller is decoded.
    for &(i0, i1) in &pairs[..np.min(8)] {
        let (i0, i1) = (i0 as usize, i1 as usize);
        let (c0, c1) = (fs[0].c[i0 & 7], fs[1].c[i1 & 7]);
        // The sector of each endpoint (`U_{2x}` or `U_{2x+1}`) from the
        // position relative to `rho`; `None` in the fan.
        let role = |x: usize, i: usize| {
            let k = fs[x].n;
            let rel = if i >= rho[x] {
                i - rho[x]
            } else {
                i + k - rho[x]
            };
            if rel <= n1[x] {
                Some(2 * x)
            } else if rel <= n1[x] + m[x] {
                None
            } else {
                Some(2 * x + 1)
            }
        };
        let (Some(r0), Some(r1)) = (role(0, i0), role(1, i1)) else {
            return Err(format!(
                "edge split: slot {} is a fan face and a face of the other endpoint",
                c1 >> 2
            ));
        };
        let slot = c1 >> 2;
        let (k0, k1) = ((c0 & 3) as usize, (c1 & 3) as usize);
        let mut qd = quads[slot as usize];
        qd[k0] = u(r0);
        qd[k1] = u(r1);
        let (kb, best) = if pv[r0] > pv[r1] {
            (k0, pv[r0])
        } else {
            (k1, pv[r1])
        };
        // At most `INLINE` such faces and the two below: within
        // `ONE_PASS_DEFERRED`.
        pred.defer_at(&qd, kb, best as usize);
        // Two distinct corners of a stored quad replaced by two distinct
        // new vertices: still four distinct corners.
        rw[n & (FAST_REWRITES - 1)] = (slot, qd);
        masks[n & (FAST_REWRITES - 1)] = 0;
        n += 1;
    }
    if bad != [0, 0] {
        return Err(repeated_fan_corner(st, fs, bad));
    }
    let [x0, x1] = ends;
    let canon = [[x0, u(1), u(2), x1], [x0, x1, u(3), u(0)], tri[0], tri[1]];
    // As in `build`.
    let later = |a: usize, b: usize| if pv[a] > pv[b] { (1, a) } else { (0, b) };
    let (d0, t0) = later(1, 2);
    pred.defer_at(&canon[0], 2 - d0, pv[t0] as usize);
    let (d1, t1) = later(3, 0);
    pred.defer_at(&canon[1], 3 - d1, pv[t1] as usize);
    for x in 0..2 {
        let [xv, _, l, o] = tri[x];
        pred.add_single(q, pv[2 * x] as usize, l, o, xv);
    }
    // No `check_distinct` (`build` checks them, and they always pass):
    // `C_0` and `C_1` are the two distinct endpoints and two distinct new
    // vertices; `T_x = [X, U_2x, l, o]` has `l` and `o`, the next and far
    // corners of `X` in one stored quad, and a new vertex.
    for (i, cq) in canon.into_iter().enumerate() {
        app[pf[i] as usize] = rotl(cq, (ra >> (2 * i)) & 3);
    }
    Ok((n, ns))
}

/// [`build_fast`]'s sector face at star position `w` of an endpoint `X`
/// (star `s`), a face of that endpoint only: `X` (corner `s.c[w]`)
/// becomes new vertex `t` (index from `V`), into `sec[*ns]`. Its
/// parallelogram is the face's other corners: `X`'s next (`nx`) and
/// previous — the next position's `nx` (the star's walk makes each
/// face's `pv` its successor's `nx`) — and its far corner. (Always
/// inlined: as a closure it was a call.)
#[inline(always)]
fn sector_face(
    st: &MeshState,
    s: &FastStar,
    w: usize,
    t: u8,
    pred: &mut OnePass,
    sec: &mut [(u32, u32); FAST_REWRITES],
    ns: &mut usize,
) {
    let c = s.c[w & 7];
    let far = st.quads[(c >> 2) as usize][(c as usize + 2) & 3];
    let e = s.nx[(if w + 1 < s.n { w + 1 } else { 0 }) & 7];
    pred.add_single(&st.q, t as usize, s.nx[w & 7], far, e);
    // (Each star face is in `rw` or `sec` once at most.)
    sec[*ns & (FAST_REWRITES - 1)] = (c, st.q.len() as u32 + t as u32);
    *ns += 1;
}

/// [`build_fast`]'s error for a fan quad that repeats a corner, `bad[x]`
/// its star positions per endpoint: the first in star order, `X0`'s
/// first, as `check_distinct` names it (the repeated vertex is the far
/// corner of the face and of the next one).
#[cold]
#[inline(never)]
fn repeated_fan_corner(st: &MeshState, fs: [&FastStar; 2], bad: [u32; 2]) -> String {
    let x = (bad[0] == 0) as usize;
    let c = fs[x].c[bad[x].trailing_zeros() as usize & 7];
    let far = st.quads[(c >> 2) as usize][(c as usize + 2) & 3];
    format!("edge split: rewritten slot {} repeats vertex {far}", c >> 2)
}

/// Rotation `t` with `rotl(q, t) == want`.
fn rotation(q: [u32; 4], want: [u32; 4]) -> Option<u8> {
    (0..4u8).find(|&t| rotl(q, t) == want)
}

/// The edge-split fields that reproduce `r` exactly (spec §7.10), with the
/// endpoint whose `refs` delta from `cursor` is shorter as the anchor;
/// `None` when `r` is not such a record (not 4 new vertices and 4 appended
/// quads with nothing moved, a boundary endpoint, a fan over the crossing
/// side, …). Checked by rebuilding with [`build`].
pub fn derive(st: &MeshState, r: &QRecord, cursor: u32, sc: &mut Scratch) -> Option<EdgeSplit> {
    let v0 = st.q.len() as u32;
    if r.new_pos.len() != 4 || r.appended.len() != 4 || !r.moved.is_empty() {
        return None;
    }
    // The endpoints are the old vertices of three appended quads (C_0, C_1
    // and their own corner quad); other old corners are in one.
    let mut cand = [0u32; 16];
    let mut n = 0;
    for q in &r.appended {
        for &v in q {
            if v < v0
                && !cand[..n].contains(&v)
                && r.appended.iter().filter(|p| p.contains(&v)).count() >= 3
            {
                cand[n] = v;
                n += 1;
            }
        }
    }
    if n != 2 {
        return None;
    }
    let (x0, x1) = (cand[0].min(cand[1]), cand[0].max(cand[1]));
    // Stars with X0 as the anchor (the fields do not depend on it).
    anchor_star(st, x0, sc).ok()?;
    let r0 = sc.stars[0].link.iter().position(|&v| v == x1)?;
    let (ends, rho) = stars(st, x0, r0, sc).ok()?;
    let new_of = |slot: u32| -> Option<[u32; 4]> {
        r.rewritten
            .binary_search_by_key(&slot, |w| w.0)
            .ok()
            .map(|i| r.rewritten[i].1)
    };
    let (mut n1, mut m) = ([0usize; 2], [0usize; 2]);
    let mut pv = [u8::MAX; 4];
    let mut rots = Vec::new();
    for x in 0..2 {
        let s = &sc.stars[x];
        let k = s.faces.len();
        let xv = ends[x];
        let g = |i: usize| s.faces[(rho[x] + i) % k];
        // Fan faces keep X; sector faces lose it to a new vertex.
        let mut keeps = [false; 255];
        for (i, kp) in keeps.iter_mut().enumerate().take(k) {
            *kp = new_of(g(i))?.contains(&xv);
        }
        let first = (0..k).find(|&i| keeps[i])?;
        let len = (first..k).take_while(|&i| keeps[i]).count();
        if first == 0 || first + len >= k || keeps[first + len..k].iter().any(|&b| b) {
            return None;
        }
        n1[x] = first - 1;
        m[x] = len;
        // u1 / u2 replace X in g_0 / g_{K-1}, which keep their corner order.
        for (i, t) in [(0, 2 * x), (k - 1, 2 * x + 1)] {
            let old = st.quads[g(i) as usize];
            let c = old.iter().position(|&v| v == xv)?;
            let id = new_of(g(i))?[c];
            if id < v0 || id >= v0 + 4 {
                return None;
            }
            pv[t] = (id - v0) as u8;
        }
    }
    let pvn = PERMS.iter().position(|p| *p == pv)?;
    // Fan rotations and the appended order: rebuild with rotation 0 and
    // identity π_f, then read them off.
    let zero = vec![0u8; m[0] + m[1]];
    let mut canon = QRecord::default();
    build(st, ends, rho, n1, m, 24 * pvn, 0, &zero, sc, &mut canon).ok()?;
    if canon.rewritten.len() != r.rewritten.len() {
        return None;
    }
    // Fan slots in the order `build` reads their rotations.
    sc.fan_slots.clear();
    for x in 0..2 {
        let s = &sc.stars[x];
        let k = s.faces.len();
        for j in 0..m[x] {
            let slot = s.faces[(rho[x] + n1[x] + 1 + j) % k];
            let i = canon.rewritten.binary_search_by_key(&slot, |w| w.0).ok()?;
            rots.push(rotation(canon.rewritten[i].1, new_of(slot)?)?);
            sc.fan_slots.push(slot);
        }
    }
    let mut pf = [u8::MAX; 4];
    let mut ra = 0u8;
    for (i, &q) in canon.appended.iter().enumerate() {
        let (j, t) = (0..4).find_map(|j| {
            (!pf.contains(&(j as u8)))
                .then(|| rotation(q, r.appended[j]).map(|t| (j, t)))
                .flatten()
        })?;
        pf[i] = j as u8;
        ra |= t << (2 * i);
    }
    let pfn = PERMS.iter().position(|p| *p == pf)?;
    let p = 24 * pvn + pfn;
    // Anchor: the endpoint with the shorter delta.
    let dist = |v: u32| (v as i64 - cursor as i64).unsigned_abs();
    let a = if dist(ends[1]) < dist(ends[0]) {
        ends[1]
    } else {
        ends[0]
    };
    let ra_link = if a == ends[0] { rho[0] } else { rho[1] };
    let e = EdgeSplit {
        a,
        r: ra_link,
        n1,
        m,
        p,
        ra,
        rots,
    };
    // The proof: the decoder's path on these fields gives `r` exactly.
    anchor_star(st, e.a, sc).ok()?;
    let (ends2, rho2) = stars(st, e.a, e.r, sc).ok()?;
    build(
        st, ends2, rho2, e.n1, e.m, e.p, e.ra, &e.rots, sc, &mut canon,
    )
    .ok()?;
    (ends2 == ends && canon.rewritten == r.rewritten && canon.appended == r.appended).then_some(e)
}
