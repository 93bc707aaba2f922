//! The emitted kernels are reviewed like any diff (insta snapshots in
//! `generated/tests/snapshots/`). A small model's module is snapshotted in full; a large one's
//! (over [`FULL_TEXT_LINES`] lines: the Freedom 6S, the Panda, the Puma 560) as a summary a
//! reviewer can read in a pull request: the module's declarations verbatim (header with the
//! operation counts per configuration, constants, module lines) and, per kernel, its
//! signature's name, its length, its operation counts and an FNV-1a hash of its body. A change
//! in the generator or a model shows as a changed count or hash of the kernels it touched;
//! `cargo xtask gen --model M --config C` prints the full text of one configuration.

/// Modules longer than this are summarised instead of snapshotted in full.
const FULL_TEXT_LINES: usize = 1400;

/// FNV-1a, 64 bits: a hash that is stable across Rust versions and platforms.
fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The summary of a module's source: declarations verbatim, each function as one line.
fn summary(source: &str) -> String {
    let mut out = String::new();
    let mut lines = source.lines();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        let indent = &line[..line.len() - trimmed.len()];
        let rest = ["pub fn ", "pub(crate) fn ", "fn "]
            .iter()
            .find_map(|p| trimmed.strip_prefix(p));
        let Some(rest) = rest else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let name = rest.split(['(', '<']).next().unwrap_or(rest);
        let close = format!("{indent}}}");
        let mut body = String::from(line);
        let mut n = 1;
        for l in lines.by_ref() {
            body.push_str(l);
            body.push('\n');
            n += 1;
            if l == close {
                break;
            }
        }
        let count = |pats: &[&str]| pats.iter().map(|p| body.matches(p).count()).sum::<usize>();
        let add = count(&[" + ", " - "]);
        let mul = count(&[" * ", " / "]);
        let calls = count(&[".sin()", ".cos()", ".sqrt()", ".powi("]);
        out.push_str(&format!(
            "{indent}fn {name}: {n} lines, {add} add, {mul} mul, {calls} calls, fnv1a {:016x}\n",
            fnv1a(&body)
        ));
    }
    out
}

#[test]
fn emitted_sources_match_reviewed_snapshots() {
    assert!(!generated::SOURCES.is_empty());
    for (name, source) in generated::SOURCES {
        if source.lines().count() <= FULL_TEXT_LINES {
            insta::assert_snapshot!(format!("kernels_{name}"), source);
        } else {
            insta::assert_snapshot!(format!("summary_{name}"), summary(source));
        }
    }
}

#[test]
fn the_summary_lists_every_kernel_and_changes_with_any_body() {
    let source = generated::SOURCES
        .iter()
        .find(|(n, _)| *n == "freedom6s")
        .unwrap()
        .1;
    let s = summary(source);
    // Every configuration's eight kernels in their two forms (computing the trigonometry,
    // and reading it: `_trig`), their slice-form wrappers (`_dyn`, and `_trig_dyn` for the
    // four the simulator calls), forward dynamics' loop invariants and its form reading
    // them (each with its wrapper), and the two parameter conversions appear once each,
    // and no function body is left.
    let kernels = s
        .lines()
        .filter(|l| l.trim_start().starts_with("fn "))
        .count();
    assert_eq!(kernels, 12 * (8 * 3 + 4 + 4) + 2, "{s}");
    assert!(!s.contains("let "), "{s}");
    assert_eq!(s.matches("fn forward_dynamics:").count(), 12);
    // One changed character in one body changes exactly that kernel's line.
    let k5 = source.find("pub mod k5").unwrap();
    let at = k5 + source[k5..].find(" * ").unwrap();
    let changed = format!("{} / {}", &source[..at], &source[at + 3..]);
    let t = summary(&changed);
    let differing = s.lines().zip(t.lines()).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 1);
    assert!(s.lines().count() < source.lines().count() / 5);
}

#[test]
fn emps_kernels_are_the_one_dof_mass() {
    // τ = M q̈ for a point mass on a prismatic joint; forward dynamics inverts it.
    let m = generated::model("emps").unwrap();
    let c = m.configuration("full").unwrap();
    let (q, qd, qdd, p) = ([0.3], [0.2], [1.5], [95.0]);
    let mut out = [0.0];
    (c.inverse_dynamics)(&q, &qd, &qdd, &p, &mut out);
    assert_eq!(out[0], 95.0 * 1.5);
    let mut acc = [0.0];
    (c.forward_dynamics)(&q, &qd, &out, &p, &mut acc);
    assert!((acc[0] - 1.5).abs() < 1e-15);
    let mut y = [0.0];
    (c.regressor)(&q, &qd, &qdd, &mut y);
    assert_eq!(y, [1.5]);
}
