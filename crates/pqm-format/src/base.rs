//! The base mesh section's payload (spec §6): the delta layout of versions
//! 1–3 and, from version 4, a layout byte and the traversal layout (§6.1).
//!
//! The traversal layout codes the faces in slot order as a breadth-first
//! walk across edges: a face attached to an open edge of an earlier face
//! costs a gate byte (its rotation) and two corner symbols, each mostly
//! "a new vertex" or "the vertex that closes the fan" — a few bits per
//! face where the delta layout spends 20–30 bits per base vertex. The
//! positions follow in id order, each predicted by §7.6's version-4
//! stencil over the base faces whose other corners come earlier.
//!
//! Invariants a decoded traversal base keeps (checked, else the payload
//! is invalid): every face has 4 distinct corners, no half-edge is in two
//! faces, no vertex is in more than [`MAX_FACES_PER_VERTEX`] faces, every
//! vertex is in a face, and vertex ids are in the walk's order of first
//! appearance.

use crate::codec::{self, MeshState};
use crate::varint::{put_s, put_u, Reader};

/// Layout byte (version ≥ 4): the delta layout follows.
pub const LAYOUT_DELTA: u8 = 0;
/// Layout byte (version ≥ 4): the traversal layout (§6.1) follows.
pub const LAYOUT_TRAVERSAL: u8 = 1;
/// Most faces one vertex may be in, in the traversal layout: bounds the
/// per-vertex lists a decoder scans (spec §6.1).
pub const MAX_FACES_PER_VERTEX: usize = 255;

/// How a base section is coded (spec §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseLayout {
    /// Corner and code deltas (every version; from 4.0 behind layout byte 0).
    Delta,
    /// The walk across edges of §6.1 (layout byte 1, version 4).
    Traversal,
}

/// The layout of a decompressed base payload of a file of major version
/// `major` (what its first byte says from version 4 on; an unknown byte
/// is the decoder's error to report, so it reads as `Delta` here).
pub fn layout_of(payload: &[u8], major: u16) -> BaseLayout {
    if major >= 4 && payload.first() == Some(&LAYOUT_TRAVERSAL) {
        BaseLayout::Traversal
    } else {
        BaseLayout::Delta
    }
}

/// A candidate payload for the base section and the offsets where a writer
/// may end a zstd block (after each part whose statistics differ).
pub struct BasePayload {
    pub payload: Vec<u8>,
    pub cuts: Vec<usize>,
}

/// The delta layout (§6) — for `major ≥ 4` behind the layout byte.
pub fn encode_delta(q: &[[u32; 3]], quads: &[[u32; 4]], major: u16) -> BasePayload {
    let mut payload = Vec::new();
    if major >= 4 {
        payload.push(LAYOUT_DELTA);
    }
    let head = payload.len();
    payload.extend_from_slice(&codec::encode_base(q, quads));
    // the corner deltas and the code deltas in blocks of their own, if
    // that pays (the writer's `compress_best` chooses)
    let faces_len = head + codec::encode_base(&[], quads).len();
    let mut cuts = Vec::new();
    if head < faces_len && faces_len < payload.len() {
        cuts.push(faces_len);
    }
    BasePayload { payload, cuts }
}

/// Decoded half-edges around each vertex, with whether each one's reverse
/// is decoded too (the walk's open edges are those whose reverse is not).
/// Flat arrays: half-edge `4 f + t` is face `f`'s `g[t] → g[t + 1]`, and
/// each vertex lists its outgoing half-edges in decode order (linked
/// through `next_out`); no allocation per vertex.
///
/// There is no list of incoming half-edges: a face holds its vertex `v`
/// once, so the half-edge entering `v` in face `f` is the one before the
/// half-edge leaving it (`4 f + k` leaves `v`, `4 f + (k + 3) mod 4`
/// enters it), and `v`'s outgoing list, in decode order, gives its
/// incoming half-edges in decode order too: one list kept up per corner
/// instead of two.
struct HalfEdges {
    /// Half-edge `4 f + t`, for the faces decoded so far (pushed a face
    /// at a time into room for `cap`: no entry written before its face).
    he: Vec<HalfEdge>,
    cap: usize,
    /// Per vertex: its outgoing list's ends, its face count and its list
    /// of the faces whose largest corner it is.
    at: Vec<VertexLists>,
    /// Per face: the next corner in its largest corner's `top` list.
    next_top: Vec<u32>,
}

