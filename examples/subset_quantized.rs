//! Inverted corners of subset-placement levels after quantization — a
//! development aid for `Placement::Subset` (what `pqm encode` uses).
//!
//! `cargo run --release --example subset_quantized -- IN [BITS]`
//!
//! Coarsens `IN` as `pqm encode` does by default (subset placement, as far
//! as the rules allow), writes the file with the default encoder options
//! (`BITS` per axis, default 14), decodes it and walks every level that
//! lies between whole coarsening steps (not after a doublet re-insertion,
//! whose step is half done; about 2,000 of them spread over a large file),
//! measuring each quad's Scaled Jacobian on the
//! decoded (quantized) positions. Prints the base size, the file's bits per
//! vertex, and how many of those levels have an inverted corner (and the
//! worst), before quantization and after.
use pqm::core::coarsen::{CoarsenOptions, Coarsener, Placement};
use pqm::core::progressive::OpKind;
use pqm::core::{io, ops, subdivide, Mesh};
use pqm::format::{decode_all, write_to_vec, EncodeOptions, Limits, Target};

fn worst_sj(pos: &[glam::DVec3], quads: &[[u32; 4]]) -> f64 {
    quads
        .iter()
        .map(|q| ops::quad_scaled_jacobian(q.map(|v| pos[v as usize])))
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = std::path::Path::new(&args[0]);
    let bits: u8 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(14);
    let mut im = io::read_mesh(path).expect("read");
    if !im.is_quad_only() {
        im = subdivide::catmull_clark_split(&im, subdivide::SplitMode::Linear).expect("split");
    }
    let mesh = Mesh::from_indexed(&im).expect("mesh");
    let opts = CoarsenOptions {
        placement: Placement::Subset,
        ..Default::default()
    };
    let mut c = Coarsener::with_defaults(mesh, 60.0, &[], opts).expect("features");
    c.run(&mut |_| {});
    let pm = c.into_progressive();
    let eopts = EncodeOptions {
        bits,
        ..Default::default()
    };
    let (bytes, _) = write_to_vec(&pm, &eopts).expect("encode");
    let mut d = decode_all(&bytes, Limits::default()).expect("decode");
    let n = pm.records.len();
    let (mut levels, mut bad_exact, mut bad_quant) = (0usize, 0usize, 0usize);
    let (mut worst_exact, mut worst_quant) = (f64::INFINITY, f64::INFINITY);
    // every level of a small file, about 2,000 spread over a large one
    let stride = (n / 2000).max(1);
    for k in (0..=n).step_by(stride) {
        if k > 0 && pm.records[k - 1].op == OpKind::Doublet {
            continue;
        }
        levels += 1;
        let (pos, quads) = pm.level_quads(k);
        let w = worst_sj(&pos, &quads);
        worst_exact = worst_exact.min(w);
        bad_exact += (w < 0.0) as usize;
        d.set_level(Target::Level(k)).expect("level");
        let w = worst_sj(&d.positions_f64(), d.quads());
        worst_quant = worst_quant.min(w);
        bad_quant += (w < 0.0) as usize;
    }
    println!(
        "{}: {} -> {} base faces, {} records, {:.1} bits per input vertex ({} bytes, {bits}-bit); \
         whole-step levels checked {levels}: inverted exact {bad_exact} (worst {worst_exact:.4}), \
         quantized {bad_quant} (worst {worst_quant:.4})",
        path.display(),
        im.face_count(),
        pm.base.face_count(),
        n,
        8.0 * bytes.len() as f64 / im.positions.len() as f64,
        bytes.len()
    );
}
