//! Spheres and capped cylinders as triangle meshes, for comparing Embree's user geometry
//! (analytic, through callbacks) with its native triangles on the same scene.
//!
//! Every vertex lies exactly on the analytic surface (up to rounding), so the mesh is
//! inscribed: a ray hitting the mesh hits the shape, and the mesh lies within about two chord
//! sagittas `r (1 - cos(π / segments))` of the surface (the most at the middle of a quad). Triangles wind counter-clockwise
//! seen from outside, so `(p1 - p0) × (p2 - p0)` points out. Per-vertex normals are the
//! analytic ones (radial on spheres and cylinder sides, the axis on caps); the rim of a
//! cylinder has its vertices twice (side and cap normals) at identical positions, so the
//! surface is closed without cracks.

use crate::geometry::{Cylinder, Frame, Sphere, TriMesh};
use glam::Vec3;
use std::f32::consts::PI;

/// A mesh made from analytic shapes, with the shape each triangle came from.
#[derive(Clone, Debug)]
pub struct Tessellation {
    pub mesh: TriMesh,
    /// `source[t]` is the index (in the input slice) of the shape triangle `t` belongs to.
    pub source: Vec<u32>,
}

/// Triangles per sphere for `segments` around the polar axis (rings = segments / 2).
pub fn sphere_triangle_count(segments: u32) -> usize {
    let (s, r) = sphere_grid(segments);
    (2 * s * (r - 1)) as usize
}

/// Triangles per cylinder for `segments` around the axis (side quads plus two cap fans).
pub fn cylinder_triangle_count(segments: u32) -> usize {
    4 * segments.max(3) as usize
}

fn sphere_grid(segments: u32) -> (u32, u32) {
    let s = segments.max(3);
    (s, (s / 2).max(2))
}

/// Latitude-longitude spheres about the z axis: `segments`
/// meridians (at least 3) and `segments / 2` bands (at least 2); the polar bands are fans.
pub fn tessellate_spheres(spheres: &[Sphere], segments: u32) -> Tessellation {
    let (s, r) = sphere_grid(segments);
    let mut out = MeshBuilder::default();
    for (k, sp) in spheres.iter().enumerate() {
        let first = out.positions.len() as u32;
        // Vertex 0: south pole, then rings 1..r-1 of s vertices each, then the north pole.
        let mut vertex = |n: Vec3| out.vertex(sp.center + sp.radius * n, n);
        vertex(Vec3::NEG_Z);
        for i in 1..r {
            let theta = PI * i as f32 / r as f32 - 0.5 * PI; // latitude
            let (sz, cz) = theta.sin_cos();
            for j in 0..s {
                let phi = 2.0 * PI * j as f32 / s as f32;
                let (sy, cx) = phi.sin_cos();
                vertex(Vec3::new(cz * cx, cz * sy, sz));
            }
        }
        vertex(Vec3::Z);
        let ring = |i: u32, j: u32| first + 1 + (i - 1) * s + j % s;
        let (south, north) = (first, first + 1 + (r - 1) * s);
        let src = k as u32;
        for j in 0..s {
            out.triangle([south, ring(1, j + 1), ring(1, j)], src);
            out.triangle([north, ring(r - 1, j), ring(r - 1, j + 1)], src);
        }
        for i in 1..r - 1 {
            for j in 0..s {
                let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
                out.triangle([a, b, c], src);
                out.triangle([a, c, d], src);
            }
        }
    }
    out.finish("tessellated spheres")
}