#[derive(Clone, Copy)]
struct HalfEdge {
    src: u32,
    dst: u32,
    next_out: u32,
    /// The reverse half-edge is not decoded (yet).
    open: bool,
}

const NIL: u32 = u32::MAX;

/// Which candidate list a corner symbol may name (spec §6.1).
#[derive(Clone, Copy)]
enum Cands {
    /// A component start's corner: none.
    None,
    /// `X`: the open half-edges into `a`.
    Into(u32),
    /// `Y`: the open half-edges out of `b`.
    OutOf(u32),
}

/// What a corner symbol tells of its vertex besides its id: what
/// [`HalfEdges::add_across`] needs to know instead of walking lists.
#[derive(Clone, Copy)]
enum Named {
    /// A new vertex (`0`): in no decoded half-edge.
    New,
    /// A candidate: the open half-edge of its list (`x → a` for `X`,
    /// `b → y` for `Y`).
    Open(u32),
    /// An escape (or a component start's corner): nothing known.
    Other,
}

/// First and last outgoing half-edge of a vertex ([`NIL`]: none), the
/// faces decoded around it, and the first of its corners `4 f + k` where it
/// is face `f`'s largest corner ([`NIL`]: none; linked through
/// `next_top`).
#[derive(Clone, Copy)]
struct VertexLists {
    out: [u32; 2],
    faces: u32,
    top: u32,
}

/// The half-edge entering the corner that half-edge `e` leaves (the one
/// before it in its face).
#[inline(always)]
fn entering(e: u32) -> u32 {
    (e & !3) | (e.wrapping_add(3) & 3)
}

impl HalfEdges {
    fn new(nv: usize, nf: usize) -> Self {
        HalfEdges {
            he: Vec::with_capacity(4 * nf),
            cap: 4 * nf,
            at: vec![
                VertexLists {
                    out: [NIL; 2],
                    faces: 0,
                    top: NIL,
                };
                nv
            ],
            next_top: Vec::with_capacity(nf),
        }
    }

    /// Whether the reverse of decoded half-edge `e` (face `e / 4`'s corner
    /// `e % 4` to the next) is decoded: O(1), no list walked.
    fn closed(&self, e: usize) -> bool {
        !self.he[e].open
    }

    /// `(u, v)` of decoded half-edge `e` (`u → v`) if it is open (its
    /// reverse not decoded).
    #[inline(always)]
    fn open_ends(&self, e: usize) -> Option<(u32, u32)> {
        let h = self.he[e];
        h.open.then_some((h.src, h.dst))
    }

    /// The decoded half-edge `u → v`, if any.
    fn find(&self, u: u32, v: u32) -> Option<u32> {
        let mut e = self.at[u as usize].out[0];
        while e != NIL {
            let h = self.he[e as usize];
            if h.dst == v {
                return Some(e);
            }
            e = h.next_out;
        }
        None
    }

    /// Adds face `g`'s half-edges (as half-edges `4 f .. 4 f + 4` of the
    /// `f`-th face added); `Err` names the problem. Inlined: out of line,
    /// the address of `self` it took kept the decoder's `HalfEdges` in
    /// memory, its arrays' pointers and lengths loaded again around every
    /// store of the walk, while it runs for about one face in ten
    /// (makehuman's base: 422 of 3,987).
    #[inline(always)]
    fn add_face(&mut self, g: [u32; 4]) -> Result<(), String> {
        // One walk of each corner's outgoing list finds both what would be
        // a repeat of the face's half-edge leaving it (`g[t] → g[t + 1]`)
        // and the reverse of the one entering it (`g[t] → g[t − 1]`).
        let mut rev = [NIL; 4];
        for t in 0..4 {
            let (w, next, prev) = (g[t], g[(t + 1) & 3], g[(t + 3) & 3]);
            let at = self.at[w as usize];
            if at.faces as usize >= MAX_FACES_PER_VERTEX {
                return Err(crowded(w));
            }
            let mut e = at.out[0];
            while e != NIL {
                let h = self.he[e as usize];
                if h.dst == next {
                    return Err(repeated(w, next));
                }
                if h.dst == prev {
                    // the reverse of `prev → w`, the face's half-edge t − 1
                    rev[(t + 3) & 3] = e;
                }
                e = h.next_out;
            }
        }
        self.link::<false>(&g, rev)
    }

