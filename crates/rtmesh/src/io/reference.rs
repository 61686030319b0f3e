//! The one rule for the files an asset refers to (OBJ `mtllib`, glTF buffer URIs): a
//! reference resolves relative to the asset's own folder (also when the asset is named
//! by a bare file name) and must stay inside that folder, or inside the asset root the
//! user gives ([`super::ReadOptions::asset_root`]). Absolute paths, `..` that
//! climbs out, and symbolic links that lead out are refused with an error naming the
//! asset and the reference. Only regular files are opened (never a device such as
//! `/dev/zero`), and their size is checked against [`MAX_REFERENCED_BYTES`] before
//! anything is read. glTF `data:` URIs are decoded in memory under the same limit.

use super::MeshError;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The largest file an asset may refer to, and the largest `data:` URI payload: 1 GiB.
pub const MAX_REFERENCED_BYTES: u64 = 1 << 30;

/// The folder an asset's references resolve in: its own folder, `.` for a bare file
/// name.
pub(crate) fn asset_folder(asset: &Path) -> PathBuf {
    match asset.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent.to_owned(),
        _ => PathBuf::from("."),
    }
}

/// `path` made absolute (against the current directory) with `.` and `..` resolved
/// lexically, touching no file; `None` where `..` would climb above the file system's
/// root.
pub(crate) fn lexical(path: &Path) -> Option<PathBuf> {
    let absolute = std::path::absolute(path).ok()?;
    let mut out = PathBuf::new();
    for component in absolute.components() {
        match component {
            Component::ParentDir => {
                if !out.pop() {
                    return None;
                }
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    Some(out)
}

/// Why a reference of `asset` is refused.
fn refused(asset: &Path, reference: &str, why: &str) -> MeshError {
    MeshError::invalid(asset, format!("refers to '{reference}', which {why}"))
}

/// The path `reference` (relative, `/`-separated, already percent-decoded) of `asset`
/// names, resolved in the asset's folder and checked to stay inside `root` (the asset's
/// folder unless the user gave another); the file need not exist.
pub(crate) fn resolve(asset: &Path, reference: &str, root: &Path) -> Result<PathBuf, MeshError> {
    if reference.is_empty() {
        return Err(refused(asset, reference, "is empty"));
    }
    if Path::new(reference).is_absolute()
        || reference.starts_with(['/', '\\'])
        || reference.contains(':')
    {
        return Err(refused(
            asset,
            reference,
            "is an absolute path or names a drive or scheme: references must be relative to the asset's folder",
        ));
    }
    let path = asset_folder(asset).join(reference);
    let inside = match (lexical(&path), lexical(root)) {
        (Some(path), Some(root)) => path.starts_with(root),
        _ => false,
    };
    if !inside {
        return Err(refused(
            asset,
            reference,
            &format!("climbs out of {} with '..'", root_name(asset, root)),
        ));
    }
    Ok(path)
}

/// How errors name `root`: the asset's folder, or the asset root the user gave.
fn root_name(asset: &Path, root: &Path) -> String {
    if lexical(root) == lexical(&asset_folder(asset)) {
        "the asset's folder".into()
    } else {
        format!("the asset root {}", root.display())
    }
}

/// The bytes of the file `reference` of `asset` names, by the rule above; `Ok(None)`
/// when there is no such file (the caller decides whether that is an error).
pub(crate) fn read_referenced(
    asset: &Path,
    reference: &str,
    root: &Path,
) -> Result<Option<Vec<u8>>, MeshError> {
    let Some((real, length)) = check_referenced(asset, reference, root)? else {
        return Ok(None);
    };
    let mut bytes = Vec::with_capacity(length as usize);
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

/// The file `reference` of `asset` names, checked by the rule above without reading it:
/// its real path and length; `Ok(None)` when there is no such file.
pub(crate) fn check_referenced(
    asset: &Path,
    reference: &str,
    root: &Path,
) -> Result<Option<(PathBuf, u64)>, MeshError> {
    let path = resolve(asset, reference, root)?;
    let metadata = match std::fs::metadata(&path) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(MeshError::io(&path, e)),
    };
    if !metadata.is_file() {
        return Err(refused(asset, reference, "is not a regular file"));
    }
    // A symbolic link inside the folder may still lead out of it.
    let real_root = root.canonicalize().map_err(|e| MeshError::io(root, e))?;
    let real = path.canonicalize().map_err(|e| MeshError::io(&path, e))?;
    if !real.starts_with(&real_root) {
        return Err(refused(
            asset,
            reference,
            &format!("leads out of {} through a link", root_name(asset, root)),
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
    Ok(Some((real, metadata.len())))
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

/// A relative file path as a URI reference: every byte but the unreserved ones and `/`
/// `%XX`-escaped, so that [`percent_decode`] gives it back.
pub(crate) fn percent_encode(path: &str) -> String {
    let mut out = String::with_capacity(path.len());
    for &byte in path.as_bytes() {
        if byte.is_ascii_alphanumeric() || b"-._~/".contains(&byte) {
            out.push(byte as char);
        } else {
            out.push_str(&format!("%{byte:02X}"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_encoding_round_trips() {
        for path in ["tex/a b.png", "tëx/100%.jpg", "plain/name_1-2.~x"] {
            assert_eq!(percent_decode(&percent_encode(path)).as_deref(), Some(path));
        }
        assert_eq!(percent_encode("tex/a b#1.png"), "tex/a%20b%231.png");
    }

    #[test]
    fn references_stay_in_the_assets_folder() {
        let asset = Path::new("assets/model.obj");
        let folder = Path::new("assets");
        assert_eq!(
            resolve(asset, "model.mtl", folder).unwrap(),
            Path::new("assets/model.mtl")
        );
        assert_eq!(
            resolve(asset, "textures/../model.mtl", folder).unwrap(),
            Path::new("assets/textures/../model.mtl")
        );
        assert_eq!(
            resolve(Path::new("model.gltf"), "model.bin", Path::new(".")).unwrap(),
            Path::new("./model.bin")
        );
        // A root above the asset's folder lets references climb as far as it.
        let deep = Path::new("library/assets/model.obj");
        assert!(resolve(deep, "../shared/wood.mtl", Path::new("library")).is_ok());
        let message = resolve(deep, "../../x.mtl", Path::new("library"))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("climbs out of the asset root library"),
            "{message}"
        );
        for bad in [
            "/etc/passwd",
            "../secret.bin",
            "a/../../b",
            "C:/x",
            "\\\\server\\x",
            "",
        ] {
            let message = resolve(asset, bad, folder).unwrap_err().to_string();
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
