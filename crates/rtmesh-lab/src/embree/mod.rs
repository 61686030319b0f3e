//! Embree 3 side by side (feature `embree`): a thin FFI over the few `rtc*` calls needed
//! to build a scene and trace single rays, so that rtmesh can be compared with the
//! reference CPU ray tracer on the very same rays. Links Debian's `libembree3`
//! (`apt-get install libembree-dev`, 3.13).
//!
//! Each scene instance becomes one Embree triangle geometry in world space (geometry id
//! = instance id, primitive id = input triangle id), built with the default (medium)
//! quality, so hits compare one to one with [`rtmesh::trace::Hit`]. Or, given a pairing
//! per mesh, one QUAD geometry per instance: every pair a quad, every unpaired triangle
//! the degenerate quad `(v0, v1, v2, v2)` (a QUAD geometry beside a TRIANGLE geometry
//! makes each ray walk two BVHs, measured 0.56–0.88× as fast); hits are mapped back to
//! the triangle of the quad they fall in. A memory monitor counts the bytes Embree
//! keeps for the BVH.
//!
//! The structs are declared by hand, and `layout.rs` holds them to `rtcore.h` by size,
//! alignment and offset (bindgen would need libclang at build time for six structs).

#[cfg(test)]
mod layout;

use crate::reference::Reference;
use crate::LabError;
use rtmesh::trace::{Counters, Hit, Tracer};
use rtmesh::{Ray, Scene};
use std::ffi::{c_char, c_void, CString};

#[allow(non_camel_case_types)]
type RTCDevice = *mut c_void;
#[allow(non_camel_case_types)]
type RTCScene = *mut c_void;
#[allow(non_camel_case_types)]
type RTCGeometry = *mut c_void;

const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
const RTC_GEOMETRY_TYPE_QUAD: u32 = 1;
const RTC_FORMAT_UINT4: u32 = 0x5004;
const RTC_BUFFER_TYPE_INDEX: u32 = 0;
const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
const RTC_FORMAT_UINT3: u32 = 0x5003;
const RTC_FORMAT_FLOAT3: u32 = 0x9003;
const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
/// `RTC_SCENE_FLAG_DYNAMIC` (Embree 3 and 4: `1 << 0`).
const RTC_SCENE_FLAG_DYNAMIC: u32 = 1 << 0;
/// `RTC_SCENE_FLAG_COMPACT` (Embree 3 and 4: `1 << 1`).
const RTC_SCENE_FLAG_COMPACT: u32 = 1 << 1;

#[repr(C)]
struct RTCIntersectContext {
    flags: u32,
    filter: *const c_void,
    inst_id: [u32; 1],
}

#[repr(C, align(16))]
#[derive(Default)]
struct RTCRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

#[repr(C, align(16))]
#[derive(Default)]
struct RTCHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 1],
}

#[repr(C)]
#[derive(Default)]
struct RTCRayHit {
    ray: RTCRay,
    hit: RTCHit,
}

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    fn rtcSetDeviceMemoryMonitorFunction(
        device: RTCDevice,
        monitor: extern "C" fn(*mut c_void, isize, bool) -> bool,
        user: *mut c_void,
    );
    fn rtcReleaseDevice(device: RTCDevice);
    fn rtcGetDeviceError(device: RTCDevice) -> u32;
    fn rtcNewScene(device: RTCDevice) -> RTCScene;
    fn rtcReleaseScene(scene: RTCScene);
    fn rtcCommitScene(scene: RTCScene);
    fn rtcSetSceneFlags(scene: RTCScene, flags: u32);
    fn rtcSetSceneBuildQuality(scene: RTCScene, quality: u32);
    fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: u32);
    fn rtcUpdateGeometryBuffer(geometry: RTCGeometry, kind: u32, slot: u32);
    fn rtcGetGeometry(scene: RTCScene, id: u32) -> RTCGeometry;
    fn rtcNewGeometry(device: RTCDevice, kind: u32) -> RTCGeometry;
    fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: u32,
        slot: u32,
        format: u32,
        stride: usize,
        count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RTCGeometry);
    fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, id: u32);
    fn rtcReleaseGeometry(geometry: RTCGeometry);
    fn rtcIntersect1(scene: RTCScene, context: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
    fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
}

