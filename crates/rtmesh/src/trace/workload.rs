//! Deterministic ray workloads, as DESIGN.md defines them, and the runners that trace
//! them on all threads of the current rayon pool.
//!
//! - Camera: looks at the bounds' centre from the (1, 1, 1) diagonal direction, at 1.2 ×
//!   the bounds' diagonal, 45° vertical field of view, +Y up.
//! - `primary`: one ray per pixel centre, in 8×8 tiles (tile-major order: coherent
//!   rays run together and threads take whole tiles).
//! - `diffuse`: from each primary hit, one cosine-weighted bounce about the geometric
//!   normal (turned to face the camera), seeded per pixel.
//! - `shadow`: from each primary hit, an occlusion ray toward a point light at
//!   `centre + diagonal · (0.3, 1.0, 0.5)`, stopping just short of it.
//!
//! Secondary rays start `1e-4 ·` diagonal off the surface. Pixels whose primary ray
//! misses have no secondary ray.

use super::run::trace_closest;
use super::{Hit, NoCounters, Tracer, TILE};
use crate::geom::{Aabb, Ray};
use crate::mesh::Scene;
use crate::random::SplitMix64;
use glam::Vec3;
use rayon::prelude::*;

/// Which rays to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// Camera rays, closest hit.
    Primary,
    /// One diffuse bounce per primary hit, closest hit.
    Diffuse,
    /// Occlusion toward a point light per primary hit, any hit.
    Shadow,
}

impl RayKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Diffuse => "diffuse",
            RayKind::Shadow => "shadow",
        }
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit right vector scaled by tan(fov/2)·aspect.
    pub right: Vec3,
    /// Unit up vector scaled by tan(fov/2).
    pub up: Vec3,
}

impl Camera {
    /// The default camera for `bounds` and an image of `width` × `height`
    /// ([`View::Iso`]).
    pub fn default_for(bounds: &Aabb, width: usize, height: usize) -> Self {
        View::Iso.camera(bounds, width, height)
    }

    /// A camera at `eye` looking at `target`, `fov_degrees` vertical field of view, +Y
    /// up.
    pub fn look_at(eye: Vec3, target: Vec3, fov_degrees: f32, width: usize, height: usize) -> Self {
        Self::look_at_up(eye, target, Vec3::Y, fov_degrees, width, height)
    }

    /// A camera at `eye` looking at `target` with `up` (any vector off the view
    /// direction) pointing up in the image, `fov_degrees` vertical field of view.
    pub fn look_at_up(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_degrees: f32,
        width: usize,
        height: usize,
    ) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let tan = (fov_degrees.to_radians() * 0.5).tan();
        let aspect = width as f32 / height.max(1) as f32;
        Self {
            eye,
            forward,
            right: right * tan * aspect,
            up: up * tan,
        }
    }

    /// The ray through pixel `(x, y)` (row 0 at the top) of a `width` × `height` image.
    pub fn ray(&self, x: usize, y: usize, width: usize, height: usize) -> Ray {
        let sx = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
        let sy = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
        Ray::new(
            self.eye,
            (self.forward + self.right * sx + self.up * sy).normalize(),
        )
    }
}

/// Where the camera of a workload or picture stands: a named view of the scene's
/// bounds, or an explicit camera (`--camera`).
///
/// The named views look at the bounds' centre from 1.2 × the bounds' diagonal, 45°
/// vertical field of view: `iso` from the (1, 1, 1) diagonal (the default of every
/// workload), `front` from +Z, `back` from −Z, `left` from −X, `right` from +X, `top`
/// from +Y (with −Z up in the image). An explicit camera is written
/// `EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV`: eye, target, up, vertical field of view in degrees.
#[derive(Clone, Copy, Debug, PartialEq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    /// From the (1, 1, 1) diagonal, +Y up.
    #[default]
    Iso,
    /// From +Z.
    Front,
    /// From −Z.
    Back,
    /// From −X.
    Left,
    /// From +X.
    Right,
    /// From +Y, −Z up.
    Top,
    /// Eye, target, up and vertical field of view in degrees.
    Explicit {
        /// Eye position.
        eye: [f32; 3],
        /// Point looked at.
        target: [f32; 3],
        /// Up in the image.
        up: [f32; 3],
        /// Vertical field of view, degrees.
        fov: f32,
    },
}

/// A `--camera` value that is neither a view name nor ten numbers.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown camera `{0}`: expected iso, front, back, left, right, top, or EX,EY,EZ,TX,TY,TZ,UX,UY,UZ,FOV (eye, target, up, field of view in degrees, eye ≠ target)")]
pub struct UnknownView(pub String);