    /// [`add_face`](Self::add_face) for a face `g` coded across the open
    /// half-edge `gate` (`a → b`): `g[r] = b`, `g[r + 1] = a`, and `x =
    /// g[r + 2]`, `y = g[r + 3]` named as `x` and `y` say. The same
    /// checks and the same result, with what the lists would be walked
    /// for known from how the corners were named:
    ///
    /// * `b → a` is no repeat (`a → b` is open) and its reverse is `gate`;
    /// * `a → x` is no repeat and has no reverse if `x` is new, and if `x`
    ///   is a candidate `x → a` is open (so `a → x` is not decoded) and is
    ///   its reverse; likewise `y → b` with `b → y`;
    /// * `x → y` is no repeat and has no reverse if either is new; if both
    ///   are candidates, two lists are walked as `add_face` would.
    ///
    /// Anything else (an escape, a repeat) is left to `add_face`, so that
    /// an error is the one it reports. A crowded corner is found by
    /// [`link`](Self::link) as it counts the face in (no repeat being
    /// possible by then, `add_face`'s error would be that of the first
    /// crowded corner, as `link`'s is): four loads and tests fewer than
    /// testing the corners first. The face is then half linked, which does
    /// not matter: the error ends the decode.
    ///
    /// `g` by reference (and so to [`link`](Self::link)): taken by value it
    /// was copied whole, a 16-byte load right after the decoder's four
    /// 4-byte stores of it at variable places, which stalls until they
    /// leave the store buffer (no store forwarding across stores).
    fn add_across(
        &mut self,
        g: &[u32; 4],
        r: usize,
        gate: u32,
        x: Named,
        y: Named,
    ) -> Result<(), String> {
        let (ta, tx, ty) = ((r + 1) & 3, (r + 2) & 3, (r + 3) & 3);
        let mut rev = [NIL; 4];
        rev[r] = gate;
        match (x, y) {
            (Named::Other, _) | (_, Named::Other) => return self.add_face(*g),
            (Named::Open(ex), Named::Open(ey)) => {
                rev[ta] = ex;
                rev[ty] = ey;
                if self.find(g[tx], g[ty]).is_some() {
                    return self.add_face(*g);
                }
                if let Some(e) = self.find(g[ty], g[tx]) {
                    rev[tx] = e;
                }
            }
            (Named::Open(ex), Named::New) => rev[ta] = ex,
            (Named::New, Named::Open(ey)) => rev[ty] = ey,
            (Named::New, Named::New) => {}
        }
        self.link::<true>(g, rev)
    }

    /// Appends face `g`'s half-edges, `rev[t]` the decoded reverse of its
    /// half-edge `t` ([`NIL`]: none), which the caller has checked are no
    /// repeats. Its corners are in fewer than the most faces: checked by
    /// the caller, or with `CROWDED` here, where an error leaves the face
    /// half linked (the caller's decode ends with it).
    #[inline(always)]
    fn link<const CROWDED: bool>(&mut self, g: &[u32; 4], rev: [u32; 4]) -> Result<(), String> {
        let first = self.he.len();
        if first + 4 > self.cap {
            return Err("more faces than the base has".into());
        }
        // the face's largest corner (its corners are distinct): the one
        // vertex whose prediction takes the face's parallelogram term
        let k01 = (g[1] > g[0]) as usize;
        let k23 = 2 + (g[3] > g[2]) as usize;
        let k = if g[k23] > g[k01] { k23 } else { k01 };
        let top = &mut self.at[g[k] as usize].top;
        self.next_top.push(*top);
        *top = (first + k) as u32;
        let new = |t: usize| HalfEdge {
            src: g[t],
            dst: g[(t + 1) & 3],
            next_out: NIL,
            open: rev[t] == NIL,
        };
        self.he.extend_from_slice(&[new(0), new(1), new(2), new(3)]);
        // as slices: a `Vec`'s pointer and length were loaded again after
        // every store through it (a store might have changed them)
        let (he, at) = (&mut self.he[..], &mut self.at[..]);
        for t in 0..4 {
            if rev[t] != NIL {
                he[rev[t] as usize].open = false;
            }
            let e = (first + t) as u32;
            let au = &mut at[g[t] as usize];
            if CROWDED && au.faces as usize >= MAX_FACES_PER_VERTEX {
                return Err(crowded(g[t]));
            }
            au.faces += 1;
            let out_last = au.out[1];
            au.out[1] = e;
            if out_last == NIL {
                au.out[0] = e;
            } else {
                he[out_last as usize].next_out = e;
            }
        }
        Ok(())
    }

