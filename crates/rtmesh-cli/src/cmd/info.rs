//! `rtmesh info`: counts, bounds and topology of a mesh.

use crate::args::load;
use crate::output::emit;
use anyhow::Result;
use rtmesh::mesh::MeshInfo;

/// Counts, bounds and topology of a mesh (after welding identical positions).
///
/// Prints vertices, triangles, welded vertices, bounds, edge-connected components,
/// boundary and non-manifold edges, and the broken triangles found.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Read the mesh and report on it.
pub fn run(args: Args) -> Result<()> {
    let info = MeshInfo::of(&load(&args.mesh)?);
    emit(&info, args.json, |info| print(&args.mesh, info))
}

/// The text form of `info` for the mesh called `name`.
pub fn print(name: &str, info: &MeshInfo) {
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
    if !b.is_empty() {
        println!(
            "  bounds             [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
    } else {
        println!("  bounds             none (no finite corner)");
    }
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
    for a in &info.attributes {
        println!(
            "  attribute          {:>10}  {} x {}{}, {} vertices in {} geometries",
            a.name,
            a.components,
            a.component_type,
            if a.normalized { " (normalized)" } else { "" },
            a.vertices,
            a.geometries
        );
    }
    let d = &info.document;
    if d.nodes + d.skins + d.animations + d.textures + d.images + d.cameras > 0 {
        println!(
            "  document           {:>10} nodes, {} skins, {} animations, {} textures, {} images, {} cameras",
            d.nodes, d.skins, d.animations, d.textures, d.images, d.cameras
        );
    }
    for library in &d.material_libraries {
        println!("  material library   {library:>10}");
    }
    if info.strip_degenerates_dropped > 0 {
        println!(
            "  strips             {:>10} degenerate strip triangles (swaps and joins) dropped on reading",
            info.strip_degenerates_dropped
        );
    }
    if info.ignored_line_and_point_statements > 0 {
        println!(
            "  ignored            {:>10} OBJ line and point statements (not triangles)",
            info.ignored_line_and_point_statements
        );
    }
}
