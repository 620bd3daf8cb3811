//! Reference answers in double precision: ray/shape intersections and the direct light of a
//! point light on diffuse surfaces, computed independently of the renderer's f32 code.

use glam::DVec3;

/// A shape as the reference sees it.
#[derive(Clone, Copy, Debug)]
pub enum Solid {
    /// Parallelogram `corner + a·e1 + b·e2`, a, b in [0, 1].
    Quad {
        corner: DVec3,
        e1: DVec3,
        e2: DVec3,
    },
    Sphere {
        center: DVec3,
        radius: f64,
    },
    /// Capped cylinder around the axis p0 → p1.
    Cylinder {
        p0: DVec3,
        p1: DVec3,
        radius: f64,
    },
    /// Axis-aligned box.
    Box {
        min: DVec3,
        max: DVec3,
    },
}

/// A reference hit.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceHit {
    /// Distance along the ray, in units of its direction's length (as [`crate::geometry::Hit`]'s).
    pub t: f64,
    pub point: DVec3,
    /// Unit outward normal.
    pub normal: DVec3,
}

impl Solid {
    /// The closest hit of the ray `origin + t · direction` with t > tmin.
    pub fn hit(&self, origin: DVec3, direction: DVec3, tmin: f64) -> Option<ReferenceHit> {
        let (o, d) = (origin, direction);
        let best = |ts: &mut Vec<(f64, DVec3)>| -> Option<ReferenceHit> {
            ts.retain(|(t, _)| *t > tmin && t.is_finite());
            ts.sort_by(|a, b| a.0.total_cmp(&b.0));
            ts.first().map(|&(t, normal)| ReferenceHit { t, point: o + t * d, normal })
        };
        match *self {
            Solid::Quad { corner, e1, e2 } => {
                let n = e1.cross(e2);
                let denom = d.dot(n);
                if denom == 0.0 {
                    return None;
                }
                let t = (corner - o).dot(n) / denom;
                let q = o + t * d - corner;
                // Coordinates along e1, e2 from the dual basis.
                let a = q.dot(e2.cross(n)) / e1.dot(e2.cross(n));
                let b = q.dot(e1.cross(n)) / e2.dot(e1.cross(n));
                if !(0.0..=1.0).contains(&a) || !(0.0..=1.0).contains(&b) {
                    return None;
                }
                best(&mut vec![(t, n.normalize())])
            }
            Solid::Sphere { center, radius } => {
                let f = o - center;
                let a = d.length_squared();
                let b = f.dot(d);
                let c = f.length_squared() - radius * radius;
                let disc = b * b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let mut ts: Vec<(f64, DVec3)> =
                    [(-b - s) / a, (-b + s) / a].into_iter().map(|t| (t, ((o + t * d) - center) / radius)).collect();
                best(&mut ts)
            }
            Solid::Cylinder { p0, p1, radius } => {
                let h = (p1 - p0).length();
                let ax = (p1 - p0) / h;
                let f = o - p0;
                let (oz, dz) = (f.dot(ax), d.dot(ax));
                let (fp, dp) = (f - oz * ax, d - dz * ax);
                let mut ts = Vec::new();
                let a = dp.length_squared();
                if a > 0.0 {
                    let b = fp.dot(dp);
                    let c = fp.length_squared() - radius * radius;
                    let disc = b * b - a * c;
                    if disc >= 0.0 {
                        for t in [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a] {
                            let z = oz + t * dz;
                            if (0.0..=h).contains(&z) {
                                ts.push((t, (fp + t * dp) / radius));
                            }
                        }
                    }
                }
                if dz != 0.0 {
                    for (z, n) in [(0.0, -ax), (h, ax)] {
                        let t = (z - oz) / dz;
                        if (fp + t * dp).length_squared() <= radius * radius {
                            ts.push((t, n));
                        }
                    }
                }
                best(&mut ts)
            }
            Solid::Box { min, max } => {
                // Slabs, with zero direction components handled explicitly.
                let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
                let (mut n0, mut n1) = (DVec3::ZERO, DVec3::ZERO);
                for i in 0..3 {
                    let e = DVec3::AXES[i];
                    if d[i] == 0.0 {
                        if o[i] < min[i] || o[i] > max[i] {
                            return None;
                        }
                        continue;
                    }
                    let (mut a, mut b) = ((min[i] - o[i]) / d[i], (max[i] - o[i]) / d[i]);
                    let (mut na, mut nb) = (-e, e);
                    if a > b {
                        std::mem::swap(&mut a, &mut b);
                        std::mem::swap(&mut na, &mut nb);
                    }
                    if a > t0 {
                        t0 = a;
                        n0 = na;
                    }
                    if b < t1 {
                        t1 = b;
                        n1 = nb;
                    }
                }
                if t0 > t1 {
                    return None;
                }
                best(&mut vec![(t0, n0), (t1, n1)])
            }
        }
    }
}

/// The closest hit among `solids` of the ray `origin + t · direction`, t > 0: (index, hit).
pub fn first_hit(solids: &[Solid], origin: DVec3, direction: DVec3) -> Option<(usize, ReferenceHit)> {
    solids
        .iter()
        .enumerate()
        .filter_map(|(i, s)| s.hit(origin, direction, 0.0).map(|h| (i, h)))
        .min_by(|a, b| a.1.t.total_cmp(&b.1.t))
}

/// Whether the segment from `start` (on solid `from`) to `end` is blocked by another solid.
pub fn blocked(solids: &[Solid], from: usize, start: DVec3, end: DVec3) -> bool {
    let d = end - start;
    solids.iter().enumerate().any(|(i, s)| i != from && s.hit(start, d, 0.0).is_some_and(|h| h.t < 1.0))
}

/// Radiance leaving a diffuse `point` (with `normal`, seen from `eye`) lit by a point light
/// of intensity `intensity` at `light`: albedo/π · I cosθ / r² when the light is on the side
/// the point is seen from, else 0 (visibility is the caller's).
pub fn diffuse_point_light(albedo: f64, point: DVec3, normal: DVec3, eye: DVec3, light: DVec3, intensity: f64) -> f64 {
    let n = if normal.dot(eye - point) < 0.0 { -normal } else { normal };
    let l = light - point;
    let r2 = l.length_squared();
    let cos = n.dot(l) / r2.sqrt();
    if cos <= 0.0 { 0.0 } else { albedo / std::f64::consts::PI * intensity * cos / r2 }
}
