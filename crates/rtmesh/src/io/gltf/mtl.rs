//! glTF materials in MTL's terms, for an OBJ written from a glTF (`convert a.glb a.obj`):
//! without a library the OBJ names its materials and nothing says how they look. The
//! translation is the inverse of `material_from_mtl` (write.rs) wherever both formats
//! hold the thing, term by term:
//!
//! - base colour factor → `Kd` (its rgb), and its alpha → `d` unless `alphaMode` is OPAQUE;
//! - base colour texture → `map_Kd`; under MASK or BLEND also `map_d` on the same image
//!   (its alpha, as exporters write it), which the OBJ reader takes as cut-out;
//! - metallic and roughness factors → `Pm`, `Pr` (MTL's PBR extension, which Blender
//!   reads); the metallic-roughness texture → `map_Pm -imfchan b` and
//!   `map_Pr -imfchan g` (glTF packs metalness in blue and roughness in green; three.js
//!   reads neither, so the option costs it nothing);
//! - emissive factor (times `KHR_materials_emissive_strength`) → `Ke`; emissive texture
//!   → `map_Ke`;
//! - normal texture → `norm` (its scale as `-bm` when not 1).
//!
//! Texture coordinates are written as they are, bit for bit. glTF's image origin is the
//! top-left corner and OBJ's the bottom-left, so each map carries MTL's `-s`/`-o`
//! (uv·s + o) for the flip, v ↦ 1 − v, composed with the texture's
//! `KHR_texture_transform` offset and scale: a glTF written from an OBJ carries exactly
//! the inverse transform, so a round trip gives plain maps.
//!
//! MTL has no place for the occlusion texture, `alphaCutoff`, a texture rotation, a
//! texture on a set other than `TEXCOORD_0` (OBJ holds one) or other material
//! extensions: each is named in [`MtlLibrary::not_held`]. An image stored as a file is
//! named by its URI as written (the side files copy it beside an output elsewhere); one
//! stored in the GLB or in a `data:` URI is written beside the OBJ as `STEM_imageN.EXT`.
//! Cost: one pass over the materials; each image's bytes copied once.

use super::GltfDocument;
use crate::io::reference::percent_decode;
use serde_json::Value;
use std::fmt::Write;

/// A material library translated from a glTF document.
#[derive(Debug, Default)]
pub(crate) struct MtlLibrary {
    /// The library's text.
    pub text: String,
    /// Each scene material's `newmtl` name, in the scene's order.
    pub names: Vec<String>,
    /// The images the document stores itself, to write beside the library: each file's
    /// name and bytes.
    pub images: Vec<(String, Vec<u8>)>,
    /// What MTL cannot hold, in words.
    pub not_held: Vec<String>,
}

/// Translate the `materials` scene materials read from `document` (its materials in
/// order, then the default material, glTF's white metal), naming extracted images after
/// `stem`.
pub(crate) fn mtl_library(document: &GltfDocument, materials: usize, stem: &str) -> MtlLibrary {
    let root = serde_json::to_value(document.root()).unwrap_or(Value::Null);
    let mut library = MtlLibrary::default();
    let mut image_files: Vec<Option<String>> = vec![None; array(&root, "images").len()];
    let _ = writeln!(
        library.text,
        "# written by rtmesh {} from a glTF document's materials",
        env!("CARGO_PKG_VERSION")
    );
    let gltf_materials = array(&root, "materials");
    for m in 0..materials {
        let default = Value::Null;
        let material = gltf_materials.get(m).unwrap_or(&default);
        let name = unique_name(material, m, &library.names);
        let mut translation = Translation {
            document,
            root: &root,
            stem,
            image_files: &mut image_files,
            images: &mut library.images,
            not_held: &mut library.not_held,
            material: &name,
        };
        let statements = translation.statements(material);
        let _ = writeln!(library.text, "\nnewmtl {name}");
        for statement in statements {
            let _ = writeln!(library.text, "{statement}");
        }
        library.names.push(name);
    }
    library
}

