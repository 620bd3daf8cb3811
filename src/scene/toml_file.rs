//! Reading a TOML scene file (its schema is `format.rs`) into a [`Scene`]: each section's
//! values become ember's geometry, materials, lights and camera; the meshes it names come
//! through the mesh-file door (`mesh_file`).

use super::format::{self, BackgroundSection, ColorSource, LightSection, MaterialSection, ScaleSpec, SceneFile};
use super::{CameraSpec, MaterialBinding, Scene, SceneError, mesh_file};
use crate::geometry::{Cylinder, Geometry, Sphere, TriMesh};
use crate::light::{Background, Environment, Light, PointLight};
use crate::material::{
    DiffuseMaterial, EmissiveMaterial, GlassMaterial, Material, MaterialKind, MetalMaterial, PlasticMaterial,
};
use crate::memory::{self, LoadBudget};
use crate::settings::{RenderDefaults, RenderSettings};
use crate::texture::{Encoding, Image, MipImage, Texture, colour_map};
use glam::{Affine3A, Quat, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// 1-based line of byte offset `pos` in `text`.
fn line_of(text: &str, pos: usize) -> usize {
    text[..pos.min(text.len())].bytes().filter(|&b| b == b'\n').count() + 1
}

/// The scene file being read: where it is, its text (for line numbers) and the images
/// loaded so far (each file once).
struct SceneFileReader<'a> {
    budget: &'a LoadBudget,
    path: &'a Path,
    text: &'a str,
    dir: PathBuf,
    images: HashMap<PathBuf, Arc<MipImage>>,
    /// Files read so far, for [`Scene::inputs`].
    inputs: Vec<PathBuf>,
}

impl SceneFileReader<'_> {
    fn err_at(&self, span: std::ops::Range<usize>, msg: impl Into<String>) -> SceneError {
        SceneError::new(self.path, Some(line_of(self.text, span.start)), msg)
    }

    fn resolve(&self, file: &str) -> PathBuf {
        self.dir.join(file)
    }

    fn image(&mut self, file: &str, span: std::ops::Range<usize>) -> Result<Arc<MipImage>, SceneError> {
        let p = self.resolve(file);
        if let Some(img) = self.images.get(&p) {
            return Ok(img.clone());
        }
        let img = MipImage::load(&p, self.budget, Encoding::Srgb)
            .map_err(|e| self.err_at(span, format!("texture {}: {e}", p.display())))?;
        let img = Arc::new(img);
        self.inputs.push(p.clone());
        self.images.insert(p, img.clone());
        Ok(img)
    }

    /// The environment image `file`: 8-bit (sRGB) or HDR (linear).
    fn environment_image(&mut self, file: &str, span: std::ops::Range<usize>) -> Result<Arc<Image>, SceneError> {
        let p = self.resolve(file);
        let img = Image::load_environment(&p, self.budget)
            .map_err(|e| self.err_at(span, format!("environment image {}: {e}", p.display())))?;
        self.inputs.push(p);
        Ok(Arc::new(img))
    }

    fn texture(&mut self, c: ColorSource, at: std::ops::Range<usize>) -> Result<Texture, SceneError> {
        let given = c.color.is_some() as u8 + c.texture.is_some() as u8 + c.checker.is_some() as u8;
        if given > 1 {
            return Err(self.err_at(at, "give only one of color, texture and checker"));
        }
        Ok(if let Some(t) = c.texture {
            colour_map(self.image(&t, at)?)
        } else if let Some(ch) = c.checker {
            Texture::Checker { a: ch.a.0, b: ch.b.0, scale: ch.scale.0 }
        } else {
            Texture::Constant(c.color.map_or(Vec3::splat(0.8), |c| c.0))
        })
    }
}

/// Memory to parse a TOML scene file, per byte of it (measured: 620 MB peak for a 14.4 MB file
/// of 200,000 spheres, 43 bytes per byte).
const PARSE_BYTES_PER_BYTE: u64 = 48;

/// Bytes kept per sphere or cylinder (its shape and its material index).
const BYTES_PER_SHAPE: u64 = 32;

