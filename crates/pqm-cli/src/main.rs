//! `pqm`: progressive quad meshes from the command line.
//!
//! Every command lives in its own module under [`cmd`] and exposes
//! `pub struct Args` (clap) and `pub fn run(args: &Args, ctx: &Ctx) ->
//! anyhow::Result<()>`; [`ctx`] holds the global flags and output rules.
//!
//! Exit codes: 0 success; 1 the command failed (bad input, I/O error, one
//! file of a batch failed); 2 bad usage (clap's usage errors, and
//! [`ctx::UsageError`]). `pqm` with no arguments prints the help on stderr
//! and exits 2, as clap does for a missing subcommand.

mod cmd;
mod ctx;
mod pipeline;
mod stats;
mod util;

use clap::{ArgAction, Parser, Subcommand};
use ctx::{Ctx, UsageError};
use std::process::ExitCode;

const AFTER_HELP: &str = "\
Examples:
  pqm demo                                   run the whole pipeline on the bundled cow
  pqm stats spot.obj                         quality figures of a mesh
  pqm coarsen spot.obj -o spot_700.obj --faces 700
  pqm encode spot.obj -o spot.pqm            progressive file, as coarse as the rules allow
  pqm info spot.pqm                          header and chunk table
  pqm decode spot.pqm -o spot_1k.glb --faces 1000
  pqm view spot.pqm                          stream it into a browser viewer (prints the URL)

Exit codes: 0 ok, 1 failed, 2 bad usage. `pqm` alone prints this help and exits 2.";

/// Progressive quad meshes: coarsen quad meshes with qCoarsen, stream them as
/// .pqm files, decode any level to glTF/OBJ/PLY/OFF.
#[derive(Parser, Debug)]
#[command(
    name = "pqm",
    version,
    arg_required_else_help = true,
    after_help = AFTER_HELP,
    max_term_width = 100
)]
struct Cli {
    /// Quiet: no notes, no progress bars, no summaries (errors and the
    /// results of `stats`/`info` still print).
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Verbose: more detail on stderr (repeatable).
    #[arg(short, long, global = true, action = ArgAction::Count)]
    verbose: u8,
    /// Print one JSON object on stdout and nothing else.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    Stats(cmd::stats::Args),
    Convert(cmd::convert::Args),
    Coarsen(cmd::coarsen::Args),
    Encode(cmd::encode::Args),
    Decode(cmd::decode::Args),
    Info(cmd::info::Args),
    Levels(cmd::levels::Args),
    Remesh(cmd::remesh::Args),
    View(cmd::view::Args),
    Demo(cmd::demo::Args),
    #[command(hide = true)]
    Fixtures(cmd::fixtures::Args),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // clap: --help/--version exit 0 (stdout), usage errors exit 2.
            let _ = e.print();
            return ExitCode::from(e.exit_code().clamp(0, 255) as u8);
        }
    };
    let ctx = Ctx::new(cli.quiet, cli.verbose, cli.json);
    let result = match &cli.command {
        Command::Stats(a) => cmd::stats::run(a, &ctx),
        Command::Convert(a) => cmd::convert::run(a, &ctx),
        Command::Coarsen(a) => cmd::coarsen::run(a, &ctx),
        Command::Encode(a) => cmd::encode::run(a, &ctx),
        Command::Decode(a) => cmd::decode::run(a, &ctx),
        Command::Info(a) => cmd::info::run(a, &ctx),
        Command::Levels(a) => cmd::levels::run(a, &ctx),
        Command::Remesh(a) => cmd::remesh::run(a, &ctx),
        Command::View(a) => cmd::view::run(a, &ctx),
        Command::Demo(a) => cmd::demo::run(a, &ctx),
        Command::Fixtures(a) => cmd::fixtures::run(a, &ctx),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined by ": ".
            let msg = format!("{e:#}").replace('\n', " ");
            ctx.error_line(msg);
            if e.downcast_ref::<UsageError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
