//! The `maamplan` binary: parse the command line, run, map errors to exit
//! codes (2 for user errors, 1 for internal failures).

// The commands' lines on stdout and stderr: a reader that has gone away
// (`maamplan plan -v | head -1`) must not panic the run (std's `println!`
// does on a closed pipe). The run goes on, writes its outputs and exits as
// it would; only lines nobody reads are lost. Defined before `mod cli` so
// that every command's `println!` and `eprintln!` are these.
macro_rules! println {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    // Mesa's Vulkan loader probes Wayland and prints an "error:" line when
    // XDG_RUNTIME_DIR is unset (headless machines, CI); point it somewhere
    // harmless before any thread exists.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the outermost context, then the cause.
            let msg = e
                .chain()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(": ");
            eprintln!("error: {msg}");
            ExitCode::from(exit_code(&e))
        }
    }
}

/// 2 when the user can fix it (inputs, arguments), 3 when `--strict`
/// refused to skip waypoints, 1 otherwise.
fn exit_code(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if cause.is::<cli::plan::StrictError>() {
            return 3;
        }
        if cause.is::<cli::UsageError>() {
            return 2;
        }
        if let Some(user) = maamplan::errors::user_can_fix(cause) {
            return if user { 2 } else { 1 };
        }
    }
    1
}
