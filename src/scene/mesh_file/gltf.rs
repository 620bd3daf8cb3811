//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`), read with the `gltf` crate
//! for the JSON, its validation and the GLB container. Buffers, images and accessors are read
//! here, so that only regular files are opened, every byte range is checked (a bad file is an
//! error naming its JSON path, never a panic) and memory is checked before it is allocated.
//!
//! What is read and how it maps onto ember (also in docs/scene-format.md):
//! - every mesh primitive of the default scene (or scene 0) with its node's world transform
//!   (matrix or TRS, composed down the hierarchy; normals by the inverse transpose, winding
//!   reversed under a mirroring transform): TRIANGLES, and TRIANGLE_STRIP / TRIANGLE_FAN
//!   converted; POINTS and LINES* skipped with a warning. POSITION, NORMAL, TEXCOORD_0 (v
//!   flipped: glTF's v runs down the image, ember's up), COLOR_0; indexed or not; sparse
//!   accessors; any component type the accessor declares (so KHR_mesh_quantization too);
//! - materials (metallic-roughness): see [`material`];
//! - the first perspective camera found walking the scene → [`CameraSpec`];
//! - `KHR_lights_punctual` point lights → [`PointLight`], candela / 683 → W/sr.

use super::{FileMesh, MeshFile, meshopt};
use crate::light::PointLight;
use crate::material::{AlphaMode, Clearcoat, GlassMaterial, Material, MaterialKind, NormalMap, PbrMaterial, Sheen};
use crate::memory::{self, LoadBudget};
use crate::scene::format::MAX_COORDINATE;
use crate::scene::{CameraSpec, SceneError, input};
use crate::texture::{Encoding, MipImage, Sampler, Texture, TextureMap, UvTransform, Wrap};
use base64::Engine;
use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Luminous efficacy that defines the candela: 683 lm/W at 540 THz. glTF gives point light
/// intensity in candela (lm/sr); ember's is radiant intensity (W/sr). Dividing by 683 is the
/// SI conversion, and it makes Blender's exports round-trip: its glTF exporter (default
/// "standard" lighting mode) writes a point lamp of P watts as P / 4π · 683 cd, which this
/// reads back as P / 4π W/sr, the radiant intensity of an isotropic P-watt source.
pub const CANDELA_PER_WATT_PER_SR: f32 = 683.0;

/// Transmission factor above which a material is ember's glass.
pub const GLASS_THRESHOLD: f32 = 0.5;

/// Extensions whose data is read (the rest are warned about, or refused when required).
const SUPPORTED: [&str; 13] = [
    "EXT_meshopt_compression",
    "KHR_draco_mesh_compression",
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_mesh_quantization",
    "KHR_meshopt_compression",
    "KHR_texture_transform",
];

/// Memory per vertex of a world-space mesh while it is built: the accessor values read as
/// f32 (up to 12 floats, 48 bytes) and the mesh's arrays (position, normal, uv, colour: 44).
const VERTEX_BYTES: u64 = 92;
/// Memory per index: read as u32 (4) and kept in triangles (4).
const INDEX_BYTES: u64 = 8;

pub(super) fn load(path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let len = input::regular_file_len(path)?;
    // The file's bytes, the copy of a GLB's binary chunk and the JSON document built from it.
    budget
        .admit(format!("glTF file of {}", memory::format_bytes(len)), len.saturating_mul(4))
        .map_err(|e| SceneError::new(path, None, e.to_string()))?;
    parse(input::read(path)?, path, budget)
}

/// Reads a glTF or GLB file's `bytes` within `budget`; `path` names it in messages, and the
/// files it names are looked for beside it.
pub fn parse(bytes: Vec<u8>, path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    // The gltf crate unwraps where its validation leaves gaps: the ones known are checked
    // first (`check_before_crate`); one still unknown is an error naming the file, not a crash.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| parse_unguarded(bytes, path, budget))).unwrap_or_else(
        |panic| {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(SceneError::new(path, None, format!("malformed glTF: the gltf crate failed on it ({what})")))
        },
    )
}

fn parse_unguarded(bytes: Vec<u8>, path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| parse_error(path, e))?;
    drop(bytes);
    let gltf::Gltf { document, blob } = gltf;
    let json = document.into_json();
    check_before_crate(&json).map_err(|m| SceneError::new(path, None, m))?;
    let document = validated(json).map_err(|e| parse_error(path, e))?;
    Loader { path, budget, doc: &document, inputs: Default::default() }.load(blob)
}

/// The document after the `gltf` crate's validation, which takes the accessors of a
/// Draco-compressed primitive (no `bufferView`: their data is in the extension's) for missing
/// data, and extensions read here but unknown to it (Draco, meshopt, mesh quantization) in
/// `extensionsRequired` for unsupported: those reports, and only those, are let through.
fn validated(json: gltf::json::Root) -> Result<gltf::Document, gltf::Error> {
    let compressed: std::collections::BTreeSet<String> = json
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .filter(|p| p.extensions.as_ref().is_some_and(|e| e.others.contains_key("KHR_draco_mesh_compression")))
        .flat_map(|p| p.attributes.values().map(|i| i.value()).chain(p.indices.map(|i| i.value())))
        .filter(|&i| json.accessors.get(i).is_some_and(|a| a.buffer_view.is_none()))
        .map(|i| format!("accessors[{i}].bufferView"))
        .collect();
    // Required extensions read here, which the crate may report as unsupported (it knows
    // neither the compression extensions nor KHR_mesh_quantization).
    let read_here: Vec<String> = SUPPORTED
        .iter()
        .filter(|e| json.extensions_required.iter().any(|r| r == *e))
        .map(|e| format!("= \"{e}\""))
        .collect();
    if compressed.is_empty() && read_here.is_empty() {
        return gltf::Document::from_json(json);
    }
    match gltf::Document::from_json(json.clone()) {
        Err(gltf::Error::Validation(errors)) => {
            let rest: Vec<_> = errors
                .into_iter()
                .filter(|(p, e)| {
                    use gltf::json::validation::Error::{Missing, Unsupported};
                    !(matches!(e, Missing) && compressed.contains(p.as_str())
                        || matches!(e, Unsupported)
                            && p.as_str().starts_with("extensions")
                            && read_here.iter().any(|d| p.as_str().ends_with(d.as_str())))
                })
                .collect();
            if rest.is_empty() {
                Ok(gltf::Document::from_json_without_validation(json))
            } else {
                Err(gltf::Error::Validation(rest))
            }
        }
        other => other,
    }
}

