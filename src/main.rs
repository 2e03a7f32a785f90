//! `taut`: the host tool. Parses the command line and runs one subcommand; see `taut --help`.

use clap::Parser as _;
use taut::cli::{Cli, Command, ReportKind};
use taut::output::report_failure;

fn main() {
    let cli = Cli::parse();
    let status = match &cli.command {
        None => taut::job::main(&cli.job),
        Some(Command::Panel(args)) => taut::panel::main(args),
        Some(Command::Paper(args)) => taut::paper::main(args),
        Some(Command::Pull(args)) => taut::pull::main(args),
        Some(Command::Report { which }) => match which {
            ReportKind::Accuracy(args) => taut::report::accuracy::main(args),
            ReportKind::Ablation(args) => taut::report::ablation::main(args),
            ReportKind::Robustness(args) => taut::report::robustness::main(args),
            ReportKind::Machine(args) => taut::report::machine::main(args),
            ReportKind::String(args) => taut::report::string::main(args),
        },
    };
    std::process::exit(match status {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(failure) => report_failure(&failure),
    });
}
