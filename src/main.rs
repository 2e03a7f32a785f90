//! `taut`: the host tool. Parses the command line and runs one subcommand; see `taut --help`.

#![deny(
    clippy::print_stderr,
    reason = "`eprintln!` panics when stderr is closed: diagnostics go through `output::to_stderr`"
)]

use clap::Parser as _;
use taut::cli::{Cli, Command, ReportKind};
use taut::output::{CLOSED_STDOUT_STATUS, report_failure};

fn main() {
    quiet_on_closed_stdout();
    let cli = Cli::parse();
    let status = match &cli.command {
        None => taut::job::main(&cli.job),
        Some(Command::Panel(args)) => taut::panel::main(args),
        Some(Command::Paper(args)) => taut::paper::main(args),
        Some(Command::Pull(args)) => taut::pull::main(args),
        Some(Command::Connect(args)) => taut::link::commands::connect(args),
        Some(Command::Log(args)) => taut::link::commands::log(args),
        Some(Command::Backup(args)) => taut::link::commands::backup(args),
        Some(Command::Restore(args)) => taut::link::commands::restore(args),
        Some(Command::Report { which }) => match which {
            ReportKind::Accuracy(args) => taut::report::accuracy::main(args),
            ReportKind::Ablation(args) => taut::report::ablation::main(args),
            ReportKind::Robustness(args) => taut::report::robustness::main(args),
            ReportKind::Machine(args) => taut::report::machine::main(args),
            ReportKind::String(args) => taut::report::string::main(args),
            ReportKind::Session(args) => taut::report::session::main(args),
        },
    };
    std::process::exit(match status {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(failure) => report_failure(&failure),
    });
}

/// A reader that closes the pipe early (`taut pull … | head`) ends the output: the process
/// exits quietly, as a Unix filter killed by `SIGPIPE` does (status 128 + 13), instead of
/// printing `println!`'s panic and a backtrace. Every other panic keeps the default report.
fn quiet_on_closed_stdout() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied());
        let closed = message.is_some_and(|message| {
            message.starts_with("failed printing to stdout") && message.contains("Broken pipe")
        });
        if closed {
            std::process::exit(CLOSED_STDOUT_STATUS);
        }
        report(info);
    }));
}
