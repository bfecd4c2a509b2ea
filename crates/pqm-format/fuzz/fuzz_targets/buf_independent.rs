//! Fuzz where the input is cut: a `.pqm` file pushed to the decoder whole,
//! in pieces at up to 15 points the input chooses, and (files up to 2 KiB)
//! one byte at a time must give the same outcome, events, deepest level and
//! mesh, and the forward-only decoder the same deepest level and mesh
//! (`split_check.rs`). Issue 4: split points must not change the result.
//!
//! Input: one byte `k`, then `k % 16` cut positions as u16 little-endian
//! (taken modulo the file length + 1), then the file.
//! `cargo fuzz run buf_independent -s none` from `crates/pqm-format`; seed
//! corpus: `spec/vectors/*.pqm`, each prefixed with a zero byte.
#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "split_check.rs"]
mod split_check;

fuzz_target!(|data: &[u8]| {
    let Some((&k, rest)) = data.split_first() else {
        return;
    };
    let k = (k % 16) as usize;
    if rest.len() < 2 * k {
        return;
    }
    let (cut_bytes, file) = rest.split_at(2 * k);
    let cuts: Vec<usize> = cut_bytes
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize % (file.len() + 1))
        .collect();
    split_check::check_pieces(file, &cuts);
    if file.len() <= 2048 {
        let every: Vec<usize> = (1..file.len()).collect();
        split_check::check_pieces(file, &every);
    }
});
