//! Building the suite's scenes in code, so that `ember check` needs nothing but the binary
//! (the teapot's OBJ text is compiled in).

use crate::geometry::{Aabb, Cylinder, Geometry, Sphere, TriMesh};
use crate::light::{Background, Light, PointLight};
use crate::material::{DiffuseMaterial, EmissiveMaterial, GlassMaterial, Material, MaterialKind};
use crate::memory::LoadBudget;
use crate::scene::mesh_file::obj::parse_obj;
use crate::scene::{CameraSpec, MaterialBinding, Scene};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::{Arc, OnceLock};

/// Builds a hard case's scene in code: materials, shapes, lights, background, camera.
/// (Not [`crate::embree::SceneBuilder`], which builds an Embree scene.)
pub struct CaseSceneBuilder {
    scene: Scene,
}

impl CaseSceneBuilder {
    pub fn new(name: &str) -> CaseSceneBuilder {
        CaseSceneBuilder { scene: Scene::empty(format!("check:{name}")) }
    }

    /// Adds a material; returns its id.
    pub fn material(&mut self, kind: MaterialKind, emission: Vec3) -> u32 {
        let id = self.scene.materials.len() as u32;
        self.scene.materials.push(Material { name: format!("m{id}"), kind, emission: Texture::Constant(emission) });
        id
    }

    pub fn diffuse(&mut self, albedo: f32) -> u32 {
        self.material(
            MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(Vec3::splat(albedo)) }),
            Vec3::ZERO,
        )
    }

    /// Emits `radiance` and reflects nothing.
    pub fn emitter(&mut self, radiance: f32) -> u32 {
        self.material(MaterialKind::Emissive(EmissiveMaterial), Vec3::splat(radiance))
    }

    pub fn glass(&mut self, ior: f32) -> u32 {
        self.material(MaterialKind::Glass(GlassMaterial::clear(ior, Vec3::ONE)), Vec3::ZERO)
    }

    pub fn mesh(&mut self, mesh: TriMesh, material: u32) {
        self.scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
        self.scene.bindings.push(MaterialBinding::Uniform(material));
    }

    /// The parallelogram corner, corner + e1, corner + e1 + e2, corner + e2 (uv 0..1 along
    /// e1, e2), as the scene format's quads.
    pub fn quad(&mut self, corner: Vec3, e1: Vec3, e2: Vec3, material: u32) {
        self.mesh(quad_mesh(corner, e1, e2), material);
    }

    pub fn sphere(&mut self, center: Vec3, radius: f32, material: u32) {
        self.scene.geometry.push(Geometry::Spheres(vec![Sphere::new(center, radius)].into()));
        self.scene.bindings.push(MaterialBinding::Uniform(material));
    }

    pub fn cylinder(&mut self, p0: Vec3, p1: Vec3, radius: f32, material: u32) {
        self.scene.geometry.push(Geometry::Cylinders(vec![Cylinder::new(p0, p1, radius)].into()));
        self.scene.bindings.push(MaterialBinding::Uniform(material));
    }

    pub fn point_light(&mut self, position: Vec3, intensity: f32) {
        self.scene.lights.push(Light::Point(PointLight { position, intensity: Vec3::splat(intensity) }));
    }

    pub fn background(&mut self, background: Background) {
        self.scene.set_background(background);
    }

    /// A pinhole camera.
    pub fn camera(&mut self, position: Vec3, look_at: Vec3, up: Vec3, fov: f32) {
        self.scene.camera = Some(CameraSpec::pinhole(position, look_at, up, fov));
    }

    pub fn build(self) -> Scene {
        self.scene
    }
}

/// The quad of the scene format as a two-triangle mesh.
pub fn quad_mesh(corner: Vec3, e1: Vec3, e2: Vec3) -> TriMesh {
    let uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    TriMesh::new(
        "quad",
        vec![corner, corner + e1, corner + e1 + e2, corner + e2],
        vec![[0, 1, 2], [0, 2, 3]],
        vec![],
        uvs,
    )
    .expect("a quad's indices are in range")
}

/// A closed axis-aligned box (12 triangles, outward winding).
pub fn box_mesh(min: Vec3, max: Vec3) -> TriMesh {
    let positions = Aabb::new(min, max).corners().collect();
    let faces: [[u32; 4]; 6] = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let indices = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
    TriMesh::new("box", positions, indices, vec![], vec![]).expect("box indices are in range")
}

/// A closed, watertight sphere mesh: an icosahedron subdivided `levels` times, vertices
/// shared between triangles (20 · 4^levels triangles).
pub fn icosphere(center: Vec3, radius: f32, levels: u32) -> TriMesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    // Wind every face outward (glass decides inside from the winding).
    for t in &mut f {
        let [a, b, c] = t.map(|i| v[i as usize]);
        if (b - a).cross(c - a).dot(a + b + c) < 0.0 {
            t.swap(1, 2);
        }
    }
    let positions = v.iter().map(|&p| center + radius * p).collect();
    TriMesh::new("icosphere", positions, f, vec![], vec![]).expect("icosphere indices are in range")
}

/// The teapot of `scenes/teapot.obj` (compiled in), with smooth vertex normals.
pub fn teapot() -> TriMesh {
    static TEAPOT: OnceLock<TriMesh> = OnceLock::new();
    TEAPOT
        .get_or_init(|| {
            let text = include_str!("../../../scenes/teapot.obj");
            let no_mtl = |_: &Path| Err(std::io::Error::other("no MTL files here"));
            let obj = parse_obj(text.as_bytes(), Path::new("teapot.obj (built in)"), &no_mtl, &LoadBudget::unlimited())
                .expect("the built-in teapot parses");
            let mut mesh = obj.meshes.into_iter().next().expect("the teapot has a mesh").mesh;
            mesh.compute_vertex_normals();
            mesh
        })
        .clone()
}

/// `scene` with every position mapped by `point` and every length multiplied by `scale`
/// (point-light intensities by scale², so irradiance is unchanged). Directions, radiance and
/// materials are kept.
pub fn map_scene(scene: &Scene, point: impl Fn(Vec3) -> Vec3, scale: f32) -> Scene {
    let mut out = scene.clone();
    out.geometry = scene
        .geometry
        .iter()
        .map(|g| match g {
            Geometry::Mesh(m) => {
                let mut m = (**m).clone();
                m.positions.iter_mut().for_each(|p| *p = point(*p));
                Geometry::Mesh(Arc::new(m))
            }
            Geometry::Instance(i) => {
                let mut m = i.placed_copy();
                m.positions.iter_mut().for_each(|p| *p = point(*p));
                Geometry::Mesh(Arc::new(m))
            }
            Geometry::Spheres(s) => {
                Geometry::Spheres(s.iter().map(|s| Sphere::new(point(s.center), s.radius * scale)).collect())
            }
            Geometry::Cylinders(c) => Geometry::Cylinders(
                c.iter().map(|c| Cylinder::new(point(c.p0), point(c.p1), c.radius * scale)).collect(),
            ),
        })
        .collect();
    for l in &mut out.lights {
        let Light::Point(l) = l else { continue };
        l.position = point(l.position);
        l.intensity *= scale * scale;
    }
    if let Some(c) = &mut out.camera {
        c.position = point(c.position);
        c.look_at = point(c.look_at);
        c.focus_distance = c.focus_distance.map(|f| f * scale);
    }
    out
}
