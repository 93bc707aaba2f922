//! The model reader survives any input: the bundled model files with random splices of
//! hostile tokens and random truncations, 10,000 cases; refusals are fine, panics and stack
//! overflows are not. (Validation only: no Symbolica call.)

use codegen::model::Model;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const TOKENS: &[&str] = &[
    "(",
    ")",
    "((((((((((((((((",
    "-",
    "- - - -",
    "1e308",
    "nan",
    "/0",
    "^",
    "^99",
    "\"",
    "[",
    "]",
    "[[",
    "=",
    "\n",
    "#",
    ",",
    "sin(",
    "q0",
    "pi",
    "é",
    "\u{0}",
];

fn seeds() -> Vec<String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../model");
    ["freedom6s.toml", "planar2r.toml", "emps.toml"]
        .iter()
        .map(|f| std::fs::read_to_string(dir.join(f)).unwrap())
        .collect()
}

/// `seed` with `edits` applied: each (position as a fraction of the length, token index,
/// truncate?) splices a token in, or cuts the text there.
fn mutate(seed: &str, edits: &[(f64, usize, bool)]) -> String {
    let mut b = seed.as_bytes().to_vec();
    for &(p, k, cut) in edits {
        let i = ((p * b.len() as f64) as usize).min(b.len());
        if cut {
            b.truncate(i);
        } else {
            b.splice(i..i, TOKENS[k].bytes());
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

#[test]
fn mutated_model_files_are_refused_or_read_never_a_panic() {
    let seeds = seeds();
    let n = seeds.len();
    let edit = (0.0..1.0f64, 0..TOKENS.len(), prop::bool::weighted(0.05));
    let config = ProptestConfig {
        cases: 10_000,
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    proptest!(config, |(k in 0..n, edits in prop::collection::vec(edit, 1..6))| {
        let text = mutate(&seeds[k], &edits);
        let _ = Model::from_toml(Path::new("model/fuzz.toml"), &text);
    });
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    for deep in [
        format!("{}q0{}", "(".repeat(200_000), ")".repeat(200_000)),
        format!("{}q0", "-".repeat(200_000)),
    ] {
        let e = codegen::expr::Expr::parse(&deep).unwrap_err();
        assert!(e.message.contains("nested deeper than 64"), "{}", e.message);
    }
    assert!(codegen::expr::Expr::parse(&format!("{}q0{}", "(".repeat(64), ")".repeat(64))).is_ok());
}
