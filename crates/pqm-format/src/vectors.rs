//! Test vectors of `spec/vectors/` (spec §11): how they are generated and
//! digested. Used by `examples/make_vectors.rs` (writes them) and by
//! `tests/vectors.rs` (regenerates them in memory and compares).

use crate::{write_to_vec, Decoder, EncodeOptions, Target};
use pqm_core::progressive::testgen::{generate_with, BaseShape, GenOptions, Rng};
use pqm_core::{OpKind, ProgressiveMesh, SplitRecord};
use std::fmt::Write as _;

/// One test vector: a file and the levels whose digests are recorded.
pub struct Vector {
    /// File stem (`NAME.pqm`, `NAME.json`, `NAME.levelK.obj`).
    pub name: &'static str,
    /// The encoded file.
    pub bytes: Vec<u8>,
    /// Levels recorded in the JSON digest (and as OBJ files).
    pub levels: Vec<usize>,
    /// Records per form: general, split, local, face split, edge split
    /// (spec §7.3).
    pub forms: [usize; 5],
}

/// Rotates the rewritten quads of every record by `(record + slot) mod 4`
/// corners (the same faces, another first corner), as the coarsener's
/// records do when it restores a face starting at another corner — what the
/// local form's rotation bits are for.
pub fn rotate_rewritten(pm: &mut ProgressiveMesh) {
    for (k, r) in pm.records.iter_mut().enumerate() {
        for (s, q) in r.rewritten.iter_mut() {
            let rot = (k + *s as usize) % 4;
            *q = [0, 1, 2, 3].map(|j| q[(j + rot) % 4]);
        }
    }
}

/// Appends `n` random **face splits** to `pm` as `Doublet` records — the
/// inverse of a doublet removal, the shape of spec §7.9: each cuts a random
/// quad of the finest level along a random diagonal `m–o` by a new vertex
/// `c` near the quad's centre, and stores the halves `(m, p, o, c)` and
/// `(m, c, o, q)` in a random order (which one keeps the slot) and random
/// rotations. A face split may cut a quad an earlier one made (so `c`
/// chains), and about one in five records also moves `m` (no longer a pure
/// face split: those fall back to the local or general form). Positions:
/// the centroid plus up to 15 % of the diagonal per axis, so predictions
/// are good but not exact. Deterministic in `seed`.
pub fn add_face_splits(pm: &mut ProgressiveMesh, n: usize, seed: u64) {
    let mut rng = Rng(seed ^ 0x5EED_FACE_5B11_7000);
    let (mut pos, mut quads) = pm.level_quads(pm.records.len());
    if quads.is_empty() {
        return;
    }
    for _ in 0..n {
        let s = rng.below(quads.len());
        let f = quads[s];
        let k = rng.below(4);
        let (m, p, o, q) = (f[k], f[(k + 1) % 4], f[(k + 2) % 4], f[(k + 3) % 4]);
        let c = pos.len() as u32;
        let (a, b) = ([m, p, o, c], [m, c, o, q]);
        let (x, y) = if rng.below(2) == 0 { (a, b) } else { (b, a) };
        let (rx, ry) = (rng.below(4), rng.below(4));
        let x = [0, 1, 2, 3].map(|i| x[(i + rx) % 4]);
        let y = [0, 1, 2, 3].map(|i| y[(i + ry) % 4]);
        let corners = f.map(|v| pos[v as usize]);
        let centre = corners.iter().sum::<glam::DVec3>() / 4.0;
        let size = corners[k].distance(corners[(k + 2) % 4]);
        let jitter = glam::DVec3::new(rng.signed(), rng.signed(), rng.signed()) * 0.15 * size;
        let new = centre + jitter;
        let mut moved = Vec::new();
        if rng.below(5) == 0 {
            let to = pos[m as usize].lerp(new, 0.2);
            moved.push((m, to));
            pos[m as usize] = to;
        }
        pm.records.push(SplitRecord {
            op: OpKind::Doublet,
            new_vertices: vec![new],
            moved,
            rewritten: vec![(s as u32, x)],
            appended_faces: vec![y],
        });
        pos.push(new);
        quads[s] = x;
        quads.push(y);
        if !pm.vertex_order.is_empty() {
            pm.vertex_order.push(c);
        }
        if let Some(&last) = pm.level_error.last() {
            pm.level_error.push(last);
        }
    }
}

