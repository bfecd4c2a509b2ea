//! View-dependent level of detail (`pqm_format::view`): the projection rule
//! agrees with glam's projection matrices; the level chosen is the coarsest
//! whose error the view cannot see, so a camera approaching refines and a
//! receding one coarsens; the hysteresis keeps a level between what the view
//! asks for and what `budget / hysteresis` allows, and a jitter smaller than
//! it never turns back; `bytes_for` is exactly the prefix of the file that
//! reaches a target.

use glam::{DMat4, DVec3, DVec4};
use pqm_core::progressive::testgen::{self, GenOptions};
use pqm_format::view::{
    bytes_for, file_diagonal, level_error, pixels_per_world_unit, Projection, ViewLod,
};
use pqm_format::{write_to_vec, DecodeError, Decoder, EncodeOptions, Limits, Target};
use proptest::prelude::*;

/// A file of several chunks with its decoder, fully decoded.
fn file(seed: u64, splits: usize, chunk_bytes: usize) -> (Vec<u8>, Decoder) {
    let pm = testgen::generate_with(&GenOptions::new(seed, splits));
    let opts = EncodeOptions {
        chunk_bytes,
        ..EncodeOptions::default()
    };
    let bytes = write_to_vec(&pm, &opts).expect("encode").0;
    let mut dec = Decoder::new(Limits::default());
    dec.push(&bytes).expect("decode");
    (bytes, dec)
}

/// Level 0 and every chunk boundary, with their error bounds.
fn boundaries(dec: &Decoder) -> Vec<(usize, f64)> {
    let mut out = vec![(0, dec.header().unwrap().base_error as f64)];
    let mut at = 0;
    for c in dec.chunks() {
        at += c.record_count as usize;
        out.push((at, c.error as f64));
    }
    out
}

