//! Writes a procedural shape to a mesh file (development aid).
//! `cargo run -p pqm-core --example write_shape -- torus|sphere|bumpy OUT [n]`
use pqm_core::{io, shapes};
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let n: u32 = a.get(2).and_then(|x| x.parse().ok()).unwrap_or(60);
    let m = match a[0].as_str() {
        "torus" => shapes::torus(2 * n, n, 3.0, 1.0),
        "sphere" => shapes::quad_sphere(n, 1.0),
        _ => shapes::bumpy_torus(2 * n, n, 3.0, 1.0, 0.05, 1),
    };
    io::write_mesh(std::path::Path::new(&a[1]), &m).expect("write");
}
