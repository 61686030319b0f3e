//! Pictures: primary-ray images shaded by the surface normal, and heatmaps of the
//! tracer's work per pixel (box tests or triangle tests) in the perceptual viridis
//! colour map, with a legend bar and its scale, written as PNG.
//!
//! The legend's labels use a 3×5 pixel bitmap font defined here (digits, the letters
//! the labels need, and a few signs): a font library would be a large dependency for
//! a dozen glyphs.

use crate::mesh::Scene;
use crate::trace::run::trace_closest;
use crate::trace::workload::geometric_normal;
use crate::trace::{RayCounters, Tracer, View, Workload};
use glam::Vec3;
use std::path::Path;

/// An 8-bit RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major RGB bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A `width` × `height` image filled with `color`.
    pub fn new(width: usize, height: usize, color: [u8; 3]) -> Self {
        Self {
            width,
            height,
            rgb: color
                .iter()
                .copied()
                .cycle()
                .take(width * height * 3)
                .collect(),
        }
    }

    /// Set pixel `(x, y)`; outside the image does nothing.
    pub fn set(&mut self, x: usize, y: usize, color: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x);
            self.rgb[i..i + 3].copy_from_slice(&color);
        }
    }

    /// Pixel `(x, y)`.
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Write as an 8-bit RGB PNG.
    pub fn write_png(&self, path: &Path) -> std::io::Result<()> {
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        self.encode_png(file)
    }

    /// The 8-bit RGB PNG file's bytes.
    pub fn png_bytes(&self) -> Vec<u8> {
        let mut bytes = Vec::new();
        self.encode_png(&mut bytes)
            .expect("encoding into memory does not fail");
        bytes
    }

    fn encode_png(&self, out: impl std::io::Write) -> std::io::Result<()> {
        let mut encoder = png::Encoder::new(out, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&self.rgb)
            .map_err(std::io::Error::other)
    }
}

const BACKGROUND: [u8; 3] = [24, 24, 28];

/// The scene seen from `view`, each pixel coloured by its hit's geometric normal
/// (`0.5 · n + 0.5` as RGB); misses are dark grey.
pub fn normals(
    scene: &Scene,
    accel: &impl Tracer,
    view: View,
    (width, height): (usize, usize),
) -> Image {
    let camera = view.camera(&scene.bounds(), width, height);
    let work = Workload::primary(&camera, width, height);
    let (hits, _) = trace_closest::<crate::trace::NoCounters>(accel, &work.rays);
    let mut image = Image::new(width, height, BACKGROUND);
    for ((hit, &pixel), ray) in hits.iter().zip(&work.pixels).zip(&work.rays) {
        if hit.is_hit() {
            let mut n = geometric_normal(scene, hit);
            if n.dot(ray.direction) > 0.0 {
                n = -n;
            }
            let c = (n * 0.5 + Vec3::splat(0.5)) * 255.0;
            image.set(
                pixel as usize % width,
                pixel as usize / width,
                [c.x as u8, c.y as u8, c.z as u8],
            );
        }
    }
    image
}

/// Which counter a heatmap shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeatmapMetric {
    /// Ray–box tests per pixel.
    BoxTests,
    /// Ray–triangle tests per pixel.
    TriangleTests,
}

/// A heatmap and its scale.
#[derive(Clone, Debug)]
pub struct Heatmap {
    /// The picture, with a legend strip below the scene.
    pub image: Image,
    /// The count that maps to the top of the scale (99.5th percentile, so a few
    /// outliers do not wash out the rest).
    pub scale_max: u64,
    /// Mean count per pixel.
    pub mean: f64,
    /// Largest count of any pixel.
    pub max: u64,
}

/// Matplotlib's viridis at nine evenly spaced stops, interpolated linearly.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [72, 40, 120],
    [62, 73, 137],
    [49, 104, 142],
    [38, 130, 142],
    [31, 158, 137],
    [53, 183, 121],
    [110, 206, 88],
    [253, 231, 37],
];

