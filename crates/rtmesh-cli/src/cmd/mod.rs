//! The subcommands, one file each: its clap arguments, a `run` that calls the library
//! and builds a typed report, and the text printing of that report.

pub mod animate;
pub mod bench;
pub mod cluster;
pub mod convert;
pub mod demo;
pub mod dynamic;
pub mod info;
pub mod lint;
pub mod optimize;
pub mod pair;
pub mod render;
pub mod repair;
pub mod strip;
pub mod trace;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// Prepare triangle meshes for ray tracing and measure the gain.
///
/// MESH arguments are files (.obj, .ply, .gltf, .glb, .stl) or a built-in scene written
/// `builtin:NAME` (blob, grid, cylinder, room). Every subcommand prints a human
/// summary, or with --json a JSON report carrying `rtmesh_version` and `schema`.
#[derive(Parser)]
#[command(name = "rtmesh", version, about, long_about)]
pub struct Cli {
    /// The folder that files a mesh refers to (OBJ mtllib, glTF buffers) must stay in.
    /// By default the mesh's own folder: references that climb out of it with '..', are
    /// absolute, or lead out through a link are refused.
    #[arg(long, global = true, value_name = "DIR")]
    asset_root: Option<std::path::PathBuf>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Optimize(optimize::Args),
    Info(info::Args),
    Convert(convert::Args),
    Pair(pair::Args),
    Lint(lint::Args),
    Repair(repair::Args),
    Trace(trace::Args),
    Render(render::Args),
    Bench(bench::Args),
    Cluster(cluster::Args),
    Strip(strip::Args),
    Dynamic(dynamic::Args),
    Animate(animate::Args),
    Demo(demo::Args),
}

/// Run the subcommand the command line names.
pub fn run(cli: Cli) -> Result<()> {
    crate::args::set_read_options(rtmesh::io::ReadOptions {
        asset_root: cli.asset_root,
    });
    match cli.command {
        Command::Optimize(args) => optimize::run(args),
        Command::Info(args) => info::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Pair(args) => pair::run(args),
        Command::Lint(args) => lint::run(args),
        Command::Repair(args) => repair::run(args),
        Command::Trace(args) => trace::run(args),
        Command::Render(args) => render::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Cluster(args) => cluster::run(args),
        Command::Strip(args) => strip::run(args),
        Command::Dynamic(args) => dynamic::run(args),
        Command::Animate(args) => animate::run(args),
        Command::Demo(args) => demo::run(args),
    }
}
