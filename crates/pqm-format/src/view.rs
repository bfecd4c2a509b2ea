//! View-dependent level of detail: the level a camera needs, as 3D Tiles
//! picks tiles by their *screen-space error*.
//!
//! Every level of a `.pqm` file has a geometric error bound (spec §3 and
//! §4: the header's `base_error` for level 0, the chunk table's `error`
//! after each chunk), in units of the input's bounding-box diagonal. A
//! camera draws an error `e` as `e × diagonal × pixels_per_world_unit`
//! pixels tall, so the level to draw is the coarsest whose error stays
//! under a pixel budget — closer objects refine, farther ones coarsen, and
//! the chunk table says how many bytes of the file that level needs before
//! any of them arrives (HTTP range requests).
//!
//! ```
//! use pqm_format::view::{file_diagonal, pixels_per_world_unit, Projection, ViewLod};
//! # use pqm_format::{write_to_vec, Decoder, EncodeOptions, Limits};
//! # use pqm_core::progressive::testgen::{self, GenOptions};
//! # let file = write_to_vec(&testgen::generate_with(&GenOptions::new(1, 500)), &EncodeOptions::default()).unwrap().0;
//! let mut dec = Decoder::new(Limits::default());
//! dec.push(&file)?;
//! // a 60° camera, 1080 pixels tall, 12 world units from the object's
//! // bounding sphere; the object drawn at scale 1
//! let ppu = pixels_per_world_unit(Projection::Perspective { fov_y: 60f64.to_radians() }, 1080.0, 12.0);
//! let lod = ViewLod::default(); // at most 1 pixel, hysteresis 1.5
//! let diagonal = file_diagonal(&dec).unwrap();
//! let (choice, change) = lod.update(&mut dec, ppu, diagonal)?;
//! assert!(choice.screen_error <= 1.0 || Some(choice.level) == dec.deepest_level());
//! // `change` holds the buffer sub-ranges to upload, as from `set_level`
//! # let _ = change;
//! # Ok::<(), pqm_format::DecodeError>(())
//! ```
//!
//! The JavaScript binding has the same rule (`PQMProgressiveMesh.updateForView`
//! in `web/pqm-three`).

use crate::{Change, DecodeError, Decoder, Target};

/// A camera's projection, as far as the size of an error on screen goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective: the vertical field of view in radians (divided by the
    /// camera's zoom, if it has one).
    Perspective {
        /// Vertical field of view, radians, in `(0, π)`.
        fov_y: f64,
    },
    /// Orthographic: the world units the viewport's height spans.
    Orthographic {
        /// Height of the view volume in world units (`top − bottom`).
        height: f64,
    },
}

/// Pixels one world unit spans on screen, across the view, `distance` world
/// units in front of the camera (perspective:
/// `viewport_height / (2 distance tan(fov_y / 2))`; orthographic:
/// `viewport_height / height`, at any distance). `viewport_height` is the
/// drawing buffer's height in pixels; `distance` is from the camera to the
/// nearest point of the object (its bounding sphere), in world units. A
/// perspective distance of 0 or less (the camera inside the object) gives
/// `+∞`: every error is too large to see through.
pub fn pixels_per_world_unit(projection: Projection, viewport_height: f64, distance: f64) -> f64 {
    match projection {
        Projection::Perspective { fov_y } => {
            if distance > 0.0 {
                viewport_height / (2.0 * distance * (fov_y / 2.0).tan())
            } else {
                f64::INFINITY
            }
        }
        Projection::Orthographic { height } => viewport_height / height,
    }
}

/// The diagonal of the file's bounding box (the header's bounds, which
/// hold every level; the quantization grid for files without them) in the
/// file's own units — the unit of every error bound. Multiply it by the
/// object's largest scale for world units. `None` before the header.
pub fn file_diagonal(dec: &Decoder) -> Option<f64> {
    let [lo, hi] = dec.bounds()?;
    Some(
        (0..3)
            .map(|k| (hi[k] - lo[k]) * (hi[k] - lo[k]))
            .sum::<f64>()
            .sqrt(),
    )
}

/// A level a client can stop at: level 0 or the level after a chunk, as
/// the header and the chunk table describe it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boundary {
    /// Records applied: 0, then the level after each chunk.
    pub level: usize,
    /// Faces of the level.
    pub faces: u32,
    /// Vertices of the level.
    pub vertices: u32,
    /// Geometric error (file units, spec §3).
    pub error: f64,
    /// File bytes needed to reach the level: the end of the base section
    /// for level 0, else the end of the chunk.
    pub bytes: u64,
}

/// Level 0 and the level after every chunk read so far, coarse to fine;
/// empty before the header.
pub fn boundaries(dec: &Decoder) -> Vec<Boundary> {
    let Some(h) = dec.header() else {
        return Vec::new();
    };
    let base_end = h.header_len as u64
        + h.chunk_count as u64 * h.chunk_entry_len as u64
        + 4
        + h.base_compressed_len as u64;
    let mut out = Vec::with_capacity(dec.chunks().len() + 1);
    out.push(Boundary {
        level: 0,
        faces: h.base_face_count,
        vertices: h.base_vertex_count,
        error: h.base_error as f64,
        bytes: base_end,
    });
    let mut level = 0usize;
    for c in dec.chunks() {
        level += c.record_count as usize;
        out.push(Boundary {
            level,
            faces: c.face_count,
            vertices: c.vertex_count,
            error: c.error as f64,
            bytes: c.offset + c.compressed_len as u64,
        });
    }
    out
}

