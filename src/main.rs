//! The `lockstep` binary.
use clap::Parser;

mod commands;

fn main() {
    // Ctrl-C: remove the temporary files of unfinished writes, exit as a shell expects
    // (128 + SIGINT). Completed outputs stay as they are.
    let _ = ctrlc::set_handler(|| {
        lockstep::files::remove_staged_files();
        std::process::exit(130);
    });
    let cli = commands::Cli::parse();
    if let Err(e) = commands::run(cli) {
        lockstep::errln!("error: {e:#}");
        std::process::exit(1);
    }
}
