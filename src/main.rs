//! The `lockstep` binary.
use clap::Parser;

fn main() {
    let cli = lockstep::cli::Cli::parse();
    if let Err(e) = lockstep::cli::run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
