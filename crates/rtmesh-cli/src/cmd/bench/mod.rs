//! `rtmesh bench`: tables that compare methods or tracers on many meshes, one file per
//! table; the rows come from the lab crate.

mod clusters;
mod intersect;
mod packets;
mod pairing;
mod strips;
mod trace;

use anyhow::Result;
use clap::Subcommand;

/// Benchmark tables that compare methods or tracers on many meshes.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    table: Table,
}

#[derive(Subcommand)]
enum Table {
    Trace(trace::Args),
    Pairing(pairing::Args),
    Packets(packets::Args),
    Intersect(intersect::Args),
    Strips(strips::Args),
    Clusters(clusters::Args),
}

/// Measure and print the table asked for.
pub fn run(args: Args) -> Result<()> {
    match args.table {
        Table::Trace(args) => trace::run(args),
        Table::Pairing(args) => pairing::run(args),
        Table::Packets(args) => packets::run(args),
        Table::Intersect(args) => intersect::run(args),
        Table::Strips(args) => strips::run(args),
        Table::Clusters(args) => clusters::run(args),
    }
}