pub(super) fn load(path: &Path, budget: &LoadBudget) -> Result<Scene, SceneError> {
    let len = super::input::regular_file_len(path)?;
    budget
        .admit(format!("scene file of {}", memory::format_bytes(len)), len.saturating_mul(PARSE_BYTES_PER_BYTE))
        .map_err(|e| SceneError::new(path, None, e.to_string()))?;
    let text = super::input::read_to_string(path)?;
    from_str(&text, path, budget)
}

pub(super) fn from_str(text: &str, path: &Path, budget: &LoadBudget) -> Result<Scene, SceneError> {
    // A UTF-8 byte-order mark, as some editors write, is not part of the first line.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let file: SceneFile = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        SceneError::new(path, line, e.message().trim().to_string())
    })?;
    let limit_error = |e: memory::LimitError| SceneError::new(path, None, e.to_string());
    let render = render_defaults(&file.render);
    budget.keep_film(render.width, render.height, RenderSettings::default().size()).map_err(limit_error)?;
    let shapes = (file.spheres.len() + file.cylinders.len()) as u64;
    budget.keep(shapes * BYTES_PER_SHAPE);
    budget.keep_primitives(2 * file.quads.len() as u64, shapes);
    let mut ctx = SceneFileReader {
        budget,
        path,
        text,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        images: HashMap::new(),
        inputs: vec![path.to_path_buf()],
    };
    let mut scene = Scene::empty(path);
    scene.render = render;

    // Materials, by name.
    let mut by_name: HashMap<String, u32> = HashMap::new();
    for (name, m) in file.materials {
        let span = m.span();
        let material = material(&mut ctx, name.clone(), m.into_inner(), span)?;
        by_name.insert(name, scene.materials.len() as u32);
        scene.materials.push(material);
    }
    let lookup = |ctx: &SceneFileReader, name: &toml::Spanned<String>| -> Result<u32, SceneError> {
        by_name.get(name.get_ref()).copied().ok_or_else(|| {
            let mut known: Vec<&str> = by_name.keys().map(String::as_str).collect();
            known.sort();
            ctx.err_at(name.span(), format!("unknown material {:?} (defined: {})", name.get_ref(), known.join(", ")))
        })
    };

    for m in &file.meshes {
        let mesh_path = ctx.resolve(m.file.get_ref());
        let loaded = mesh_file::load(&mesh_path, budget).map_err(|e| {
            if e.line.is_none() && e.path == mesh_path {
                // Point at the scene line that names the file, and say what is wrong with it.
                ctx.err_at(m.file.span(), format!("mesh {}: {}", mesh_path.display(), e.message))
            } else {
                e
            }
        })?;
        let transform = mesh_transform(&ctx, m)?;
        let over = m.material.as_ref().map(|n| lookup(&ctx, n)).transpose()?.map(|id| (id, m.scope));
        mesh_file::add_to_scene(&mut scene, &mesh_path, loaded, Some(transform), over, m.smooth)
            .map_err(|e| ctx.err_at(m.file.span(), format!("mesh {}: {e}", mesh_path.display())))?;
    }
    for q in &file.quads {
        let id = lookup(&ctx, &q.material)?;
        let (c, e1, e2) = (q.corner.0, q.edge1.0, q.edge2.0);
        if e1.cross(e2).length_squared() == 0.0 {
            return Err(ctx.err_at(q.material.span(), "quad edges are parallel or zero: the quad has no area"));
        }
        let mesh = TriMesh::new(
            "quad",
            vec![c, c + e1, c + e1 + e2, c + e2],
            vec![[0, 1, 2], [0, 2, 3]],
            vec![],
            vec![
                glam::Vec2::new(0.0, 0.0),
                glam::Vec2::new(1.0, 0.0),
                glam::Vec2::new(1.0, 1.0),
                glam::Vec2::new(0.0, 1.0),
            ],
        )
        .expect("a quad's indices are in range");
        scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
        scene.bindings.push(MaterialBinding::Uniform(id));
    }
    if !file.spheres.is_empty() {
        let mut shapes = Vec::new();
        let mut ids = Vec::new();
        for s in &file.spheres {
            ids.push(lookup(&ctx, &s.material)?);
            shapes.push(Sphere::new(s.center.0, s.radius.0));
        }
        scene.geometry.push(Geometry::Spheres(shapes.into()));
        scene.bindings.push(MaterialBinding::PerPrim(ids.into()));
    }
    if !file.cylinders.is_empty() {
        let mut shapes = Vec::new();
        let mut ids = Vec::new();
        for c in &file.cylinders {
            ids.push(lookup(&ctx, &c.material)?);
            if c.p0.0 == c.p1.0 {
                return Err(ctx.err_at(c.material.span(), "cylinder p0 and p1 are the same point"));
            }
            if scene.materials[*ids.last().unwrap() as usize].is_emissive() {
                scene.warnings.push(format!(
                    "{}: emissive cylinders are not sampled as lights; they glow but light nothing directly",
                    path.display()
                ));
            }
            shapes.push(Cylinder::new(c.p0.0, c.p1.0, c.radius.0));
        }
        scene.geometry.push(Geometry::Cylinders(shapes.into()));
        scene.bindings.push(MaterialBinding::PerPrim(ids.into()));
    }
    for l in &file.lights {
        match l {
            LightSection::Point { position, intensity } => {
                scene.lights.push(Light::Point(PointLight { position: position.0, intensity: intensity.0 }))
            }
        }
    }
    let background_span = file.background.as_ref().map(|b| b.span());
    let background = match file.background.map(toml::Spanned::into_inner) {
        None => None,
        Some(BackgroundSection::Constant { color }) => Some(Background::Constant(color.0)),
        Some(BackgroundSection::Gradient { zenith, horizon, ground }) => Some(Background::Gradient {
            zenith: zenith.0,
            horizon: horizon.0,
            ground: ground.map_or(horizon.0, |g| g.0),
        }),
        Some(BackgroundSection::Image { file, strength, rotate }) => {
            let span = background_span.unwrap_or(0..0);
            let image = ctx.environment_image(&file, span.clone())?;
            let sampling = memory::environment_sampling_bytes(image.width, image.height);
            budget
                .admit(
                    format!("sampling distribution of the {}x{} environment image", image.width, image.height),
                    sampling,
                )
                .map_err(|e| ctx.err_at(span, e.to_string()))?;
            let env = Environment::new(image, strength.map_or(1.0, |s| s.0), rotate.map_or(0.0, |r| r.0));
            budget.keep(env.sampling_bytes());
            Some(Background::Image(Arc::new(env)))
        }
    };
    if let Some(b) = background {
        scene.set_background(b);
    }
    if let Some(c) = file.camera {
        scene.camera = Some(camera(&ctx, c)?);
    }
    if scene.geometry.is_empty() {
        return Err(SceneError::new(path, None, "the scene has no geometry (meshes, quads, spheres or cylinders)"));
    }
    scene.inputs.extend(ctx.inputs);
    Ok(scene)
}