impl std::str::FromStr for View {
    type Err = UnknownView;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let named = match s {
            "iso" => Some(View::Iso),
            "front" => Some(View::Front),
            "back" => Some(View::Back),
            "left" => Some(View::Left),
            "right" => Some(View::Right),
            "top" => Some(View::Top),
            _ => None,
        };
        if let Some(view) = named {
            return Ok(view);
        }
        let numbers: Vec<f32> = s
            .split(',')
            .map(|n| n.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| UnknownView(s.to_owned()))?;
        let [ex, ey, ez, tx, ty, tz, ux, uy, uz, fov] = numbers[..] else {
            return Err(UnknownView(s.to_owned()));
        };
        let (eye, target, up) = (
            Vec3::new(ex, ey, ez),
            Vec3::new(tx, ty, tz),
            Vec3::new(ux, uy, uz),
        );
        let forward = target - eye;
        let usable = numbers.iter().all(|n| n.is_finite())
            && forward.length_squared() > 0.0
            && forward.cross(up).length_squared() > 0.0
            && fov > 0.0
            && fov < 180.0;
        if !usable {
            return Err(UnknownView(s.to_owned()));
        }
        Ok(View::Explicit {
            eye: eye.into(),
            target: target.into(),
            up: up.into(),
            fov,
        })
    }
}

impl std::fmt::Display for View {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            View::Iso => write!(f, "iso"),
            View::Front => write!(f, "front"),
            View::Back => write!(f, "back"),
            View::Left => write!(f, "left"),
            View::Right => write!(f, "right"),
            View::Top => write!(f, "top"),
            View::Explicit {
                eye,
                target,
                up,
                fov,
            } => {
                let numbers: Vec<String> = eye
                    .iter()
                    .chain(target)
                    .chain(up)
                    .chain([fov])
                    .map(f32::to_string)
                    .collect();
                write!(f, "{}", numbers.join(","))
            }
        }
    }
}

impl View {
    /// The camera of this view for `bounds` and an image of `width` × `height`.
    pub fn camera(&self, bounds: &Aabb, width: usize, height: usize) -> Camera {
        let center = if bounds.is_empty() {
            Vec3::ZERO
        } else {
            bounds.center()
        };
        let distance = 1.2 * bounds.diagonal_length().max(1e-6);
        let (from, up) = match *self {
            View::Iso => (Vec3::ONE.normalize(), Vec3::Y),
            View::Front => (Vec3::Z, Vec3::Y),
            View::Back => (-Vec3::Z, Vec3::Y),
            View::Left => (-Vec3::X, Vec3::Y),
            View::Right => (Vec3::X, Vec3::Y),
            View::Top => (Vec3::Y, -Vec3::Z),
            View::Explicit {
                eye,
                target,
                up,
                fov,
            } => {
                return Camera::look_at_up(eye.into(), target.into(), up.into(), fov, width, height)
            }
        };
        Camera::look_at_up(center + from * distance, center, up, 45.0, width, height)
    }
}

/// Rays to trace, with the pixel each belongs to.
#[derive(Clone, Debug)]
pub struct Workload {
    /// Which rays these are.
    pub kind: RayKind,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The rays, in tile order.
    pub rays: Vec<Ray>,
    /// `pixels[i]` = `y · width + x` of ray `i`.
    pub pixels: Vec<u32>,
}

/// Pixel indices of a `width` × `height` image in 8×8 tile order.
fn tile_order(width: usize, height: usize) -> Vec<u32> {
    let mut pixels = Vec::with_capacity(width * height);
    for ty in (0..height).step_by(TILE) {
        for tx in (0..width).step_by(TILE) {
            for y in ty..(ty + TILE).min(height) {
                for x in tx..(tx + TILE).min(width) {
                    pixels.push((y * width + x) as u32);
                }
            }
        }
    }
    pixels
}

impl Workload {
    /// Camera rays for every pixel.
    pub fn primary(camera: &Camera, width: usize, height: usize) -> Self {
        let pixels = tile_order(width, height);
        let rays = pixels
            .iter()
            .map(|&p| camera.ray(p as usize % width, p as usize / width, width, height))
            .collect();
        Self {
            kind: RayKind::Primary,
            width,
            height,
            rays,
            pixels,
        }
    }

    /// Camera rays grouped into packets of `side` × `side` neighbouring pixels (see
    /// [`Self::grouped`]).
    pub fn primary_packets(
        camera: &Camera,
        width: usize,
        height: usize,
        side: usize,
    ) -> (Self, Vec<u32>) {
        Self::primary(camera, width, height).grouped(side)
    }

