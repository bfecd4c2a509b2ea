//! # pqm-format
//!
//! The `.pqm` progressive quad mesh file format — byte layout in
//! `spec/pqm.md`, the single source of truth — with a writer ([`write()`]) and a
//! push-style streaming decoder ([`Decoder`]) that refines and coarsens
//! between levels exactly.
//!
//! ```
//! use pqm_format::{write_to_vec, Decoder, EncodeOptions, Event, Limits, Target};
//! let pm = pqm_core::progressive::testgen::generate(1, 200);
//! let (bytes, report) = write_to_vec(&pm, &EncodeOptions::default()).unwrap();
//! assert!(report.bits_per_vertex.total > 0.0);
//!
//! let mut dec = Decoder::new(Limits::default());
//! for piece in bytes.chunks(100) {
//!     for event in dec.push(piece).unwrap() {
//!         if let Event::ChunkReady(_) = event {
//!             // Refine as far as the bytes received so far allow.
//!             let change = dec.refine_to(Target::Level(usize::MAX)).unwrap();
//!             // Upload `change.vertices_appended`, `change.vertices_moved`,
//!             // `change.faces_rewritten`, `change.faces_appended` …
//!             let _ = change;
//!         }
//!     }
//! }
//! assert_eq!(dec.level(), pm.records.len());
//! assert_eq!(dec.quads().len(), pm.final_face_count());
//! ```
//!
//! ## Level errors
//! [`write()`] puts the progressive mesh's own level errors in the header
//! and the chunk table (the coarsener's bounds). [`level_error::measure`]
//! then measures each chunk boundary's sampled Hausdorff distance to the
//! finest level and [`level_error::set`] writes those instead, changing no
//! other byte: what `pqm encode` does by default, several times tighter,
//! so that a client choosing levels by screen-space error
//! ([`view::ViewLod`]) stops downloading sooner.
//!
//! ## Using it in a game loop
//! See `examples/game_loop.rs` (`cargo run -p pqm-format --example
//! game_loop`): bytes arrive in pieces between frames; each frame the game
//! pushes what arrived, picks a target (a face budget, or a screen-space
//! error: [`view::ViewLod`] turns a camera's distance and projection into
//! the coarsest level whose error spans at most a pixel, with hysteresis,
//! and [`view::bytes_for`] says how many bytes of the file a level needs),
//! calls [`Decoder::set_level`] and applies the returned [`Change`] to its
//! GPU buffers:
//!
//! * vertex buffer: write `positions()[r]` for `vertices_appended` and for
//!   each run in [`Change::moved_ranges`]; shrink the draw range to
//!   `vertices_removed.start` when coarsening;
//! * index buffer: quad slot `f` is triangles `2f = (v0, v1, v2)` and
//!   `2f + 1 = (v0, v2, v3)` (see [`quad_triangles`]), i.e. indices
//!   `6f .. 6f + 6`; rewrite those for [`Change::rewritten_ranges`] and
//!   `faces_appended`, and draw `6 * quads().len()` indices. (Or split each
//!   written quad along its shorter diagonal, [`quad_triangles_shorter`],
//!   as modelling tools draw quads: fewer folds on a quad input's coarse
//!   levels; keep [`quad_triangles`] where [`Header::finest_diagonals`]
//!   says the diagonals are meant.)
//!
//! Slots never move while they exist, so every update is a sub-range write.
//! A renderer that shades smoothly keeps [`normals::SmoothNormals`] beside
//! its buffers: it takes the same `Change` and names the vertex ranges whose
//! normals changed.
//!
//! A game that will also coarsen (the camera moves away) calls
//! [`Decoder::keep_undo_logs`] before pushing: by default a general decoder
//! keeps no undo data until its first move below the deepest level, which
//! then decodes the chunks again (a whole decode's time, in one frame);
//! with the logs asked for up front they are written while decoding
//! instead. A client that only ever refines uses [`Decoder::forward_only`].
//! A client that decodes asset after asset keeps one decoder and calls
//! [`Decoder::reset`] between them, or makes a new one per asset: either
//! way the next file decodes in the memory the last one used, whose pages
//! are already mapped (capacity is all that is kept; a dropped decoder of
//! up to 64 MiB leaves its allocations to the next [`Decoder::new`], and on
//! Linux up to 64 MiB of freed large arrays stay mapped for it, until
//! [`release_recycled`] frees both).

pub mod base;
pub mod codec;
pub mod decoder;
pub mod edge_split;
pub mod encoder;
pub mod error;
pub mod huge_pages;
pub mod layout;
pub mod level_error;
pub mod normals;
pub mod quant;
pub mod varint;
pub mod view;
pub mod vorder;

pub use decoder::{
    decode_all, quad_triangles, quad_triangles_shorter, release_recycled, Change, Decoder, Event,
    Limits, Status, Target,
};
pub use encoder::{
    write, write_stored, write_to_vec, BitsPerVertex, CornerOrder, EncodeOptions, EncodeReport,
    OpStats, VertexOrderCode, ZstdBlocks, ZstdMinMatch, BLOCK_PENALTY_BYTES,
};
pub use error::{DecodeError, EncodeError, FormatError, Section};
pub use layout::{ChunkInfo, Header};
pub use quant::{Grid, Quantizer};
#[doc(hidden)]
pub mod vectors;
