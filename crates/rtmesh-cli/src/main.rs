//! `rtmesh`: the command-line face of the rtmesh library. `main` parses the command
//! line and hands each subcommand to its file under `cmd/`, which calls the library,
//! then prints a human summary or, with `--json`, the typed report as JSON.

mod args;
mod cmd;
mod output;

use clap::Parser;

fn main() {
    // Rust ignores SIGPIPE, so `rtmesh lint MESH | head` would panic on the closed pipe;
    // restore the default (exit quietly) as command-line tools expect.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; SIG_DFL is a
    // valid disposition for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    if let Err(error) = cmd::run(cmd::Cli::parse()) {
        eprintln!("error: {error:#}");
        std::process::exit(1);
    }
}