    /// The same rays grouped into packets by `side` × `side` blocks of pixels (smaller
    /// at the right and bottom edges when `side` does not divide the image; pixels
    /// without a ray leave packets short), blocks row-major, rays row-major inside.
    /// Returns the reordered workload and the packet boundaries: packet `k` is
    /// `rays[starts[k]..starts[k + 1]]`.
    pub fn grouped(&self, side: usize) -> (Self, Vec<u32>) {
        let side = side.max(1);
        let blocks_across = self.width.div_ceil(side);
        let block = |pixel: u32| {
            let (x, y) = (pixel as usize % self.width, pixel as usize / self.width);
            (y / side) * blocks_across + x / side
        };
        let mut order: Vec<u32> = (0..self.rays.len() as u32).collect();
        order.sort_unstable_by_key(|&i| (block(self.pixels[i as usize]), self.pixels[i as usize]));
        let mut starts = vec![0u32];
        for k in 1..order.len() {
            if block(self.pixels[order[k] as usize]) != block(self.pixels[order[k - 1] as usize]) {
                starts.push(k as u32);
            }
        }
        starts.push(order.len() as u32);
        if order.is_empty() {
            starts.truncate(1);
        }
        let grouped = Self {
            kind: self.kind,
            width: self.width,
            height: self.height,
            rays: order.iter().map(|&i| self.rays[i as usize]).collect(),
            pixels: order.iter().map(|&i| self.pixels[i as usize]).collect(),
        };
        (grouped, starts)
    }

    /// The workload of `kind` for `scene` seen by the default camera (secondary rays
    /// start from primary hits found with `accel`).
    pub fn generate(
        kind: RayKind,
        scene: &Scene,
        accel: &impl Tracer,
        width: usize,
        height: usize,
        seed: u64,
    ) -> Self {
        Self::generate_from(View::Iso, kind, scene, accel, (width, height), seed)
    }

    /// [`Self::generate`] seen from `view`.
    pub fn generate_from(
        view: View,
        kind: RayKind,
        scene: &Scene,
        accel: &impl Tracer,
        (width, height): (usize, usize),
        seed: u64,
    ) -> Self {
        let bounds = scene.bounds();
        let primary = Self::primary(&view.camera(&bounds, width, height), width, height);
        if kind == RayKind::Primary {
            return primary;
        }
        let hits = trace_closest::<NoCounters>(accel, &primary.rays).0;
        let diagonal = bounds.diagonal_length();
        let offset = 1e-4 * diagonal;
        let light = bounds.center() + diagonal * Vec3::new(0.3, 1.0, 0.5);
        let secondary: Vec<(Ray, u32)> = (0..hits.len())
            .into_par_iter()
            .filter(|&i| hits[i].is_hit())
            .map(|i| {
                let (ray, hit) = (&primary.rays[i], &hits[i]);
                let normal = geometric_normal(scene, hit);
                let normal = if normal.dot(ray.direction) > 0.0 {
                    -normal
                } else {
                    normal
                };
                let origin = ray.at(hit.t) + normal * offset;
                let pixel = primary.pixels[i];
                let ray = match kind {
                    RayKind::Shadow => Ray {
                        origin,
                        direction: light - origin,
                        t_min: 0.0,
                        t_max: 1.0 - 1e-4,
                    },
                    _ => {
                        let mut rng = SplitMix64::new(
                            seed ^ (pixel as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                        );
                        Ray::new(
                            origin,
                            cosine_direction(normal, rng.next_f32(), rng.next_f32()),
                        )
                    }
                };
                (ray, pixel)
            })
            .collect();
        let (rays, pixels) = secondary.into_iter().unzip();
        Self {
            kind,
            width,
            height,
            rays,
            pixels,
        }
    }
}

/// Unit geometric normal of the hit triangle in world space.
pub fn geometric_normal(scene: &Scene, hit: &Hit) -> Vec3 {
    let instance = &scene.instances[hit.instance as usize];
    let [a, b, c] = scene.meshes[instance.mesh]
        .corners(hit.triangle as usize)
        .map(|p| instance.transform.transform_point3(p));
    (b - a).cross(c - a).normalize_or(Vec3::Y)
}

/// A cosine-weighted direction about the unit `normal` from two uniform numbers.
fn cosine_direction(normal: Vec3, r1: f32, r2: f32) -> Vec3 {
    let (tangent, bitangent) = normal.any_orthonormal_pair();
    let phi = std::f32::consts::TAU * r1;
    let radius = r2.sqrt();
    (tangent * (radius * phi.cos())
        + bitangent * (radius * phi.sin())
        + normal * (1.0 - r2).max(0.0).sqrt())
    .normalize()
}