/// Capped cylinders with `segments` (at least 3) around the axis: the side as quads split in
/// two, each cap as a fan around its centre.
pub fn tessellate_cylinders(cylinders: &[Cylinder], segments: u32) -> Tessellation {
    let s = segments.max(3);
    let mut out = MeshBuilder::default();
    for (k, cy) in cylinders.iter().enumerate() {
        let axis = cy.p1 - cy.p0;
        let a = axis.normalize_or_zero();
        if a == Vec3::ZERO || !(cy.radius > 0.0) {
            continue; // invalid cylinders are skipped, as Embree skips their empty bounds
        }
        let f = Frame::from_normal(a);
        let radial = |j: u32| {
            let phi = 2.0 * PI * j as f32 / s as f32;
            let (sn, cs) = phi.sin_cos();
            cs * f.t + sn * f.b
        };
        let base = out.positions.len() as u32;
        // Side: ring 0 at p0 (indices base + j), ring 1 at p1 (base + s + j).
        for end in [cy.p0, cy.p1] {
            for j in 0..s {
                let n = radial(j);
                out.vertex(end + cy.radius * n, n);
            }
        }
        // Caps: the same rim positions with axial normals, then the two centres.
        let cap0 = base + 2 * s;
        let cap1 = cap0 + s;
        for (end, n) in [(cy.p0, -a), (cy.p1, a)] {
            for j in 0..s {
                out.vertex(end + cy.radius * radial(j), n);
            }
        }
        let (c0, c1) = (cap1 + s, cap1 + s + 1);
        out.vertex(cy.p0, -a);
        out.vertex(cy.p1, a);
        let src = k as u32;
        for j in 0..s {
            let jn = (j + 1) % s;
            // (t, b, a) is right-handed, so increasing angle runs counter-clockwise about a.
            out.triangle([base + j, base + jn, base + s + jn], src);
            out.triangle([base + j, base + s + jn, base + s + j], src);
            out.triangle([c0, cap0 + jn, cap0 + j], src);
            out.triangle([c1, cap1 + j, cap1 + jn], src);
        }
    }
    out.finish("tessellated cylinders")
}

#[derive(Default)]
struct MeshBuilder {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    source: Vec<u32>,
}

impl MeshBuilder {
    fn vertex(&mut self, p: Vec3, n: Vec3) {
        self.positions.push(p);
        self.normals.push(n);
    }

    fn triangle(&mut self, t: [u32; 3], source: u32) {
        self.indices.push(t);
        self.source.push(source);
    }

    fn finish(self, name: &str) -> Tessellation {
        let mesh = TriMesh {
            name: name.into(),
            positions: self.positions,
            indices: self.indices,
            normals: self.normals,
            ..TriMesh::default()
        };
        Tessellation { mesh, source: self.source }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Ray, Shape, WatertightRay};
    use std::collections::HashMap;

    /// Every undirected edge (by vertex position) is used by exactly two triangles, once in
    /// each direction: the surface is closed and consistently wound.
    fn assert_closed(m: &TriMesh) {
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut edges: HashMap<([u32; 3], [u32; 3]), i32> = HashMap::new();
        for t in 0..m.triangle_count() {
            let p = m.triangle(t);
            for k in 0..3 {
                let (a, b) = (key(p[k]), key(p[(k + 1) % 3]));
                *edges.entry(if a < b { (a, b) } else { (b, a) }).or_default() += if a < b { 1 } else { -1 };
            }
        }
        // An edge seen once each way sums to 0.
        assert!(edges.values().all(|&v| v == 0), "an edge is not shared by two oppositely wound triangles");
    }

    fn outward(m: &TriMesh, centre_of: impl Fn(usize, Vec3) -> Vec3) {
        for t in 0..m.triangle_count() {
            let [a, b, c] = m.triangle(t);
            let ng = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            assert!(ng.dot(centroid - centre_of(t, centroid)) > 0.0, "triangle {t} faces inward");
        }
    }

    #[test]
    fn sphere_mesh_is_closed_inscribed_and_outward() {
        let spheres = [Sphere::new(Vec3::new(1.0, -2.0, 0.5), 0.75), Sphere::new(Vec3::ZERO, 3.0)];
        let tess = tessellate_spheres(&spheres, 24);
        assert_eq!(tess.mesh.triangle_count(), 2 * sphere_triangle_count(24));
        assert_eq!(sphere_triangle_count(24), 2 * 24 * 11);
        assert_eq!(tess.source.len(), tess.mesh.triangle_count());
        assert_closed(&tess.mesh);
        let n = sphere_triangle_count(24);
        for (i, p) in tess.mesh.positions.iter().enumerate() {
            let s = &spheres[if i < tess.mesh.positions.len() / 2 { 0 } else { 1 }];
            assert!(((*p - s.center).length() - s.radius).abs() < 1e-5 * s.radius.max(1.0));
        }
        outward(&tess.mesh, |t, _| spheres[tess.source[t] as usize].center);
        assert!(tess.source[..n].iter().all(|&s| s == 0) && tess.source[n..].iter().all(|&s| s == 1));
    }