/// Appends up to `n` random **edge splits** to `pm` as `QeMerge` records —
/// the inverse of a qeMerge, the shape of spec §7.10: each picks a random
/// interior vertex `A` of the finest level, a random link neighbour `D`
/// (also interior), random first-sector and fan lengths per endpoint, a
/// random new-vertex and appended-quad order and random rotations, and
/// takes the explicit record the edge-split form's own builder makes
/// (attempts that do not fit are skipped). New vertices sit 30 % of the
/// way from their endpoint to the centroid of their sector's link
/// vertices. Every level stays a closed, oriented manifold (it may hold
/// doublets: two faces sharing two edges). Deterministic in `seed`;
/// independent of the coarsener, so the vectors stay fixed when it changes.
pub fn add_edge_splits(pm: &mut ProgressiveMesh, n: usize, seed: u64) {
    use crate::codec::{MeshState, QRecord};
    use crate::edge_split::{anchor_star, build, stars, Scratch};
    let mut rng = Rng(seed ^ 0xED6E_5B11_7000_0004);
    let (mut pos, quads) = pm.level_quads(pm.records.len());
    if quads.is_empty() {
        return;
    }
    // Only connectivity matters to the builder: zero codes.
    let mut st = MeshState::new(1, vec![[0; 3]; pos.len()], quads);
    let mut sc = Scratch::default();
    let mut out = QRecord::default();
    let mut done = 0;
    for _ in 0..50 * n {
        if done == n {
            break;
        }
        let a = rng.below(pos.len()) as u32;
        if anchor_star(&st, a, &mut sc).is_err() {
            continue;
        }
        let r = rng.below(sc.stars[0].faces.len());
        let Ok((ends, rho)) = stars(&st, a, r, &mut sc) else {
            continue;
        };
        let (mut n1, mut m) = ([0; 2], [0; 2]);
        let mut fits = true;
        for x in 0..2 {
            let k = sc.stars[x].faces.len();
            if k < 3 {
                fits = false;
                break;
            }
            n1[x] = rng.below(k - 2);
            m[x] = 1 + rng.below(k - 2 - n1[x]);
        }
        if !fits {
            continue;
        }
        let p = rng.below(576);
        let ra = rng.below(256) as u8;
        let rots: Vec<u8> = (0..m[0] + m[1]).map(|_| rng.below(4) as u8).collect();
        // New vertex positions, canonical order U_0..U_3, before π_v.
        let mut canon_pos = [glam::DVec3::ZERO; 4];
        for x in 0..2 {
            let s = &sc.stars[x];
            let k = s.faces.len();
            let xp = pos[ends[x] as usize];
            for (half, range) in [(0, 0..n1[x] + 1), (1, n1[x] + m[x] + 1..k)] {
                let len = range.len() as f64;
                let c = range
                    .map(|i| pos[s.link[(rho[x] + i) % k] as usize])
                    .sum::<glam::DVec3>()
                    / len;
                canon_pos[2 * x + half] = xp.lerp(c, 0.3);
            }
        }
        if build(&st, ends, rho, n1, m, p, ra, &rots, &mut sc, &mut out).is_err() {
            continue;
        }
        let pv = crate::edge_split::PERMS[p / 24];
        let mut new = [glam::DVec3::ZERO; 4];
        for i in 0..4 {
            new[pv[i] as usize] = canon_pos[i];
        }
        out.new_pos = vec![[0; 3]; 4];
        st.apply(&out);
        let v0 = pos.len() as u32;
        pos.extend_from_slice(&new);
        pm.records.push(SplitRecord {
            op: OpKind::QeMerge,
            new_vertices: new.to_vec(),
            moved: Vec::new(),
            rewritten: out.rewritten.clone(),
            appended_faces: out.appended.clone(),
        });
        if !pm.vertex_order.is_empty() {
            pm.vertex_order.extend(v0..v0 + 4);
        }
        if let Some(&last) = pm.level_error.last() {
            pm.level_error.push(last);
        }
        done += 1;
    }
}

