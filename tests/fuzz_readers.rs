//! Every reader of user input survives any input: valid files of each kind mutated at
//! random (bytes flipped, inserted, deleted, duplicated, truncated; tokens such as `1e308`,
//! `nan`, `[[`, `((((` spliced in) and random bytes, 10,000 cases per reader. A reader may
//! refuse (that is the point) but never panic, never hang and never abort.
//!
//! The mutations are proptest strategies, so a failure is shrunk to a small input and
//! printed; nothing is persisted between runs (the cases are seeded afresh each run).

use lockstep::control::closedloop::ClosedLoop;
use lockstep::control::fuzzy::Fam;
use lockstep::control::WallSetup;
use lockstep::excitation::Excitations;
use lockstep::measurement::{Measurement, Table};
use lockstep::plant::Plant;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const CASES: u32 = 10_000;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: CASES,
        failure_persistence: None,
        max_shrink_iters: 2000,
        ..ProptestConfig::default()
    }
}

/// One edit of a byte string; positions are fractions of its length (so they stay valid).
#[derive(Debug, Clone)]
enum Edit {
    Flip(f64, u8),
    Insert(f64, u8),
    Delete(f64, usize),
    Duplicate(f64, usize),
    Truncate(f64),
    Splice(f64, usize),
}

/// Tokens that broke readers before (overflow, NaN, nesting, quoting, TOML structure).
const TOKENS: &[&str] = &[
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    "0",
    "-",
    ",",
    ",,",
    "\n",
    "\"",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "=",
    "((((((((",
    ")",
    "#",
    "\u{0}",
    "é",
    "9999999999999999999999",
    "-0",
    "1/0",
];

fn edit() -> impl Strategy<Value = Edit> {
    let at = 0.0..1.0f64;
    prop_oneof![
        (at.clone(), any::<u8>()).prop_map(|(p, b)| Edit::Flip(p, b)),
        (at.clone(), any::<u8>()).prop_map(|(p, b)| Edit::Insert(p, b)),
        (at.clone(), 1..64usize).prop_map(|(p, n)| Edit::Delete(p, n)),
        (at.clone(), 1..256usize).prop_map(|(p, n)| Edit::Duplicate(p, n)),
        at.clone().prop_map(Edit::Truncate),
        (at, 0..TOKENS.len()).prop_map(|(p, k)| Edit::Splice(p, k)),
    ]
}

fn apply(seed: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for e in edits {
        let at = |p: f64, len: usize| ((p * len as f64) as usize).min(len);
        match *e {
            Edit::Flip(p, x) => {
                if !b.is_empty() {
                    let i = at(p, b.len() - 1);
                    b[i] ^= x;
                }
            }
            Edit::Insert(p, x) => {
                let i = at(p, b.len());
                b.insert(i, x);
            }
            Edit::Delete(p, n) => {
                let i = at(p, b.len());
                let j = (i + n).min(b.len());
                b.drain(i..j);
            }
            Edit::Duplicate(p, n) => {
                let i = at(p, b.len());
                let j = (i + n).min(b.len());
                let piece = b[i..j].to_vec();
                b.splice(j..j, piece);
            }
            Edit::Truncate(p) => {
                let i = at(p, b.len());
                b.truncate(i);
            }
            Edit::Splice(p, k) => {
                let i = at(p, b.len());
                b.splice(i..i, TOKENS[k].bytes());
            }
        }
    }
    b.truncate(64 * 1024);
    b
}

/// A mutated seed (1 to 8 edits) or, one case in ten, random bytes.
fn input(seeds: Vec<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    let n = seeds.len();
    prop_oneof![
        9 => (0..n, prop::collection::vec(edit(), 1..8))
            .prop_map(move |(k, e)| apply(&seeds[k], &e)),
        1 => prop::collection::vec(any::<u8>(), 0..2048),
    ]
}

fn read(p: &str) -> Vec<u8> {
    std::fs::read(root().join(p)).unwrap()
}

/// The first `rows` lines of a file.
fn head(p: &str, rows: usize) -> Vec<u8> {
    let text = String::from_utf8(read(p)).unwrap();
    let mut out: String = text.lines().take(rows).collect::<Vec<_>>().join("\n");
    out.push('\n');
    out.into_bytes()
}

