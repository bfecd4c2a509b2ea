//! A game-style triangle asset from a UV-mapped quad mesh, and what
//! pairing and bridging make of it.
//!
//! A triangle mesh from a game or web pipeline is UV-mapped and decimated:
//! its UV islands hold any number of triangles, odd ones too, and no pair
//! may straddle a seam, so a perfect pairing rarely exists. This example
//! makes such an asset from a shared quad mesh with texture coordinates —
//! each quad split along `q0–q2` into glTF-style vertices (one per
//! position and texture coordinate), simplified by meshoptimizer (which
//! keeps UV seams) to a fraction of its triangles — writes it as OBJ, and
//! prints what `pairing::pair_triangles` and `bridging::pair_and_bridge`
//! do with it.
//!
//! ```sh
//! cargo run --release -p pqm-core --example decimated_asset -- \
//!     ../shared/meshes/quad/loki.obj 0.5 /tmp/loki_decimated.obj
//! pqm encode /tmp/loki_decimated.obj -o /tmp/loki_decimated.pqm --json
//! ```

use pqm_core::bridging::pair_and_bridge;
use pqm_core::pairing::pair_triangles;
use pqm_core::{io, IndexedMesh};
use std::collections::HashMap;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, input, ratio, output] = args.as_slice() else {
        eprintln!("usage: decimated_asset INPUT.obj RATIO OUTPUT.obj");
        std::process::exit(2);
    };
    let ratio: f64 = ratio.parse().expect("RATIO is a number");
    let m = io::read_mesh(std::path::Path::new(input)).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        !m.corner_texcoords.is_empty(),
        "{input} has no texture coordinates"
    );
    // glTF-style vertices: one per (position, texture coordinate).
    let mut vertex_of: HashMap<(u32, u32), u32> = HashMap::new();
    let mut verts: Vec<(u32, u32)> = Vec::new();
    let mut tris: Vec<u32> = Vec::new();
    for f in 0..m.face_count() {
        let s = m.face_starts[f] as usize;
        let face = m.face(f);
        let ids: Vec<u32> = (0..face.len())
            .map(|k| {
                let key = (face[k], m.corner_texcoords[s + k]);
                *vertex_of.entry(key).or_insert_with(|| {
                    verts.push(key);
                    verts.len() as u32 - 1
                })
            })
            .collect();
        for k in 1..ids.len() - 1 {
            tris.extend([ids[0], ids[k], ids[k + 1]]);
        }
    }
    let xyz: Vec<[f32; 3]> = verts
        .iter()
        .map(|&(p, _)| m.positions[p as usize].to_array().map(|x| x as f32))
        .collect();
    let bytes: Vec<u8> = xyz.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("adapter");
    let target = ((tris.len() / 3) as f64 * ratio) as usize * 3;
    let out = meshopt::simplify(
        &tris,
        &adapter,
        target,
        1.0,
        meshopt::SimplifyOptions::empty(),
        None,
    );
    // Back to an indexed mesh: positions welded by input index, texture
    // coordinates per corner, unused positions dropped.
    let mut new_pos: HashMap<u32, u32> = HashMap::new();
    let mut asset = IndexedMesh::new();
    asset.texcoords = m.texcoords.clone();
    for t in out.chunks_exact(3) {
        let face: Vec<u32> = t
            .iter()
            .map(|&v| {
                let p = verts[v as usize].0;
                *new_pos.entry(p).or_insert_with(|| {
                    asset.positions.push(m.positions[p as usize]);
                    asset.positions.len() as u32 - 1
                })
            })
            .collect();
        asset.push_face(&face);
        asset
            .corner_texcoords
            .extend(t.iter().map(|&v| verts[v as usize].1));
    }
    io::write_mesh(std::path::Path::new(output), &asset).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{input}: {} quads -> {} triangles, simplified to {} triangles, {} vertices -> {output}",
        m.face_count(),
        tris.len() / 3,
        asset.face_count(),
        asset.vertex_count()
    );
    match pair_triangles(&asset) {
        Ok((q, r)) => println!("pair_triangles: {} quads, {r:?}", q.face_count()),
        Err(e) => println!("pair_triangles: {e}"),
    }
    match pair_and_bridge(&asset) {
        Ok((q, r, b)) => println!(
            "pair_and_bridge: {} quads, {} vertices (+{}), {r:?}\n  {b:?}",
            q.face_count(),
            q.vertex_count(),
            q.vertex_count() - asset.vertex_count()
        ),
        Err(e) => println!("pair_and_bridge: {e}"),
    }
}