    /// The half-edges leaving `v` (as `4 f + k`: `v` is face `f`'s corner `k`).
    #[inline(always)]
    fn out_corners(&self, v: u32) -> impl Iterator<Item = u32> + Clone + '_ {
        let mut e = self.at[v as usize].out[0];
        std::iter::from_fn(move || {
            (e != NIL).then(|| {
                let here = e;
                e = self.he[e as usize].next_out;
                here
            })
        })
    }

    /// `X` of §6.1: the sources `w` of the open half-edges `w → a`, in
    /// decode order, each with that half-edge (a decoder takes the one a
    /// symbol names, a writer looks for its vertex: neither builds the
    /// list). Walks `a`'s outgoing list for its incoming half-edges.
    fn open_into(&self, a: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let mut e = self.at[a as usize].out[0];
        std::iter::from_fn(move || {
            while e != NIL {
                let i = entering(e);
                e = self.he[e as usize].next_out;
                let h = self.he[i as usize];
                if h.open {
                    return Some((h.src, i));
                }
            }
            None
        })
    }

    /// Entry `nth` of [`open_into`](Self::open_into): the same walk as a
    /// loop of its own (the iterator's closure was a call per entry).
    #[inline(always)]
    fn nth_open_into(&self, a: u32, mut nth: usize) -> Option<(u32, u32)> {
        let mut e = self.at[a as usize].out[0];
        while e != NIL {
            let i = entering(e);
            let h = self.he[i as usize];
            if h.open {
                if nth == 0 {
                    return Some((h.src, i));
                }
                nth -= 1;
            }
            e = self.he[e as usize].next_out;
        }
        None
    }

    /// Entry `nth` of [`open_out_of`](Self::open_out_of), as a loop.
    #[inline(always)]
    fn nth_open_out_of(&self, b: u32, mut nth: usize) -> Option<(u32, u32)> {
        let mut e = self.at[b as usize].out[0];
        while e != NIL {
            let h = self.he[e as usize];
            if h.open {
                if nth == 0 {
                    return Some((h.dst, e));
                }
                nth -= 1;
            }
            e = h.next_out;
        }
        None
    }

    /// `Y` of §6.1: the targets `z` of the open half-edges `b → z`, in
    /// decode order, each with that half-edge.
    fn open_out_of(&self, b: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let mut e = self.at[b as usize].out[0];
        std::iter::from_fn(move || {
            while e != NIL {
                let here = e;
                let h = self.he[e as usize];
                e = h.next_out;
                if h.open {
                    return Some((h.dst, here));
                }
            }
            None
        })
    }
}

#[cold]
fn crowded(v: u32) -> String {
    format!("vertex {v} is in more than {MAX_FACES_PER_VERTEX} faces")
}

#[cold]
fn repeated(u: u32, v: u32) -> String {
    format!("half-edge {u} -> {v} is in two faces")
}

/// The rotation `r` with `g[r] = b` and `g[r + 1] = a`, if `g` holds the
/// half-edge `b → a`.
fn across(g: &[u32; 4], a: u32, b: u32) -> Option<usize> {
    (0..4).find(|&r| g[r] == b && g[(r + 1) & 3] == a)
}

