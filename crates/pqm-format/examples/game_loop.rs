//! How a game loop streams a `.pqm` file into GPU buffers.
//!
//! `cargo run -p pqm-format --example game_loop`
//!
//! Simulated frames: each frame a few kilobytes of the file "arrive from the
//! network" and are pushed into the decoder; the game picks the level the
//! (simulated) camera needs — the coarsest whose geometric error (measured
//! when the file is written, [`level_error`]) spans at most one pixel on screen ([`ViewLod`], 3D Tiles' screen-space error) —, moves
//! the decoder there, and applies the returned [`Change`] to its vertex and
//! index buffers as sub-range writes — never re-uploading whole buffers.
//! Smooth shading keeps a normal buffer beside them ([`SmoothNormals`]: the
//! vertex ranges whose normals a change touched). At the end the simulated
//! GPU buffers are checked against the decoder.

use pqm_core::progressive::testgen::{self, BaseShape, GenOptions};
use pqm_format::level_error;
use pqm_format::normals::SmoothNormals;
use pqm_format::view::{file_diagonal, pixels_per_world_unit, Projection, ViewLod};
use pqm_format::{quad_triangles, write_to_vec, Change, Decoder, EncodeOptions, Event, Limits};

/// Stand-in for GPU buffers: a vertex buffer, an index buffer (6 indices per
/// quad slot) and counters of what was uploaded.
#[derive(Default)]
struct GpuMesh {
    vertices: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u32>,
    /// Smooth normals kept in step with the level.
    normal_source: SmoothNormals,
    uploaded_vertex_bytes: usize,
    uploaded_index_bytes: usize,
}

impl GpuMesh {
    /// Applies one change: every write is a contiguous sub-range update
    /// (`glBufferSubData` / `queue.write_buffer` with an offset).
    fn apply(&mut self, dec: &Decoder, c: &Change) {
        let pos = dec.positions();
        let quads = dec.quads();
        // Coarsening: shrink the draw ranges (no upload needed).
        self.vertices.truncate(c.vertices_removed.start as usize);
        self.indices.truncate(6 * c.faces_truncated.start as usize);
        // Moved vertices, one write per run of consecutive ids.
        for r in c.moved_ranges() {
            let (a, b) = (r.start as usize, r.end as usize);
            self.vertices[a..b].copy_from_slice(&pos[a..b]);
            self.uploaded_vertex_bytes += 12 * (b - a);
        }
        // Appended vertices: one write at the end.
        let (a, b) = (
            c.vertices_appended.start as usize,
            c.vertices_appended.end as usize,
        );
        self.vertices.extend_from_slice(&pos[a..b]);
        self.uploaded_vertex_bytes += 12 * (b - a);
        // Rewritten quads: slot f is indices 6f .. 6f + 6.
        for r in c.rewritten_ranges() {
            for f in r {
                let f = f as usize;
                self.indices[6 * f..6 * f + 6].copy_from_slice(&quad_triangles(quads[f]));
                self.uploaded_index_bytes += 24;
            }
        }
        for f in c.faces_appended.clone() {
            self.indices
                .extend_from_slice(&quad_triangles(quads[f as usize]));
            self.uploaded_index_bytes += 24;
        }
        // Normals: the ranges the change touched (the buffer follows the
        // vertex count).
        self.normals.resize(pos.len(), [0.0; 3]);
        for r in self.normal_source.apply(dec, c) {
            let (a, b) = (r.start as usize, r.end as usize);
            self.normals[a..b].copy_from_slice(&self.normal_source.normals()[a..b]);
            self.uploaded_vertex_bytes += 12 * (b - a);
        }
    }
}