/// Writes a case's bytes to a new file at `path`. The old file is unlinked first: truncating
/// it in place makes ext4 wait for the previous case's data to reach the disk (its
/// replace-by-truncate heuristic flushes on close; figures in the build-and-CI record).
fn write(path: &Path, bytes: &[u8]) {
    let _ = std::fs::remove_file(path);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn csv_records_and_their_side_files() {
    let d = tempfile::tempdir().unwrap();
    let (csv, side) = (d.path().join("r.csv"), d.path().join("r.toml"));
    let seeds = vec![
        head("data/emps/emps_train.csv", 80),
        b"t,tau0,q0,qd0\n0,1,0,0\n0.01,1,1e-4,0.01\n0.02,1,4e-4,0.02\n".to_vec(),
    ];
    let sides = vec![read("data/emps/emps_train.toml")];
    proptest!(config(), |(c in input(seeds.clone()), s in input(sides.clone()), with_side in any::<bool>())| {
        write(&csv, &c);
        if with_side { write(&side, &s) } else { let _ = std::fs::remove_file(&side); }
        let _ = Measurement::read(&csv, &["q0"]);
        let _ = Table::read(&csv);
    });
}

#[test]
fn mat_files() {
    let d = tempfile::tempdir().unwrap();
    let ours = d.path().join("ours.mat");
    let names: Vec<String> = ["t", "tau0", "q0"].iter().map(|s| s.to_string()).collect();
    let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.01).collect();
    let u: Vec<f64> = t.iter().map(|x| x.sin()).collect();
    let q: Vec<f64> = t.iter().map(|x| 0.1 * x.cos()).collect();
    lockstep::measurement::write_columns(&ours, &names, &[&t, &u, &q]).unwrap();
    let seeds = vec![
        std::fs::read(&ours).unwrap(),
        read("tests/data/scipy_v5.mat"),
    ];
    let path = d.path().join("m.mat");
    proptest!(config(), |(b in input(seeds.clone()))| {
        write(&path, &b);
        let _ = Measurement::read(&path, &["q0"]);
    });
}

#[test]
fn plant_files() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("p.toml");
    let seeds = vec![
        read("model/plants/emps_symmetric.toml"),
        read("model/plants/freedom6s_appendix_d_isolated.toml"),
    ];
    proptest!(config(), |(b in input(seeds.clone()))| {
        write(&path, &b);
        let _ = Plant::load(&path);
    });
}

#[test]
fn excitation_files() {
    let model = lockstep::util::model("freedom6s").unwrap();
    let seeds = vec![read("model/excitation/freedom6s.toml")];
    proptest!(config(), |(b in input(seeds.clone()))| {
        let text = String::from_utf8_lossy(&b);
        if let Ok(ex) = Excitations::parse(&text, "fuzz.toml", model) {
            // What parses must also sample without a panic.
            if let Some(t) = ex.tables.first() {
                if let Some(test) = t.tests.first() {
                    let _ = test.sample(model.joints.len(), &[0, 1, 2, 3, 4, 5], 0.05, 100.0);
                }
            }
        }
    });
}

#[test]
fn wall_and_closed_loop_files() {
    let d = tempfile::tempdir().unwrap();
    let control = d.path().join("control");
    std::fs::create_dir_all(&control).unwrap();
    std::fs::create_dir_all(d.path().join("plants")).unwrap();
    std::fs::copy(
        root().join("model/plants/freedom6s_appendix_d_coupled.toml"),
        d.path().join("plants/freedom6s_appendix_d_coupled.toml"),
    )
    .unwrap();
    let seeds = vec![
        read("model/control/freedom6s_wall.toml"),
        read("model/control/freedom6s_closedloop.toml"),
    ];
    let path = control.join("spec.toml");
    proptest!(config(), |(b in input(seeds.clone()))| {
        write(&path, &b);
        let _ = WallSetup::load(&path);
        let _ = ClosedLoop::load(&path, None, Some(0.05));
    });
}

#[test]
fn fuzzy_rule_tables_fll_and_fis() {
    let fll = read("model/control/freedom6s_wall_tuned.fll");
    let fis = read("model/control/freedom6s_wall_tuned.fis");
    let seeds = vec![fll, fis, read("tests/data/fuzzylite_wall_rules.txt")];
    proptest!(config(), |(b in input(seeds.clone()))| {
        let text = String::from_utf8_lossy(&b);
        let _ = Fam::from_fll(&text, "fuzz.fll");
        let _ = Fam::from_fis(&text, "fuzz.fis");
    });
}