/// How Embree builds a scene each frame (`RTCBuildQuality`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// `RTC_BUILD_QUALITY_LOW`: Morton-code builds, for per-frame rebuilds.
    Low = 0,
    /// `RTC_BUILD_QUALITY_MEDIUM`: binned SAH (the default).
    Medium = 1,
    /// `RTC_BUILD_QUALITY_REFIT` on the geometry of a `RTC_SCENE_FLAG_DYNAMIC` scene:
    /// the first frame's BVH, its boxes refitted.
    Refit = 3,
}

/// A committed Embree scene.
pub struct EmbreeScene {
    device: RTCDevice,
    scene: RTCScene,
    /// Seconds from the first geometry to the committed scene.
    pub build_seconds: f64,
    /// Bytes Embree allocated while committing the scene and kept: the BVH (its
    /// geometry buffers, allocated before, not counted).
    pub bvh_bytes: usize,
    /// For a quad scene, per geometry: the two triangles of every quad (the second
    /// `u32::MAX` for an unpaired triangle's degenerate quad).
    quads: Option<Vec<Vec<[u32; 2]>>>,
    /// Each geometry's id and shared vertex buffer (x, y, z per vertex), for
    /// [`Self::update_positions`].
    vertex_buffers: Vec<(u32, *mut f32, usize)>,
    /// The bytes Embree holds now: the memory monitor adds to it while the device
    /// lives, so it is kept (and dropped after the device is released).
    _allocated: Box<std::sync::atomic::AtomicIsize>,
}

// SAFETY: Embree documents committed scenes as safe to query from many threads at
// once; the handles are only released in `drop`.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

