/* The layout of the Embree 3 structs that src/embree/mod.rs declares by hand, read
 * from rtcore.h by the C compiler: sizeof, alignof and offsetof, in the order that
 * src/embree/layout.rs lists them. */
#include <embree3/rtcore.h>
#include <stddef.h>

const size_t rtmesh_embree_layout[] = {
    sizeof(struct RTCRay), _Alignof(struct RTCRay),
    offsetof(struct RTCRay, org_x), offsetof(struct RTCRay, tnear),
    offsetof(struct RTCRay, dir_x), offsetof(struct RTCRay, time),
    offsetof(struct RTCRay, tfar), offsetof(struct RTCRay, mask),
    offsetof(struct RTCRay, id), offsetof(struct RTCRay, flags),
    sizeof(struct RTCHit), _Alignof(struct RTCHit),
    offsetof(struct RTCHit, Ng_x), offsetof(struct RTCHit, u), offsetof(struct RTCHit, v),
    offsetof(struct RTCHit, primID), offsetof(struct RTCHit, geomID),
    offsetof(struct RTCHit, instID),
    sizeof(struct RTCRayHit), offsetof(struct RTCRayHit, hit),
    sizeof(struct RTCIntersectContext), offsetof(struct RTCIntersectContext, flags),
    offsetof(struct RTCIntersectContext, filter), offsetof(struct RTCIntersectContext, instID),
    RTC_GEOMETRY_TYPE_TRIANGLE, RTC_BUFFER_TYPE_INDEX, RTC_BUFFER_TYPE_VERTEX,
    RTC_FORMAT_UINT3, RTC_FORMAT_FLOAT3, RTC_INVALID_GEOMETRY_ID,
};
const size_t rtmesh_embree_layout_len = sizeof(rtmesh_embree_layout) / sizeof(size_t);
