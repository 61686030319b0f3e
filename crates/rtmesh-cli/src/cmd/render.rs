//! `rtmesh render`: a PNG of the mesh shaded by its normals, or of the tracer's work.

use crate::args::{load, parse_size, CameraArg};
use crate::output::emit;
use anyhow::Result;
use clap::ValueEnum;
use rtmesh::bvh::BuildSettings;
use rtmesh::render::HeatmapMetric;
use rtmesh::trace::SceneAccel;
use serde::Serialize;
use std::path::PathBuf;

/// What a heatmap counts per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Heatmap {
    /// Ray–box tests of the pixel's primary ray.
    Boxes,
    /// Ray–triangle tests of the pixel's primary ray.
    Tris,
}

impl Heatmap {
    fn name(self) -> &'static str {
        match self {
            Heatmap::Boxes => "boxes",
            Heatmap::Tris => "tris",
        }
    }
}

/// Render a PNG: the mesh shaded by its normals, or a heatmap of the tracer's work.
///
/// The default camera looks at the centre of the bounds from the (1, 1, 1) diagonal.
/// `--heatmap boxes` colours each pixel by the ray–box tests its primary ray needed,
/// `--heatmap tris` by the triangle tests, with a legend bar below.
#[derive(clap::Args)]
pub struct Args {
    /// The mesh file, or builtin:NAME.
    mesh: String,
    /// Output PNG file.
    #[arg(short, long)]
    output: PathBuf,
    /// Show work per pixel instead of normals.
    #[arg(long, value_enum)]
    heatmap: Option<Heatmap>,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600", value_parser = parse_size)]
    size: (usize, usize),
    #[command(flatten)]
    camera: CameraArg,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What `render` wrote.
#[derive(Serialize)]
pub struct Report {
    output: PathBuf,
    width: usize,
    height: usize,
    /// `normals` for a shaded picture.
    #[serde(skip_serializing_if = "Option::is_none")]
    shading: Option<&'static str>,
    /// The heatmap's count, for a heatmap.
    #[serde(skip_serializing_if = "Option::is_none")]
    heatmap: Option<&'static str>,
    /// Mean count per pixel, for a heatmap.
    #[serde(skip_serializing_if = "Option::is_none")]
    mean_per_ray: Option<f64>,
    /// Largest count of any pixel, for a heatmap.
    #[serde(skip_serializing_if = "Option::is_none")]
    max_per_ray: Option<u64>,
    /// The count at the top of the colour scale, for a heatmap.
    #[serde(skip_serializing_if = "Option::is_none")]
    scale_max: Option<u64>,
}

/// Build, render, write.
pub fn run(args: Args) -> Result<()> {
    let scene = load(&args.mesh)?;
    let accel = SceneAccel::build(&scene, &BuildSettings::default());
    let (width, height) = args.size;
    let mut report = Report {
        output: args.output,
        width,
        height,
        shading: None,
        heatmap: None,
        mean_per_ray: None,
        max_per_ray: None,
        scale_max: None,
    };
    match args.heatmap {
        None => {
            rtmesh::render::normals(&scene, &accel, args.camera.view, args.size)
                .write_png(&report.output)?;
            report.shading = Some("normals");
        }
        Some(kind) => {
            let metric = match kind {
                Heatmap::Boxes => HeatmapMetric::BoxTests,
                Heatmap::Tris => HeatmapMetric::TriangleTests,
            };
            let map = rtmesh::render::heatmap(&scene, &accel, args.camera.view, args.size, metric);
            map.image.write_png(&report.output)?;
            report.heatmap = Some(kind.name());
            report.mean_per_ray = Some(map.mean);
            report.max_per_ray = Some(map.max);
            report.scale_max = Some(map.scale_max);
        }
    }
    emit(&report, args.json, |r| {
        println!(
            "wrote {} ({}x{}{})",
            r.output.display(),
            r.width,
            r.height,
            match (r.heatmap, r.mean_per_ray, r.max_per_ray) {
                (Some(h), Some(mean), Some(max)) =>
                    format!(", heatmap of {h} tests per ray: mean {mean:.2}, max {max}"),
                _ => String::new(),
            }
        )
    })
}
