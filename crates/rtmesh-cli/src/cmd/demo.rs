//! `rtmesh demo`: `rtmesh optimize` on the built-in scenes.

use super::optimize::{run_jobs, Job, Settings};
use anyhow::Result;
use rtmesh::optimize::OptimizeOptions;
use std::path::PathBuf;

/// Run the main job, `rtmesh optimize`, on the built-in scenes (blob, grid, cylinder,
/// room): each is linted, repaired, paired and written as GLB, traced before and after,
/// and given an HTML report, with index.html linking them.
#[derive(clap::Args)]
pub struct Args {
    /// The folder to write the scenes and reports to (default: rtmesh-demo in the
    /// system's temporary folder).
    #[arg(short, long, value_name = "DIR")]
    output: Option<PathBuf>,
    /// Print one JSON line per scene instead of text.
    #[arg(long)]
    json: bool,
}

/// Optimize every built-in scene into the folder, and say where the reports are.
pub fn run(args: Args) -> Result<()> {
    let dir = args
        .output
        .unwrap_or_else(|| std::env::temp_dir().join("rtmesh-demo"));
    let jobs: Vec<Job> = rtmesh::scenes::NAMES
        .iter()
        .map(|name| Job::builtin(name, &dir))
        .collect();
    let settings = Settings {
        options: OptimizeOptions::default(),
        dry_run: false,
        json: args.json,
        picture_size: (480, 360),
        // One scene at a time on every core: steadier Mrays/s than one per core.
        jobs: 1,
    };
    let index = dir.join("index.html");
    run_jobs(&jobs, &settings, Some(&index))?;
    if !args.json {
        println!(
            "\nopen {} for the reports; next: rtmesh optimize YOUR_MESH -o OUT --report report.html",
            index.display()
        );
    }
    Ok(())
}
