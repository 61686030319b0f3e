//! `rtmesh info`: counts, bounds and topology of a mesh.

use crate::args::load;
use crate::output::emit;
use anyhow::Result;
use rtmesh::io::SideFileCheck;
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

/// `info`'s report: the mesh's figures, and the files it refers to.
#[derive(serde::Serialize)]
struct Report {
    #[serde(flatten)]
    info: MeshInfo,
    /// The material libraries, textures and images it refers to besides what was read:
    /// `present`, `missing`, `refused` (by the rule for references).
    side_files: SideFileCheck,
}

/// Read the mesh and report on it.
pub fn run(args: Args) -> Result<()> {
    let scene = load(&args.mesh)?;
    let side_files = if args.mesh.starts_with("builtin:") {
        SideFileCheck::default()
    } else {
        let options = crate::args::read_options();
        rtmesh::io::check_side_files(std::path::Path::new(&args.mesh), &scene, options)
    };
    let report = Report {
        info: MeshInfo::of(&scene),
        side_files,
    };
    emit(&report, args.json, |r| {
        print(&args.mesh, &r.info);
        let files = &r.side_files;
        if !files.present.is_empty() {
            println!("  side files         {:>10} there", files.present.len());
        }
        for missing in &files.missing {
            println!("  missing            {missing:>10}  (referred to, not there)");
        }
        for why in &files.refused {
            println!("  refused reference  {why}");
        }
    })
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
    let streams = [
        ("attribute         ", &info.attributes, "vertices"),
        ("triangle attribute", &info.triangle_attributes, "triangles"),
    ];
    for (label, attributes, of) in streams {
        for a in attributes {
            println!(
                "  {label} {:>10}  {} x {}{}, {} {of} in {} geometries",
                a.name,
                a.components,
                a.component_type,
                if a.normalized { " (normalized)" } else { "" },
                a.vertices,
                a.geometries
            );
        }
    }
    let d = &info.document;
    if d.nodes + d.skins + d.animations + d.textures + d.images + d.cameras > 0 {
        println!(
            "  document           {:>10} nodes, {} skins, {} animations, {} textures, {} images, {} cameras",
            d.nodes, d.skins, d.animations, d.textures, d.images, d.cameras
        );
    }
    if d.scenes > 1 {
        println!(
            "  scenes             {:>10} (the default one is traced; every one is written back)",
            d.scenes
        );
    }
    for library in &d.material_libraries {
        println!("  material library   {library:>10}");
    }
    for comment in &d.ply_comments {
        println!("  PLY comment        {comment}");
    }
    if !d.stl_header.is_empty() {
        println!("  STL header         {}", d.stl_header);
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
    for what in &info.not_read {
        println!("  not read           {what}");
    }
}