/// Viridis colour of `x` in `[0, 1]` (clamped).
pub fn viridis(x: f32) -> [u8; 3] {
    let x = x.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f32;
    let i = (x as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    [0, 1, 2].map(|k| (a[k] as f32 + (b[k] as f32 - a[k] as f32) * f).round() as u8)
}

/// Work per pixel (row-major) of the primary rays of `scene` seen from `view`.
pub fn work_per_pixel(
    scene: &Scene,
    accel: &impl Tracer,
    view: View,
    (width, height): (usize, usize),
    metric: HeatmapMetric,
) -> Vec<u64> {
    let camera = view.camera(&scene.bounds(), width, height);
    let work = Workload::primary(&camera, width, height);
    let (_, counters) = trace_closest::<RayCounters>(accel, &work.rays);
    let mut values = vec![0; width * height];
    for (c, &pixel) in counters.iter().zip(&work.pixels) {
        values[pixel as usize] = match metric {
            HeatmapMetric::BoxTests => c.box_tests,
            HeatmapMetric::TriangleTests => c.triangle_tests,
        };
    }
    values
}

/// The top of a heatmap's colour scale for `values`: their 99.5th percentile (at least
/// 1), so that a few outliers do not wash out the rest.
pub fn scale_top(values: &[u64]) -> u64 {
    let mut sorted = values.to_vec();
    sorted.sort_unstable();
    sorted
        .get(sorted.len() * 995 / 1000)
        .copied()
        .unwrap_or(0)
        .max(1)
}

/// `values` (row-major, `width` wide) in viridis from 0 to `scale_max` (and above).
pub fn heatmap_image(values: &[u64], width: usize, scale_max: u64) -> Image {
    let height = values.len() / width.max(1);
    let mut image = Image::new(width, height, BACKGROUND);
    for (i, &v) in values.iter().enumerate() {
        image.set(
            i % width,
            i / width,
            viridis(v as f32 / scale_max.max(1) as f32),
        );
    }
    image
}

/// `after − before` per pixel on a diverging scale: blue where `after` needs fewer
/// tests, red where it needs more, white where they are equal; full colour at
/// ±`scale` tests.
pub fn difference_image(before: &[u64], after: &[u64], width: usize, scale: u64) -> Image {
    let height = before.len() / width.max(1);
    let mut image = Image::new(width, height, BACKGROUND);
    for (i, (&b, &a)) in before.iter().zip(after).enumerate() {
        let d = ((a as f32 - b as f32) / scale.max(1) as f32).clamp(-1.0, 1.0);
        let fade = |full: f32| (255.0 + (full - 255.0) * d.abs()).round() as u8;
        let color = if d < 0.0 {
            [fade(33.0), fade(102.0), fade(172.0)]
        } else {
            [fade(178.0), fade(24.0), fade(43.0)]
        };
        image.set(i % width, i / width, color);
    }
    image
}

/// Work per pixel of the primary rays, as a heatmap with a legend.
pub fn heatmap(
    scene: &Scene,
    accel: &impl Tracer,
    view: View,
    (width, height): (usize, usize),
    metric: HeatmapMetric,
) -> Heatmap {
    let values = work_per_pixel(scene, accel, view, (width, height), metric);
    let max = values.iter().copied().max().unwrap_or(0);
    let scale_max = scale_top(&values);
    let mean = values.iter().sum::<u64>() as f64 / values.len().max(1) as f64;
    let legend_height = 44;
    let mut image = heatmap_image(&values, width, scale_max);
    image.height += legend_height;
    image.rgb.extend(
        BACKGROUND
            .iter()
            .copied()
            .cycle()
            .take(width * legend_height * 3),
    );
    // Legend: a colour bar from 0 to the scale's top, with its ends and label.
    let (left, right) = (8, width.saturating_sub(8).max(9));
    for x in left..right {
        let color = viridis((x - left) as f32 / (right - left - 1).max(1) as f32);
        for y in height + 6..height + 18 {
            image.set(x, y, color);
        }
    }
    let white = [235, 235, 235];
    let label = match metric {
        HeatmapMetric::BoxTests => "BOX TESTS PER RAY",
        HeatmapMetric::TriangleTests => "TRIANGLE TESTS PER RAY",
    };
    draw_text(&mut image, left, height + 24, "0", white);
    let top = format!("{scale_max}+");
    draw_text(
        &mut image,
        right.saturating_sub(text_width(&top)),
        height + 24,
        &top,
        white,
    );
    let middle = format!("{label}  MEAN {mean:.1}  MAX {max}");
    draw_text(
        &mut image,
        (width.saturating_sub(text_width(&middle))) / 2,
        height + 24,
        &middle,
        white,
    );
    Heatmap {
        image,
        scale_max,
        mean,
        max,
    }
}

const GLYPH_SCALE: usize = 2;

/// 3×5 glyphs, five rows of three bits (most significant bit = left column).
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '+' => [0, 2, 7, 2, 0],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'G' => [7, 4, 5, 5, 7],
        'I' => [7, 2, 2, 2, 7],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [5, 7, 7, 7, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        _ => [0; 5],
    }
}