/// The geometric error of level `level` (file units): the header's base
/// error at level 0, else the error of the last chunk boundary at or
/// before the level (errors never grow with the level, so a level between
/// two boundaries is at least as fine as the one before it). `None` before
/// the header. The level need not be decoded yet.
pub fn level_error(dec: &Decoder, level: usize) -> Option<f64> {
    boundaries(dec)
        .iter()
        .take_while(|b| b.level <= level)
        .last()
        .map(|b| b.error)
}

/// Bytes of the file needed to reach `t` — the end offset of the chunk
/// that gets there (the base section's end for level 0), from the header
/// and chunk table alone, for an HTTP range request: [`Target::Level`]
/// `k`, [`Target::Faces`] `n` (the finest level with at most `n` faces:
/// the first chunk that ends above `n` faces is needed, it may hold that
/// level) or [`Target::Error`] `e` (the first chunk boundary with error
/// ≤ `e`; the whole file when none is). `None` before the chunk table.
pub fn bytes_for(dec: &Decoder, t: Target) -> Option<u64> {
    if dec.chunks().len() != dec.header()?.chunk_count as usize {
        return None;
    }
    let all = boundaries(dec);
    // the first boundary that reaches `t` (level 0 included), else the end
    let reaches = |b: &Boundary| match t {
        Target::Level(k) => b.level >= k,
        Target::Faces(n) => b.faces as usize > n,
        Target::Error(e) => b.error <= e,
    };
    all.iter()
        .find(|b| reaches(b))
        .or(all.last())
        .map(|b| b.bytes)
}

/// Picks levels by screen-space error, with hysteresis: it refines as soon
/// as the view asks for a finer level, but coarsens only as far as
/// `max_screen_error / hysteresis` allows, so a view whose scale jitters by
/// less than `hysteresis` never flickers between two levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewLod {
    /// The largest error to draw, in pixels (> 0). Default 1.
    pub max_screen_error: f64,
    /// ≥ 1; 1 turns the hysteresis off. Default 1.5.
    pub hysteresis: f64,
}

impl Default for ViewLod {
    fn default() -> Self {
        ViewLod {
            max_screen_error: 1.0,
            hysteresis: 1.5,
        }
    }
}

/// What [`ViewLod::choose`] picked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewChoice {
    /// The level to draw.
    pub level: usize,
    /// The error the view asks for, in file units.
    pub target_error: f64,
    /// Pixels the chosen level's error bound spans.
    pub screen_error: f64,
    /// File bytes that reach the target ([`bytes_for`]).
    pub bytes_for: u64,
    /// How many of those have not been pushed yet (0 when the decoded
    /// levels suffice).
    pub bytes_needed: u64,
}

impl ViewLod {
    /// The error (file units) the view asks for: `max_screen_error` pixels
    /// at `pixels_per_world_unit` ([`pixels_per_world_unit`]) on an object
    /// whose file diagonal ([`file_diagonal`]) is `world_diagonal` world
    /// units long (the file's diagonal times the object's largest scale).
    pub fn target_error(&self, pixels_per_world_unit: f64, world_diagonal: f64) -> f64 {
        self.max_screen_error / (pixels_per_world_unit * world_diagonal)
    }

    /// The level to draw from the decoder's current level: the coarsest
    /// decoded level whose error is at most the target (the deepest decoded
    /// one if none is), reached at once when finer than the current level;
    /// a coarser one only as far as `target / hysteresis` allows.
    /// `Parameter` errors for a budget that is not positive, a hysteresis
    /// below 1, or no base mesh yet.
    pub fn choose(
        &self,
        dec: &Decoder,
        pixels_per_world_unit: f64,
        world_diagonal: f64,
    ) -> Result<ViewChoice, DecodeError> {
        if !(self.max_screen_error > 0.0 && self.hysteresis >= 1.0) {
            return Err(DecodeError::Parameter(format!(
                "ViewLod needs max_screen_error > 0 and hysteresis >= 1, got {} and {}",
                self.max_screen_error, self.hysteresis
            )));
        }
        let scale = pixels_per_world_unit * world_diagonal;
        let target_error = self.max_screen_error / scale;
        let want = dec.resolve(Target::Error(target_error))?;
        let current = dec.level();
        let level = if want > current {
            want
        } else if want < current {
            current.min(dec.resolve(Target::Error(target_error / self.hysteresis))?)
        } else {
            current
        };
        let e = level_error(dec, level).unwrap_or(f64::INFINITY);
        let bytes_for = bytes_for(dec, Target::Error(target_error)).unwrap_or(0);
        let s = dec.status();
        Ok(ViewChoice {
            level,
            target_error,
            // an exact level spans no pixel, even up close
            screen_error: if e == 0.0 { 0.0 } else { e * scale },
            bytes_for,
            bytes_needed: bytes_for.saturating_sub(s.bytes_consumed + s.bytes_buffered),
        })
    }

    /// [`ViewLod::choose`], then moves the decoder there; the [`Change`]
    /// is empty when the level stays.
    pub fn update(
        &self,
        dec: &mut Decoder,
        pixels_per_world_unit: f64,
        world_diagonal: f64,
    ) -> Result<(ViewChoice, Change), DecodeError> {
        let choice = self.choose(dec, pixels_per_world_unit, world_diagonal)?;
        let change = dec.set_level(Target::Level(choice.level))?;
        Ok((choice, change))
    }
}
