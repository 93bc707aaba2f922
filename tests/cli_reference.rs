//! The command reference in the book (`docs/src/reference/cli.md`) is the binary's own
//! `--help` text (`--help-long` where a command has it) for every command and subcommand,
//! so it cannot drift from the code.
//! `LOCKSTEP_UPDATE_DOCS=1 cargo test --release --test cli_reference` rewrites it.

mod common;
use common::{lockstep, ok};
use std::path::Path;

/// The subcommands a help text lists under `Commands:` (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut inside = false;
    for line in help.lines() {
        if line.starts_with("Commands:") {
            inside = true;
            continue;
        }
        if inside {
            if !line.starts_with("  ") {
                break;
            }
            // A subcommand's line is indented by two; a wrapped description by more.
            let name = line.split_whitespace().next().unwrap_or("");
            if !line.starts_with("   ") && !name.is_empty() && name != "help" {
                names.push(name.to_string());
            }
        }
    }
    names
}

fn render(path: &[String], out: &mut String) {
    let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
    args.push("--help");
    let mut help = ok(&lockstep(&args));
    // A command whose --help is the short one: its details in the reference.
    if help.contains("--help-long") {
        args.pop();
        args.push("--help-long");
        help = ok(&lockstep(&args));
    }
    let title = if path.is_empty() {
        "lockstep".to_string()
    } else {
        format!("lockstep {}", path.join(" "))
    };
    out.push_str(&format!(
        "## `{title}`\n\n```text\n{}\n```\n\n",
        help.trim_end()
    ));
    for sub in subcommands(&help) {
        let mut p = path.to_vec();
        p.push(sub);
        render(&p, out);
    }
}

#[test]
fn the_command_reference_is_the_binarys_help() {
    let mut text = String::from(
        "# Command reference\n\n\
         Generated from `lockstep <command> --help` by `tests/cli_reference.rs` \
         (`LOCKSTEP_UPDATE_DOCS=1 cargo test --release --test cli_reference` rewrites it); \
         every default is shown where the option is.\n\n",
    );
    render(&[], &mut text);
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/src/reference/cli.md");
    if std::env::var_os("LOCKSTEP_UPDATE_DOCS").is_some() {
        std::fs::write(&file, &text).unwrap();
    }
    let on_disk = std::fs::read_to_string(&file).unwrap_or_default();
    assert!(
        on_disk == text,
        "{} differs from the binary's --help: rerun with LOCKSTEP_UPDATE_DOCS=1",
        file.display()
    );
    // Every command of the binary has its section.
    for cmd in [
        "identify",
        "compare",
        "diagnose",
        "refit",
        "effect add",
        "wall tune",
        "simulate",
    ] {
        assert!(text.contains(&format!("## `lockstep {cmd}`")), "{cmd}");
    }
}