/// The camera a `[camera]` table describes.
fn camera(ctx: &SceneFileReader, c: format::CameraSection) -> Result<CameraSpec, SceneError> {
    let fov = c.fov.as_ref().map_or(super::DEFAULT_FOV, |f| f.get_ref().0);
    if fov >= 180.0 {
        return Err(ctx.err_at(c.fov.unwrap().span(), format!("fov must be below 180 degrees, found {fov}")));
    }
    if c.position.get_ref().0 == c.look_at.0 {
        return Err(ctx.err_at(c.position.span(), "camera position and look_at are the same point"));
    }
    let orthographic = c.kind.as_ref().is_some_and(|k| k.get_ref().0 == format::Projection::Orthographic);
    let ortho_width = if orthographic {
        // What belongs to a perspective camera is refused rather than ignored.
        let lens = [
            ("fov", c.fov.as_ref().map(|f| f.span())),
            ("aperture", c.aperture.as_ref().map(|a| a.span())),
            ("focus_distance", c.focus_distance.as_ref().map(|f| f.span())),
        ];
        if let Some((key, span)) = lens.into_iter().find_map(|(key, span)| Some((key, span?))) {
            return Err(ctx.err_at(span, format!("an orthographic camera has no {key} (its view is `width` wide)")));
        }
        let span = c.kind.as_ref().map(|k| k.span()).unwrap_or_default();
        let width = c
            .width
            .as_ref()
            .ok_or_else(|| ctx.err_at(span, "an orthographic camera needs `width`, the view's width in world units"))?;
        Some(width.get_ref().0)
    } else {
        if let Some(w) = &c.width {
            return Err(ctx.err_at(w.span(), "`width` is an orthographic camera's (type = \"orthographic\")"));
        }
        None
    };
    Ok(CameraSpec {
        position: c.position.get_ref().0,
        look_at: c.look_at.0,
        up: c.up.map_or(Vec3::Y, |u| u.0),
        fov,
        aperture: c.aperture.map_or(0.0, |a| a.get_ref().0),
        focus_distance: c.focus_distance.map(|f| f.get_ref().0),
        ortho_width,
    })
}