/// Every vector, generated deterministically. All but `edge_split`,
/// `box_vnbr`, `zstd_blocks` and `cube_grid` are written as 2.0 (a 3.0
/// file without edge splits differs only in its version field), so they
/// keep their bytes and 2.0 readers keep reading them (`box_vord` keeps
/// the 3.0 `VORD` section); `edge_split` is the 3.0 vector, `box_vnbr` the
/// 3.1 one (a `VNBR` section), `cube_grid` the 3.2 one (the cube grid and
/// the header's bounds, spec §3, §5). Every other vector keeps the box
/// grid, as before 3.2, so its bytes stay as they were.
pub fn all() -> Vec<Vector> {
    let make = |name: &'static str, gen: GenOptions, opts: EncodeOptions| {
        let opts = EncodeOptions {
            version_major: if name.starts_with("v4_") {
                opts.version_major
            } else if ["edge_split", "box_vnbr", "zstd_blocks", "cube_grid"].contains(&name) {
                opts.version_major.min(3)
            } else {
                opts.version_major.min(2)
            },
            grid: if name == "cube_grid" || name.starts_with("v4_") {
                crate::Grid::Cube
            } else {
                crate::Grid::Box
            },
            // A compression parameter, not a format one: the vectors keep
            // the frames they were written with (the level's own minimum
            // match; a decoder reads any standard frame).
            zstd_min_match: crate::ZstdMinMatch::Level,
            ..opts
        };
        let mut pm = generate_with(&gen);
        if name == "local_form" {
            rotate_rewritten(&mut pm);
        }
        if name == "face_split" {
            add_face_splits(&mut pm, 60, 6);
        }
        if name == "edge_split" {
            add_edge_splits(&mut pm, 30, 7);
        }
        if name == "box_vnbr" {
            coherent_vertex_order(&mut pm, 8, 6);
        }
        if name == "cube_grid" {
            // a flat, off-centre box: the cube grid is far from the bounds
            stretch(&mut pm, [1.5, 0.375, 0.125], [0.25, -3.0, 7.0]);
        }
        if name.starts_with("v4_") {
            // every compact form, each predicting with the stencil
            add_face_splits(&mut pm, 20, 13);
            add_edge_splits(&mut pm, 12, 13);
        }
        if name == "v4_delta_base" {
            reverse_base_vertices(&mut pm);
        }
        let n = pm.records.len();
        let (bytes, r) = write_to_vec(&pm, &opts).expect("vector encodes");
        Vector {
            name,
            bytes,
            levels: vec![0, n / 3, 2 * n / 3, n],
            forms: [
                r.general_records,
                r.split_records,
                r.local_records,
                r.face_split_records,
                r.edge_split_records,
            ],
        }
    };
    // `mixed_bits24` is written twice: as 2.0 and, for the 1.x rules, as 1.1
    let mixed_gen = || GenOptions {
        base: BaseShape::Box { n: 3 },
        fuse_prob: 0.3,
        smooth_prob: 0.1,
        ..GenOptions::new(4, 60)
    };
    let mixed_encode = |version_major| EncodeOptions {
        bits: 24,
        chunk_records: Some(16),
        zstd_level: 3,
        version_major,
        ..EncodeOptions::default()
    };
    vec![
        make(
            "grid_small",
            GenOptions {
                base: BaseShape::Grid { nx: 3, ny: 3 },
                vertex_order: false,
                ..GenOptions::new(1, 12)
            },
            EncodeOptions {
                chunk_records: Some(4),
                ..EncodeOptions::default()
            },
        ),
        make(
            "box_vord",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                ..GenOptions::new(2, 40)
            },
            EncodeOptions {
                chunk_records: Some(10),
                ..EncodeOptions::default()
            },
        ),
        make(
            "general_bits8",
            GenOptions {
                base: BaseShape::Grid { nx: 4, ny: 2 },
                ..GenOptions::new(3, 20)
            },
            EncodeOptions {
                bits: 8,
                split_form: false,
                local_form: false,
                chunk_bytes: 64,
                // The chunk cuts this vector was written with (before
                // chunks grew with the file).
                chunk_growth: 0.0,
                ..EncodeOptions::default()
            },
        ),
        make(
            "local_form",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(5, 300)
            },
            EncodeOptions {
                split_form: false,
                chunk_records: Some(12),
                ..EncodeOptions::default()
            },
        ),
        make("mixed_bits24", mixed_gen(), mixed_encode(2)),
        make(
            "face_split",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                ..GenOptions::new(6, 30)
            },
            EncodeOptions {
                chunk_records: Some(15),
                ..EncodeOptions::default()
            },
        ),
        // Edge splits (spec §7.10, version 3) after a few vertex splits:
        // random orders and rotations, so every field of the form varies.
        make(
            "edge_split",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                vertex_order: false,
                ..GenOptions::new(7, 20)
            },
            EncodeOptions {
                chunk_records: Some(10),
                ..EncodeOptions::default()
            },
        ),
        // A 3.1 file: the vertex order in a VNBR section (spec §8.2), a
        // coherent order with a few transpositions, so that candidates,
        // the base-vertex symbol and escapes all occur.
        make(
            "box_vnbr",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                ..GenOptions::new(8, 60)
            },
            EncodeOptions {
                chunk_records: Some(12),
                ..EncodeOptions::default()
            },
        ),
        // Every section's zstd frame in several blocks (the base: corners |
        // codes; each chunk: ops | conn | refs | slots + pos), as
        // `ZstdBlocks::Auto` writes where it pays on real meshes: decoders
        // must read a frame of many blocks (spec §1).
        make(
            "zstd_blocks",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(11, 80)
            },
            EncodeOptions {
                chunk_records: Some(20),
                zstd_blocks: crate::ZstdBlocks::PerPart,
                ..EncodeOptions::default()
            },
        ),
        // A 3.2 file: the cube grid (every axis the step of the largest
        // extent) and the positions' exact bounds in the header.
        make(
            "cube_grid",
            GenOptions {
                base: BaseShape::Box { n: 2 },
                ..GenOptions::new(12, 40)
            },
            EncodeOptions {
                chunk_records: Some(10),
                ..EncodeOptions::default()
            },
        ),
        // 4.0 files (spec §6.1, §7.6 version 4): the base in the traversal
        // layout, then in the delta layout behind its layout byte (its
        // vertex ids reversed, so not in the walk's order); both with
        // split, face-split and edge-split records predicted by the stencil.
        make(
            "v4_traversal",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(13, 60)
            },
            EncodeOptions {
                chunk_records: Some(16),
                ..EncodeOptions::default()
            },
        ),
        // Quads stored where each record's form builds them (every rotation
        // field 0, `CornerOrder::Canonical`, what `pqm encode` writes):
        // the same 4.0 rules; the levels hold the progressive mesh turned.
        make(
            "v4_canonical",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(22, 60)
            },
            EncodeOptions {
                chunk_records: Some(16),
                corner_order: crate::CornerOrder::Canonical,
                ..EncodeOptions::default()
            },
        ),
        // A 4.1 file: header flag bit 3 says the finest level's `v0–v2`
        // diagonals are meant (`pqm encode` on a paired triangle mesh),
        // with `CornerOrder::Diagonal`, which keeps them. 4.0 readers
        // ignore the flag and decode the same levels.
        make(
            "v4_1_diagonals",
            GenOptions {
                base: BaseShape::Box { n: 3 },
                ..GenOptions::new(23, 60)
            },
            EncodeOptions {
                chunk_records: Some(16),
                corner_order: crate::CornerOrder::Diagonal,
                finest_diagonals: true,
                ..EncodeOptions::default()
            },
        ),
        make(
            "v4_delta_base",
            GenOptions {
                base: BaseShape::Grid { nx: 4, ny: 3 },
                ..GenOptions::new(14, 40)
            },
            EncodeOptions {
                chunk_records: Some(16),
                ..EncodeOptions::default()
            },
        ),
        // A 1.1 file (version-1 prediction, no face-split form): the bytes
        // of `mixed_bits24` before format 2.0, kept so that every decoder
        // keeps testing the 1.x rules (spec §9).
        make("v1_1_mixed_bits24", mixed_gen(), mixed_encode(1)),
    ]
}