    #[test]
    fn sphere_mesh_area_converges_to_four_pi_r_squared() {
        // The inscribed mesh's area approaches 4πr² from below; the error falls ~4x per
        // doubling of the segments (second order in the angle).
        let area = |segments| {
            let m = tessellate_spheres(&[Sphere::new(Vec3::ZERO, 2.0)], segments).mesh;
            (0..m.triangle_count())
                .map(|t| {
                    let [a, b, c] = m.triangle(t);
                    0.5 * (b - a).cross(c - a).length() as f64
                })
                .sum::<f64>()
        };
        let exact = 4.0 * std::f64::consts::PI * 4.0;
        let (e16, e32) = (exact - area(16), exact - area(32));
        assert!(e16 > 0.0 && e32 > 0.0, "inscribed mesh must be smaller: {e16} {e32}");
        assert!(e16 / exact < 0.04 && e32 / exact < 0.01, "{e16} {e32}");
        assert!((3.5..4.5).contains(&(e16 / e32)), "ratio {}", e16 / e32);
    }

    #[test]
    fn cylinder_mesh_is_closed_on_the_surface_and_outward() {
        let cyls = [
            Cylinder::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.5),
            Cylinder::new(Vec3::new(1.0, 1.0, 1.0), Vec3::new(-2.0, 3.0, 0.5), 0.25),
        ];
        let tess = tessellate_cylinders(&cyls, 20);
        assert_eq!(tess.mesh.triangle_count(), 2 * cylinder_triangle_count(20));
        assert_closed(&tess.mesh);
        // Every vertex is on the closed surface: on a cap disc or the side.
        for p in &tess.mesh.positions {
            let ok = cyls.iter().any(|c| {
                let a = (c.p1 - c.p0).normalize();
                let z = (*p - c.p0).dot(a);
                let rho = ((*p - c.p0) - z * a).length();
                let h = (c.p1 - c.p0).length();
                let on_side = (rho - c.radius).abs() < 1e-5 && z > -1e-5 && z < h + 1e-5;
                let on_cap = (z.abs() < 1e-5 || (z - h).abs() < 1e-5) && rho <= c.radius + 1e-5;
                on_side || on_cap
            });
            assert!(ok, "{p} is off every cylinder");
        }
        outward(&tess.mesh, |t, centroid| {
            let c = &cyls[tess.source[t] as usize];
            let a = (c.p1 - c.p0).normalize();
            let h = (c.p1 - c.p0).length();
            let z = (centroid - c.p0).dot(a);
            // Outward from the axis point at the centroid's height, pulled inside for caps.
            c.p0 + a * z.clamp(0.01 * h, 0.99 * h)
        });
        assert!(tessellate_cylinders(&[Cylinder::new(Vec3::ZERO, Vec3::ZERO, 1.0)], 8).mesh.indices.is_empty());
    }

    #[test]
    fn rays_hit_the_mesh_where_they_hit_the_shape() {
        // Rays aimed at the centre from outside: the mesh hit is never closer than the sphere's
        // (inscribed mesh) and at most two sagittas farther (the middle of a split quad).
        let s = Sphere::new(Vec3::new(0.3, 0.2, -0.1), 1.5);
        let segments = 32;
        let m = tessellate_spheres(&[s], segments).mesh;
        let sagitta = s.radius * (1.0 - (PI / segments as f32).cos());
        let mut rng = crate::sampler::Rng::new(5, 0);
        for _ in 0..200 {
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = 2.0 * PI * rng.next_f32();
            let r = (1.0 - z * z).sqrt();
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let ray = Ray::new(s.center + 5.0 * dir, -dir);
            let exact = s.intersect(&ray, 0.0, f32::INFINITY).unwrap().t;
            let wt = WatertightRay::new(&ray);
            let t = (0..m.triangle_count())
                .filter_map(|i| {
                    let [a, b, c] = m.triangle(i);
                    wt.intersect(a, b, c, 0.0, f32::INFINITY).map(|h| h.t)
                })
                .fold(f32::INFINITY, f32::min);
            assert!(t >= exact - 1e-4 && t <= exact + 2.0 * sagitta + 1e-4, "t {t} vs sphere {exact}");
        }
    }
}
