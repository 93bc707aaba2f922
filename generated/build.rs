//! Regenerates the kernels from `model/*.toml` whenever a model (or the URDF it reads) or
//! the generator changes.
//!
//! Symbolica (restricted, unlicensed) prints a banner on stdout at first use; cargo ignores
//! build-script lines that do not start with `cargo:`, so the banner never reaches the
//! generated files. Messages for the user go to stderr (shown with `cargo build -vv`).

use std::path::PathBuf;

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let model_dir = manifest.join("..").join("model");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it"));
    println!("cargo:rerun-if-changed={}", model_dir.display());
    let files = match codegen::model_files(&model_dir) {
        Ok(f) => f,
        Err(e) => fail(&e.to_string()),
    };
    let mut names = Vec::new();
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
        let model = codegen::load(f).unwrap_or_else(|e| fail(&e.to_string()));
        if let Some((urdf, _)) = &model.urdf {
            println!("cargo:rerun-if-changed={}", urdf.display());
        }
        for w in &model.warnings {
            println!("cargo:warning={}: {w}", f.display());
        }
        let g = codegen::generate::generate(&model, None)
            .unwrap_or_else(|e| fail(&format!("{}: {e}", f.display())));
        let path = out.join(format!("{}.rs", model.name));
        codegen::write_if_changed(&path, &g.source).unwrap_or_else(|e| fail(&e.to_string()));
        eprintln!(
            "lockstep-codegen: {} -> {} ({} configurations, {:.1} s)",
            f.display(),
            path.display(),
            g.configs.len(),
            g.model_seconds + g.configs.iter().map(|c| c.seconds).sum::<f64>()
        );
        names.push(model.name.clone());
    }
    codegen::write_if_changed(&out.join("models.rs"), &codegen::models_index(&names))
        .unwrap_or_else(|e| fail(&e.to_string()));
}

fn fail(msg: &str) -> ! {
    // One clear line; cargo shows it under "error: failed to run custom build command".
    eprintln!("error: {msg}");
    std::process::exit(1);
}
