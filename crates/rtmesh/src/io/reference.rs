//! The one rule for the files an asset refers to (OBJ `mtllib`, glTF buffer URIs): a
//! reference resolves relative to the asset's own folder (also when the asset is named
//! by a bare file name) and must stay inside that folder. Absolute paths, `..` that
//! climbs out, and symbolic links that lead out are refused with an error naming the
//! asset and the reference. Only regular files are opened (never a device such as
//! `/dev/zero`), and their size is checked against [`MAX_REFERENCED_BYTES`] before
//! anything is read. glTF `data:` URIs are decoded in memory under the same limit.

use super::MeshError;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The largest file an asset may refer to, and the largest `data:` URI payload: 1 GiB.
pub const MAX_REFERENCED_BYTES: u64 = 1 << 30;

/// The folder an asset's references must stay in: its own folder, `.` for a bare file
/// name.
fn asset_folder(asset: &Path) -> PathBuf {
    match asset.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent.to_owned(),
        _ => PathBuf::from("."),
    }
}

/// Why a reference of `asset` is refused.
fn refused(asset: &Path, reference: &str, why: &str) -> MeshError {
    MeshError::invalid(asset, format!("refers to '{reference}', which {why}"))
}

/// The path `reference` (relative, `/`-separated, already percent-decoded) of `asset`
/// names, checked by the rule above (the file need not exist).
pub(crate) fn resolve(asset: &Path, reference: &str) -> Result<PathBuf, MeshError> {
    let relative = Path::new(reference);
    if reference.is_empty() {
        return Err(refused(asset, reference, "is empty"));
    }
    if relative.is_absolute() || reference.starts_with(['/', '\\']) || reference.contains(':') {
        return Err(refused(
            asset,
            reference,
            "is an absolute path or names a drive or scheme: references must be relative to the asset's folder",
        ));
    }
    let mut depth = 0usize;
    for component in relative.components() {
        match component {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir if depth > 0 => depth -= 1,
            _ => {
                return Err(refused(
                    asset,
                    reference,
                    "climbs out of the asset's folder with '..'",
                ))
            }
        }
    }
    Ok(asset_folder(asset).join(relative))
}

/// The bytes of the file `reference` of `asset` names, by the rule above; `Ok(None)`
/// when there is no such file (the caller decides whether that is an error).
pub(crate) fn read_referenced(asset: &Path, reference: &str) -> Result<Option<Vec<u8>>, MeshError> {
    let path = resolve(asset, reference)?;
    let metadata = match std::fs::metadata(&path) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(MeshError::io(&path, e)),
    };
    if !metadata.is_file() {
        return Err(refused(asset, reference, "is not a regular file"));
    }
    // A symbolic link inside the folder may still lead out of it.
    let folder = asset_folder(asset)
        .canonicalize()
        .map_err(|e| MeshError::io(asset, e))?;
    let real = path.canonicalize().map_err(|e| MeshError::io(&path, e))?;
    if !real.starts_with(&folder) {
        return Err(refused(
            asset,
            reference,
            "leads out of the asset's folder through a link",
        ));
    }
    if metadata.len() > MAX_REFERENCED_BYTES {
        return Err(refused(
            asset,
            reference,
            &format!(
                "has {} bytes, over the limit of {MAX_REFERENCED_BYTES}",
                metadata.len()
            ),
        ));
    }
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    std::fs::File::open(&real)
        .and_then(|file| file.take(MAX_REFERENCED_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| MeshError::io(&real, e))?;
    if bytes.len() as u64 > MAX_REFERENCED_BYTES {
        return Err(refused(
            asset,
            reference,
            "grew past the size limit while read",
        ));
    }
    Ok(Some(bytes))
}

/// `%XX` escapes of a URI decoded (glTF URIs are URI-encoded); `None` when an escape is
/// malformed or the result is not UTF-8.
pub(crate) fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_stay_in_the_assets_folder() {
        let asset = Path::new("assets/model.obj");
        assert_eq!(
            resolve(asset, "model.mtl").unwrap(),
            Path::new("assets/model.mtl")
        );
        assert_eq!(
            resolve(asset, "textures/../model.mtl").unwrap(),
            Path::new("assets/textures/../model.mtl")
        );
        assert_eq!(
            resolve(Path::new("model.gltf"), "model.bin").unwrap(),
            Path::new("./model.bin")
        );
        for bad in [
            "/etc/passwd",
            "../secret.bin",
            "a/../../b",
            "C:/x",
            "\\\\server\\x",
            "",
        ] {
            let message = resolve(asset, bad).unwrap_err().to_string();
            assert!(
                message.starts_with("assets/model.obj: refers to '"),
                "{bad}: {message}"
            );
        }
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("%2e%2e/x").as_deref(), Some("../x"));
        assert_eq!(percent_decode("bad%2"), None);
    }
}