/// `array(v, key)`: the JSON array at `key`, or none.
fn array<'a>(value: &'a Value, key: &str) -> &'a [Value] {
    value[key].as_array().map_or(&[], Vec::as_slice)
}

/// The material's name with whitespace replaced (MTL names are one word), `material{m}`
/// when it has none, with `_{m}` appended when an earlier material took it.
fn unique_name(material: &Value, m: usize, taken: &[String]) -> String {
    let name = match material["name"].as_str() {
        Some(name) if !name.trim().is_empty() => name.replace(char::is_whitespace, "_"),
        _ => format!("material{m}"),
    };
    if taken.contains(&name) {
        format!("{name}_{m}")
    } else {
        name
    }
}

/// The state of translating one material.
struct Translation<'a> {
    document: &'a GltfDocument,
    root: &'a Value,
    stem: &'a str,
    /// The file each image was given, once it was.
    image_files: &'a mut Vec<Option<String>>,
    images: &'a mut Vec<(String, Vec<u8>)>,
    not_held: &'a mut Vec<String>,
    material: &'a str,
}

/// `f32` as MTL writes it: the shortest decimal that reads back the same.
fn number(x: f64) -> String {
    format!("{}", x as f32)
}

impl Translation<'_> {
    /// The MTL statements of `material` (JSON; null for glTF's default material).
    fn statements(&mut self, material: &Value) -> Vec<String> {
        let pbr = &material["pbrMetallicRoughness"];
        let factor = |value: &Value, default: f64| value.as_f64().unwrap_or(default);
        let base: Vec<f64> = (0..4)
            .map(|c| factor(&pbr["baseColorFactor"][c], 1.0))
            .collect();
        let alpha_mode = material["alphaMode"].as_str().unwrap_or("OPAQUE");
        let mut out = vec![
            format!(
                "Kd {} {} {}",
                number(base[0]),
                number(base[1]),
                number(base[2])
            ),
            format!(
                "d {}",
                number(if alpha_mode == "OPAQUE" { 1.0 } else { base[3] })
            ),
            format!("Pm {}", number(factor(&pbr["metallicFactor"], 1.0))),
            format!("Pr {}", number(factor(&pbr["roughnessFactor"], 1.0))),
        ];
        let strength = factor(
            &material["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"],
            1.0,
        );
        let emissive: Vec<f64> = (0..3)
            .map(|c| factor(&material["emissiveFactor"][c], 0.0) * strength)
            .collect();
        if emissive.iter().any(|&e| e != 0.0) {
            let [r, g, b] = [0, 1, 2].map(|c| number(emissive[c]));
            out.push(format!("Ke {r} {g} {b}"));
        }
        if let Some(map) = self.map(&pbr["baseColorTexture"], "base colour") {
            out.push(format!("map_Kd {map}"));
            if alpha_mode != "OPAQUE" {
                // The same image, as exporters write it: readers take its alpha (three.js
                // would read an `-imfchan` option as part of the file name).
                out.push(format!("map_d {map}"));
            }
        }
        if let Some(map) = self.map(&pbr["metallicRoughnessTexture"], "metallic-roughness") {
            out.push(format!("map_Pm -imfchan b {map}"));
            out.push(format!("map_Pr -imfchan g {map}"));
        }
        if let Some(map) = self.map(&material["emissiveTexture"], "emissive") {
            out.push(format!("map_Ke {map}"));
        }
        let normal = &material["normalTexture"];
        if let Some(map) = self.map(normal, "normal") {
            match normal["scale"].as_f64() {
                Some(scale) if scale != 1.0 => {
                    out.push(format!("norm -bm {} {map}", number(scale)))
                }
                _ => out.push(format!("norm {map}")),
            }
        }
        if material["occlusionTexture"].is_object() {
            self.lost("its occlusion texture");
        }
        if alpha_mode == "MASK" {
            self.lost("its alphaCutoff");
        }
        let extensions = material["extensions"].as_object().into_iter().flatten();
        for (extension, _) in extensions {
            if extension != "KHR_materials_emissive_strength" {
                self.lost(&format!("its {extension}"));
            }
        }
        out
    }

    fn lost(&mut self, what: &str) {
        self.not_held
            .push(format!("material '{}': {what}", self.material));
    }

    /// A texture reference (`textureInfo`) as an MTL map's options and file, or `None`
    /// where there is none or it names no image.
    fn map(&mut self, info: &Value, role: &str) -> Option<String> {
        let texture = info["index"].as_u64()? as usize;
        let Some(image) = self.root["textures"][texture]["source"].as_u64() else {
            self.lost(&format!(
                "its {role} texture (texture {texture} has no image in glTF's core)"
            ));
            return None;
        };
        let file = self.image_file(image as usize)?;
        let transform = &info["extensions"]["KHR_texture_transform"];
        let set = transform["texCoord"]
            .as_u64()
            .or(info["texCoord"].as_u64())
            .unwrap_or(0);
        if set != 0 {
            self.lost(&format!(
                "its {role} texture's coordinate set TEXCOORD_{set} (OBJ holds TEXCOORD_0)"
            ));
        }
        if transform["rotation"].as_f64().is_some_and(|r| r != 0.0) {
            self.lost(&format!("its {role} texture's rotation"));
        }
        let pair =
            |key: &str, c: usize, default: f64| transform[key][c].as_f64().unwrap_or(default);
        // glTF samples the image at T(uv) from its top-left corner; MTL at uv·s + o from
        // the bottom-left: (s, o) = ((sx, −sy), (ox, 1 − oy)).
        let (scale, offset) = (
            [pair("scale", 0, 1.0), -pair("scale", 1, 1.0)],
            [pair("offset", 0, 0.0), 1.0 - pair("offset", 1, 0.0)],
        );
        let mut options = String::new();
        if scale != [1.0, 1.0] {
            let [u, v] = scale.map(number);
            let _ = write!(options, "-s {u} {v} 1 ");
        }
        if offset != [0.0, 0.0] {
            let [u, v] = offset.map(number);
            let _ = write!(options, "-o {u} {v} 0 ");
        }
        Some(format!("{options}{file}"))
    }

    /// The file image `i` is named by in the library: its URI as written, or for an
    /// image the document stores, the file it is extracted to.
    fn image_file(&mut self, i: usize) -> Option<String> {
        if let Some(Some(file)) = self.image_files.get(i) {
            return Some(file.clone());
        }
        let image = &self.root["images"][i];
        let stored = match image["uri"].as_str() {
            Some(uri) if !uri.starts_with("data:") => {
                let Some(file) = percent_decode(uri) else {
                    self.lost(&format!("image {i} (its URI has a malformed %-escape)"));
                    return None;
                };
                *self.image_files.get_mut(i)? = Some(file.clone());
                return Some(file);
            }
            Some(uri) => gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
                .ok()
                .map(|data| {
                    let mime = uri["data:".len()..].split([';', ',']).next();
                    (data.0, mime.unwrap_or_default().to_owned())
                }),
            None => self.view_bytes(image["bufferView"].as_u64()).map(|bytes| {
                let mime = image["mimeType"].as_str().unwrap_or_default();
                (bytes, mime.to_owned())
            }),
        };
        let Some((bytes, mime)) = stored else {
            self.lost(&format!("image {i} (its data could not be read)"));
            return None;
        };
        let extension = match mime.as_str() {
            "image/png" => "png",
            "image/jpeg" => "jpg",
            "image/webp" => "webp",
            "image/ktx2" => "ktx2",
            _ => "bin",
        };
        let file = format!("{}_image{i}.{extension}", self.stem);
        self.images.push((file.clone(), bytes));
        *self.image_files.get_mut(i)? = Some(file.clone());
        Some(file)
    }

    /// The bytes of buffer view `view`, where they lie within their buffer.
    fn view_bytes(&self, view: Option<u64>) -> Option<Vec<u8>> {
        let view = &self.root["bufferViews"][view? as usize];
        let buffer = self
            .document
            .buffers()
            .get(view["buffer"].as_u64()? as usize)?;
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
        let end = start.checked_add(view["byteLength"].as_u64()? as usize)?;
        buffer.get(start..end).map(<[u8]>::to_vec)
    }
}