/// What `gltf` 1.4.1 and `gltf-json` 1.4.1 unwrap without checking (each a panic otherwise),
/// checked before either looks: the accessor each primitive's POSITION names (the validator
/// indexes with it), an image's source (`Image::source` wants a `uri`, or a `bufferView` with
/// a `mimeType`), a camera's projection (`Camera::projection` wants the object its `type`
/// names).
fn check_before_crate(json: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    // Before the crate validates: a compressed mesh's accessors have no data of their own, and
    // its message ("accessors[0].bufferView: missing data") would not say why.
    if let Some(ext) = json.extensions_required.iter().find(|e| !SUPPORTED.contains(&e.as_str())) {
        return Err(unsupported_required(ext));
    }
    for (i, image) in json.images.iter().enumerate() {
        match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => return Err(format!("images[{i}]: has neither a uri nor a bufferView")),
            (None, Some(_), None) => return Err(format!("images[{i}]: a bufferView image needs a mimeType")),
            _ => {}
        }
    }
    for (i, camera) in json.cameras.iter().enumerate() {
        let missing = match camera.type_ {
            Checked::Valid(Type::Perspective) if camera.perspective.is_none() => Some("perspective"),
            Checked::Valid(Type::Orthographic) if camera.orthographic.is_none() => Some("orthographic"),
            _ => None,
        };
        if let Some(kind) = missing {
            return Err(format!("cameras[{i}]: its type is {kind} but it has no {kind} object"));
        }
    }
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let pos = prim.attributes.get(&gltf::json::validation::Checked::Valid(gltf::Semantic::Positions));
            if let Some(i) = pos.map(|i| i.value()).filter(|&i| i >= json.accessors.len()) {
                return Err(format!(
                    "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {i} out of range (the file has {})",
                    json.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// Why a file that requires extension `ext` is refused.
fn unsupported_required(ext: &str) -> String {
    format!("extensionsRequired: {ext} is not supported; supported: {}", SUPPORTED.join(", "))
}

/// A `gltf` crate error as a located [`SceneError`].
fn parse_error(path: &Path, e: gltf::Error) -> SceneError {
    match e {
        gltf::Error::Deserialize(e) => SceneError::new(path, Some(e.line()), format!("invalid glTF JSON: {e}")),
        gltf::Error::Validation(errors) => {
            let (p, first) = &errors[0];
            let more = match errors.len() {
                1 => String::new(),
                n => format!(" (and {} more problems)", n - 1),
            };
            let first = first.to_string().to_lowercase();
            SceneError::new(path, None, format!("{p}: {first}{more}"))
        }
        gltf::Error::Binary(e) => SceneError::new(path, None, format!("invalid GLB: {e}")),
        e => SceneError::new(path, None, e.to_string()),
    }
}

struct Loader<'a> {
    path: &'a Path,
    budget: &'a LoadBudget,
    doc: &'a gltf::Document,
    /// The external files read (buffers, images).
    inputs: std::cell::RefCell<Vec<PathBuf>>,
}

/// A mesh placed in the world by a node.
struct Instance<'a> {
    mesh: gltf::Mesh<'a>,
    world: Mat4,
}

/// A primitive's mesh decoded from `KHR_draco_mesh_compression`, and which of its attributes
/// each glTF attribute name is.
struct Draco {
    mesh: draco_core::Mesh,
    attributes: BTreeMap<String, u32>,
    /// Where the extension is, for messages.
    at: String,
}

impl Draco {
    /// The values of attribute `name` per point, `width` components each, as f32 (integers
    /// normalised where the attribute says so); `None` if the extension does not have it.
    fn values(&self, name: &str, widths: &[usize]) -> Option<Result<(Vec<f32>, usize), String>> {
        let id = *self.attributes.get(name)?;
        Some(self.read(name, id, widths))
    }

    fn read(&self, name: &str, id: u32, widths: &[usize]) -> Result<(Vec<f32>, usize), String> {
        use draco_core::DataType as T;
        let a =
            self.mesh.attribute_by_unique_id(id).ok_or(format!("attributes.{name}: no attribute {id} in the data"))?;
        let width = a.num_components() as usize;
        if !widths.contains(&width) {
            return Err(format!("attributes.{name}: {width} components per value, expected {widths:?}"));
        }
        let size = match a.data_type() {
            T::Int8 | T::Uint8 => 1,
            T::Int16 | T::Uint16 => 2,
            T::Int32 | T::Uint32 | T::Float32 => 4,
            T::Float64 => 8,
            t => return Err(format!("attributes.{name}: values of type {t:?} are not read")),
        };
        let stride = usize::try_from(a.byte_stride()).unwrap_or(0).max(width * size);
        let data = a.buffer().data();
        let norm = a.normalized();
        let n = self.mesh.num_points();
        let mut out = Vec::with_capacity(n * width);
        for p in 0..n {
            let v = a.mapped_index(draco_core::PointIndex(p as u32)).0 as usize;
            for c in 0..width {
                let at = v.checked_mul(stride).and_then(|o| o.checked_add(c * size));
                let b = at
                    .and_then(|o| data.get(o..o + size))
                    .ok_or(format!("attributes.{name}: point {p} has no value"))?;
                let x = match a.data_type() {
                    T::Int8 => i8::from_le_bytes([b[0]]) as f32 / if norm { 127.0 } else { 1.0 },
                    T::Uint8 => b[0] as f32 / if norm { 255.0 } else { 1.0 },
                    T::Int16 => i16::from_le_bytes([b[0], b[1]]) as f32 / if norm { 32767.0 } else { 1.0 },
                    T::Uint16 => u16::from_le_bytes([b[0], b[1]]) as f32 / if norm { 65535.0 } else { 1.0 },
                    T::Int32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                    T::Uint32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                    T::Float32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                    _ => f64::from_le_bytes(b.try_into().unwrap_or([0; 8])) as f32,
                };
                out.push(if norm && matches!(a.data_type(), T::Int8 | T::Int16) { x.max(-1.0) } else { x });
            }
        }
        Ok((out, width))
    }

    /// The triangles' corners (point indices).
    fn corners(&self) -> Vec<u32> {
        (0..self.mesh.num_faces()).flat_map(|f| self.mesh.face(draco_core::FaceIndex(f as u32)).map(|p| p.0)).collect()
    }
}

/// Problems of one kind, reported once: how many and the first place.
#[derive(Default)]
struct Tally(BTreeMap<String, (usize, String)>);

impl Tally {
    fn add(&mut self, kind: impl Into<String>, at: impl Into<String>) {
        let e = self.0.entry(kind.into()).or_insert_with(|| (0, at.into()));
        e.0 += 1;
    }
}

impl<'a> Loader<'a> {
    /// `KHR_materials_sheen`: its colour and roughness, each a factor times its texture if it
    /// has one (`map` loads a texture reference); `None` without the extension or with a black
    /// sheen colour.
    fn sheen(
        &self,
        m: &gltf::Material,
        at: &str,
        map: &mut MapFn<'a, '_>,
        ignored: &mut Tally,
    ) -> Result<Option<Sheen>, SceneError> {
        let Some(v) = m.extension_value("KHR_materials_sheen") else { return Ok(None) };
        let at = format!("{at}.extensions.KHR_materials_sheen");
        let color = self.unit_color(v, "sheenColorFactor", &at, Vec3::ZERO)?;
        let roughness = self.unit_factor(v, "sheenRoughnessFactor", &at)?;
        if color.max_element() <= 0.0 {
            return Ok(None);
        }
        let mut texture =
            |key: &str, factor: Vec3, encoding| self.factor_texture(v, key, &at, factor, encoding, map, ignored);
        Ok(Some(Sheen {
            color: texture("sheenColorTexture", color, Encoding::Srgb)?,
            roughness: texture("sheenRoughnessTexture", Vec3::splat(roughness), Encoding::Linear)?,
        }))
    }

    /// `KHR_materials_clearcoat`: its weight and roughness, each a factor times its texture if
    /// it has one, and its own normal map (`clearcoatNormalTexture`, with its `scale`) if it
    /// has one; `None` without the extension or with a factor of 0.
    fn clearcoat(
        &self,
        m: &gltf::Material,
        at: &str,
        map: &mut MapFn<'a, '_>,
        ignored: &mut Tally,
    ) -> Result<Option<Clearcoat>, SceneError> {
        let Some(v) = m.extension_value("KHR_materials_clearcoat") else { return Ok(None) };
        let at = format!("{at}.extensions.KHR_materials_clearcoat");
        let factor = self.unit_factor(v, "clearcoatFactor", &at)?;
        let roughness = self.unit_factor(v, "clearcoatRoughnessFactor", &at)?;
        if factor <= 0.0 {
            return Ok(None);
        }
        let mut texture = |key: &str, factor: f32| {
            self.factor_texture(v, key, &at, Vec3::splat(factor), Encoding::Linear, map, ignored)
        };
        let (factor, roughness) =
            (texture("clearcoatTexture", factor)?, texture("clearcoatRoughnessTexture", roughness)?);
        let normal = match v.get("clearcoatNormalTexture") {
            Some(info) => {
                let at = format!("{at}.clearcoatNormalTexture");
                let slot = TextureSlot::raw(self.doc, info).map_err(|m| self.err(&at, m))?;
                let scale = self.number(info, "scale", &at, 1.0, |x| (x as f32).is_finite(), "a finite number")?;
                let texture = Texture::Map { map: map(slot, &at, Encoding::Linear, ignored)?, factor: Vec3::ONE };
                Some(NormalMap { texture, scale })
            }
            None => None,
        };
        Ok(Some(Clearcoat { factor, roughness, normal }))
    }

    /// An extension's factor `factor` times its texture `key` (a `textureInfo` in the
    /// extension's JSON `v`), or the factor alone without one.
    #[allow(clippy::too_many_arguments)]
    fn factor_texture(
        &self,
        v: &serde_json::Value,
        key: &str,
        at: &str,
        factor: Vec3,
        encoding: Encoding,
        map: &mut MapFn<'a, '_>,
        ignored: &mut Tally,
    ) -> Result<Texture, SceneError> {
        let Some(info) = v.get(key) else { return Ok(Texture::Constant(factor)) };
        let at = format!("{at}.{key}");
        let slot = TextureSlot::raw(self.doc, info).map_err(|m| self.err(&at, m))?;
        Ok(Texture::Map { map: map(slot, &at, encoding, ignored)?, factor })
    }

    /// The absorption of `KHR_materials_volume` (σ = −ln(attenuationColor) / attenuationDistance,
    /// per channel) for glass; its thickness is not needed (ember traces the real geometry).
    /// On a material that is not glass the extension is ignored, with a warning.
    fn volume(&self, m: &gltf::Material, at: &str, is_glass: bool, ignored: &mut Tally) -> Result<Vec3, SceneError> {
        let Some(v) = m.extension_value("KHR_materials_volume") else { return Ok(Vec3::ZERO) };
        let at = format!("{at}.extensions.KHR_materials_volume");
        if !is_glass {
            ignored.add("KHR_materials_volume without transmission above 0.5 (opaque)", &at);
            return Ok(Vec3::ZERO);
        }
        let distance = self.number(v, "attenuationDistance", &at, f32::INFINITY, |d| d > 0.0, "a number > 0")?;
        let color = self.unit_color(v, "attenuationColor", &at, Vec3::ONE)?;
        if v.get("thicknessTexture").is_some() {
            ignored.add("thicknessTexture (ember traces the real geometry)", &at);
        }
        Ok(GlassMaterial::absorption_for(color, distance))
    }

    /// An extension's factor `key` in [0, 1] (0 where absent).
    fn unit_factor(&self, v: &serde_json::Value, key: &str, at: &str) -> Result<f32, SceneError> {
        self.number(v, key, at, 0.0, |x| (0.0..=1.0).contains(&x), "a number in [0, 1]")
    }

    /// An extension's number `key` (`default` where absent), which must pass `valid`
    /// (`what` names the range in the error).
    fn number(
        &self,
        v: &serde_json::Value,
        key: &str,
        at: &str,
        default: f32,
        valid: impl Fn(f64) -> bool,
        what: &str,
    ) -> Result<f32, SceneError> {
        match v.get(key) {
            None => Ok(default),
            Some(x) => match x.as_f64() {
                Some(y) if valid(y) => Ok(y as f32),
                _ => Err(self.err(at, format!("{key} must be {what}, found {x}"))),
            },
        }
    }

    /// An extension's colour `key`, 3 numbers in [0, 1] (`default` where absent).
    fn unit_color(&self, v: &serde_json::Value, key: &str, at: &str, default: Vec3) -> Result<Vec3, SceneError> {
        let Some(c) = v.get(key) else { return Ok(default) };
        match c.as_array().map(|a| a.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>()) {
            Some(Some(a)) if a.len() == 3 && a.iter().all(|x| (0.0..=1.0).contains(x)) => {
                Ok(Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32))
            }
            _ => Err(self.err(at, format!("{key} must be 3 numbers in [0, 1], found {c}"))),
        }
    }

    fn err(&self, at: impl AsRef<str>, msg: impl AsRef<str>) -> SceneError {
        SceneError::new(self.path, None, format!("{}: {}", at.as_ref(), msg.as_ref()))
    }

    fn load(&self, blob: Option<Vec<u8>>) -> Result<MeshFile, SceneError> {
        let mut warnings = Vec::new();
        let file = self.path.display();
        for ext in self.doc.extensions_used() {
            if !SUPPORTED.contains(&ext) {
                warnings.push(format!("{file}: glTF extension {ext} is not supported; its data is ignored"));
            }
        }

        // The scene's nodes, walked depth first: meshes, the first camera, lights.
        let scene = self.doc.default_scene().or_else(|| self.doc.scenes().next());
        let roots: Vec<gltf::Node> = match &scene {
            Some(s) => s.nodes().collect(),
            None => {
                warnings.push(format!("{file}: the file defines no scene; using every node without a parent"));
                let mut child = vec![false; self.doc.nodes().len()];
                for n in self.doc.nodes() {
                    for c in n.children() {
                        child[c.index()] = true;
                    }
                }
                self.doc.nodes().filter(|n| !child[n.index()]).collect()
            }
        };
        let mut instances = Vec::new();
        let mut camera = None;
        let mut point_lights = Vec::new();
        let mut ignored = Tally::default();
        let mut stack: Vec<(gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
        // glTF's nodes form trees: a node met twice is a cycle or a node with two parents
        // (which could also multiply the meshes without bound).
        let mut seen = vec![false; self.doc.nodes().len()];
        while let Some((node, parent)) = stack.pop() {
            let at = format!("nodes[{}]", node.index());
            if std::mem::replace(&mut seen[node.index()], true) {
                return Err(self.err(
                    at,
                    "the node is met twice in the scene: glTF nodes must form trees (a cycle, or two parents)",
                ));
            }
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            if let Some(mesh) = node.mesh() {
                instances.push(Instance { mesh, world });
            }
            if let Some(cam) = node.camera() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) if camera.is_none() => {
                        camera = self.camera(&at, world, p.yfov(), &mut warnings)?;
                    }
                    gltf::camera::Projection::Perspective(_) => {
                        ignored.add("more than one camera: the first is used", &at)
                    }
                    gltf::camera::Projection::Orthographic(_) => {
                        ignored.add("orthographic cameras (ember's camera is perspective)", &at)
                    }
                }
            }
            if let Some(light) = node.light() {
                let at = format!("{at}.extensions.KHR_lights_punctual");
                match light.kind() {
                    gltf::khr_lights_punctual::Kind::Point => {
                        let intensity = Vec3::from(light.color()) * light.intensity() / CANDELA_PER_WATT_PER_SR;
                        if !intensity.is_finite() || intensity.min_element() < 0.0 {
                            return Err(self.err(at, "light colour and intensity must be finite and not negative"));
                        }
                        if light.range().is_some() {
                            ignored.add("light range (ember's point lights reach everywhere)", &at);
                        }
                        let position = self.position(&at, world, "light")?;
                        point_lights.push(PointLight { position, intensity });
                    }
                    gltf::khr_lights_punctual::Kind::Directional => ignored.add("directional lights", &at),
                    gltf::khr_lights_punctual::Kind::Spot { .. } => ignored.add("spot lights", &at),
                }
            }
            if node.skin().is_some() {
                ignored.add("skins (the mesh is used in its bind pose)", &at);
            }
            for c in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((c, world));
            }
        }

        // A mesh that several nodes use is loaded once and placed by each (instances).
        let mut uses = vec![0usize; self.doc.meshes().len()];
        for inst in &instances {
            uses[inst.mesh.index()] += 1;
        }
        let shared = |mesh: &gltf::Mesh| uses[mesh.index()] > 1;

        // Memory: the buffers, and every mesh's vertices and indices, once per node that uses
        // it unless it is shared.
        let buffer_bytes: u64 = self.doc.buffers().map(|b| b.length() as u64).sum();
        let mut vertices = 0u64;
        let mut index_count = 0u64;
        let mut counted = vec![false; uses.len()];
        for inst in &instances {
            if shared(&inst.mesh) && std::mem::replace(&mut counted[inst.mesh.index()], true) {
                continue;
            }
            for p in inst.mesh.primitives() {
                let n = p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
                vertices = vertices.saturating_add(n);
                index_count = index_count.saturating_add(p.indices().map_or(n, |a| a.count() as u64));
            }
        }
        let need = buffer_bytes
            .saturating_add(vertices.saturating_mul(VERTEX_BYTES))
            .saturating_add(index_count.saturating_mul(INDEX_BYTES));
        self.budget
            .admit(
                format!(
                    "glTF meshes of {vertices} vertices and {index_count} indices ({} of buffers)",
                    memory::format_bytes(buffer_bytes)
                ),
                need,
            )
            .map_err(|e| SceneError::new(self.path, None, e.to_string()))?;
        let buffers = self.buffers(blob)?;

        let materials = self.materials(&buffers, &mut ignored)?;
        let mut meshes = Vec::new();
        let mut loaded = vec![false; uses.len()];
        for inst in &instances {
            let (world, places) = if shared(&inst.mesh) {
                if std::mem::replace(&mut loaded[inst.mesh.index()], true) {
                    continue;
                }
                let places: Vec<Affine3A> = instances
                    .iter()
                    .filter(|i| i.mesh.index() == inst.mesh.index())
                    .map(|i| Affine3A::from_mat4(i.world))
                    .collect();
                (Mat4::IDENTITY, places)
            } else {
                (inst.world, Vec::new())
            };
            for prim in inst.mesh.primitives() {
                let at = format!("meshes[{}].primitives[{}]", inst.mesh.index(), prim.index());
                // A normal-mapped material needs tangents, for its normal map's coordinate set
                // (the base's, else the coat's: one frame serves both).
                let tangents = prim.material().index().and_then(|i| match &materials[i].kind {
                    MaterialKind::Pbr(PbrMaterial { normal, clearcoat, .. }) => {
                        let coat = clearcoat.as_ref().and_then(|c| c.normal.as_ref());
                        normal.iter().chain(coat).find_map(|n| match &n.texture {
                            Texture::Map { map, .. } => Some(map.set),
                            _ => None,
                        })
                    }
                    _ => None,
                });
                if let Some(mut m) =
                    self.primitive(&at, &inst.mesh, &prim, world, &buffers, tangents, &mut ignored, &mut warnings)?
                {
                    m.instances = places.clone();
                    meshes.push(m);
                }
            }
        }
        for (kind, (n, first)) in ignored.0 {
            let times = if n == 1 { String::new() } else { format!(", {n} times") };
            warnings.push(format!("{file}: {kind} not supported; ignored (at {first}{times})"));
        }
        if meshes.is_empty() {
            return Err(SceneError::new(
                self.path,
                None,
                "no triangles: the scene has no triangle meshes (or only degenerate ones)",
            ));
        }
        let inputs = self.inputs.take();
        Ok(MeshFile { meshes, materials, camera, point_lights, warnings, inputs })
    }

    /// Where a node at `world` puts a `what` (a light, a camera): its origin, which must be
    /// finite and within ±[`MAX_COORDINATE`] as in a scene file (a NaN light would make the
    /// image silently black).
    fn position(&self, at: &str, world: Mat4, what: &str) -> Result<Vec3, SceneError> {
        let p = world.transform_point3(Vec3::ZERO);
        if !(p.is_finite() && p.abs().max_element() <= MAX_COORDINATE) {
            return Err(self.err(
                at,
                format!(
                    "the {what} is at {:?}: its position (from the node's transforms) must be finite and within \
                     ±{MAX_COORDINATE:e}",
                    p.to_array()
                ),
            ));
        }
        Ok(p)
    }

    /// The camera of a node at `world`: at the node's origin, looking down its −Z, up its +Y.
    fn camera(
        &self,
        at: &str,
        world: Mat4,
        yfov: f32,
        warnings: &mut Vec<String>,
    ) -> Result<Option<CameraSpec>, SceneError> {
        let fov = yfov.to_degrees();
        let position = self.position(at, world, "camera")?;
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
        if !(fov > 0.0 && fov < 180.0 && forward != Vec3::ZERO && up.is_finite()) {
            warnings.push(format!(
                "{}: {at}: camera ignored (field of view {fov}° or its transform unusable); the scene is framed instead",
                self.path.display()
            ));
            return Ok(None);
        }
        Ok(Some(CameraSpec::pinhole(position, position + forward, up, fov)))
    }

    /// The bytes of every buffer, by index: no more than its byteLength (what was counted),
    /// each file read once however many buffers name it, meshopt-compressed views decoded.
    fn buffers(&self, blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, SceneError> {
        let mut blob = blob;
        let mut out = Vec::new();
        let mut files: HashMap<PathBuf, Vec<u8>> = HashMap::new();
        for b in self.doc.buffers() {
            let at = format!("buffers[{}]", b.index());
            let data = match b.source() {
                // Filled by decoding the compressed views that lie in it.
                _ if meshopt::is_fallback(&b) => vec![0; b.length()],
                gltf::buffer::Source::Bin => blob
                    .take()
                    .ok_or_else(|| self.err(&at, "refers to the GLB binary chunk, which the file does not have"))?,
                gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => self.uri(&at, uri)?.into_owned(),
                gltf::buffer::Source::Uri(uri) => {
                    let file = self.named_file(&at, uri)?;
                    // The most any buffer naming this file takes from it.
                    let wanted = self
                        .doc
                        .buffers()
                        .filter(|o| matches!(o.source(), gltf::buffer::Source::Uri(u) if u == uri))
                        .map(|o| o.length())
                        .max()
                        .unwrap_or(0);
                    if !files.contains_key(&file) {
                        let bytes = self.read_file(&at, uri, &file, Some(wanted as u64))?;
                        files.insert(file.clone(), bytes);
                    }
                    let data = &files[&file];
                    data[..b.length().min(data.len())].to_vec()
                }
            };
            if data.len() < b.length() {
                return Err(
                    self.err(at, format!("byteLength is {} but the data has only {} bytes", b.length(), data.len()))
                );
            }
            out.push(data);
        }
        meshopt::decode_views(self.doc, &mut out).map_err(|(at, what)| self.err(at, what))?;
        Ok(out)
    }

    /// The bytes a URI names: a `data:` URI's, or a file's relative to the glTF file.
    fn uri(&self, at: &str, uri: &str) -> Result<Cow<'static, [u8]>, SceneError> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (head, payload) = rest.split_once(',').ok_or_else(|| self.err(at, "data URI without a comma"))?;
            if !head.ends_with(";base64") {
                return Err(self.err(at, "data URI is not base64"));
            }
            let bytes = base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| self.err(at, format!("data URI: {e}")))?;
            return Ok(Cow::Owned(bytes));
        }
        let file = self.named_file(at, uri)?;
        Ok(Cow::Owned(self.read_file(at, uri, &file, None)?))
    }

    /// The file a URI names, if the model may read it ([`input::named_file`]).
    fn named_file(&self, at: &str, uri: &str) -> Result<PathBuf, SceneError> {
        if uri.contains("://") {
            return Err(self.err(at, format!("{uri:?}: only data: URIs and relative file names are read")));
        }
        input::named_file(self.path, &percent_decode(uri), self.budget.external_files()).map_err(|e| self.err(at, e))
    }

    /// The bytes of `file` (the one `uri` names), at most `most` of them, counted in the
    /// budget first.
    fn read_file(&self, at: &str, uri: &str, file: &Path, most: Option<u64>) -> Result<Vec<u8>, SceneError> {
        let fail = |e: std::io::Error| self.err(at, format!("{uri:?}: {}", crate::regular_file::describe(&e)));
        let (opened, len) = crate::regular_file::open(file).map_err(fail)?;
        let len = most.map_or(len, |m| m.min(len));
        self.budget
            .admit(format!("{uri:?} of {}", memory::format_bytes(len)), len)
            .map_err(|e| self.err(at, e.to_string()))?;
        let bytes = match most {
            Some(_) => crate::regular_file::read_prefix(opened, len),
            None => crate::regular_file::read_opened(opened, len),
        }
        .map_err(fail)?;
        self.inputs.borrow_mut().push(file.to_path_buf());
        Ok(bytes)
    }

    /// ember's materials, one per glTF material, in order: glTF's metallic-roughness material
    /// ([`PbrMaterial`]) with its textures, or glass.
    ///
    /// - Base colour (factor × texture, RGBA: alpha for `alphaMode` `MASK` and `BLEND`),
    ///   metallic-roughness (factors × the texture's B and G), normal texture (with its
    ///   scale), emission (factor × `KHR_materials_emissive_strength` × texture), each texture
    ///   through its sampler, its `texCoord` set (0 or 1) and `KHR_texture_transform`.
    /// - `KHR_materials_ior` (the dielectric's index) and `KHR_materials_specular` (its
    ///   weight and colour factors).
    /// - `KHR_materials_transmission` above [`GLASS_THRESHOLD`]: ember's smooth glass (IOR
    ///   from `KHR_materials_ior`; tint = base colour factor).
    /// - `occlusionTexture` is read past: it is ambient occlusion baked for rasterisers, the
    ///   shadowing a path tracer computes itself.
    ///
    /// Each image is decoded once per encoding (sRGB for colours, linear for data), however
    /// many textures and materials use it.
    fn materials(&self, buffers: &[Vec<u8>], ignored: &mut Tally) -> Result<Vec<Material>, SceneError> {
        let mut images: HashMap<(usize, bool), Arc<MipImage>> = HashMap::new();
        let mut out = Vec::new();
        let file_name = self.path.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned());
        for m in self.doc.materials() {
            let i = m.index().unwrap_or(0);
            let at = format!("materials[{i}]");
            let pbr = m.pbr_metallic_roughness();
            let factor = pbr.base_color_factor();
            let base = Vec3::new(factor[0], factor[1], factor[2]);
            // glTF's range; a negative colour would make radiance negative.
            if !factor.iter().all(|c| (0.0..=1.0).contains(c)) {
                return Err(self.err(
                    format!("{at}.pbrMetallicRoughness.baseColorFactor"),
                    format!("{factor:?}: each component must be between 0 and 1"),
                ));
            }
            let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
            let metallic = pbr.metallic_factor();
            // `at`: the reference's JSON path.
            let mut map = |slot: TextureSlot<'a>, at: &str, encoding: Encoding, ignored: &mut Tally| {
                let set = match slot.tex_coord {
                    0 | 1 => slot.tex_coord as usize,
                    k => {
                        ignored.add("texture coordinate sets beyond TEXCOORD_1 (set 0 is used)", format!("{at}: {k}"));
                        0
                    }
                };
                let key = (slot.texture.source().index(), encoding == Encoding::Srgb);
                let image = match images.get(&key) {
                    Some(done) => done.clone(),
                    None => {
                        let loaded = Arc::new(self.image(at, &slot.texture.source(), buffers, encoding)?);
                        images.insert(key, loaded.clone());
                        loaded
                    }
                };
                let transform = slot.transform.map_err(|e| self.err(at, e))?;
                Ok::<TextureMap, SceneError>(texture_map(image, &slot.texture.sampler(), set, transform))
            };
            let color = match pbr.base_color_texture() {
                Some(info) => Texture::Map {
                    map: map(
                        TextureSlot::of(&info),
                        &format!("{at}.pbrMetallicRoughness.baseColorTexture"),
                        Encoding::Srgb,
                        ignored,
                    )?,
                    factor: base,
                },
                None => Texture::Constant(base),
            };
            let mr = Vec3::new(1.0, roughness, metallic);
            let metal_rough = match pbr.metallic_roughness_texture() {
                Some(info) => Texture::Map {
                    map: map(
                        TextureSlot::of(&info),
                        &format!("{at}.pbrMetallicRoughness.metallicRoughnessTexture"),
                        Encoding::Linear,
                        ignored,
                    )?,
                    factor: mr,
                },
                None => Texture::Constant(mr),
            };
            let normal = match m.normal_texture() {
                Some(n) => {
                    let slot = TextureSlot::normal(&n);
                    let texture = Texture::Map {
                        map: map(slot, &format!("{at}.normalTexture"), Encoding::Linear, ignored)?,
                        factor: Vec3::ONE,
                    };
                    Some(NormalMap { texture, scale: n.scale() })
                }
                None => None,
            };
            let emission = Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
            if !emission.is_finite() || emission.min_element() < 0.0 {
                return Err(self.err(format!("{at}.emissiveFactor"), "emission must be finite and not negative"));
            }
            let emission = match m.emissive_texture() {
                Some(info) if emission != Vec3::ZERO => Texture::Map {
                    map: map(TextureSlot::of(&info), &format!("{at}.emissiveTexture"), Encoding::Srgb, ignored)?,
                    factor: emission,
                },
                _ => Texture::Constant(emission),
            };
            let ior = m.ior().unwrap_or(1.5);
            if !(ior.is_finite() && ior >= 1.0) {
                return Err(
                    self.err(format!("{at}.extensions.KHR_materials_ior"), format!("ior must be ≥ 1, found {ior}"))
                );
            }
            let alpha_mode = match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5)),
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            };
            let (specular, specular_color) = match m.specular() {
                Some(s) => {
                    if s.specular_texture().is_some() || s.specular_color_texture().is_some() {
                        ignored.add(
                            "KHR_materials_specular textures (its factors are used)",
                            format!("{at}.extensions.KHR_materials_specular"),
                        );
                    }
                    (s.specular_factor(), Vec3::from(s.specular_color_factor()))
                }
                None => (1.0, Vec3::ONE),
            };
            if !(specular.is_finite()
                && specular >= 0.0
                && specular_color.is_finite()
                && specular_color.min_element() >= 0.0)
            {
                return Err(self.err(
                    format!("{at}.extensions.KHR_materials_specular"),
                    "specular factors must be finite and not negative",
                ));
            }
            let clearcoat = self.clearcoat(&m, &at, &mut map, ignored)?;
            let sheen = self.sheen(&m, &at, &mut map, ignored)?;
            for ext in ["KHR_materials_unlit"] {
                if m.extension_value(ext).is_some() {
                    ignored.add(ext, format!("{at}.extensions.{ext}"));
                }
            }
            let transmission = m.transmission();
            let is_glass = matches!(&transmission, Some(t) if t.transmission_factor() > GLASS_THRESHOLD);
            let absorption = self.volume(&m, &at, is_glass, ignored)?;
            let kind = match &transmission {
                Some(t) if t.transmission_factor() > GLASS_THRESHOLD => {
                    if t.transmission_texture().is_some() {
                        ignored.add("transmissionTexture", format!("{at}.extensions.KHR_materials_transmission"));
                    }
                    if pbr.base_color_texture().is_some() {
                        ignored.add("baseColorTexture on glass (the base colour factor tints it)", &at);
                    }
                    MaterialKind::Glass(GlassMaterial {
                        absorption,
                        ..GlassMaterial::clear(ior, base.clamp(Vec3::ZERO, Vec3::ONE))
                    })
                }
                _ => MaterialKind::Pbr(PbrMaterial {
                    base: color,
                    alpha: factor[3],
                    alpha_mode,
                    metal_rough,
                    normal,
                    ior,
                    specular,
                    specular_color,
                    clearcoat,
                    sheen,
                }),
            };
            if matches!(&transmission, Some(t) if t.transmission_factor() > 0.0 && t.transmission_factor() <= GLASS_THRESHOLD)
            {
                ignored
                    .add("partial transmission (≤ 0.5: opaque)", format!("{at}.extensions.KHR_materials_transmission"));
            }
            let name = format!("{file_name}:{}", m.name().map_or_else(|| at.clone(), str::to_string));
            out.push(Material { name, kind, emission });
        }
        Ok(out)
    }

    /// Decodes an image (PNG or JPEG) from a buffer view or a URI.
    fn image(
        &self,
        at: &str,
        img: &gltf::Image,
        buffers: &[Vec<u8>],
        encoding: Encoding,
    ) -> Result<MipImage, SceneError> {
        let at = format!("{at}: images[{}]", img.index());
        let bytes: Cow<[u8]> = match img.source() {
            gltf::image::Source::View { view, .. } => Cow::Borrowed(self.view_bytes(&at, &view, buffers)?),
            gltf::image::Source::Uri { uri, .. } => self.uri(&at, uri)?,
        };
        MipImage::decode(&bytes, self.budget, encoding).map_err(|e| self.err(at, e.to_string()))
    }

    /// The bytes of a buffer view.
    /// A primitive's `KHR_draco_mesh_compression` data, decoded (`None` without it).
    fn draco(&self, at: &str, prim: &gltf::Primitive, buffers: &[Vec<u8>]) -> Result<Option<Draco>, SceneError> {
        let Some(ext) = prim.extension_value("KHR_draco_mesh_compression") else { return Ok(None) };
        let at = format!("{at}.extensions.KHR_draco_mesh_compression");
        let view = ext
            .get("bufferView")
            .and_then(|v| v.as_u64())
            .and_then(|v| self.doc.views().nth(v as usize))
            .ok_or_else(|| self.err(&at, "its bufferView is missing or out of range"))?;
        let bytes = self.view_bytes(&at, &view, buffers)?;
        let mut mesh = draco_core::Mesh::new();
        draco_core::MeshDecoder::new()
            .decode(&mut draco_core::DecoderBuffer::new(bytes), &mut mesh)
            .map_err(|e| self.err(&at, format!("the compressed mesh cannot be decoded: {e}")))?;
        let mut attributes = BTreeMap::new();
        for (name, id) in ext.get("attributes").and_then(|a| a.as_object()).into_iter().flatten() {
            let id = id.as_u64().and_then(|i| u32::try_from(i).ok());
            let id = id.ok_or_else(|| self.err(&at, format!("attributes.{name} is not an attribute id")))?;
            attributes.insert(name.clone(), id);
        }
        Ok(Some(Draco { mesh, attributes, at }))
    }

    fn view_bytes<'b>(
        &self,
        at: &str,
        view: &gltf::buffer::View,
        buffers: &'b [Vec<u8>],
    ) -> Result<&'b [u8], SceneError> {
        let data = &buffers[view.buffer().index()];
        let end = view.offset().checked_add(view.length());
        end.and_then(|end| data.get(view.offset()..end)).ok_or_else(|| {
            self.err(
                at,
                format!(
                    "bufferViews[{}] (bytes {} to {}) is out of range of buffers[{}] ({} bytes)",
                    view.index(),
                    view.offset(),
                    view.offset() as u128 + view.length() as u128,
                    view.buffer().index(),
                    data.len()
                ),
            )
        })
    }

    /// One primitive as a world-space mesh, or `None` (with a warning) if it has none.
    #[allow(clippy::too_many_arguments)]
    fn primitive(
        &self,
        at: &str,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        world: Mat4,
        buffers: &[Vec<u8>],
        tangents: Option<usize>,
        ignored: &mut Tally,
        warnings: &mut Vec<String>,
    ) -> Result<Option<FileMesh>, SceneError> {
        match prim.mode() {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {}
            mode => {
                ignored.add(format!("primitives of mode {mode:?} (points and lines have no area)"), at);
                return Ok(None);
            }
        }
        let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
            ignored.add("primitives without POSITION", at);
            return Ok(None);
        };
        let attr = |name: &str| format!("{at}.attributes.{name}");
        let draco = self.draco(at, prim, buffers)?;
        // An attribute's values: decoded, for a compressed primitive that has it; else read
        // from its accessor.
        let values = |name: &str, a: &gltf::Accessor, dims: &[Dimensions]| -> Result<Vec<f32>, SceneError> {
            if let Some(d) = &draco {
                let width = match a.dimensions() {
                    Dimensions::Vec2 => 2,
                    Dimensions::Vec3 => 3,
                    Dimensions::Vec4 => 4,
                    _ => 1,
                };
                if let Some(r) = d.values(name, &[width]) {
                    return r.map(|(v, _)| v).map_err(|m| self.err(&d.at, m));
                }
            }
            self.read(&attr(name), a, dims, buffers)
        };
        // The accessor's count is what the memory budget admitted: checked before any
        // decoded attribute is copied out.
        let n = pos.count();
        if let Some(d) = draco.as_ref().filter(|d| d.mesh.num_points() != n) {
            return Err(self.err(
                &d.at,
                format!("the compressed mesh has {} points where its POSITION accessor says {n}", d.mesh.num_points()),
            ));
        }
        let positions = values("POSITION", &pos, &[Dimensions::Vec3])?;
        let same_count = |a: &gltf::Accessor, name: &str| -> Result<(), SceneError> {
            if a.count() != n {
                return Err(
                    self.err(attr(name), format!("accessor {} has {} entries for {n} positions", a.index(), a.count()))
                );
            }
            Ok(())
        };
        let finite = |v: &[f32], name: &str, width: usize| -> Result<(), SceneError> {
            match v.iter().position(|x| !x.is_finite()) {
                Some(k) => Err(self.err(attr(name), format!("entry {} is not a finite number", k / width))),
                None => Ok(()),
            }
        };
        let normals = match prim.get(&gltf::Semantic::Normals) {
            Some(a) => {
                same_count(&a, "NORMAL")?;
                let v = values("NORMAL", &a, &[Dimensions::Vec3])?;
                finite(&v, "NORMAL", 3)?;
                v
            }
            None => Vec::new(),
        };
        let uvs = match prim.get(&gltf::Semantic::TexCoords(0)) {
            Some(a) => {
                same_count(&a, "TEXCOORD_0")?;
                let v = values("TEXCOORD_0", &a, &[Dimensions::Vec2])?;
                finite(&v, "TEXCOORD_0", 2)?;
                v
            }
            None => Vec::new(),
        };
        let uvs1 = match prim.get(&gltf::Semantic::TexCoords(1)) {
            Some(a) => {
                same_count(&a, "TEXCOORD_1")?;
                let v = values("TEXCOORD_1", &a, &[Dimensions::Vec2])?;
                finite(&v, "TEXCOORD_1", 2)?;
                v
            }
            None => Vec::new(),
        };
        let given_tangents = match prim.get(&gltf::Semantic::Tangents).filter(|_| tangents.is_some()) {
            Some(a) => {
                same_count(&a, "TANGENT")?;
                let v = values("TANGENT", &a, &[Dimensions::Vec4])?;
                finite(&v, "TANGENT", 4)?;
                v
            }
            None => Vec::new(),
        };
        let (colors, color_width) = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(a) => {
                same_count(&a, "COLOR_0")?;
                let v = values("COLOR_0", &a, &[Dimensions::Vec3, Dimensions::Vec4])?;
                let w = if a.dimensions() == Dimensions::Vec4 { 4 } else { 3 };
                finite(&v, "COLOR_0", w)?;
                // A colour scales reflected light: a negative one would make radiance negative.
                if let Some(k) = v.iter().position(|&c| c < 0.0) {
                    return Err(self.err(attr("COLOR_0"), format!("entry {} is negative", k / w)));
                }
                (v, w)
            }
            None => (Vec::new(), 3),
        };
        let corners: Vec<u32> = match (draco.as_ref(), prim.indices()) {
            (Some(d), indices) => {
                // As for the points: the count the budget admitted, before copying.
                let declared = indices.map_or(n, |a| a.count());
                if d.mesh.num_faces().checked_mul(3) != Some(declared) {
                    return Err(self.err(
                        &d.at,
                        format!(
                            "the compressed mesh has {} triangles where its accessors say {declared} corners",
                            d.mesh.num_faces()
                        ),
                    ));
                }
                let v = d.corners();
                if let Some(i) = v.iter().find(|i| **i as usize >= n) {
                    return Err(self.err(&d.at, format!("point {i} is out of range: the primitive has {n}")));
                }
                v
            }
            (None, Some(a)) => {
                let at = format!("{at}.indices");
                let v = self.read_indices(&at, &a, buffers)?;
                if let Some((k, i)) = v.iter().enumerate().find(|(_, i)| **i as usize >= n) {
                    return Err(self.err(
                        at,
                        format!(
                            "index {i} (entry {k} of accessor {}) is out of range: the primitive has {n} vertices",
                            a.index()
                        ),
                    ));
                }
                v
            }
            (None, None) => (0..n as u32).collect(),
        };
        drop(draco);
        let mut triangles: Vec<[u32; 3]> = match prim.mode() {
            Mode::TriangleStrip => (0..corners.len().saturating_sub(2))
                .map(|i| {
                    if i % 2 == 0 {
                        [corners[i], corners[i + 1], corners[i + 2]]
                    } else {
                        [corners[i + 1], corners[i], corners[i + 2]]
                    }
                })
                .collect(),
            Mode::TriangleFan => {
                (1..corners.len().saturating_sub(1)).map(|i| [corners[0], corners[i], corners[i + 1]]).collect()
            }
            _ => corners.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        };
        drop(corners);
        // A mirroring transform turns the winding around; keep the front faces in front.
        if Mat3::from_mat4(world).determinant() < 0.0 {
            for t in &mut triangles {
                t.swap(1, 2);
            }
        }
        let positions: Vec<Vec3> =
            positions.chunks_exact(3).map(|p| world.transform_point3(Vec3::new(p[0], p[1], p[2]))).collect();
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let normals: Vec<Vec3> = normals
            .chunks_exact(3)
            .map(|v| (normal_matrix * Vec3::new(v[0], v[1], v[2])).normalize_or_zero())
            .collect();
        // glTF's v runs down from the image's top; ember's (OBJ's) up from its bottom.
        let flip = |v: Vec<f32>| -> Vec<Vec2> { v.chunks_exact(2).map(|v| Vec2::new(v[0], 1.0 - v[1])).collect() };
        let (uvs, uvs1) = (flip(uvs), flip(uvs1));
        // Tangents as the normal matrix's dual: xyz by the linear part, the handedness turned
        // by a mirroring transform.
        let linear = Mat3::from_mat4(world);
        let handedness = linear.determinant().signum();
        let given_tangents: Vec<Vec4> = given_tangents
            .chunks_exact(4)
            .map(|t| (linear * Vec3::new(t[0], t[1], t[2])).normalize_or_zero().extend(t[3].signum() * handedness))
            .collect();
        let colors: Vec<Vec3> = colors.chunks_exact(color_width).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        let name = match mesh.name() {
            Some(s) => format!("{s}#{}", prim.index()),
            None => at.to_string(),
        };
        let mut tri = crate::geometry::TriMesh::new(name, positions, triangles, normals, uvs)
            .map_err(|e| self.err(at, e.to_string()))?;
        tri.uvs1 = uvs1;
        let Some(mut tri) = super::keep_hittable(self.path, tri, warnings) else {
            return Ok(None);
        };
        if let Some(set) = tangents {
            if !given_tangents.is_empty() {
                tri.tangents = tri.indices.iter().map(|t| t.map(|i| given_tangents[i as usize])).collect();
            } else if !tri.generate_tangents(set) {
                ignored.add("normal maps on primitives without texture coordinates", at);
            }
        }
        Ok(Some(tri).map(|mesh| {
            self.budget.keep(mesh.heap_bytes() + size_of_val(&colors[..]) as u64);
            self.budget.keep_primitives(mesh.triangle_count() as u64, 0);
            FileMesh { mesh, instances: Vec::new(), material: prim.material().index(), colors }
        }))
    }

    /// An accessor's values as f32 (normalised integers scaled to 0-1 or -1-1), `count ×
    /// components` of them, after checking its shape and byte ranges.
    fn read(
        &self,
        at: &str,
        a: &gltf::Accessor,
        dims: &[Dimensions],
        buffers: &[Vec<u8>],
    ) -> Result<Vec<f32>, SceneError> {
        if !dims.contains(&a.dimensions()) {
            let want: Vec<String> = dims.iter().map(|d| format!("{d:?}").to_uppercase()).collect();
            return Err(self.err(
                at,
                format!(
                    "accessor {} is {}, expected {}",
                    a.index(),
                    format!("{:?}", a.dimensions()).to_uppercase(),
                    want.join(" or ")
                ),
            ));
        }
        if a.data_type() == DataType::U32 && a.normalized() {
            return Err(self.err(at, format!("accessor {}: normalized UNSIGNED_INT is not allowed", a.index())));
        }
        let comps = a.dimensions().multiplicity();
        let (dt, normalized) = (a.data_type(), a.normalized());
        let decode = move |b: &[u8]| -> f32 {
            let raw = match dt {
                DataType::I8 => b[0] as i8 as f32,
                DataType::U8 => b[0] as f32,
                DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f32,
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32,
                DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            };
            if !normalized {
                return raw;
            }
            match dt {
                DataType::I8 => (raw / 127.0).max(-1.0),
                DataType::U8 => raw / 255.0,
                DataType::I16 => (raw / 32767.0).max(-1.0),
                DataType::U16 => raw / 65535.0,
                _ => raw,
            }
        };
        self.elements(at, a, comps, dt.size(), buffers, &decode, 0.0)
    }

    /// An index accessor's values (SCALAR, unsigned byte, short or int).
    fn read_indices(&self, at: &str, a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, SceneError> {
        let dt = a.data_type();
        if a.dimensions() != Dimensions::Scalar || !matches!(dt, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(self.err(
                at,
                format!(
                    "accessor {} is {:?} {:?}; indices must be scalar unsigned byte, short or int",
                    a.index(),
                    a.dimensions(),
                    dt
                ),
            ));
        }
        let decode = move |b: &[u8]| -> u32 {
            match dt {
                DataType::U8 => b[0] as u32,
                DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        self.elements(at, a, 1, dt.size(), buffers, &decode, 0)
    }

    /// The `count × comps` components of accessor `a` (component size `size`), decoded by
    /// `decode`: from its buffer view (zeros without one), then its sparse substitutions.
    #[allow(clippy::too_many_arguments)]
    fn elements<T: Copy>(
        &self,
        at: &str,
        a: &gltf::Accessor,
        comps: usize,
        size: usize,
        buffers: &[Vec<u8>],
        decode: &dyn Fn(&[u8]) -> T,
        zero: T,
    ) -> Result<Vec<T>, SceneError> {
        let count = a.count();
        let elem = comps * size;
        let mut out = match a.view() {
            None => vec![zero; count * comps],
            Some(view) => {
                let stride = view.stride().unwrap_or(elem);
                let bytes = self.strided(at, a.index(), &view, a.offset(), count, elem, stride, buffers)?;
                let mut out = Vec::with_capacity(count * comps);
                for k in 0..count {
                    let e = &bytes[k * stride..k * stride + elem];
                    out.extend(e.chunks_exact(size).map(decode));
                }
                out
            }
        };
        if let Some(sparse) = a.sparse() {
            let n = sparse.count();
            let iv = sparse.indices();
            let isize = iv.index_type().size();
            let ibytes = self.strided(
                &format!("{at}: sparse indices"),
                a.index(),
                &iv.view(),
                iv.offset(),
                n,
                isize,
                isize,
                buffers,
            )?;
            let vv = sparse.values();
            let vbytes = self.strided(
                &format!("{at}: sparse values"),
                a.index(),
                &vv.view(),
                vv.offset(),
                n,
                elem,
                elem,
                buffers,
            )?;
            for k in 0..n {
                let b = &ibytes[k * isize..(k + 1) * isize];
                let target = match isize {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                if target >= count {
                    return Err(self.err(
                        at,
                        format!("accessor {}: sparse index {target} is out of range ({count} entries)", a.index()),
                    ));
                }
                for (c, v) in vbytes[k * elem..(k + 1) * elem].chunks_exact(size).map(decode).enumerate() {
                    out[target * comps + c] = v;
                }
            }
        }
        Ok(out)
    }

    /// The bytes of `count` elements of `elem` bytes, `stride` apart, from `offset` into `view`;
    /// an error naming the accessor if they do not fit.
    #[allow(clippy::too_many_arguments)]
    fn strided<'b>(
        &self,
        at: &str,
        accessor: usize,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        elem: usize,
        stride: usize,
        buffers: &'b [Vec<u8>],
    ) -> Result<&'b [u8], SceneError> {
        if stride < elem {
            return Err(
                self.err(at, format!("accessor {accessor}: byteStride {stride} is less than the element size {elem}"))
            );
        }
        let data = self.view_bytes(at, view, buffers)?;
        if count == 0 {
            return Ok(&data[..0]);
        }
        let end = stride.checked_mul(count - 1).and_then(|x| x.checked_add(elem)).and_then(|x| x.checked_add(offset));
        match end {
            Some(end) if end <= data.len() => Ok(&data[offset..end]),
            _ => Err(self.err(
                at,
                format!(
                    "accessor {accessor} out of range: {count} entries of {elem} bytes (stride {stride}) from byte {offset} do not fit in bufferViews[{}] ({} bytes)",
                    view.index(),
                    data.len()
                ),
            )),
        }
    }
}

/// Loads a texture reference for a material: (the reference, where it is, the image's
/// encoding, the warnings) → the map.
type MapFn<'a, 'm> = dyn FnMut(TextureSlot<'a>, &str, Encoding, &mut Tally) -> Result<TextureMap, SceneError> + 'm;

/// Where a material takes a texture: the texture, its coordinate set, and its
/// `KHR_texture_transform` (an error message if malformed).
struct TextureSlot<'a> {
    texture: gltf::texture::Texture<'a>,
    tex_coord: u32,
    transform: Result<Option<UvTransform>, String>,
}

impl<'a> TextureSlot<'a> {
    /// A `textureInfo`: the `gltf` crate reads its `KHR_texture_transform`, whose `texCoord`
    /// overrides the `textureInfo`'s.
    fn of(info: &gltf::texture::Info<'a>) -> TextureSlot<'a> {
        let t = info.texture_transform();
        let transform = t
            .as_ref()
            .map(|t| UvTransform::offset_rotation_scale(Vec2::from(t.offset()), t.rotation(), Vec2::from(t.scale())));
        let tex_coord = t.and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
        TextureSlot { texture: info.texture(), tex_coord, transform: Ok(transform) }
    }

    /// A `textureInfo` in an extension's raw JSON (`index`, `texCoord`, and its own
    /// `KHR_texture_transform`, whose `texCoord` overrides), or what is wrong with it.
    fn raw(doc: &'a gltf::Document, info: &serde_json::Value) -> Result<TextureSlot<'a>, String> {
        let index = info.get("index").and_then(|i| i.as_u64()).ok_or("index is missing or not a whole number")?;
        let texture = usize::try_from(index)
            .ok()
            .and_then(|i| doc.textures().nth(i))
            .ok_or_else(|| format!("index {index}: no such texture (the file has {})", doc.textures().len()))?;
        let whole = |v: &serde_json::Value| v.as_u64().and_then(|t| u32::try_from(t).ok());
        let mut tex_coord = match info.get("texCoord") {
            None => 0,
            Some(t) => whole(t).ok_or_else(|| format!("texCoord {t} is not a whole number"))?,
        };
        let extensions = info.get("extensions").and_then(|e| e.as_object());
        if let Some(t) = extensions.and_then(|e| e.get("KHR_texture_transform")).and_then(|t| t.get("texCoord")) {
            tex_coord = whole(t).ok_or_else(|| format!("KHR_texture_transform.texCoord {t} is not a whole number"))?;
        }
        Ok(TextureSlot { texture, tex_coord, transform: texture_transform(extensions) })
    }

    /// A `normalTexture`, whose `KHR_texture_transform` the crate does not model: read from
    /// its raw extensions.
    fn normal(n: &gltf::material::NormalTexture<'a>) -> TextureSlot<'a> {
        TextureSlot { texture: n.texture(), tex_coord: n.tex_coord(), transform: texture_transform(n.extensions()) }
    }
}

/// The `KHR_texture_transform` in a texture reference's raw extensions, if any, or an error
/// message if malformed.
fn texture_transform(
    extensions: Option<&serde_json::Map<String, gltf::json::Value>>,
) -> Result<Option<UvTransform>, String> {
    let Some(t) = extensions.and_then(|e| e.get("KHR_texture_transform")) else {
        return Ok(None);
    };
    let pair = |key: &str, default: [f32; 2]| -> Result<Vec2, String> {
        match t.get(key) {
            None => Ok(Vec2::from(default)),
            Some(v) => v
                .as_array()
                .filter(|a| a.len() == 2)
                .and_then(|a| Some(Vec2::new(a[0].as_f64()? as f32, a[1].as_f64()? as f32)))
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("KHR_texture_transform.{key}: expected two finite numbers")),
        }
    };
    let rotation = match t.get("rotation") {
        None => 0.0,
        Some(v) => v
            .as_f64()
            .map(|r| r as f32)
            .filter(|r| r.is_finite())
            .ok_or("KHR_texture_transform.rotation: expected a finite number")?,
    };
    if t.get("texCoord").is_some() {
        return Err("KHR_texture_transform.texCoord is not supported (give textureInfo.texCoord)".into());
    }
    Ok(Some(UvTransform::offset_rotation_scale(pair("offset", [0.0, 0.0])?, rotation, pair("scale", [1.0, 1.0])?)))
}

/// A texture map of `image` through a glTF sampler (its wrap modes and magnification
/// filter), at coordinate set
/// `set`, with `transform` (`KHR_texture_transform`) applied after flipping the coordinates
/// back to glTF's (v down from the image's top: meshes keep v up, as OBJ's).
fn texture_map(
    image: Arc<MipImage>,
    sampler: &gltf::texture::Sampler,
    set: usize,
    transform: Option<UvTransform>,
) -> TextureMap {
    let wrap = |w: gltf::texture::WrappingMode| match w {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    };
    let sampler = Sampler {
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
        nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
    };
    let flip = UvTransform::FLIP_V;
    let transform = match transform {
        Some(t) => UvTransform(t.0 * flip.0),
        None => flip,
    };
    TextureMap { transform: Some(transform), set, ..TextureMap::new(image, sampler) }
}

/// `%XX` escapes of a URI decoded (glTF URIs are percent-encoded); bad escapes kept as they are.
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glTF file with an embedded buffer: a strip, an indexed fan and a LINES primitive on
    /// one node; a strip whose positions are a sparse accessor on a mirrored node.
    #[test]
    fn strips_fans_sparse_and_mirrors() {
        let mut buf = Vec::new();
        for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]] {
            buf.extend(p.iter().flat_map(|c| c.to_le_bytes()));
        }
        buf.extend([0u8, 1, 3, 2]); // fan indices, bytes 48..52
        buf.extend([3u8, 0, 0, 0]); // sparse index (vertex 3), 52..53, padded
        buf.extend([2.0f32, 2.0, 0.0].iter().flat_map(|c| c.to_le_bytes())); // its value, 56..68
        let data = base64::engine::general_purpose::STANDARD.encode(&buf);
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
            "nodes": [{{"mesh": 0}}, {{"mesh": 1, "scale": [-1, 1, 1]}}],
            "meshes": [
              {{"primitives": [{{"attributes": {{"POSITION": 0}}, "mode": 5}},
                               {{"attributes": {{"POSITION": 0}}, "indices": 1, "mode": 6}},
                               {{"attributes": {{"POSITION": 0}}, "mode": 1}}]}},
              {{"primitives": [{{"attributes": {{"POSITION": 2}}, "mode": 5}}]}}],
            "accessors": [
              {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
              {{"bufferView": 1, "componentType": 5121, "count": 4, "type": "SCALAR"}},
              {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [2, 2, 0],
                "sparse": {{"count": 1, "indices": {{"bufferView": 2, "componentType": 5121}}, "values": {{"bufferView": 3}}}}}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 4}},
              {{"buffer": 0, "byteOffset": 52, "byteLength": 1}}, {{"buffer": 0, "byteOffset": 56, "byteLength": 12}}],
            "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{data}"}}]}}"#,
            buf.len()
        );
        let path = std::env::temp_dir().join(format!("ember-gltf-unit-{}.gltf", std::process::id()));
        std::fs::write(&path, json).unwrap();
        let f = super::super::load(&path, &LoadBudget::unlimited());
        std::fs::remove_file(&path).unwrap();
        let f = f.unwrap();
        let tris: Vec<Vec<[u32; 3]>> = f.meshes.iter().map(|m| m.mesh.indices.clone()).collect();
        assert_eq!(tris, [vec![[0, 1, 2], [2, 1, 3]], vec![[0, 1, 3], [0, 3, 2]], vec![[0, 2, 1], [2, 3, 1]]]);
        assert_eq!(f.meshes[2].mesh.positions[3], Vec3::new(-2.0, 2.0, 0.0));
        assert_eq!(f.meshes[2].mesh.positions[1], Vec3::new(-1.0, 0.0, 0.0));
        assert!(f.meshes.iter().all(|m| m.material.is_none()));
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        assert!(f.warnings[0].contains("mode Lines"), "{:?}", f.warnings);
    }

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("plain.bin"), "plain.bin");
        assert_eq!(percent_decode("bad%zz%2"), "bad%zz%2");
    }
}
