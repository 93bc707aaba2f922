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
    let args: Vec<String> = std::env::args().collect();
    let matches = match commands::Cli::command().try_get_matches_from(&args) {
        Ok(m) => m,
        Err(e) => match commands::misplaced_option(&e, &args) {
            Some(message) => {
                lockstep::errln!("error: {message}");
                std::process::exit(2);
            }
            None => e.exit(),
        },
    };
    let mut cli = commands::Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let commands::Command::Identify {
        method: commands::IdentifyMethod::Sequence(args),
    } = &mut cli.command
    {
        args.oe.given = commands::given_identify_options(&matches);
    }
    if let Err(e) = commands::run(cli) {
        lockstep::errln!("error: {e:#}");
        std::process::exit(1);
    }
}
