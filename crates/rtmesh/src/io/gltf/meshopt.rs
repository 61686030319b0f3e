//! `EXT_meshopt_compression` (what `gltfpack -c` writes), decoded at read through
//! meshoptimizer's own decoders (the `meshopt` crate's bindings to the vendored
//! library, which are safe on untrusted input): each compressed buffer view is decoded
//! (`ATTRIBUTES`, `TRIANGLES` or `INDICES`, then its `OCTAHEDRAL`, `QUATERNION` or
//! `EXPONENTIAL` filter) into a buffer of its own, which the view then names, so that the
//! rest of the reader sees an uncompressed file. The fallback buffers the extension
//! declares hold no data. The output is written uncompressed, without the extension.
//! Cost: the decoders' (about 1–3 GB/s); memory: the decoded bytes, which count against
//! the same cap as a referenced file ([`MAX_REFERENCED_BYTES`] in all). The cap is on
//! what a view claims, not on its ratio to the compressed bytes (meshoptimizer's codecs
//! can hold a channel of zeros in a few bits a block, so no safe ratio exists); a view
//! claiming a gigabyte from a few bytes costs no memory, since the zeroed buffer is
//! mapped lazily and the decoder stops at the first block it cannot read (hostile
//! suite: `error-meshopt-gigabyte.gltf`, 7 MB).

use crate::io::reference::MAX_REFERENCED_BYTES;
use gltf::json;
use serde_json::Value;

/// The extension's name.
pub(super) const MESHOPT: &str = "EXT_meshopt_compression";

/// Whether `buffer` is a fallback buffer of the extension (`"fallback": true`), which
/// holds no data of its own.
pub(super) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    let fallback = buffer
        .extensions()
        .and_then(extension)
        .and_then(|e| e.get("fallback"));
    fallback.and_then(Value::as_bool) == Some(true)
}

fn extension(others: &serde_json::Map<String, Value>) -> Option<&serde_json::Map<String, Value>> {
    others.get(MESHOPT)?.as_object()
}

/// Decode every compressed view of `document` into a buffer appended to `buffers`;
/// return the document with those views naming their decoded buffers and the extension
/// no longer used.
pub(super) fn decode(
    document: gltf::Document,
    buffers: &mut Vec<gltf::buffer::Data>,
) -> Result<gltf::Document, String> {
    let mut root = document.into_json();
    let mut decoded_bytes = 0u64;
    for v in 0..root.buffer_views.len() {
        let Some(others) = root.buffer_views[v].extensions.as_ref().map(|e| &e.others) else {
            continue;
        };
        let Some(compressed) = extension(others) else {
            continue;
        };
        let number = |key: &str, default: Option<u64>| {
            compressed
                .get(key)
                .map_or(default, Value::as_u64)
                .ok_or_else(|| format!("buffer view {v}: {MESHOPT} has no valid {key}"))
        };
        let text = |key: &str, default: &'static str| {
            compressed
                .get(key)
                .map_or(Some(default), Value::as_str)
                .unwrap_or("")
                .to_owned()
        };
        let (buffer, offset, length) = (
            number("buffer", None)? as usize,
            number("byteOffset", Some(0))? as usize,
            number("byteLength", None)? as usize,
        );
        let (stride, count) = (number("byteStride", None)?, number("count", None)?);
        let (mode, filter) = (text("mode", ""), text("filter", "NONE"));
        let source = (buffers.get(buffer))
            .and_then(|b| b.0.get(offset..offset.checked_add(length)?))
            .ok_or_else(|| {
                format!("buffer view {v}: {MESHOPT} data (buffer {buffer}, bytes {offset}+{length}) is outside its buffer")
            })?;
        let size = count.checked_mul(stride).filter(|&n| {
            decoded_bytes
                .checked_add(n)
                .is_some_and(|total| total <= MAX_REFERENCED_BYTES)
        });
        let Some(size) = size else {
            return Err(format!(
                "buffer view {v}: {count} elements of {stride} bytes would pass the {MAX_REFERENCED_BYTES} bytes a file may decode"
            ));
        };
        decoded_bytes += size;
        let mut out = vec![0u8; size as usize];
        let (count, stride) = (count as usize, stride as usize);
        use std::os::raw::{c_int, c_uchar, c_void};
        type Decoder =
            unsafe extern "C" fn(*mut c_void, usize, usize, *const c_uchar, usize) -> c_int;
        type Filter = unsafe extern "C" fn(*mut c_void, usize, usize);
        let decoder: Decoder = match (mode.as_str(), stride) {
            ("ATTRIBUTES", s) if s % 4 == 0 && s <= 256 => meshopt::ffi::meshopt_decodeVertexBuffer,
            ("TRIANGLES", 2 | 4) if count % 3 == 0 => meshopt::ffi::meshopt_decodeIndexBuffer,
            ("INDICES", 2 | 4) => meshopt::ffi::meshopt_decodeIndexSequence,
            _ => {
                return Err(format!(
                    "buffer view {v}: {MESHOPT} mode '{mode}' with byteStride {stride} and count {count} is not one the extension defines"
                ))
            }
        };
        let filter: Option<Filter> = match (filter.as_str(), mode.as_str(), stride) {
            ("NONE", ..) => None,
            ("OCTAHEDRAL", "ATTRIBUTES", 4 | 8) => Some(meshopt::ffi::meshopt_decodeFilterOct),
            ("QUATERNION", "ATTRIBUTES", 8) => Some(meshopt::ffi::meshopt_decodeFilterQuat),
            ("EXPONENTIAL", "ATTRIBUTES", s) if s % 4 == 0 => Some(meshopt::ffi::meshopt_decodeFilterExp),
            _ => {
                return Err(format!(
                    "buffer view {v}: {MESHOPT} filter '{filter}' on mode '{mode}' with byteStride {stride} is not one the extension defines"
                ))
            }
        };
        // SAFETY: `out` holds `count` elements of `stride` bytes, the size each decoder
        // and filter is told (with the stride each accepts, checked above), and `source`
        // is a valid slice; the decoders check the encoded bytes.
        let code = unsafe {
            decoder(
                out.as_mut_ptr().cast(),
                count,
                stride,
                source.as_ptr(),
                source.len(),
            )
        };
        if code != 0 {
            return Err(format!(
                "buffer view {v}: {MESHOPT} data does not decode (meshoptimizer's error {code})"
            ));
        }
        if let Some(filter) = filter {
            // SAFETY: as above.
            unsafe { filter(out.as_mut_ptr().cast(), count, stride) }
        }
        let view = &mut root.buffer_views[v];
        view.buffer = json::Index::new(buffers.len() as u32);
        view.byte_offset = None;
        view.byte_length = json::validation::USize64(size);
        if let Some(extensions) = &mut view.extensions {
            extensions.others.remove(MESHOPT);
        }
        root.buffers.push(json::Buffer {
            byte_length: json::validation::USize64(size),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        buffers.push(gltf::buffer::Data(out));
    }
    root.extensions_used.retain(|e| e != MESHOPT);
    root.extensions_required.retain(|e| e != MESHOPT);
    Ok(gltf::Document::from_json_without_validation(root))
}