/// Renumbers `pm`'s base vertices in reverse (`v → nb − 1 − v`), records
/// and vertex order with them: the same levels under other ids, which are
/// not in the walk order of spec §6.1, so a 4.0 writer codes the base in
/// the delta layout.
pub fn reverse_base_vertices(pm: &mut ProgressiveMesh) {
    let faces: Vec<u32> = (0..pm.base.face_count() as u32).collect();
    let vertices: Vec<u32> = (0..pm.base.vertex_count() as u32).rev().collect();
    pm.renumber_base(&faces, &vertices);
}

/// Scales every position of `pm` per axis by `scale`, then adds `offset`.
pub fn stretch(pm: &mut ProgressiveMesh, scale: [f64; 3], offset: [f64; 3]) {
    let f = |p: &mut glam::DVec3| {
        *p = *p * glam::DVec3::from_array(scale) + glam::DVec3::from_array(offset);
    };
    pm.base.positions.iter_mut().for_each(f);
    for r in &mut pm.records {
        r.new_vertices.iter_mut().for_each(f);
        r.moved.iter_mut().for_each(|m| f(&mut m.1));
    }
}

/// FNV-1a 64 of `bytes`.
pub fn fnv1a64(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Replaces `pm.vertex_order` by a locally coherent order like those of
/// real inputs: a depth-first walk of the finest level from canonical
/// vertex 0 (input index = visit index), base vertices' input indices then
/// put in canonical order (as the coarsener's are, spec §8.2), then `swaps`
/// random transpositions (`seed`), which the `VNBR` coding must escape.
pub fn coherent_vertex_order(pm: &mut ProgressiveMesh, seed: u64, swaps: usize) {
    let (pos, quads) = pm.level_quads(pm.records.len());
    let n = pos.len();
    let mut nbr = vec![Vec::new(); n];
    for q in &quads {
        for k in 0..4 {
            nbr[q[k] as usize].push(q[(k + 1) % 4]);
            nbr[q[k] as usize].push(q[(k + 2) % 4]);
        }
    }
    let mut order = vec![u32::MAX; n];
    let mut next = 0u32;
    for s in 0..n {
        let mut stack = vec![s];
        while let Some(v) = stack.pop() {
            if order[v] != u32::MAX {
                continue;
            }
            order[v] = next;
            next += 1;
            stack.extend(nbr[v].iter().rev().map(|&w| w as usize));
        }
    }
    let b = pm.base.vertex_count().min(n);
    order[..b].sort_unstable();
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = |m: usize| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % m as u64) as usize
    };
    for _ in 0..swaps.min(n) {
        let (a, c) = (rnd(n), rnd(n));
        order.swap(a, c);
    }
    pm.vertex_order = order;
}

