//! The `lockstep` binary.
use clap::{CommandFactory, FromArgMatches};

mod commands;

fn main() {
    // Ctrl-C: remove the temporary files of unfinished writes, exit as a shell expects
    // (128 + SIGINT). Completed outputs stay as they are.
    let _ = ctrlc::set_handler(|| {
        lockstep::files::remove_staged_files();
        std::process::exit(130);
    });
    let matches = commands::Cli::command().get_matches();
    let mut cli = commands::Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let commands::Command::Identify { oe, .. } = &mut cli.command {
        oe.given = commands::given_identify_options(&matches);
    }
    if let Err(e) = commands::run(cli) {
        lockstep::errln!("error: {e:#}");
        std::process::exit(1);
    }
}
