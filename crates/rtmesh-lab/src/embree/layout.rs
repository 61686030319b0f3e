//! The FFI's hand-written struct layouts held to Embree's `rtcore.h`: `layout.c`,
//! compiled by the build script, records what the C compiler makes of the header.

use super::{
    RTCHit, RTCIntersectContext, RTCRay, RTCRayHit, RTC_BUFFER_TYPE_INDEX, RTC_BUFFER_TYPE_VERTEX,
    RTC_FORMAT_FLOAT3, RTC_FORMAT_UINT3, RTC_GEOMETRY_TYPE_TRIANGLE, RTC_INVALID_GEOMETRY_ID,
};
use std::mem::{align_of, offset_of, size_of};

extern "C" {
    static rtmesh_embree_layout: [usize; 30];
    static rtmesh_embree_layout_len: usize;
}

#[test]
fn declared_layouts_match_rtcore_h() {
    let ours = [
        size_of::<RTCRay>(),
        align_of::<RTCRay>(),
        offset_of!(RTCRay, org),
        offset_of!(RTCRay, tnear),
        offset_of!(RTCRay, dir),
        offset_of!(RTCRay, time),
        offset_of!(RTCRay, tfar),
        offset_of!(RTCRay, mask),
        offset_of!(RTCRay, id),
        offset_of!(RTCRay, flags),
        size_of::<RTCHit>(),
        align_of::<RTCHit>(),
        offset_of!(RTCHit, ng),
        offset_of!(RTCHit, u),
        offset_of!(RTCHit, v),
        offset_of!(RTCHit, prim_id),
        offset_of!(RTCHit, geom_id),
        offset_of!(RTCHit, inst_id),
        size_of::<RTCRayHit>(),
        offset_of!(RTCRayHit, hit),
        size_of::<RTCIntersectContext>(),
        offset_of!(RTCIntersectContext, flags),
        offset_of!(RTCIntersectContext, filter),
        offset_of!(RTCIntersectContext, inst_id),
        RTC_GEOMETRY_TYPE_TRIANGLE as usize,
        RTC_BUFFER_TYPE_INDEX as usize,
        RTC_BUFFER_TYPE_VERTEX as usize,
        RTC_FORMAT_UINT3 as usize,
        RTC_FORMAT_FLOAT3 as usize,
        RTC_INVALID_GEOMETRY_ID as usize,
    ];
    // SAFETY: plain constant data defined in layout.c with these very lengths.
    let (theirs, len) = unsafe { (rtmesh_embree_layout, rtmesh_embree_layout_len) };
    assert_eq!(
        len,
        ours.len(),
        "layout.c and this list disagree on the entries"
    );
    assert_eq!(ours, theirs);
}