/// `(positions digest, quads digest)` of the decoder's current level.
pub fn level_digests(dec: &Decoder) -> (u64, u64) {
    let p = fnv1a64(
        dec.positions_f64()
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f64::to_le_bytes),
    );
    let q = fnv1a64(dec.quads().iter().flatten().flat_map(|v| v.to_le_bytes()));
    (p, q)
}

/// Digest of the decoder's current level's smooth normals
/// ([`crate::normals::SmoothNormals::compute`]): x, y, z of each vertex in
/// id order as f32 little-endian (spec §11; not part of decoding, a check
/// that clients computing them as `pqm_format::normals` does agree bit for
/// bit).
pub fn normals_digest(dec: &Decoder) -> u64 {
    fnv1a64(
        crate::normals::SmoothNormals::compute(dec)
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes()),
    )
}

/// FNV-1a 64 of a vertex order: each entry as u32 little-endian (spec §11).
pub fn vertex_order_digest(order: &[u32]) -> u64 {
    fnv1a64(order.iter().flat_map(|v| v.to_le_bytes()))
}

/// The JSON digest of `levels` (moves the decoder).
pub fn digest_json(name: &str, dec: &mut Decoder, levels: &[usize], file_len: usize) -> String {
    let final_level = dec.deepest_level().unwrap_or(0);
    let mut s = String::new();
    let _ = write!(
        s,
        "{{\n  \"file\": \"{name}.pqm\",\n  \"bytes\": {file_len},\n  \"final_level\": {final_level},\n"
    );
    // A bad vertex-order section leaves the digest out (tests comparing
    // digests then fail on the missing field).
    if let Some([lo, hi]) = dec.header().and_then(|h| h.bounds) {
        let _ = writeln!(
            s,
            "  \"bounds_min\": [{:?}, {:?}, {:?}],\n  \"bounds_max\": [{:?}, {:?}, {:?}],",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        );
    }
    // Flag bit 3 (4.1) only where set, so the other digests stay as they were.
    if dec.header().is_some_and(|h| h.finest_diagonals()) {
        s.push_str("  \"finest_diagonals\": true,\n");
    }
    if let Ok(Some(o)) = dec.vertex_order() {
        let _ = writeln!(
            s,
            "  \"vertex_order_fnv1a64\": \"{:016x}\",",
            vertex_order_digest(o)
        );
    }
    s.push_str("  \"levels\": [");
    for (i, &k) in levels.iter().enumerate() {
        let _ = dec.set_level(Target::Level(k));
        let (p, q) = level_digests(dec);
        let n = normals_digest(dec);
        let _ = write!(
            s,
            "{}\n    {{\"level\": {k}, \"vertex_count\": {}, \"face_count\": {}, \"positions_fnv1a64\": \"{p:016x}\", \"quads_fnv1a64\": \"{q:016x}\", \"normals_fnv1a64\": \"{n:016x}\"}}",
            if i == 0 { "" } else { "," },
            dec.positions().len(),
            dec.quads().len()
        );
    }
    s.push_str("\n  ]\n}\n");
    s
}

/// The JSON digest of a whole `.pqm` file named `name` (its stem): levels
/// 0, n/3, 2n/3 and n by the reference decoder, as `make-pqm digest` and
/// `examples/digest.rs` write it beside real-mesh files for the
/// JavaScript decoder's tests.
pub fn digest_file(name: &str, bytes: &[u8]) -> Result<String, crate::DecodeError> {
    let mut dec = crate::decode_all(bytes, crate::Limits::default())?;
    let n = dec.deepest_level().unwrap_or(0);
    Ok(digest_json(
        name,
        &mut dec,
        &[0, n / 3, 2 * n / 3, n],
        bytes.len(),
    ))
}

/// The current level as OBJ text.
pub fn obj(dec: &Decoder) -> String {
    let mut s = String::new();
    for p in dec.positions_f64() {
        let _ = writeln!(s, "v {:?} {:?} {:?}", p.x, p.y, p.z);
    }
    for q in dec.quads() {
        let _ = writeln!(s, "f {} {} {} {}", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
    }
    s
}
