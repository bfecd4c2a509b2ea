//! The single quantization grid of a `.pqm` file (spec §5).
//!
//! One grid over the bounding box of *every* position the file ever shows
//! (base, appended and moved), shared by all levels, so a vertex never changes
//! code between levels and predictions work in integers. With `b` bits,
//! `qmax = 2^b − 1` and per axis `step = (max − min) / qmax` (f64); a code `q`
//! in `0..=qmax` dequantizes to `min + (q as f64) * step`, evaluated in f64 in
//! exactly that order so that every IEEE-754 implementation (JavaScript
//! included) gets bit-identical positions.

use glam::DVec3;

/// Which grid a writer lays over the positions (spec §5). Both are
/// ordinary `.pqm` grids: every 3.x reader decodes either.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Grid {
    /// Every axis spans the positions' largest extent, so all three steps
    /// are that extent over `2^bits − 1` — Draco's and gltfpack's
    /// quantization: `bits` bounds the error by half a step of the largest
    /// extent on every axis. The header then carries the positions' exact
    /// bounds (spec §3, version 3.2). 0.6–3.0 bits per vertex smaller
    /// than [`Grid::Box`] on the bench meshes (flat meshes the most).
    #[default]
    Cube,
    /// Each axis spans its own extent (the only grid before 3.2): finer
    /// steps on the shorter axes, so more bits per coordinate there.
    Box,
}

impl Grid {
    /// The grid's `(bbox_min, bbox_max)` for positions whose exact box is
    /// `lo ..= hi` (finite, `lo <= hi`). For [`Grid::Cube`] each axis's
    /// maximum is `max(hi, lo + e)` with `e` the largest extent, so the
    /// grid holds every position whatever the rounding of `lo + e`; the
    /// result may be infinite if `lo + e` overflows (callers check).
    pub fn over(self, lo: [f64; 3], hi: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        match self {
            Grid::Box => (lo, hi),
            Grid::Cube => {
                let e = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
                (lo, [0, 1, 2].map(|k| hi[k].max(lo[k] + e)))
            }
        }
    }
}

/// Quantization grid: bounding box and bit count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantizer {
    /// Grid origin (bounding-box minimum), per axis.
    pub min: [f64; 3],
    /// Bounding-box maximum, per axis.
    pub max: [f64; 3],
    /// Bits per axis, 8..=24.
    pub bits: u8,
    step: [f64; 3],
}

impl Quantizer {
    /// The grid over `[min, max]` with `bits` bits per axis (`min <= max`,
    /// finite; `bits` in 8..=24 — callers check).
    pub fn new(min: [f64; 3], max: [f64; 3], bits: u8) -> Self {
        let qmax = Self::qmax_of(bits) as f64;
        let step = [0, 1, 2].map(|k| (max[k] - min[k]) / qmax);
        Quantizer {
            min,
            max,
            bits,
            step,
        }
    }

    /// Largest code, `2^bits − 1`.
    pub fn qmax(&self) -> u32 {
        Self::qmax_of(self.bits)
    }

    fn qmax_of(bits: u8) -> u32 {
        ((1u64 << bits) - 1) as u32
    }

    /// Grid step per axis (0 on a flat axis).
    pub fn step(&self) -> [f64; 3] {
        self.step
    }

    /// Nearest code of `p` (clamped to the grid).
    pub fn quantize(&self, p: DVec3) -> [u32; 3] {
        let p = p.to_array();
        let qmax = self.qmax();
        [0, 1, 2].map(|k| {
            if self.step[k] > 0.0 {
                ((p[k] - self.min[k]) / self.step[k])
                    .round()
                    .clamp(0.0, qmax as f64) as u32
            } else {
                0
            }
        })
    }

    /// Dequantized position of code `q`: `min + q * step`, in f64.
    pub fn dequantize(&self, q: [u32; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| self.min[k] + (q[k] as f64) * self.step[k])
    }

    /// [`Quantizer::dequantize`] as a `DVec3`.
    pub fn dequantize_vec(&self, q: [u32; 3]) -> DVec3 {
        DVec3::from_array(self.dequantize(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_is_at_most_half_a_step_and_codes_are_stable() {
        let q = Quantizer::new([-1.0, 0.0, 5.0], [3.0, 0.0, 6.0], 14);
        for i in 0..1000 {
            let t = i as f64 / 999.0;
            let p = DVec3::new(-1.0 + 4.0 * t, 0.0, 5.0 + t * t);
            let c = q.quantize(p);
            let d = q.dequantize_vec(c);
            assert!((d - p).abs().max_element() <= 0.5 * q.step()[0].max(q.step()[2]) + 1e-12);
            assert_eq!(
                q.quantize(d),
                c,
                "re-quantizing a grid point keeps its code"
            );
        }
        assert!((q.dequantize([q.qmax(); 3])[0] - 3.0).abs() < 1e-12);
    }
}
