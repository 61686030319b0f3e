//! The report of `rtmesh optimize` as one self-contained HTML file: no script runs and
//! nothing is fetched (pictures are `data:` PNGs, histograms inline SVG, styles inline),
//! so it opens anywhere, under the Content-Security-Policy
//! `default-src 'none'; img-src data:; style-src 'unsafe-inline'` that it declares. The
//! whole [`OptimizeReport`] is embedded as JSON in a `<script type="application/json">`
//! data block (never executed) for tools to read back.

use super::{Figures, Histogram, OptimizeReport, Optimized, RayFigures};
use crate::bvh::BuildSettings;
use crate::render::{self, HeatmapMetric, Image};
use crate::trace::{LeafBlock, SceneAccel, View};
use crate::Scene;
use base64::Engine;
use serde::Serialize;
use std::fmt::Write;

/// The policy the report declares and keeps to.
pub const CONTENT_SECURITY_POLICY: &str =
    "default-src 'none'; img-src data:; style-src 'unsafe-inline'";

/// Where and how the report was made.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Header {
    /// The command line.
    pub command: String,
    /// The input file (or builtin:NAME).
    pub input: String,
    /// SHA-256 of the input file's bytes, hex.
    pub input_sha256: String,
    /// The CPU's model name.
    pub cpu: String,
    /// Threads the measurement ran on.
    pub threads: usize,
    /// When (RFC 3339, UTC).
    pub date: String,
    /// The mesh written, or empty (`--dry-run`).
    pub output: String,
    /// What the output's format cannot hold and the output goes without, in words.
    pub not_held: Vec<String>,
    /// What the input holds that rtmesh does not read, in words.
    pub not_read: Vec<String>,
}

/// The report's pictures: the shaded output and the box tests per pixel of the input
/// and the output's primary rays, seen from one view.
#[derive(Clone, Debug)]
pub struct Pictures {
    /// The output shaded by its normals.
    pub shaded: Image,
    /// Box tests per pixel (row-major) through the input's BVH.
    pub boxes_before: Vec<u64>,
    /// Box tests per pixel through the output's BVH (pair leaves for pairs).
    pub boxes_after: Vec<u64>,
    /// Width of the pictures.
    pub width: usize,
}

impl Pictures {
    /// Render the pictures of `optimized` against `input` from `view` at `size`.
    pub fn render(input: &Scene, optimized: &Optimized, view: View, size: (usize, usize)) -> Self {
        let build = BuildSettings::default();
        let before = SceneAccel::build(input, &build);
        let boxes_before =
            render::work_per_pixel(input, &before, view, size, HeatmapMetric::BoxTests);
        let pairs = optimized.pair_counts.iter().any(|&k| k > 0);
        let (shaded, boxes_after) = if pairs {
            let pairings = optimized.pairings();
            let after = SceneAccel::build_paired(&optimized.scene, &pairings, &build);
            shaded_and_boxes(&optimized.scene, &after, view, size)
        } else {
            let after = SceneAccel::build(&optimized.scene, &build);
            shaded_and_boxes(&optimized.scene, &after, view, size)
        };
        Self {
            shaded,
            boxes_before,
            boxes_after,
            width: size.0,
        }
    }
}

/// The scene shaded, and its box tests per pixel, through `accel`.
fn shaded_and_boxes<L: LeafBlock>(
    scene: &Scene,
    accel: &SceneAccel<L>,
    view: View,
    size: (usize, usize),
) -> (Image, Vec<u64>) {
    (
        render::normals(scene, accel, view, size),
        render::work_per_pixel(scene, accel, view, size, HeatmapMetric::BoxTests),
    )
}

/// Escape text for HTML.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn data_uri(image: &Image) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(image.png_bytes())
    )
}

