//! Deterministic scenes generated in memory: bumpy spheres of any triangle count (for the
//! scaling study) and a field of spheres and capped cylinders (user geometry).

use crate::geometry::{Cylinder, Sphere, TriMesh};
use crate::sampler::Rng;
use glam::Vec3;
use std::f32::consts::FRAC_PI_4;

/// Triangles of a blob with `quads_per_edge` × `quads_per_edge` quads per cube face.
pub fn blob_triangles(quads_per_edge: u32) -> usize {
    let n = quads_per_edge as usize;
    12 * n * n
}

/// The quads per cube-face edge of the blob whose triangle count is closest to `target`.
pub fn blob_resolution(target: usize) -> u32 {
    ((target as f64 / 12.0).sqrt().round() as u32).max(1)
}

/// A closed, bumpy sphere of radius about 1 around the origin: a cube with n × n quads per
/// face, n = `quads_per_edge` (12 n² triangles), projected onto the sphere with the
/// equal-angle map and displaced radially by a smooth product of sines (±12%). Seam vertices
/// are repeated per face but computed from identical cube points, so the surface has no
/// cracks; triangles wind counter-clockwise seen from outside.
pub fn blob(quads_per_edge: u32) -> TriMesh {
    let n = quads_per_edge.max(1);
    // (axis, U, V) with U × V = axis: faces wind outward.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    let side = (n + 1) as usize;
    let mut positions = Vec::with_capacity(6 * side * side);
    let mut indices = Vec::with_capacity(blob_triangles(n));
    let coord = |i: u32| (FRAC_PI_4 * (2.0 * i as f32 / n as f32 - 1.0)).tan();
    for (axis, u_axis, v_axis) in faces {
        let first = positions.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let dir = (axis + coord(i) * u_axis + coord(j) * v_axis).normalize();
                positions.push(dir * bump(dir));
            }
        }
        let at = |i: u32, j: u32| first + j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                indices.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                indices.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    TriMesh { name: format!("blob n={n}"), positions, indices, ..TriMesh::default() }
}

fn bump(d: Vec3) -> f32 {
    1.0 + 0.12 * (4.0 * d.x + 1.0).sin() * (5.0 * d.y + 2.0).sin() * (6.0 * d.z + 3.0).sin()
}

/// `spheres` spheres and `cylinders` capped cylinders of assorted sizes and axes, scattered
/// (overlaps allowed) in the cube [-10, 10]³; the same for the same `seed`.
pub fn shape_field(spheres: usize, cylinders: usize, seed: u64) -> (Vec<Sphere>, Vec<Cylinder>) {
    let mut rng = Rng::new(seed, 0x5eed);
    let mut v = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let s = (0..spheres)
        .map(|_| Sphere::new(Vec3::new(v(-10.0, 10.0), v(-10.0, 10.0), v(-10.0, 10.0)), v(0.3, 0.9)))
        .collect();
    let c = (0..cylinders)
        .map(|_| {
            let p0 = Vec3::new(v(-10.0, 10.0), v(-10.0, 10.0), v(-10.0, 10.0));
            let z = v(-1.0, 1.0);
            let phi = v(0.0, std::f32::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let axis = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            Cylinder::new(p0, p0 + axis * v(1.0, 3.0), v(0.1, 0.4))
        })
        .collect();
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blob_counts_and_resolutions() {
        assert_eq!(blob(3).triangle_count(), blob_triangles(3));
        for (target, n, tris) in
            [(1_000, 9, 972), (10_000, 29, 10_092), (100_000, 91, 99_372), (1_000_000, 289, 1_002_252)]
        {
            assert_eq!(blob_resolution(target), n);
            assert_eq!(blob_triangles(n), tris);
        }
    }

    #[test]
    fn blob_is_closed_outward_and_within_its_bump_range() {
        let m = blob(6);
        let mut edges = std::collections::HashMap::<([u32; 3], [u32; 3]), i32>::new();
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut volume = 0.0f64;
        for t in 0..m.triangle_count() {
            let p = m.triangle(t);
            for k in 0..3 {
                let (a, b) = (key(p[k]), key(p[(k + 1) % 3]));
                *edges.entry(if a < b { (a, b) } else { (b, a) }).or_default() += if a < b { 1 } else { -1 };
            }
            volume += p[0].dot(p[1].cross(p[2])) as f64 / 6.0;
        }
        assert!(edges.values().all(|&v| v == 0), "open or inconsistently wound edge");
        // Positive signed volume: the normals point out. Between the balls of radius 0.88^3..1.12^3.
        let unit = 4.0 / 3.0 * std::f64::consts::PI;
        assert!(volume > 0.88f64.powi(3) * unit * 0.9 && volume < 1.12f64.powi(3) * unit, "{volume}");
        assert!(m.positions.iter().all(|p| (0.879..=1.121).contains(&p.length())));
    }

    #[test]
    fn shape_field_is_deterministic() {
        let (a, b) = shape_field(10, 5, 7);
        assert_eq!((a.len(), b.len()), (10, 5));
        assert_eq!(shape_field(10, 5, 7), (a.clone(), b));
        assert_ne!(shape_field(10, 5, 8).0, a);
    }
}