fn main() {
    // A file to stream (in a real game: bytes from a socket or an HTTP body).
    let pm = testgen::generate_with(&GenOptions {
        base: BaseShape::Box { n: 3 },
        ..GenOptions::new(42, 20_000)
    });
    let opts = EncodeOptions {
        chunk_bytes: 4096,
        ..EncodeOptions::default()
    };
    let (mut file, report) = write_to_vec(&pm, &opts).expect("encode");
    // The levels' errors, which pick the level a view needs: measured
    // against the finest level, as `pqm encode` writes them (the generated
    // mesh's own errors are made up).
    let measured = level_error::measure(
        &file,
        Limits::default(),
        &level_error::sampling(pm.final_face_count()),
        |_, _| {},
    )
    .expect("measure");
    level_error::set(&mut file, measured.base, &measured.chunks).expect("errors");
    println!(
        "file: {} bytes, {} chunks, {} → {} quads, level 0's error {:.4} of the diagonal",
        file.len(),
        report.chunk_count,
        pm.base.face_count(),
        pm.final_face_count(),
        measured.base
    );

    let mut dec = Decoder::new(Limits::default());
    // This camera flies back out, so the decoder will coarsen: ask for the
    // undo logs up front, written while decoding, rather than have the first
    // coarsening frame decode the chunks again (a whole decode's time).
    dec.keep_undo_logs().expect("a general decoder");
    let mut gpu = GpuMesh::default();
    // A 60° camera on a 1080-pixel-tall viewport; errors drawn at most one
    // pixel tall, with the default hysteresis (refine at once, coarsen only
    // when the view allows 1.5 times less).
    let camera = Projection::Perspective {
        fov_y: 60f64.to_radians(),
    };
    let lod = ViewLod::default();
    let mut received = 0usize;
    let bytes_per_frame = 3000;
    for frame in 0..400 {
        // 1. Network: push whatever arrived this frame.
        let end = (received + bytes_per_frame).min(file.len());
        let events = dec.push(&file[received..end]).expect("decode");
        received = end;
        for e in &events {
            match e {
                Event::HeaderReady => {
                    let h = dec.header().expect("header");
                    println!(
                        "frame {frame}: header: {} levels, final {} quads",
                        h.record_count + 1,
                        h.final_face_count
                    );
                }
                Event::BaseMeshReady => {
                    // First upload: the whole base mesh.
                    gpu.apply(&dec, &dec.full_upload());
                    println!(
                        "frame {frame}: base mesh ready, {} quads uploaded",
                        dec.quads().len()
                    );
                }
                Event::Finished => println!("frame {frame}: whole file received"),
                _ => {}
            }
        }
        if dec.deepest_level().is_none() {
            continue; // nothing to draw yet
        }
        // 2. Level of detail: the camera's distance to the object's bounding
        //    sphere, in diagonals of the object (it flies in, then back out
        //    after frame 250), as pixels per world unit.
        let distance = if frame < 250 {
            40.0 - frame as f64 * 0.158
        } else {
            0.5 + (frame - 250) as f64 * 0.25
        };
        let diagonal = file_diagonal(&dec).expect("header");
        let ppu = pixels_per_world_unit(camera, 1080.0, distance * diagonal);
        // 3. Move the decoder (refines or coarsens; never past what arrived).
        let (choice, change) = lod.update(&mut dec, ppu, diagonal).expect("level");
        // 4. Upload only the changed sub-ranges.
        if !change.is_empty() {
            gpu.apply(&dec, &change);
        }
        if frame % 40 == 0 || (frame > 245 && frame % 10 == 0 && frame < 300) {
            println!(
                "frame {frame:3}: {:6} bytes in, level {:5}, {:5} quads, error {:5.2} px{}, uploads so far {} KiB",
                received,
                dec.level(),
                dec.quads().len(),
                choice.screen_error,
                if choice.bytes_needed > 0 {
                    format!(" ({} more bytes wanted)", choice.bytes_needed)
                } else {
                    String::new()
                },
                (gpu.uploaded_vertex_bytes + gpu.uploaded_index_bytes) / 1024
            );
        }
        // 5. Draw: 6 * quads indices from the index buffer (omitted).
    }
    assert_eq!(gpu.vertices, dec.positions(), "vertex buffer in sync");
    assert_eq!(gpu.indices, dec.triangle_indices(), "index buffer in sync");
    assert_eq!(
        gpu.normals,
        SmoothNormals::compute(&dec),
        "normal buffer in sync"
    );
    println!(
        "GPU buffers match the decoder: {} vertices, {} triangles",
        gpu.vertices.len(),
        gpu.indices.len() / 3
    );
}