/// Pixels between two points projected by `m` on a viewport `height` tall (vertical).
fn projected_height(m: DMat4, a: DVec3, b: DVec3, height: f64) -> f64 {
    let ndc = |p: DVec3| {
        let c = m * DVec4::new(p.x, p.y, p.z, 1.0);
        c.y / c.w
    };
    (ndc(b) - ndc(a)).abs() / 2.0 * height
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// What a segment `len` long, `d` in front of the camera, measures on
    /// screen under glam's projection matrices.
    #[test]
    fn pixels_per_world_unit_is_the_projection_scale(
        fov_deg in 5.0f64..150.0, aspect in 0.3f64..3.0, height in 100.0f64..4000.0,
        d in 0.01f64..1000.0, len in 0.001f64..10.0, half in 0.1f64..100.0,
    ) {
        let (a, b) = (DVec3::new(0.0, -len / 2.0, -d), DVec3::new(0.0, len / 2.0, -d));
        let fov_y = fov_deg.to_radians();
        let persp = DMat4::perspective_rh(fov_y, aspect, 0.001, 1e6);
        let want = projected_height(persp, a, b, height);
        let got = len * pixels_per_world_unit(Projection::Perspective { fov_y }, height, d);
        prop_assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        let ortho = DMat4::orthographic_rh(-half * aspect, half * aspect, -half, half, 0.001, 1e6);
        let want = projected_height(ortho, a, b, height);
        let proj = Projection::Orthographic { height: 2.0 * half };
        let got = len * pixels_per_world_unit(proj, height, d);
        prop_assert!((got - want).abs() <= 1e-9 * want, "{got} vs {want}");
        prop_assert_eq!(pixels_per_world_unit(proj, height, -d), pixels_per_world_unit(proj, height, d));
        prop_assert_eq!(pixels_per_world_unit(Projection::Perspective { fov_y }, height, 0.0), f64::INFINITY);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// With no hysteresis, a camera approaching from far away refines level
    /// by level to the finest, each level the coarsest boundary whose error
    /// fits the budget, and receding coarsens back to the base.
    #[test]
    fn approaching_refines_receding_coarsens(
        seed in any::<u64>(), splits in 50usize..400, chunk_bytes in 64usize..1024,
        budget in 0.25f64..8.0, fov_deg in 20.0f64..100.0,
    ) {
        let (_, mut dec) = file(seed, splits, chunk_bytes);
        let lod = ViewLod { max_screen_error: budget, hysteresis: 1.0 };
        let proj = Projection::Perspective { fov_y: fov_deg.to_radians() };
        let diag = file_diagonal(&dec).unwrap();
        let bounds = boundaries(&dec);
        let deepest = dec.deepest_level().unwrap();
        let mut ds = Vec::new();
        let mut d = diag * 1e6;
        while d > diag * 1e-6 {
            ds.push(d);
            d /= 1.4;
        }
        let path: Vec<f64> = ds.iter().chain(ds.iter().rev()).copied().collect();
        let mut levels = Vec::new();
        for &d in &path {
            let ppu = pixels_per_world_unit(proj, 1000.0, d);
            let (v, _) = lod.update(&mut dec, ppu, diag).unwrap();
            prop_assert_eq!(v.level, dec.level());
            let scale = ppu * diag;
            prop_assert!(v.screen_error <= budget * (1.0 + 1e-9) || v.level == deepest);
            let e = level_error(&dec, v.level).unwrap();
            if e > 0.0 {
                prop_assert!((v.screen_error - e * scale).abs() <= 1e-9 * v.screen_error);
            }
            // no coarser boundary would do
            for &(l, e) in bounds.iter().filter(|b| b.0 < v.level) {
                prop_assert!(e * scale > budget, "level {l} ({e}) would do for {}", v.level);
            }
            prop_assert_eq!(v.bytes_needed, 0);
            levels.push(v.level);
        }
        let n = ds.len();
        prop_assert!(levels[..n].windows(2).all(|w| w[1] >= w[0]), "approaching refines: {levels:?}");
        prop_assert!(levels[n..].windows(2).all(|w| w[1] <= w[0]), "receding coarsens: {levels:?}");
        prop_assert_eq!(levels[0], 0);
        prop_assert_eq!(levels[n - 1], deepest);
        prop_assert_eq!(*levels.last().unwrap(), 0);
    }

    /// With hysteresis `h`, every level lies between what the view asks for
    /// and what `budget / h` allows; the decoder moves only when it was
    /// outside that; a jitter of the view's scale by less than `h` never
    /// turns back, and after settling from the base at the jitter's nearest
    /// point it does not move at all.
    #[test]
    fn hysteresis_keeps_a_jittering_view_on_one_level(
        seed in any::<u64>(), splits in 50usize..400, chunk_bytes in 64usize..1024,
        h in 1.1f64..3.0, walk in prop::collection::vec((-8.0f64..4.0, prop::collection::vec(0.0f64..1.0, 8)), 1..40),
    ) {
        let (_, mut dec) = file(seed, splits, chunk_bytes);
        let lod = ViewLod { max_screen_error: 1.0, hysteresis: h };
        let diag = file_diagonal(&dec).unwrap();
        let proj = Projection::Orthographic { height: diag };
        // jitter within a factor f < h
        let f = h.sqrt();
        for (log_zoom, jitter) in walk {
            let ppu = pixels_per_world_unit(proj, 1000.0, 1.0) * 10f64.powf(log_zoom);
            let before = dec.level();
            let (v, change) = lod.update(&mut dec, ppu, diag).unwrap();
            let want = dec.resolve(Target::Error(v.target_error)).unwrap();
            let keep = dec.resolve(Target::Error(v.target_error / h)).unwrap();
            prop_assert!(want <= v.level && v.level <= keep, "{want} <= {} <= {keep}", v.level);
            prop_assert_eq!(change.is_empty(), want <= before && before <= keep);
            let mut seen = vec![dec.level()];
            for &j in &jitter {
                lod.update(&mut dec, ppu * f.powf(j), diag).unwrap();
                seen.push(dec.level());
            }
            let steps: Vec<i64> = seen.windows(2).map(|w| (w[1] as i64 - w[0] as i64).signum()).filter(|&s| s != 0).collect();
            prop_assert!(steps.iter().all(|&s| s == steps[0]), "jitter turned back: {seen:?}");
            dec.set_level(Target::Level(0)).unwrap();
            lod.update(&mut dec, ppu * f, diag).unwrap();
            for &j in &jitter {
                let (_, change) = lod.update(&mut dec, ppu * f.powf(j), diag).unwrap();
                prop_assert!(change.is_empty(), "settled, yet the jitter moved it");
            }
        }
    }

    /// `bytes_for(t)` is the shortest prefix that reaches `t`: pushed, the
    /// decoder resolves `t` to the level the whole file gives; one byte
    /// fewer does not get there (past the base; for a face count, whose
    /// level the table cannot place inside its chunk, not further).
    /// `ViewLod` reports the bytes it still lacks.
    #[test]
    fn bytes_for_is_the_prefix_that_reaches_a_target(
        seed in any::<u64>(), splits in 50usize..300, chunk_bytes in 64usize..1024,
        which in 0usize..3, x in 0.0f64..1.0,
    ) {
        let (bytes, whole) = file(seed, splits, chunk_bytes);
        let h = whole.header().unwrap();
        let t = match which {
            0 => Target::Level((x * h.record_count as f64) as usize),
            1 => Target::Faces(h.base_face_count as usize + (x * (h.final_face_count - h.base_face_count) as f64) as usize),
            _ => Target::Error(x * h.base_error as f64),
        };
        let n = bytes_for(&whole, t).unwrap() as usize;
        prop_assert!(n <= bytes.len());
        let goal = whole.resolve(t).unwrap();
        let mut dec = Decoder::new(Limits::default());
        dec.push(&bytes[..n]).unwrap();
        prop_assert_eq!(dec.resolve(t).unwrap(), goal, "{:?} after {} bytes", t, n);
        prop_assert_eq!(bytes_for(&dec, t), Some(n as u64));
        let base_end = bytes_for(&whole, Target::Level(0)).unwrap() as usize;
        if n > base_end {
            let mut short = Decoder::new(Limits::default());
            short.push(&bytes[..n - 1]).unwrap();
            if let Target::Faces(_) = t {
                // the table gives face counts at chunk ends only: the
                // chunk that ends above n faces may hold the level, or
                // start with it
                prop_assert!(short.resolve(t).unwrap() <= goal);
            } else {
                prop_assert!(short.deepest_level().unwrap() < goal);
            }
            if let Target::Error(e) = t {
                // the view asks for that error: one byte is missing
                let diag = file_diagonal(&short).unwrap();
                let lod = ViewLod { max_screen_error: 1.0, hysteresis: 1.0 };
                let v = lod.choose(&short, 1.0 / (e * diag), diag).unwrap();
                prop_assert!((v.target_error - e).abs() <= 1e-12 * e.max(1e-300));
                prop_assert_eq!(v.bytes_needed, 1);
            }
        }
    }
}

#[test]
fn before_the_base_and_bad_budgets_are_parameter_errors() {
    let (bytes, _) = file(3, 100, 256);
    let mut dec = Decoder::new(Limits::default());
    assert_eq!(file_diagonal(&dec), None);
    assert_eq!(level_error(&dec, 0), None);
    assert_eq!(bytes_for(&dec, Target::Level(0)), None);
    dec.push(&bytes[..100]).unwrap(); // the header, not the chunk table
    assert!(matches!(
        ViewLod::default().choose(&dec, 1.0, 1.0),
        Err(DecodeError::Parameter(_))
    ));
    dec.push(&bytes[100..]).unwrap();
    for lod in [
        ViewLod {
            max_screen_error: 0.0,
            hysteresis: 1.5,
        },
        ViewLod {
            max_screen_error: f64::NAN,
            hysteresis: 1.5,
        },
        ViewLod {
            max_screen_error: 1.0,
            hysteresis: 0.9,
        },
    ] {
        assert!(matches!(
            lod.choose(&dec, 1.0, 1.0),
            Err(DecodeError::Parameter(_))
        ));
    }
    // a camera inside the object asks for the finest level, whose error is 0
    let v = ViewLod::default()
        .choose(&dec, f64::INFINITY, file_diagonal(&dec).unwrap())
        .unwrap();
    assert_eq!(Some(v.level), dec.deepest_level());
    assert_eq!(v.screen_error, 0.0);
}
