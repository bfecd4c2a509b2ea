//! Files of a coarsening in rounds (`CoarsenOptions::round_fraction`, what
//! `pqm encode` can use): every level decodes to the progressive mesh's
//! level exactly, and the sorted anchors make the `refs` stream smaller.

use pqm_core::ProgressiveMesh;
use pqm_format::*;

mod common;

#[test]
fn every_level_of_a_file_in_rounds_decodes_exactly() {
    let pm = common::coarsened_torus(Some(0.1));
    let n = pm.records.len();
    assert!(n > 300, "{n} records");
    let opts = EncodeOptions {
        chunk_records: Some(97),
        ..EncodeOptions::default()
    };
    let (bytes, _) = write_to_vec(&pm, &opts).unwrap();
    let mut dec = decode_all(&bytes, Limits::default()).unwrap();
    common::assert_every_level_down_and_up(&mut dec, &pm);
}

#[test]
fn rounds_make_vertex_references_cheaper() {
    let per_record = |pm: &ProgressiveMesh| {
        let (_, report) = write_to_vec(pm, &EncodeOptions::default()).unwrap();
        report.stream_raw_bytes[2] as f64 / pm.records.len() as f64
    };
    let (one, rounds) = (
        per_record(&common::coarsened_torus(None)),
        per_record(&common::coarsened_torus(Some(0.1))),
    );
    assert!(
        rounds < one,
        "refs bytes per record: {rounds:.2} in rounds, {one:.2} one step at a time"
    );
}