/// Embree's memory monitor: adds each allocation (and subtracts each release) to the
/// counter `user` points at.
extern "C" fn count_bytes(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user` is the `AtomicIsize` boxed in the scene, alive as long as the device.
    let counter = unsafe { &*(user as *const std::sync::atomic::AtomicIsize) };
    counter.fetch_add(bytes, std::sync::atomic::Ordering::Relaxed);
    true
}

impl EmbreeScene {
    /// Build `scene` with Embree using `threads` build threads (0 = all cores).
    pub fn build(scene: &Scene, threads: usize) -> Result<Self, LabError> {
        Self::build_with(scene, None, threads, 0, None)
    }

    /// Build `scene` for animation at `quality`: each [`Self::update_positions`] then
    /// rebuilds it (`Low`, `Medium`) or refits it (`Refit`).
    pub fn build_dynamic(
        scene: &Scene,
        quality: Quality,
        threads: usize,
    ) -> Result<Self, LabError> {
        let flags = if quality == Quality::Medium {
            0
        } else {
            RTC_SCENE_FLAG_DYNAMIC
        };
        Self::build_with(scene, None, threads, flags, Some(quality))
    }

    /// Give instance `instance`'s geometry (placed untransformed) new vertex positions
    /// and commit the scene again: Embree's rebuild or refit. Returns the seconds the
    /// commit took (the copy into Embree's buffer not counted).
    pub fn update_positions(
        &mut self,
        instance: usize,
        positions: &[glam::Vec3],
    ) -> Result<f64, LabError> {
        let Some(&(id, buffer, len)) = self
            .vertex_buffers
            .iter()
            .find(|b| b.0 as usize == instance)
        else {
            return Err(LabError::Embree(format!(
                "no geometry for instance {instance}"
            )));
        };
        if len != 3 * positions.len() {
            return Err(LabError::Embree(
                "the new positions are not the geometry's count".into(),
            ));
        }
        // SAFETY: `buffer` is the geometry's vertex buffer of `len` floats, alive while
        // the scene holds the geometry; the handles are ours.
        unsafe {
            let out = std::slice::from_raw_parts_mut(buffer, len);
            for (o, p) in out.chunks_exact_mut(3).zip(positions) {
                o.copy_from_slice(&p.to_array());
            }
            let start = std::time::Instant::now();
            let geometry = rtcGetGeometry(self.scene, id);
            rtcUpdateGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0);
            rtcCommitGeometry(geometry);
            rtcCommitScene(self.scene);
            let seconds = start.elapsed().as_secs_f64();
            match rtcGetDeviceError(self.device) {
                0 => Ok(seconds),
                error => Err(LabError::Embree(format!("error {error} while updating"))),
            }
        }
    }

    /// Build `scene` with `RTC_SCENE_FLAG_COMPACT`: Embree's compact BVH and triangle
    /// layout, smaller and usually slower to trace.
    pub fn build_compact(scene: &Scene, threads: usize) -> Result<Self, LabError> {
        Self::build_with(scene, None, threads, RTC_SCENE_FLAG_COMPACT, None)
    }

    /// Build `scene` as quads, `pairings[m]` pairing mesh `m` (as
    /// [`rtmesh::pair::Pairing`]s found on the meshes' own indices).
    pub fn build_quads(
        scene: &Scene,
        pairings: &[rtmesh::pair::Pairing],
        threads: usize,
    ) -> Result<Self, LabError> {
        Self::build_with(scene, Some(pairings), threads, 0, None)
    }

    fn build_with(
        scene: &Scene,
        pairings: Option<&[rtmesh::pair::Pairing]>,
        threads: usize,
        scene_flags: u32,
        quality: Option<Quality>,
    ) -> Result<Self, LabError> {
        let config =
            CString::new(format!("threads={threads},set_affinity=0,verbose=0")).expect("no NUL");
        // Per mesh, the quads and the triangles each covers.
        let quads: Option<Vec<MeshQuads>> = pairings.map(|pairings| {
            scene
                .meshes
                .iter()
                .zip(pairings)
                .map(|(mesh, pairing)| quads_of(&mesh.triangles, pairing))
                .collect()
        });
        let allocated = Box::new(std::sync::atomic::AtomicIsize::new(0));
        // SAFETY: plain C calls on handles we created; every buffer Embree returns is
        // written within the size we asked for.
        unsafe {
            let device = rtcNewDevice(config.as_ptr());
            if device.is_null() {
                return Err(LabError::Embree("rtcNewDevice failed".into()));
            }
            rtcSetDeviceMemoryMonitorFunction(
                device,
                count_bytes,
                &*allocated as *const _ as *mut c_void,
            );
            let start = std::time::Instant::now();
            let handle = rtcNewScene(device);
            rtcSetSceneFlags(handle, scene_flags);
            // A scene of LOW quality is built in two levels, a BVH per geometry by
            // the geometry's own builder (Morton for LOW, refit for REFIT) under a top
            // BVH; MEDIUM builds one SAH BVH over all triangles.
            match quality {
                Some(Quality::Low | Quality::Refit) => {
                    rtcSetSceneBuildQuality(handle, Quality::Low as u32)
                }
                Some(Quality::Medium) => rtcSetSceneBuildQuality(handle, Quality::Medium as u32),
                None => {}
            }
            let mut vertex_buffers = Vec::new();
            for (id, instance) in scene.instances.iter().enumerate() {
                let mesh = &scene.meshes[instance.mesh];
                let (kind, format, stride, count) = match &quads {
                    Some(q) => (
                        RTC_GEOMETRY_TYPE_QUAD,
                        RTC_FORMAT_UINT4,
                        16,
                        q[instance.mesh].0.len(),
                    ),
                    None => (
                        RTC_GEOMETRY_TYPE_TRIANGLE,
                        RTC_FORMAT_UINT3,
                        12,
                        mesh.triangles.len(),
                    ),
                };
                if count == 0 || mesh.positions.is_empty() {
                    // Embree allocates no empty buffer; such a geometry holds nothing
                    // to hit, so its id stays free.
                    continue;
                }
                let geometry = rtcNewGeometry(device, kind);
                let vertices = rtcSetNewGeometryBuffer(
                    geometry,
                    RTC_BUFFER_TYPE_VERTEX,
                    0,
                    RTC_FORMAT_FLOAT3,
                    12,
                    mesh.positions.len(),
                ) as *mut f32;
                let indices = rtcSetNewGeometryBuffer(
                    geometry,
                    RTC_BUFFER_TYPE_INDEX,
                    0,
                    format,
                    stride,
                    count,
                ) as *mut u32;
                if vertices.is_null() || indices.is_null() {
                    rtcReleaseGeometry(geometry);
                    rtcReleaseScene(handle);
                    rtcReleaseDevice(device);
                    return Err(LabError::Embree("could not allocate buffers".into()));
                }
                let vertices = std::slice::from_raw_parts_mut(vertices, mesh.positions.len() * 3);
                for (out, p) in vertices.chunks_exact_mut(3).zip(&mesh.positions) {
                    out.copy_from_slice(&instance.transform.transform_point3(*p).to_array());
                }
                match &quads {
                    Some(q) => {
                        let indices = std::slice::from_raw_parts_mut(indices, count * 4);
                        for (out, quad) in indices.chunks_exact_mut(4).zip(&q[instance.mesh].0) {
                            out.copy_from_slice(quad);
                        }
                    }
                    None => {
                        let indices = std::slice::from_raw_parts_mut(indices, count * 3);
                        for (out, t) in indices.chunks_exact_mut(3).zip(&mesh.triangles) {
                            out.copy_from_slice(t);
                        }
                    }
                }
                // The per-geometry builder follows the geometry's quality.
                if let Some(q) = quality {
                    rtcSetGeometryBuildQuality(geometry, q as u32);
                }
                vertex_buffers.push((id as u32, vertices.as_mut_ptr(), vertices.len()));
                rtcCommitGeometry(geometry);
                rtcAttachGeometryByID(handle, geometry, id as u32);
                rtcReleaseGeometry(geometry);
            }
            let before_commit = allocated.load(std::sync::atomic::Ordering::Relaxed);
            rtcCommitScene(handle);
            let bvh_bytes =
                (allocated.load(std::sync::atomic::Ordering::Relaxed) - before_commit).max(0);
            let error = rtcGetDeviceError(device);
            if error != 0 {
                rtcReleaseScene(handle);
                rtcReleaseDevice(device);
                return Err(LabError::Embree(format!("error {error} while building")));
            }
            Ok(Self {
                device,
                scene: handle,
                build_seconds: start.elapsed().as_secs_f64(),
                bvh_bytes: bvh_bytes as usize,
                quads: quads.map(|q| {
                    scene
                        .instances
                        .iter()
                        .map(|i| q[i.mesh].1.clone())
                        .collect()
                }),
                vertex_buffers,
                _allocated: allocated,
            })
        }
    }

    fn context() -> RTCIntersectContext {
        RTCIntersectContext {
            flags: 0,
            filter: std::ptr::null(),
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }

    fn ray(ray: &Ray) -> RTCRay {
        RTCRay {
            org: ray.origin.to_array(),
            tnear: ray.t_min,
            dir: ray.direction.to_array(),
            tfar: ray.t_max,
            mask: u32::MAX,
            ..RTCRay::default()
        }
    }

    /// Closest hit (`rtcIntersect1`).
    pub fn intersect(&self, ray: &Ray) -> Hit {
        let mut context = Self::context();
        let mut query = RTCRayHit {
            ray: Self::ray(ray),
            hit: RTCHit {
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
                ..RTCHit::default()
            },
        };
        // SAFETY: valid scene, context and ray-hit structs laid out as rtcore_ray.h.
        unsafe { rtcIntersect1(self.scene, &mut context, &mut query) };
        if query.hit.geom_id == RTC_INVALID_GEOMETRY_ID {
            return Hit::MISS;
        }
        // A quad's first triangle (v0, v1, v3) holds u + v ≤ 1; its second the rest.
        let triangle = match &self.quads {
            Some(quads) => {
                let [a, b] = quads[query.hit.geom_id as usize][query.hit.prim_id as usize];
                if query.hit.u + query.hit.v <= 1.0 || b == u32::MAX {
                    a
                } else {
                    b
                }
            }
            None => query.hit.prim_id,
        };
        Hit {
            t: query.ray.tfar,
            u: query.hit.u,
            v: query.hit.v,
            triangle,
            instance: query.hit.geom_id,
            geometry: u32::MAX,
        }
    }

    /// Any hit (`rtcOccluded1`).
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut context = Self::context();
        let mut query = Self::ray(ray);
        // SAFETY: as above.
        unsafe { rtcOccluded1(self.scene, &mut context, &mut query) };
        query.tfar == f32::NEG_INFINITY
    }
}

/// A mesh's Embree quads, and the two triangles each covers.
type MeshQuads = (Vec<[u32; 4]>, Vec<[u32; 2]>);

/// Embree's quads of `triangles` paired by `pairing`, with the triangles each covers:
/// the pair `(v0, v1, v2)`, `(v2, v1, v3)` (rtmesh's quad convention) is Embree's quad
/// `(v0, v1, v3, v2)`, whose triangles `(v0, v1, v3)` and `(v2, v3, v1)` are the pair's
/// two; an unpaired triangle is `(v0, v1, v2, v2)`.
fn quads_of(
    triangles: &[[u32; 3]],
    pairing: &rtmesh::pair::Pairing,
) -> (Vec<[u32; 4]>, Vec<[u32; 2]>) {
    let mut quads = Vec::with_capacity(pairing.pairs.len() + pairing.unpaired.len());
    let mut covers = Vec::with_capacity(quads.capacity());
    for &[a, b] in &pairing.pairs {
        let (ta, tb) = (&triangles[a as usize], &triangles[b as usize]);
        match rtmesh::pair::quad(ta, tb) {
            Some(([v0, v1, v2, v3], _)) => {
                quads.push([v0, v1, v3, v2]);
                covers.push([a, b]);
            }
            // Not a quad by index (never for rtmesh's pairs): two degenerate quads.
            None => {
                for t in [a, b] {
                    let [v0, v1, v2] = triangles[t as usize];
                    quads.push([v0, v1, v2, v2]);
                    covers.push([t, u32::MAX]);
                }
            }
        }
    }
    for &t in &pairing.unpaired {
        let [v0, v1, v2] = triangles[t as usize];
        quads.push([v0, v1, v2, v2]);
        covers.push([t, u32::MAX]);
    }
    (quads, covers)
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: created in `build`, released once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

impl Tracer for EmbreeScene {
    #[inline]
    fn intersect<C: Counters>(&self, ray: &Ray, _: &mut C) -> Hit {
        EmbreeScene::intersect(self, ray)
    }
    #[inline]
    fn occluded<C: Counters>(&self, ray: &Ray, _: &mut C) -> bool {
        EmbreeScene::occluded(self, ray)
    }
}

impl Reference for EmbreeScene {
    const NAME: &'static str = "Embree";
    fn build(scene: &Scene, threads: usize) -> Result<(Self, f64), LabError> {
        let built = EmbreeScene::build(scene, threads)?;
        let seconds = built.build_seconds;
        Ok((built, seconds))
    }
}