/// The traversal layout (§6.1) of a base, or `None` when the base cannot
/// be written in it (a vertex in no face or in too many, a half-edge in
/// two faces, ids not in the walk's order of first appearance).
pub fn encode_traversal(q: &[[u32; 3]], quads: &[[u32; 4]], qmax: u32) -> Option<BasePayload> {
    let nv = q.len();
    let nf = quads.len();
    let mut he = HalfEdges::new(nv, nf);
    let (mut gates, mut corners, mut escapes) = (Vec::new(), Vec::new(), Vec::new());
    let mut s = 0u32;
    // One corner symbol, `cand` the index of `v` among the symbol's
    // candidates if it is one of the first 254; `None` when `v` comes
    // before its turn (or is no vertex at all).
    let mut corner = |v: u32, cand: Option<usize>, s: &mut u32| -> Option<()> {
        if v as usize >= nv {
            return None;
        }
        if v == *s {
            corners.push(0);
            *s += 1;
        } else if v > *s {
            return None;
        } else if let Some(i) = cand {
            corners.push(1 + i as u8);
        } else {
            corners.push(255);
            put_u(&mut escapes, (*s - 1 - v) as u64);
        }
        Some(())
    };
    let (mut n, mut h) = (0usize, 0usize);
    while n < nf {
        if h == n {
            let g = quads[n];
            for &v in &g {
                corner(v, None, &mut s)?;
            }
            codec::check_distinct(&g, String::new).ok()?;
            he.add_face(g).ok()?;
            n += 1;
            continue;
        }
        let f = quads[h];
        h += 1;
        for k in 0..4 {
            if n >= nf {
                break;
            }
            let (a, b) = (f[k], f[(k + 1) & 3]);
            // face `h − 1`'s half-edge `a → b` is number 4 (h − 1) + k
            if he.closed(4 * (h - 1) + k) {
                continue;
            }
            let g = quads[n];
            match across(&g, a, b) {
                Some(r) => {
                    gates.push(1 + r as u8);
                    let (x, y) = (g[(r + 2) & 3], g[(r + 3) & 3]);
                    let cand = he.open_into(a).take(254).position(|(w, _)| w == x);
                    corner(x, cand, &mut s)?;
                    let cand = he.open_out_of(b).take(254).position(|(z, _)| z == y);
                    corner(y, cand, &mut s)?;
                    codec::check_distinct(&g, String::new).ok()?;
                    he.add_face(g).ok()?;
                    n += 1;
                }
                None => gates.push(0),
            }
        }
    }
    if s as usize != nv {
        return None;
    }
    // the prediction reads only the codes below `v`, as a decoder has them,
    // over `v`'s corners as the walk's half-edges list them (as it does)
    let mut pos = Vec::with_capacity(3 * nv);
    for v in 0..nv {
        let p = predict(v, q, quads, &he, qmax);
        for t in 0..3 {
            put_s(&mut pos, q[v][t] as i64 - p[t] as i64);
        }
    }
    let mut payload = vec![LAYOUT_TRAVERSAL];
    let mut cuts = Vec::new();
    for part in [&gates, &corners, &escapes, &pos] {
        put_u(&mut payload, part.len() as u64);
        payload.extend_from_slice(part);
        cuts.push(payload.len());
    }
    cuts.pop();
    Some(BasePayload { payload, cuts })
}

/// `P(v)` of §6.1 from the codes of the vertices before `v` (only those
/// are read: a decoder has no others), over `v`'s faces as `he` lists
/// them. Inlined into its loops: a call per vertex cost as much as a
/// face's terms.
///
/// A face's three other corners all come before `v` exactly when `v` is
/// its largest corner, so the faces of `S` and `c` are `v`'s `top` list
/// (each face in one vertex's list, built as faces are added): no test
/// per face, and no walk of `v`'s other faces unless `c = 0`.
#[inline(always)]
fn predict(v: usize, q: &[[u32; 3]], quads: &[[u32; 4]], he: &HalfEdges, qmax: u32) -> [u32; 3] {
    // as a slice of length `v`, the tests `< v` are its bounds checks too
    let q = &q[..v];
    let mut fk = he.at[v].top;
    if fk != NIL {
        // the records' stencil (§7.6 version 4): edge neighbours' and
        // opposite corners' sums
        let (mut nb, mut op, mut c) = ([0i64; 3], [0i64; 3], 0i64);
        while fk != NIL {
            let g = &quads[(fk >> 2) as usize];
            codec::add_stencil_corner(q, g, (fk & 3) as usize, &mut nb, &mut op);
            c += 1;
            fk = he.next_top[(fk >> 2) as usize];
        }
        return codec::stencil_mean_rule::<true>(nb, op, c, qmax);
    }
    // no face with three earlier corners: the earlier edge neighbours' mean
    let (mut esum, mut e) = ([0i64; 3], 0i64);
    for fk in he.out_corners(v as u32) {
        let g = quads[(fk >> 2) as usize];
        let k = (fk & 3) as usize;
        for u in [g[(k + 1) & 3] as usize, g[(k + 3) & 3] as usize] {
            if u < v {
                let a = q[u];
                esum[0] += a[0] as i64;
                esum[1] += a[1] as i64;
                esum[2] += a[2] as i64;
                e += 1;
            }
        }
    }
    if e > 0 {
        codec::floor_mean(esum, e, qmax)
    } else if v > 0 {
        q[v - 1]
    } else {
        [0; 3]
    }
}

