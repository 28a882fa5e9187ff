//! The `embertrace` command line: parse the arguments and hand them to the
//! subcommand's module in `embertrace::commands`.

use clap::{CommandFactory, Parser, Subcommand};
use embertrace::commands::{bench, convert, diff, merge, parity, plan, render, study};
use embertrace::error::Error;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "embertrace",
    version = embertrace::build_info::LONG_VERSION,
    about = "A physically based path tracer (ray queries by Embree, a pure-Rust BVH or brute force).",
    after_help = "The classic form `embertrace -t 8 -s 64 -l 16 -m 5 -r 480 360 -f out.png SCENE` means `embertrace render ...`."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print nothing on stderr but errors and warnings (what the image will
    /// lack): no notes, no progress.
    #[arg(short = 'q', long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Say more on stderr: -v the settings resolved, the backend and its
    /// library, build and load times; -vv diagnostics too.
    #[arg(short = 'v', long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (.toml, .obj, .ply, glTF .gltf/.glb, pbrt-v4 .pbrt, Mitsuba 3 .xml, CS184 .dae or CSE .test) to an image.
    Render(Box<render::RenderArgs>),
    /// Measure build time, memory and ray throughput of each backend.
    Bench(bench::BenchArgs),
    /// Trace identical rays through every backend and report disagreements.
    Parity(parity::ParityArgs),
    /// Compare an image with a reference: RMSE, relative MSE, MAE, max error.
    Diff(diff::DiffArgs),
    /// Render a scene under several settings: error against time, a contact
    /// sheet and the Pareto front.
    Study(study::StudyArgs),
    /// Print the effects a scene calls for, what calls for each, and the
    /// code that runs.
    Plan(plan::PlanArgs),
    /// Write any scene the renderer reads as a TOML scene, with its meshes
    /// and images beside it.
    Convert(convert::ConvertArgs),
    /// Combine accumulation files (shards, crops, checkpoints) into the
    /// final image, bit for bit the one-process render.
    Merge(merge::MergeArgs),
    /// Print a completion script for a shell (bash, zsh, fish, elvish,
    /// powershell) to standard output, e.g. `embertrace completions bash >
    /// ~/.local/share/bash-completion/completions/embertrace`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff) to standard output, e.g. `embertrace
    /// man > embertrace.1 && man ./embertrace.1`.
    Man,
}

/// Words that start the subcommand form; anything else is the classic form.
const SUBCOMMANDS: &[&str] = &[
    "render",
    "bench",
    "parity",
    "diff",
    "study",
    "plan",
    "convert",
    "merge",
    "completions",
    "man",
    "help",
    "-h",
    "--help",
    "-V",
    "--version",
];

/// Write `bytes` to standard output; a reader that closed the pipe early
/// (`| head`) is not an error.
fn print_bytes(bytes: &[u8]) -> Result<(), Error> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(bytes).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(Error::io(std::path::Path::new("<stdout>"), e))
        }
        _ => Ok(()),
    }
}

/// `-q`, `--quiet`, `-v`, `-vv`, ..., `--verbose`.
fn is_verbosity_flag(a: &str) -> bool {
    matches!(a, "-q" | "--quiet" | "--verbose")
        || a.strip_prefix('-')
            .is_some_and(|v| !v.is_empty() && v.chars().all(|c| c == 'v'))
}

fn main() -> ExitCode {
    // arguments as the OS gives them: a path need not be UTF-8
    let mut argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    // the global -q/-v may come before the subcommand
    let first = argv
        .iter()
        .skip(1)
        .map(|a| a.to_str().unwrap_or(""))
        .find(|a| !is_verbosity_flag(a));
    if first.is_some_and(|a| !SUBCOMMANDS.contains(&a)) {
        argv.insert(1, "render".into());
    }
    let cli = match Cli::try_parse_from(argv) {
        Ok(cli) => cli,
        Err(e) => return command_line_error(e),
    };
    embertrace::log::set_level(embertrace::log::Level::from_flags(cli.quiet, cli.verbose));
    let result = match cli.command {
        Command::Render(args) => render::run(*args),
        Command::Bench(args) => bench::run(args),
        Command::Parity(args) => parity::run(args),
        Command::Diff(args) => diff::run(args),
        Command::Study(args) => study::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Completions { shell } => {
            // into memory first: the generator panics on a failed write
            let mut text = Vec::new();
            clap_complete::generate(shell, &mut Cli::command(), "embertrace", &mut text);
            print_bytes(&text)
        }
        Command::Man => {
            let mut text = Vec::new();
            clap_mangen::Man::new(Cli::command())
                .render(&mut text)
                .map_err(|e| Error::io(std::path::Path::new("<man page>"), e))
                .and_then(|()| print_bytes(&text))
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Error::Interrupted(m)) => {
            eprintln!("embertrace: {m}");
            // the shell's code for a process that SIGINT ended
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("embertrace: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Help and the version go to stdout as clap prints them; any other
/// command-line error is one line on stderr and exit status 1, like every
/// other error.
fn command_line_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        e.exit();
    }
    let text = e.render().to_string();
    let message = text.split("Usage:").next().unwrap_or_default();
    // "error: ...:" then the arguments it lists, then a tip: one line
    let mut line = String::new();
    let lines = message.lines().map(str::trim);
    for l in lines.filter(|l| !l.is_empty() && !l.starts_with("For more information")) {
        if !line.is_empty() {
            line += if line.ends_with(':') { " " } else { "; " };
        }
        line += l;
    }
    let line = line.strip_prefix("error: ").unwrap_or(&line);
    eprintln!(
        "embertrace: error: {} (see embertrace help)",
        embertrace::error::clip(line)
    );
    ExitCode::FAILURE
}