const STYLE: &str = "body{font:14px/1.45 system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222;padding:0 1em}
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.15em;margin-top:1.8em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;margin:.5em 0}td,th{padding:.2em .7em;border-bottom:1px solid #eee;text-align:right}
th{background:#f4f4f4}td:first-child,th:first-child{text-align:left}
.better{color:#1a7f37;font-weight:600}.worse{color:#b3261e;font-weight:600}
.pics{display:flex;flex-wrap:wrap;gap:1em}.pics figure{margin:0}figcaption{font-size:.9em;color:#555}
.legend{height:14px;width:320px;border:1px solid #999}
.viridis{background:linear-gradient(to right,#440154,#482878,#3e4989,#31688e,#26828e,#1f9e89,#35b779,#6ece58,#fde725)}
.diverging{background:linear-gradient(to right,#2166ac,#ffffff,#b2182b)}
.severity-error{color:#b3261e}.severity-warning{color:#9a6700}code{font-size:.92em}
svg text{font:11px system-ui,sans-serif}";

/// `before → after` with the change in percent, coloured by whether lower is better.
fn change(before: f64, after: f64, decimals: usize, lower_is_better: bool) -> String {
    if before == 0.0 {
        return format!("<td>{before:.decimals$}</td><td>{after:.decimals$}</td><td></td>");
    }
    let percent = 100.0 * (after / before - 1.0);
    let class = if percent.abs() < 1.0 {
        ""
    } else if (percent < 0.0) == lower_is_better {
        "better"
    } else {
        "worse"
    };
    format!(
        "<td>{before:.decimals$}</td><td>{after:.decimals$}</td><td class=\"{class}\">{percent:+.1}%</td>"
    )
}

fn workload_rows(out: &mut String, name: &str, before: &RayFigures, after: &RayFigures) {
    let rows = [
        (
            "box tests / ray",
            before.box_tests_per_ray,
            after.box_tests_per_ray,
            true,
        ),
        (
            "triangle tests / ray",
            before.tri_tests_per_ray,
            after.tri_tests_per_ray,
            true,
        ),
        (
            "pair tests / ray",
            before.pair_tests_per_ray,
            after.pair_tests_per_ray,
            true,
        ),
        ("Mrays/s", before.mrays_per_s, after.mrays_per_s, false),
    ];
    for (label, b, a, lower) in rows {
        let _ = writeln!(
            out,
            "<tr><td>{name}: {label}</td>{}</tr>",
            change(b, a, 2, lower)
        );
    }
}

/// What the output goes without: what rtmesh did not read, and what its format cannot
/// hold (nothing else is changed).
fn left_out(out: &mut String, header: &Header) {
    let lists = [
        ("rtmesh does not read", &header.not_read),
        ("the output's format cannot hold", &header.not_held),
    ];
    for (why, items) in lists.into_iter().filter(|(_, items)| !items.is_empty()) {
        let _ = writeln!(
            out,
            "<p class=\"left-out\">The output goes without what {why}:</p>\n<ul>"
        );
        for item in items {
            let _ = writeln!(out, "<li>{}</li>", escape(item));
        }
        out.push_str("</ul>\n");
    }
}

fn summary(out: &mut String, report: &OptimizeReport) {
    out.push_str(
        "<h2>Summary</h2>\n<table><tr><th></th><th>before</th><th>after</th><th>change</th></tr>\n",
    );
    let count = |label: &str, b: usize, a: usize| {
        format!(
            "<tr><td>{label}</td>{}</tr>\n",
            change(b as f64, a as f64, 0, true)
        )
    };
    out.push_str(&count(
        "triangles",
        report.triangles_in,
        report.triangles_out,
    ));
    out.push_str(&count(
        "geometries",
        report.geometries_in,
        report.geometries_out,
    ));
    let _ = writeln!(
        out,
        "<tr><td>paired triangles</td><td>—</td><td>{:.2}%</td><td></td></tr>",
        100.0 * report.pair_ratio
    );
    if let (Some(b), Some(a)) = (&report.before, &report.after) {
        workload_rows(out, "primary", &b.primary, &a.primary);
        workload_rows(out, "diffuse", &b.diffuse, &a.diffuse);
        workload_rows(out, "shadow", &b.shadow, &a.shadow);
        bvh_rows(out, b, a);
    }
    out.push_str("</table>\n");
    if let Some(same) = &report.same_hits {
        let _ = writeln!(
            out,
            "<p>Same first hits: <b>{:.3}%</b> of {} primary rays hit the same input triangle ({} same, {} ties at the same distance, {} different).</p>",
            100.0 * same.share, same.rays, same.same, same.ties, same.different
        );
    } else {
        out.push_str("<p>Not traced (no measurement asked).</p>\n");
    }
}

fn bvh_rows(out: &mut String, b: &Figures, a: &Figures) {
    let rows = [
        ("BVH bytes", b.bvh_bytes as f64, a.bvh_bytes as f64, 0),
        (
            "geometry bytes",
            b.geometry_bytes as f64,
            a.geometry_bytes as f64,
            0,
        ),
        ("build seconds", b.build_seconds, a.build_seconds, 4),
        ("SAH cost", b.sah_cost as f64, a.sah_cost as f64, 2),
    ];
    for (label, before, after, decimals) in rows {
        let _ = writeln!(
            out,
            "<tr><td>{label}</td>{}</tr>",
            change(before, after, decimals, true)
        );
    }
}

fn production(out: &mut String, report: &OptimizeReport) {
    out.push_str("<h2>A production tracer</h2>\n");
    if report.production.is_empty() {
        out.push_str("<p>Not measured: this rtmesh was built without Embree (<code>cargo build --release -p rtmesh-cli --features embree</code>, with Debian's <code>libembree-dev</code>, adds Embree given the input's triangles and the output's pairs as quads).</p>\n");
        return;
    }
    out.push_str("<table><tr><th>tracer</th><th>workload</th><th>Mrays/s before</th><th>after</th><th>change</th><th>BVH bytes before</th><th>after</th><th>change</th><th>build s before</th><th>after</th><th>change</th><th>same hits</th></tr>\n");
    for row in &report.production {
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td>{}{}{}<td>{:.3}%</td></tr>",
            escape(&row.tracer),
            escape(&row.workload),
            change(row.mrays_before, row.mrays_after, 2, false),
            change(
                row.bvh_bytes_before as f64,
                row.bvh_bytes_after as f64,
                0,
                true
            ),
            change(row.build_seconds_before, row.build_seconds_after, 4, true),
            100.0 * row.same_hits
        );
    }
    out.push_str("</table>\n");
}

fn repairs_and_pairing(out: &mut String, report: &OptimizeReport) {
    let r = &report.repairs;
    out.push_str("<h2>Repairs</h2>\n<table><tr><th>repair</th><th>count</th></tr>\n");
    for (label, n) in [
        ("vertices merged by welding", r.merged_vertices),
        ("degenerate triangles removed", r.removed_degenerate),
        ("exact copies removed", r.removed_duplicates),
        ("scattered geometries split into pieces", r.split_geometries),
        (
            "geometries split into opaque and alpha-tested",
            r.split_alpha_geometries,
        ),
        ("groups of overlapping geometries merged", r.merged_groups),
        (
            "geometries that may be flagged opaque",
            r.opaque_geometries.len(),
        ),
    ] {
        let _ = writeln!(out, "<tr><td>{label}</td><td>{n}</td></tr>");
    }
    out.push_str("</table>\n");
    if let Some(p) = &report.pairing {
        let _ = writeln!(
            out,
            "<h2>Pairing</h2>\n<p>Kept <code>{}</code>. Candidates:</p>\n<table><tr><th>method</th><th>paired</th></tr>",
            escape(&p.method)
        );
        for c in &p.candidates {
            let _ = writeln!(
                out,
                "<tr><td>{}</td><td>{:.2}%</td></tr>",
                escape(&c.method),
                100.0 * c.pair_ratio
            );
        }
        let f = &p.first_fit;
        let _ = writeln!(
            out,
            "</table>\n<p>Hardware first-fit pairers on the output: Embree's quadifier (window 32) {:.2}%, HIPRT (warps of 32) {:.2}%, GPURT (waves of 64) {:.2}% — {}. {} vertices copied to keep unpaired neighbours apart.</p>",
            100.0 * f.embree_window_32,
            100.0 * f.wave_32,
            100.0 * f.wave_64,
            if f.exact { "exactly rtmesh's pairs" } else { "<b class=\"worse\">not exactly rtmesh's pairs</b>" },
            f.vertices_copied
        );
    }
}

fn findings(out: &mut String, report: &OptimizeReport) {
    let lint = &report.lint;
    let _ = writeln!(
        out,
        "<h2>Findings</h2>\n<p>Lint on the input: {} triangles in {} geometries; box empty space p50 {:.2}, p90 {:.2}; aspect p50 {:.1}, p90 {:.1}.</p>",
        lint.triangles, lint.geometries, lint.empty_space.p50, lint.empty_space.p90, lint.aspect.p50, lint.aspect.p90
    );
    if lint.findings.is_empty() {
        out.push_str("<p>No findings.</p>\n");
        return;
    }
    out.push_str("<table><tr><th>kind</th><th>severity</th><th>geometry</th><th>count</th><th>worst ids</th><th style=\"text-align:left\">advice</th></tr>\n");
    for f in &lint.findings {
        let severity = format!("{:?}", f.severity).to_lowercase();
        let worst: Vec<String> = f.worst.iter().map(u32::to_string).collect();
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td class=\"severity-{severity}\">{severity}</td><td>{}</td><td>{}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>",
            f.kind,
            f.geometry,
            f.count,
            worst.join(", "),
            escape(f.advice)
        );
    }
    out.push_str("</table>\n");
}

fn geometries(out: &mut String, report: &OptimizeReport) {
    out.push_str("<h2>Geometries</h2>\n<table><tr><th>geometry</th><th>name</th><th>triangles</th><th>instances</th><th>SAH cost</th><th>BVH bytes</th><th>geometry bytes</th><th>opaque</th></tr>\n");
    const SHOWN: usize = 200;
    for (g, row) in report.geometries.iter().enumerate().take(SHOWN) {
        let _ = writeln!(
            out,
            "<tr><td>{g}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&row.name),
            row.triangles,
            row.instances,
            row.sah_cost,
            row.bvh_bytes,
            row.geometry_bytes,
            if row.opaque { "yes" } else { "no" }
        );
    }
    out.push_str("</table>\n");
    if report.geometries.len() > SHOWN {
        let _ = writeln!(
            out,
            "<p>…and {} more (all are in the JSON below).</p>",
            report.geometries.len() - SHOWN
        );
    }
}

fn pictures(out: &mut String, pictures: &Pictures) {
    let scale =
        render::scale_top(&pictures.boxes_before).max(render::scale_top(&pictures.boxes_after));
    let mean = |v: &[u64]| v.iter().sum::<u64>() as f64 / v.len().max(1) as f64;
    let before = render::heatmap_image(&pictures.boxes_before, pictures.width, scale);
    let after = render::heatmap_image(&pictures.boxes_after, pictures.width, scale);
    let difference_scale = (scale / 4).max(1);
    let difference = render::difference_image(
        &pictures.boxes_before,
        &pictures.boxes_after,
        pictures.width,
        difference_scale,
    );
    let figure = |image: &Image, alt: &str, caption: &str| {
        format!(
            "<figure><img src=\"{}\" width=\"{}\" height=\"{}\" alt=\"{alt}\"><figcaption>{caption}</figcaption></figure>\n",
            data_uri(image),
            image.width,
            image.height
        )
    };
    out.push_str("<h2>Pictures</h2>\n<div class=\"pics\">\n");
    out.push_str(&figure(
        &pictures.shaded,
        "shaded render",
        "the output, shaded by its normals",
    ));
    out.push_str("</div>\n<h3>Box tests per primary ray</h3>\n<div class=\"pics\">\n");
    out.push_str(&figure(
        &before,
        "box tests before",
        &format!("before: mean {:.1}", mean(&pictures.boxes_before)),
    ));
    out.push_str(&figure(
        &after,
        "box tests after",
        &format!("after: mean {:.1}", mean(&pictures.boxes_after)),
    ));
    out.push_str("</div>\n");
    let _ = writeln!(
        out,
        "<p>One colour scale for both: <span>0</span> <span class=\"legend viridis\" style=\"display:inline-block\"></span> <span>{scale}+ box tests</span></p>"
    );
    out.push_str("<div class=\"pics\">\n");
    out.push_str(&figure(&difference, "difference", "after − before"));
    out.push_str("</div>\n");
    let _ = writeln!(
        out,
        "<p>Difference: <span>−{difference_scale} (fewer after)</span> <span class=\"legend diverging\" style=\"display:inline-block\"></span> <span>+{difference_scale} (more after)</span>; white is no change.</p>"
    );
}

/// A bar chart of `histogram` as inline SVG.
fn histogram_svg(title: &str, histogram: &Histogram, label: impl Fn(f64) -> String) -> String {
    let (width, height, bottom) = (420.0, 180.0, 30.0);
    let bins = histogram.counts.len().max(1);
    let top = *histogram.counts.iter().max().unwrap_or(&0) as f64;
    let bar = (width - 20.0) / bins as f64;
    let mut svg = format!(
        "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" role=\"img\" aria-label=\"{title}\">"
    );
    for (i, &count) in histogram.counts.iter().enumerate() {
        let h = if top > 0.0 {
            (height - bottom - 10.0) * count as f64 / top
        } else {
            0.0
        };
        let x = 10.0 + i as f64 * bar;
        let _ = write!(
            svg,
            "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{h:.1}\" fill=\"#3e4989\"><title>{}: {count}</title></rect>",
            height - bottom - h,
            (bar - 2.0).max(1.0),
            label(histogram.edges.get(i).copied().unwrap_or(0.0))
        );
        if i % 2 == 0 {
            let _ = write!(
                svg,
                "<text x=\"{x:.1}\" y=\"{:.1}\">{}</text>",
                height - bottom + 14.0,
                label(histogram.edges.get(i).copied().unwrap_or(0.0))
            );
        }
    }
    let total: u64 = histogram.counts.iter().sum();
    let _ = writeln!(
        svg,
        "</svg><figcaption>{title} ({total} in all; the last bar counts everything above)</figcaption></figure>"
    );
    svg
}

fn histograms(out: &mut String, report: &OptimizeReport) {
    let h = &report.histograms;
    out.push_str("<h2>Distributions</h2>\n<div class=\"pics\">\n");
    out.push_str(&histogram_svg(
        "triangle box empty space",
        &h.empty_space,
        |e| format!("{e:.1}"),
    ));
    out.push_str(&histogram_svg("triangle aspect", &h.aspect, |e| {
        format!("{e:.0}")
    }));
    out.push_str(&histogram_svg(
        "pair box / triangle boxes (surface area)",
        &h.pair_box_ratio,
        |e| format!("{e:.2}"),
    ));
    out.push_str("</div>\n");
}

/// The report as one HTML document.
pub fn html(report: &OptimizeReport, header: &Header, pictures_of: Option<&Pictures>) -> String {
    let mut out = String::with_capacity(1 << 20);
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<meta http-equiv=\"Content-Security-Policy\" content=\"{CONTENT_SECURITY_POLICY}\">\n<title>rtmesh optimize: {}</title>\n<style>{STYLE}</style></head><body>\n",
        escape(&header.input)
    );
    let _ = writeln!(
        out,
        "<h1>rtmesh optimize: {}</h1>\n<p>Prepared for <b>{}</b>: {} → {} triangles, {:.2}% paired, prepared in {:.3} s.</p>",
        escape(&header.input),
        report.target,
        report.triangles_in,
        report.triangles_out,
        100.0 * report.pair_ratio,
        report.step_seconds.prepare
    );
    out.push_str("<table>\n");
    for (label, value) in [
        ("command", header.command.as_str()),
        ("rtmesh", report.rtmesh_version.as_str()),
        ("input", header.input.as_str()),
        ("input SHA-256", header.input_sha256.as_str()),
        ("CPU", header.cpu.as_str()),
        ("threads", &header.threads.to_string()),
        ("date", header.date.as_str()),
        ("output", header.output.as_str()),
    ] {
        let _ = writeln!(
            out,
            "<tr><td>{label}</td><td style=\"text-align:left\"><code>{}</code></td></tr>",
            escape(value)
        );
    }
    out.push_str("</table>\n");
    left_out(&mut out, header);
    summary(&mut out, report);
    production(&mut out, report);
    if let Some(p) = pictures_of {
        pictures(&mut out, p);
    }
    repairs_and_pairing(&mut out, report);
    findings(&mut out, report);
    geometries(&mut out, report);
    histograms(&mut out, report);
    // `</` cannot end the data block early once escaped; JSON reads `<\/` as `</`.
    let json = serde_json::to_string(&serde_json::json!({ "header": header, "report": report }))
        .expect("the report is plain data")
        .replace("</", "<\\/");
    let _ = write!(
        out,
        "<h2>Data</h2>\n<p>The whole report is in this page as JSON (<code>script#report</code>).</p>\n<script type=\"application/json\" id=\"report\">{json}</script>\n</body></html>\n"
    );
    out
}
