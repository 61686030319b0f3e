//! `rtmesh`: the command-line face of the rtmesh library. Each subcommand is a thin
//! wrapper: parse arguments, read the mesh (with a progress bar), call the library,
//! print a human summary or, with `--json`, one JSON object on stdout.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rtmesh::mesh::MeshInfo;
use rtmesh::Scene;
use std::path::{Path, PathBuf};

/// Prepare triangle meshes for ray tracing and measure the gain.
///
/// MESH arguments are files (.obj, .ply, .gltf, .glb) or a built-in scene written
/// `builtin:NAME` (blob, grid, cylinder, room).
#[derive(Parser)]
#[command(name = "rtmesh", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Counts, bounds and topology of a mesh (after welding identical positions).
    ///
    /// Prints vertices, triangles, welded vertices, bounds, edge-connected components,
    /// boundary and non-manifold edges, and the broken triangles found.
    Info {
        /// The mesh file, or builtin:NAME.
        mesh: String,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Convert between formats, keeping triangle order (format from the extension).
    ///
    /// OBJ and PLY hold one level, so instances are flattened; glTF/GLB keep them.
    Convert {
        /// Input mesh file, or builtin:NAME.
        input: String,
        /// Output file: .obj, .ply (binary), .gltf (with .bin beside it) or .glb.
        output: PathBuf,
        /// Merge vertices closer than this distance (0 = identical positions only).
        #[arg(long, value_name = "DISTANCE")]
        weld: Option<f32>,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run rtmesh on the built-in scenes (for now: their info).
    Demo {
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
}

/// Read a mesh file (with a progress bar for large files) or make a built-in scene.
fn load(mesh: &str) -> Result<Scene> {
    if let Some(name) = mesh.strip_prefix("builtin:") {
        return rtmesh::scenes::by_name(name).with_context(|| {
            format!(
                "no built-in scene '{name}' (have: {})",
                rtmesh::scenes::NAMES.join(", ")
            )
        });
    }
    let path = Path::new(mesh);
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let bar = if size > 4 << 20 {
        ProgressBar::new(size).with_style(
            ProgressStyle::with_template("reading {msg} {bar:30} {bytes}/{total_bytes} ({eta})")
                .expect("valid template"),
        )
    } else {
        ProgressBar::hidden()
    };
    bar.set_message(mesh.to_owned());
    let scene = rtmesh::io::read_with_progress(path, &mut |done, _| bar.set_position(done));
    bar.finish_and_clear();
    Ok(scene?)
}

fn print_json(value: &impl serde::Serialize) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

fn print_info(name: &str, info: &MeshInfo) {
    let b = &info.bounds;
    println!("{name}");
    println!(
        "  vertices           {:>10}  ({} after welding)",
        info.vertices, info.welded_vertices
    );
    println!("  triangles          {:>10}", info.triangles);
    println!(
        "  geometries         {:>10}  ({} instances, {} materials)",
        info.meshes, info.instances, info.materials
    );
    println!(
        "  bounds             [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
    );
    println!("  components         {:>10}", info.components);
    println!(
        "  edges              {:>10} manifold, {} boundary, {} non-manifold",
        info.manifold_edges, info.boundary_edges, info.nonmanifold_edges
    );
    println!(
        "  alpha-tested       {:>10} triangles",
        info.alpha_tested_triangles
    );
    println!(
        "  broken triangles   {:>10} non-finite, {} repeated-vertex, {} zero-area",
        info.non_finite_triangles, info.repeated_vertex_triangles, info.zero_area_triangles
    );
}

fn main() {
    let cli = Cli::parse();
    if let Err(error) = run(cli) {
        eprintln!("error: {error:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { mesh, json } => {
            let info = MeshInfo::of(&load(&mesh)?);
            if json {
                print_json(&info)
            } else {
                print_info(&mesh, &info);
                Ok(())
            }
        }
        Command::Convert {
            input,
            output,
            weld,
            json,
        } => {
            let mut scene = load(&input)?;
            let mut merged = 0;
            if let Some(tolerance) = weld {
                for mesh in &mut scene.meshes {
                    let result = rtmesh::mesh::weld(mesh, tolerance);
                    merged += result.merged;
                    *mesh = result.mesh;
                }
            }
            rtmesh::io::write(&scene, &output)?;
            let summary = serde_json::json!({
                "input": input, "output": output, "triangles": scene.instanced_triangle_count(),
                "vertices": scene.instanced_vertex_count(), "merged_vertices": merged,
            });
            if json {
                print_json(&summary)
            } else {
                println!(
                    "wrote {} ({} triangles, {} vertices, {} merged by welding)",
                    output.display(),
                    summary["triangles"],
                    summary["vertices"],
                    merged
                );
                Ok(())
            }
        }
        Command::Demo { json } => {
            let infos: Vec<(&str, MeshInfo)> = rtmesh::scenes::NAMES
                .iter()
                .map(|&name| {
                    (
                        name,
                        MeshInfo::of(&rtmesh::scenes::by_name(name).expect("built-in")),
                    )
                })
                .collect();
            if json {
                print_json(
                    &infos
                        .iter()
                        .map(|(n, i)| serde_json::json!({"scene": n, "info": i}))
                        .collect::<Vec<_>>(),
                )
            } else {
                for (name, info) in &infos {
                    print_info(&format!("builtin:{name}"), info);
                }
                Ok(())
            }
        }
    }
}