/// Decodes a base payload of a file of major version `major` with `nv`
/// vertices and `nf` quads (spec §6).
pub fn decode(buf: &[u8], nv: u32, nf: u32, qmax: u32, major: u16) -> Result<MeshState, String> {
    decode_with::<true>(buf, nv, nf, qmax, major)
}

/// [`decode`] without its shortcuts: every face's half-edges found by
/// walking lists ([`HalfEdges::add_face`]). The same result and the same
/// errors as `decode` on any input; a test holds them to it.
#[doc(hidden)]
pub fn decode_reference(
    buf: &[u8],
    nv: u32,
    nf: u32,
    qmax: u32,
    major: u16,
) -> Result<MeshState, String> {
    decode_with::<false>(buf, nv, nf, qmax, major)
}

fn decode_with<const FAST: bool>(
    buf: &[u8],
    nv: u32,
    nf: u32,
    qmax: u32,
    major: u16,
) -> Result<MeshState, String> {
    if major < 4 {
        return codec::decode_base(buf, nv, nf, qmax);
    }
    match buf.first() {
        Some(&LAYOUT_DELTA) => codec::decode_base(&buf[1..], nv, nf, qmax),
        Some(&LAYOUT_TRAVERSAL) => decode_traversal::<FAST>(&buf[1..], nv, nf, qmax),
        Some(&l) => Err(format!("unknown base layout {l}")),
        None => Err("the base payload is empty (no layout byte)".into()),
    }
}

/// The streams a corner symbol reads, and `s` of §6.1.
struct CornerStreams<'a> {
    corners: Reader<'a>,
    escapes: Reader<'a>,
    s: u32,
    nv: u32,
}

impl CornerStreams<'_> {
    /// One corner symbol (§6.1) of face `face`: its vertex, and how it was
    /// named. The candidates are looked up only for a symbol that names
    /// one (most are "new").
    #[inline(always)]
    fn corner<const FAST: bool>(
        &mut self,
        he: &HalfEdges,
        cands: Cands,
        face: usize,
    ) -> Result<(u32, Named), String> {
        let sym = self.corners.byte()?;
        if sym == 0 {
            if self.s >= self.nv {
                return Err(all_seen(face, self.nv));
            }
            self.s += 1;
            return Ok((self.s - 1, Named::New));
        }
        self.named::<FAST>(he, cands, face, sym)
    }

    /// [`corner`](Self::corner) for a symbol other than "new": the walk
    /// for a candidate inlined (nearly every other symbol is one).
    #[inline(always)]
    fn named<const FAST: bool>(
        &mut self,
        he: &HalfEdges,
        cands: Cands,
        face: usize,
        sym: u8,
    ) -> Result<(u32, Named), String> {
        if sym == 255 {
            return escape(&mut self.escapes, self.s, face);
        }
        let nth = sym as usize - 1;
        match match cands {
            Cands::None => None,
            Cands::Into(a) if FAST => he.nth_open_into(a, nth),
            Cands::OutOf(b) if FAST => he.nth_open_out_of(b, nth),
            Cands::Into(a) => he.open_into(a).nth(nth),
            Cands::OutOf(b) => he.open_out_of(b).nth(nth),
        } {
            Some((v, e)) => Ok((v, Named::Open(e))),
            None => Err(too_few(face, sym)),
        }
    }
}

/// [`CornerStreams::corner`] for an escape, with `s` of §6.1. Out of line
/// with the escape stream alone: given the whole `CornerStreams`, its
/// address taken kept all of it in memory, its counters loaded and stored
/// again around every store of the walk.
#[inline(never)]
fn escape(escapes: &mut Reader, s: u32, face: usize) -> Result<(u32, Named), String> {
    let u = escapes.u()?;
    if u >= s as u64 {
        return Err(format!(
            "face {face} escapes to vertex {} before vertex 0",
            s as i64 - 1 - u.min(u32::MAX as u64) as i64
        ));
    }
    Ok((s - 1 - u as u32, Named::Other))
}

