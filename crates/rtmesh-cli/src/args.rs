//! Option values shared by several subcommands: image sizes, packet shapes, ray kinds
//! and intersectors as clap value enums (so `--help` lists them and a bad value gets
//! clap's error), and the mesh argument.

use anyhow::{Context, Result};
use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};
use rtmesh::trace::intersect::IntersectorKind;
use rtmesh::trace::RayKind;
use rtmesh::Scene;
use std::path::Path;

/// Which rays to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Rays {
    /// Camera rays, one per pixel, closest hit.
    Primary,
    /// One cosine-weighted bounce from each primary hit, closest hit.
    Diffuse,
    /// Occlusion rays from each primary hit toward a point light, any hit.
    Shadow,
}

impl From<Rays> for RayKind {
    fn from(rays: Rays) -> Self {
        match rays {
            Rays::Primary => RayKind::Primary,
            Rays::Diffuse => RayKind::Diffuse,
            Rays::Shadow => RayKind::Shadow,
        }
    }
}

/// The library's ray kinds of a list of `--rays` values.
pub fn ray_kinds(rays: &[Rays]) -> Vec<RayKind> {
    rays.iter().map(|&r| r.into()).collect()
}

/// `--camera`, shared by `trace`, `render` and `optimize`.
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct CameraArg {
    /// Where the camera stands: iso (from the (1, 1, 1) diagonal), front (+Z), back,
    /// left (−X), right, top (+Y), each looking at the centre of the bounds from 1.2 ×
    /// their diagonal with a 45° field of view; or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV for
    /// eye, target, up and vertical field of view in degrees. Primary rays come from
    /// it, and the diffuse and shadow rays from their hits.
    #[arg(long = "camera", default_value = "iso", value_name = "VIEW")]
    pub view: rtmesh::trace::View,
}

/// A ray-triangle test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Intersector {
    /// Möller–Trumbore, edges computed per test.
    Moller,
    /// Möller–Trumbore with precomputed edges and normal.
    MollerPre,
    /// The packet paper's Möller: shared terms once per packet and triangle.
    MollerPacket,
    /// Plücker coordinates.
    Pluecker,
    /// Woop, Benthin and Wald's watertight test.
    Watertight,
}

impl From<Intersector> for IntersectorKind {
    fn from(kind: Intersector) -> Self {
        match kind {
            Intersector::Moller => IntersectorKind::Moller,
            Intersector::MollerPre => IntersectorKind::MollerPre,
            Intersector::MollerPacket => IntersectorKind::MollerPacket,
            Intersector::Pluecker => IntersectorKind::Pluecker,
            Intersector::Watertight => IntersectorKind::Watertight,
        }
    }
}

/// A square packet of neighbouring pixels' rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PacketShape {
    /// One ray.
    #[value(name = "1x1")]
    One,
    /// 2×2 rays.
    #[value(name = "2x2")]
    Two,
    /// 4×4 rays.
    #[value(name = "4x4")]
    Four,
    /// 8×8 rays.
    #[value(name = "8x8")]
    Eight,
}

impl PacketShape {
    /// The side, in rays.
    pub fn side(self) -> usize {
        match self {
            PacketShape::One => 1,
            PacketShape::Two => 2,
            PacketShape::Four => 4,
            PacketShape::Eight => 8,
        }
    }
}

/// WIDTHxHEIGHT with sides 1..32768.
pub fn parse_size(text: &str) -> Result<(usize, usize), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or("expected WIDTHxHEIGHT, e.g. 1024x768")?;
    let parse = |v: &str| v.parse::<usize>().ok().filter(|&n| n > 0 && n <= 1 << 15);
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!(
            "bad size '{text}': expected WIDTHxHEIGHT with sides 1..32768"
        )),
    }
}

/// WIDTHxHEIGHT, or 0x0 for "none".
pub fn parse_size_or_zero(text: &str) -> Result<(usize, usize), String> {
    if text == "0x0" {
        Ok((0, 0))
    } else {
        parse_size(text)
    }
}

/// How every mesh of this run is read (`--asset-root`), set once by `cmd::run`.
static READ_OPTIONS: std::sync::OnceLock<rtmesh::io::ReadOptions> = std::sync::OnceLock::new();

/// Set how meshes are read for the rest of the run.
pub fn set_read_options(options: rtmesh::io::ReadOptions) {
    READ_OPTIONS
        .set(options)
        .expect("read options are set once");
}

/// How meshes are read in this run.
pub fn read_options() -> &'static rtmesh::io::ReadOptions {
    READ_OPTIONS.get_or_init(Default::default)
}

/// Read a mesh file (with a progress bar for large files) or make a built-in scene
/// (`builtin:NAME`).
pub fn load(mesh: &str) -> Result<Scene> {
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
    let scene = rtmesh::io::read_with(path, read_options(), &mut |done, _| bar.set_position(done));
    bar.finish_and_clear();
    Ok(scene?)
}

/// The file name of a mesh argument (the argument itself for builtin:NAME), for tables.
pub fn file_name(mesh: &str) -> &str {
    Path::new(mesh)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(mesh)
}