fn text_width(text: &str) -> usize {
    text.chars().count() * 4 * GLYPH_SCALE
}

fn draw_text(image: &mut Image, x0: usize, y0: usize, text: &str, color: [u8; 3]) {
    for (i, c) in text.chars().enumerate() {
        for (row, bits) in glyph(c).iter().enumerate() {
            for column in 0..3 {
                if bits & (4 >> column) != 0 {
                    for dy in 0..GLYPH_SCALE {
                        for dx in 0..GLYPH_SCALE {
                            let x = x0 + (i * 4 + column) * GLYPH_SCALE + dx;
                            image.set(x, y0 + row * GLYPH_SCALE + dy, color);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildSettings;
    use crate::trace::SceneAccel;

    #[test]
    fn heatmap_and_difference_pixels() {
        let image = heatmap_image(&[0, 5, 10, 20], 2, 10);
        assert_eq!((image.width, image.height), (2, 2));
        assert_eq!(image.get(0, 0), viridis(0.0));
        assert_eq!(image.get(1, 0), viridis(0.5));
        assert_eq!(image.get(1, 1), viridis(1.0), "clamped above the scale");
        let difference = difference_image(&[4, 4, 4], &[4, 0, 12], 3, 4);
        assert_eq!(difference.get(0, 0), [255, 255, 255], "no change is white");
        assert_eq!(
            difference.get(1, 0),
            [33, 102, 172],
            "fewer tests: full blue"
        );
        assert_eq!(
            difference.get(2, 0),
            [178, 24, 43],
            "more tests: full red (clamped)"
        );
        assert_eq!(scale_top(&[0; 10]), 1);
        assert_eq!(scale_top(&(0..1000).collect::<Vec<u64>>()), 995);
    }

    #[test]
    fn viridis_ends_and_clamps() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(-1.0), viridis(0.0));
    }

    #[test]
    fn normal_image_shows_the_blob_and_background() {
        let scene = Scene::from_mesh(crate::scenes::scan_blob(2_000, 1));
        let accel = SceneAccel::build(&scene, &BuildSettings::default());
        let image = normals(&scene, &accel, View::Iso, (64, 48));
        assert_eq!(
            (image.width, image.height, image.rgb.len()),
            (64, 48, 64 * 48 * 3)
        );
        assert_eq!(image.get(0, 0), BACKGROUND, "corner sees the background");
        assert_ne!(image.get(32, 24), BACKGROUND, "centre sees the blob");
        let map = heatmap(&scene, &accel, View::Iso, (64, 48), HeatmapMetric::BoxTests);
        assert_eq!(map.image.height, 48 + 44);
        assert!(map.mean > 0.0 && map.max >= map.scale_max);
    }
}