fn render_defaults(r: &format::RenderSection) -> RenderDefaults {
    RenderDefaults {
        width: r.width.map(|s| s.0),
        height: r.height.map(|s| s.0),
        spp: r.spp.map(|s| s.0),
        max_depth: r.max_depth,
        rr_depth: r.rr_depth.map(|v| v.0),
        seed: r.seed,
        denoise: r.denoise,
        exposure: r.exposure.map(|e| e.0),
        tonemap: r.tonemap.map(|t| t.0),
        filter: r.filter.map(|f| f.0),
        sampler: r.sampler.map(|v| v.0),
        light_vertices: r.light_vertices.map(|v| v.0),
        caustics: r.caustics.map(|v| v.0),
    }
}

fn material(
    ctx: &mut SceneFileReader,
    name: String,
    m: MaterialSection,
    span: std::ops::Range<usize>,
) -> Result<Material, SceneError> {
    let e = |x: Option<format::Rgb>| x.map_or(Vec3::ZERO, |c| c.0);
    let (kind, emission) = match m {
        MaterialSection::Diffuse { color, emission } => {
            (MaterialKind::Diffuse(DiffuseMaterial { color: ctx.texture(color, span)? }), e(emission))
        }
        MaterialSection::Metal { color, roughness, emission } => (
            MaterialKind::Metal(MetalMaterial {
                color: ctx.texture(color, span)?,
                roughness: roughness.map_or(0.0, |r| r.0),
            }),
            e(emission),
        ),
        MaterialSection::Plastic { color, roughness, emission } => (
            MaterialKind::Plastic(PlasticMaterial {
                color: ctx.texture(color, span)?,
                roughness: roughness.map_or(0.2, |r| r.0),
            }),
            e(emission),
        ),
        MaterialSection::Glass { ior, tint, attenuation_color, attenuation_distance } => (
            MaterialKind::Glass(GlassMaterial {
                absorption: GlassMaterial::absorption_for(
                    attenuation_color.map_or(Vec3::ONE, |c| c.0),
                    attenuation_distance.map_or(f32::INFINITY, |d| d.0),
                ),
                ..GlassMaterial::clear(ior.map_or(1.5, |i| i.0), tint.map_or(Vec3::ONE, |t| t.0))
            }),
            Vec3::ZERO,
        ),
        MaterialSection::Emissive { emission } => (MaterialKind::Emissive(EmissiveMaterial), emission.0),
    };
    Ok(Material { name, kind, emission: Texture::Constant(emission) })
}

fn mesh_transform(ctx: &SceneFileReader, m: &format::MeshSection) -> Result<Affine3A, SceneError> {
    let scale = match m.scale.as_ref().map(|s| (*s.get_ref(), s.span())) {
        None => Vec3::ONE,
        Some((ScaleSpec::Uniform(s), span)) => {
            if s.0 == 0.0 {
                return Err(ctx.err_at(span, "scale must not be 0"));
            }
            Vec3::splat(s.0)
        }
        Some((ScaleSpec::PerAxis(v), span)) => {
            if v.0.cmpeq(Vec3::ZERO).any() {
                return Err(ctx.err_at(span, "scale components must not be 0"));
            }
            v.0
        }
    };
    let r = m.rotate.map_or(Vec3::ZERO, |r| r.0) * (std::f32::consts::PI / 180.0);
    let rot = Quat::from_rotation_z(r.z) * Quat::from_rotation_y(r.y) * Quat::from_rotation_x(r.x);
    let t = m.translate.map_or(Vec3::ZERO, |t| t.0);
    Ok(Affine3A::from_scale_rotation_translation(scale, rot, t))
}