#[cold]
fn too_few(face: usize, sym: u8) -> String {
    format!("face {face} names candidate {sym}, a list has fewer (spec §6.1)")
}

#[cold]
fn all_seen(face: usize, nv: u32) -> String {
    format!("face {face} has a new vertex but all {nv} vertices are seen")
}

fn decode_traversal<const FAST: bool>(
    buf: &[u8],
    nv: u32,
    nf: u32,
    qmax: u32,
) -> Result<MeshState, String> {
    // Every vertex takes at least three bytes of `pos`, every face at
    // least two corner bytes: check the counts before allocating.
    if (nv as u64) * 3 + (nf as u64) * 2 > buf.len() as u64 {
        return Err(format!(
            "{nv} vertices and {nf} faces cannot fit in {} bytes",
            buf.len()
        ));
    }
    let mut r = Reader::new(buf, "base");
    let mut part = |name: &'static str| -> Result<Reader<'_>, String> {
        let len = r.u()?;
        let len = usize::try_from(len).map_err(|_| format!("{name}: {len} bytes"))?;
        let bytes = r.bytes(len)?;
        Ok(Reader::new(bytes, name))
    };
    let mut gates = part("base gates")?;
    let corners = part("base corners")?;
    let escapes = part("base escapes")?;
    let mut pos = part("base positions")?;
    if r.remaining() != 0 {
        return Err(format!(
            "{} bytes after the last base stream",
            r.remaining()
        ));
    }
    let nfu = nf as usize;
    let mut quads: Vec<[u32; 4]> = Vec::with_capacity(nfu);
    let mut he = HalfEdges::new(nv as usize, nfu);
    let mut cs = CornerStreams {
        corners,
        escapes,
        s: 0,
        nv,
    };
    let (mut n, mut h) = (0usize, 0usize);
    while n < nfu {
        if h == n {
            let mut g = [0u32; 4];
            for c in g.iter_mut() {
                *c = cs.corner::<FAST>(&he, Cands::None, n)?.0;
            }
            codec::check_distinct(&g, || format!("face {n}"))?;
            he.add_face(g).map_err(|m| format!("face {n}: {m}"))?;
            quads.push(g);
            n += 1;
            continue;
        }
        // The reference's walk reads the face's corners (unchanged since
        // it was written); the fast one the half-edge's ends (below).
        let f = if FAST { [0; 4] } else { quads[h] };
        h += 1;
        for k in 0..4 {
            if n >= nfu {
                break;
            }
            // face `h − 1`'s half-edge `a → b` (its corners `k`, `k + 1`)
            // is number 4 (h − 1) + k: `b → a` is decoded exactly when
            // that one is closed. The fast walk takes its ends from the
            // half-edge, loaded for the test anyway, rather than from a
            // copy of the face (the same vertices).
            let ab = 4 * (h - 1) + k;
            let (a, b) = if FAST {
                match he.open_ends(ab) {
                    Some(e) => e,
                    None => continue,
                }
            } else {
                if he.closed(ab) {
                    continue;
                }
                (f[k], f[(k + 1) & 3])
            };
            let gate = gates.byte()?;
            match gate {
                0 => {}
                1..=4 => {
                    let r = (gate - 1) as usize;
                    let (x, nx) = cs.corner::<FAST>(&he, Cands::Into(a), n)?;
                    let (y, ny) = cs.corner::<FAST>(&he, Cands::OutOf(b), n)?;
                    let mut g = [0u32; 4];
                    g[r] = b;
                    g[(r + 1) & 3] = a;
                    g[(r + 2) & 3] = x;
                    g[(r + 3) & 3] = y;
                    // `a ≠ b` (an edge of a face); a new `x` or `y` is none
                    // of the others; a candidate `x` (`x → a` open) is not
                    // `a`, nor `b` (`b → a` is not decoded, `a → b` being
                    // open), and likewise a candidate `y` (`b → y` open):
                    // only two candidates may be equal, and an escape may
                    // be anything
                    let distinct = FAST
                        && match (nx, ny) {
                            (Named::Open(_), Named::Open(_)) => x != y,
                            (Named::Other, _) | (_, Named::Other) => false,
                            _ => true,
                        };
                    if !distinct {
                        codec::check_distinct(&g, || format!("face {n}"))?;
                    }
                    if FAST {
                        he.add_across(&g, r, ab as u32, nx, ny)
                    } else {
                        he.add_face(g)
                    }
                    .map_err(|m| format!("face {n}: {m}"))?;
                    quads.push(g);
                    n += 1;
                }
                _ => return Err(format!("gate byte {gate} before face {n} (spec §6.1)")),
            }
        }
    }
    if cs.s != nv {
        return Err(format!("the faces use {} of the {nv} base vertices", cs.s));
    }
    for (rd, name) in [
        (&gates, "gates"),
        (&cs.corners, "corners"),
        (&cs.escapes, "escapes"),
    ] {
        if rd.remaining() != 0 {
            return Err(format!(
                "{} unused bytes in the base {name}",
                rd.remaining()
            ));
        }
    }
    // Each vertex's outgoing half-edges are its corners: half-edge
    // `4 f + k` leaves face `f`'s corner `k`.
    let mut q: Vec<[u32; 3]> = Vec::with_capacity(nv as usize);
    for v in 0..nv as usize {
        let p = predict(v, &q, &quads, &he, qmax);
        let code = codec::add_residual(p, &mut pos, qmax)?;
        q.push(code);
    }
    if pos.remaining() != 0 {
        return Err(format!(
            "{} unused bytes in the base positions",
            pos.remaining()
        ));
    }
    Ok(MeshState::new(qmax, q, quads))
}

