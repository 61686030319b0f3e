//! Embree 3 side by side (feature `embree`): a thin FFI over the few `rtc*` calls needed
//! to build a scene and trace single rays, so that rtmesh can be compared with the
//! reference CPU ray tracer on the very same rays. Links Debian's `libembree3`
//! (`apt-get install libembree-dev`, 3.13).
//!
//! Each scene instance becomes one Embree triangle geometry in world space (geometry id
//! = instance id, primitive id = input triangle id), built with the default (medium)
//! quality, so hits compare one to one with [`rtmesh::trace::Hit`].
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
const RTC_BUFFER_TYPE_INDEX: u32 = 0;
const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
const RTC_FORMAT_UINT3: u32 = 0x5003;
const RTC_FORMAT_FLOAT3: u32 = 0x9003;
const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;

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
    fn rtcReleaseDevice(device: RTCDevice);
    fn rtcGetDeviceError(device: RTCDevice) -> u32;
    fn rtcNewScene(device: RTCDevice) -> RTCScene;
    fn rtcReleaseScene(scene: RTCScene);
    fn rtcCommitScene(scene: RTCScene);
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

/// A committed Embree scene.
pub struct EmbreeScene {
    device: RTCDevice,
    scene: RTCScene,
    /// Seconds from the first geometry to the committed scene.
    pub build_seconds: f64,
}

// SAFETY: Embree documents committed scenes as safe to query from many threads at
// once; the handles are only released in `drop`.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

impl EmbreeScene {
    /// Build `scene` with Embree using `threads` build threads (0 = all cores).
    pub fn build(scene: &Scene, threads: usize) -> Result<Self, LabError> {
        let config =
            CString::new(format!("threads={threads},set_affinity=0,verbose=0")).expect("no NUL");
        // SAFETY: plain C calls on handles we created; every buffer Embree returns is
        // written within the size we asked for.
        unsafe {
            let device = rtcNewDevice(config.as_ptr());
            if device.is_null() {
                return Err(LabError::Embree("rtcNewDevice failed".into()));
            }
            let start = std::time::Instant::now();
            let handle = rtcNewScene(device);
            for (id, instance) in scene.instances.iter().enumerate() {
                let mesh = &scene.meshes[instance.mesh];
                let geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
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
                    RTC_FORMAT_UINT3,
                    12,
                    mesh.triangles.len(),
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
                let indices = std::slice::from_raw_parts_mut(indices, mesh.triangles.len() * 3);
                for (out, t) in indices.chunks_exact_mut(3).zip(&mesh.triangles) {
                    out.copy_from_slice(t);
                }
                rtcCommitGeometry(geometry);
                rtcAttachGeometryByID(handle, geometry, id as u32);
                rtcReleaseGeometry(geometry);
            }
            rtcCommitScene(handle);
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
        Hit {
            t: query.ray.tfar,
            u: query.hit.u,
            v: query.hit.v,
            triangle: query.hit.prim_id,
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
