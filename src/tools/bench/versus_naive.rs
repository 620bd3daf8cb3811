//! Checking a strategy's answers against the naive loop's on the same queries.
//!
//! Closest hits agree when both miss, or both hit at the same `t` (1e-5 relative, on the scale
//! of `t` or of the origin's distance, as in tests/embree_vs_naive.rs); the same `t` on a
//! different primitive is a tie (a shared edge or coincident surfaces), not a mismatch. Any
//! other difference is a mismatch; a mismatch is put down to an edge when the hit that one
//! side found lies within 1e-4 (barycentric) of its triangle's edge, or grazes a sphere or
//! cylinder (|cos| < 1e-3 between ray and normal), where the two tests may legitimately differ.

use super::measure::Answer;
use super::rays::Query;
use crate::accel::{Accel, AccelError};
use crate::geometry::{Geometry, Hit, Ray, WatertightRay};

/// How far a strategy's answers agree with the naive loop's ([`compare_with_naive`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AgreementWithNaive {
    pub checked: usize,
    pub mismatches: usize,
    /// Mismatches at a triangle edge or a grazing hit.
    pub at_edges: usize,
    /// Same `t`, different primitive.
    pub ties: usize,
    /// Descriptions of the first few mismatches.
    pub examples: Vec<String>,
}

const EXAMPLES: usize = 3;

/// Compares `candidate`'s answers with the reference ones on `queries`. For an occlusion
/// mismatch, the blocker is found by a closest-hit query on the accelerator that reported it,
/// to tell whether it is an edge case.
pub fn compare_with_naive(
    geometry: &[Geometry],
    queries: &[Query],
    reference: &[Answer],
    reference_accel: &dyn Accel,
    candidate: &[Answer],
    candidate_accel: &dyn Accel,
) -> Result<AgreementWithNaive, AccelError> {
    let mut a =
        AgreementWithNaive { checked: queries.len().min(reference.len()).min(candidate.len()), ..Default::default() };
    for ((q, r), c) in queries.iter().zip(reference).zip(candidate) {
        let (edge, what) = match (r, c) {
            (Answer::Closest(None), Answer::Closest(None)) => continue,
            (Answer::Closest(Some(h)), Answer::Closest(Some(k))) => {
                if close(&q.ray, h.t, k.t) {
                    if (h.geom, h.prim) != (k.geom, k.prim) {
                        a.ties += 1;
                    }
                    continue;
                }
                (at_edge(geometry, &q.ray, h) || at_edge(geometry, &q.ray, k), format!("t {} vs {}", h.t, k.t))
            }
            (Answer::Closest(h), Answer::Closest(k)) => {
                let found = h.or(*k).expect("one side hit");
                (at_edge(geometry, &q.ray, &found), format!("{} vs {}", describe(h), describe(k)))
            }
            (Answer::Occluded(x), Answer::Occluded(y)) => {
                if x == y {
                    continue;
                }
                let by = if *x { reference_accel } else { candidate_accel };
                let edge = match by.intersect(&q.ray, 0.0, q.tmax)? {
                    Some(h) => at_edge(geometry, &q.ray, &h),
                    None => true, // occluded yet no closest hit: the two queries disagree at a boundary
                };
                (edge, format!("occluded {x} vs {y}"))
            }
            _ => panic!("answers of different kinds compared"),
        };
        a.mismatches += 1;
        a.at_edges += edge as usize;
        if a.examples.len() < EXAMPLES {
            let r = &q.ray;
            a.examples.push(format!(
                "ray o=({:.6}, {:.6}, {:.6}) d=({:.6}, {:.6}, {:.6}) tmax={}: naive {what}{}",
                r.o.x,
                r.o.y,
                r.o.z,
                r.d.x,
                r.d.y,
                r.d.z,
                q.tmax,
                if edge { " (at an edge)" } else { "" }
            ));
        }
    }
    Ok(a)
}

fn describe(h: &Option<Hit>) -> String {
    match h {
        Some(h) => format!("hit t={} geom {} prim {}", h.t, h.geom, h.prim),
        None => "miss".into(),
    }
}

fn close(ray: &Ray, a: f32, b: f32) -> bool {
    let scale = a.abs().max(b.abs()).max(ray.o.length() / ray.d.length());
    (a - b).abs() <= 1e-5 * scale
}

fn at_edge(geometry: &[Geometry], ray: &Ray, hit: &Hit) -> bool {
    match geometry.get(hit.geom as usize) {
        Some(g @ (Geometry::Mesh(_) | Geometry::Instance(_))) if (hit.prim as usize) < g.len() => {
            // In the mesh's own space, where a placed mesh's hit is.
            let (m, ray) = match g {
                Geometry::Instance(i) => (&i.mesh, i.ray_to_object(ray)),
                _ => (g.mesh().expect("a mesh"), *ray),
            };
            let [a, b, c] = m.triangle(hit.prim as usize);
            match WatertightRay::new(&ray).intersect(a, b, c, 0.0, f32::INFINITY) {
                Some(t) => t.u < 1e-4 || t.v < 1e-4 || 1.0 - t.u - t.v < 1e-4,
                None => true, // missed by the watertight test: it slipped past an edge
            }
        }
        Some(_) => {
            let cos = hit.ng.normalize_or_zero().dot(ray.d.normalize_or_zero());
            cos.abs() < 1e-3
        }
        None => false,
    }
}