#[cfg(test)]
mod tests {
    use super::{predict, HalfEdges};

    /// `P(v)` as §6.1 words it: every face holding `v`, tested for three
    /// earlier corners.
    fn predict_as_specified(v: usize, q: &[[u32; 3]], quads: &[[u32; 4]], qmax: u32) -> [u32; 3] {
        let (mut s, mut c, mut es, mut e) = ([0i64; 3], 0i64, [0i64; 3], 0i64);
        for g in quads {
            let Some(k) = g.iter().position(|&w| w as usize == v) else {
                continue;
            };
            let [n1, o, n3] = [1, 2, 3].map(|d| g[(k + d) & 3] as usize);
            if n1 < v && o < v && n3 < v {
                for t in 0..3 {
                    s[t] += 5 * (q[n1][t] as i64 + q[n3][t] as i64) - 2 * q[o][t] as i64;
                }
                c += 1;
            }
            for u in [n1, n3] {
                if u < v {
                    for t in 0..3 {
                        es[t] += q[u][t] as i64;
                    }
                    e += 1;
                }
            }
        }
        let clamp = |x: i64| x.clamp(0, qmax as i64) as u32;
        if c > 0 {
            s.map(|x| clamp(x.div_euclid(8 * c)))
        } else if e > 0 {
            es.map(|x| clamp(x.div_euclid(e)))
        } else if v > 0 {
            q[v - 1]
        } else {
            [0; 3]
        }
    }

    /// `predict` (the faces of `S` from each vertex's list of the faces
    /// whose largest corner it is) is §6.1's `P(v)`, on grids with ids and
    /// face order shuffled.
    #[test]
    fn predict_is_as_specified() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        for round in 0..60 {
            let (w, h) = (2 + round % 5, 1 + round % 4);
            let nv = (w + 1) * (h + 1);
            let mut id: Vec<u32> = (0..nv as u32).collect();
            for i in (1..nv).rev() {
                id.swap(i, rnd(i as u64 + 1) as usize);
            }
            let mut quads: Vec<[u32; 4]> = (0..w * h)
                .map(|f| {
                    let (i, j) = (f % w, f / w);
                    let c = |i: usize, j: usize| id[j * (w + 1) + i];
                    [c(i, j), c(i + 1, j), c(i + 1, j + 1), c(i, j + 1)]
                })
                .collect();
            for i in (1..quads.len()).rev() {
                quads.swap(i, rnd(i as u64 + 1) as usize);
            }
            let qmax = 1 + rnd(5000) as u32;
            let q: Vec<[u32; 3]> = (0..nv)
                .map(|_| [0; 3].map(|_: u32| rnd(qmax as u64 + 1) as u32))
                .collect();
            let mut he = HalfEdges::new(nv, quads.len());
            for &g in &quads {
                he.add_face(g).unwrap();
            }
            for v in 0..nv {
                assert_eq!(
                    predict(v, &q, &quads, &he, qmax),
                    predict_as_specified(v, &q, &quads, qmax),
                    "round {round} vertex {v}"
                );
            }
        }
    }
}
