//! Shared by the `decode` and `buf_independent` fuzz targets: a file
//! pushed whole and pushed in pieces must decode alike — the pieces into
//! the same decoder after [`Decoder::reset`], so a reset decoder must
//! also decode as a fresh one does, whatever the file before left in it.

use pqm_format::{Decoder, Limits, Target};

/// The decoders' budget under fuzzing (large enough for the vectors, small
/// enough that a hostile header is refused quickly).
fn limits() -> Limits {
    Limits {
        max_vertices: 1 << 20,
        max_faces: 1 << 20,
        max_memory_bytes: 256 << 20,
    }
}

/// What [`outcome`] observes (`d` reset, then fed the parts): whether every push succeeded, the events,
/// the deepest level, its mesh, and the mesh of the level halfway.
type Outcome = (
    bool,
    Vec<pqm_format::Event>,
    Option<usize>,
    Vec<[u32; 4]>,
    Vec<[u32; 3]>,
    Vec<[u32; 4]>,
    Vec<[u32; 3]>,
);

fn outcome(d: &mut Decoder, parts: &[&[u8]]) -> Outcome {
    d.reset(limits());
    let mut events = Vec::new();
    let mut ok = true;
    for p in parts {
        match d.push(p) {
            Ok(e) => events.extend(e),
            Err(_) => {
                ok = false;
                break;
            }
        }
    }
    let _ = d.status();
    let mut mid = (Vec::new(), Vec::new());
    if let Some(deepest) = d.deepest_level() {
        let c = d
            .set_level(Target::Level(usize::MAX))
            .expect("reachable level");
        assert_eq!(Some(c.to_level), d.deepest_level());
        let back = d.set_level(Target::Level(0)).expect("level 0");
        assert_eq!(back.to_level, 0);
        // A replay below the deepest level (the records' new codes and
        // quads unwound from the frontier), then up again.
        d.set_level(Target::Level(deepest / 2))
            .expect("level halfway");
        mid = (d.quads().to_vec(), d.position_codes().to_vec());
        d.set_level(Target::Level(usize::MAX))
            .expect("refine again");
    }
    (
        ok,
        events,
        d.deepest_level(),
        d.quads().to_vec(),
        d.position_codes().to_vec(),
        mid.0,
        mid.1,
    )
}

/// `d`, a [`Decoder::forward_only`] decoder, reset then fed the parts:
/// whether every push succeeded, the deepest level and its mesh.
fn forward(
    d: &mut Decoder,
    parts: &[&[u8]],
) -> (bool, Option<usize>, Vec<[u32; 4]>, Vec<[u32; 3]>) {
    d.reset(limits());
    let mut ok = true;
    for p in parts {
        if d.push(p).is_err() {
            ok = false;
            break;
        }
    }
    if d.deepest_level().is_some() {
        let c = d
            .refine_to(Target::Level(usize::MAX))
            .expect("deepest level");
        assert_eq!(Some(c.to_level), d.deepest_level());
    }
    (
        ok,
        d.deepest_level(),
        d.quads().to_vec(),
        d.position_codes().to_vec(),
    )
}

/// `bytes` pushed whole and cut at `cuts` (positions into `bytes`, any
/// order, clamped) must give the same outcome, the same events and the
/// same deepest level and mesh; a [`Decoder::forward_only`] decoder fed the
/// pieces must reach the same outcome, deepest level and mesh.
pub fn check_pieces(bytes: &[u8], cuts: &[usize]) {
    let mut cuts: Vec<usize> = cuts.iter().map(|&c| c.min(bytes.len())).collect();
    cuts.sort_unstable();
    let mut parts = Vec::with_capacity(cuts.len() + 1);
    let mut at = 0;
    for &c in &cuts {
        parts.push(&bytes[at..c]);
        at = c;
    }
    parts.push(&bytes[at..]);
    // One decoder for both: the split decode runs after a reset from the
    // whole one (with its moves down and up, and any error).
    let mut d = Decoder::new(limits());
    let whole = outcome(&mut d, &[bytes]);
    let split = outcome(&mut d, &parts);
    // Once an error happened, events after it are lost either way; the
    // levels decoded before the error must agree.
    assert_eq!(whole.0, split.0);
    if whole.0 {
        assert_eq!(whole.1, split.1);
    }
    assert_eq!(whole.2, split.2);
    assert_eq!(whole.3, split.3);
    assert_eq!(whole.4, split.4);
    assert_eq!(whole.5, split.5);
    assert_eq!(whole.6, split.6);
    // The one-way decoder keeps the same deepest level, error or not (fed
    // the whole file first, then reset: the pieces are its second file).
    let mut f = Decoder::forward_only(limits());
    forward(&mut f, &[bytes]);
    let fwd = forward(&mut f, &parts);
    assert_eq!(whole.0, fwd.0);
    assert_eq!(whole.2, fwd.1);
    assert_eq!(whole.3, fwd.2);
    assert_eq!(whole.4, fwd.3);
}
