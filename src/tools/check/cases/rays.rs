//! Rays with zero direction components, queried directly (no render): the six axis
//! directions and the twelve with one zero component, from a grid of origins (some inside
//! the shapes, some exactly in the planes of box faces or through cylinder rims), against a
//! sphere, axis-aligned and oblique cylinders and an axis-aligned box mesh, through Embree
//! and the naive loop. Each answer (shape hit and distance) must match double precision
//! (`versus_f64.rs`); rays on a surface, along a face, through an edge or tangent are ambiguous
//! and only need finite answers.

use super::super::analytic::Solid;
use super::super::scenes::box_mesh;
use super::super::versus_f64::{compare_with_f64, float_steps};
use super::{CaseRun, CheckError, Verdict};
use crate::accel::{Accel, NaiveAccel};
use crate::geometry::{Cylinder, Geometry, Ray, Sphere};
use glam::Vec3;
use std::sync::Arc;

pub fn axis_parallel(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (bmin, bmax) = (Vec3::new(-1.0, -4.5, -1.0), Vec3::new(1.0, -3.5, 1.0));
    let sphere = Sphere::new(Vec3::new(0.25, -0.5, 0.125), 1.5);
    let cylinders = [
        Cylinder::new(Vec3::new(-2.0, 3.0, 0.5), Vec3::new(2.0, 3.0, 0.5), 0.5),
        Cylinder::new(Vec3::new(3.5, -1.0, -2.0), Vec3::new(3.5, -1.0, 2.0), 0.75),
        Cylinder::new(Vec3::new(-3.5, -3.0, -1.0), Vec3::new(-2.0, -3.5, 1.0), 0.4),
    ];
    let mut geometry = vec![Geometry::Mesh(Arc::new(box_mesh(bmin, bmax))), Geometry::Spheres(vec![sphere].into())];
    let mut solids = vec![
        Solid::Box { min: bmin.as_dvec3(), max: bmax.as_dvec3() },
        Solid::Sphere { center: sphere.center.as_dvec3(), radius: 1.5 },
    ];
    for c in cylinders {
        geometry.push(Geometry::Cylinders(vec![c].into()));
        solids.push(Solid::Cylinder { p0: c.p0.as_dvec3(), p1: c.p1.as_dvec3(), radius: c.radius as f64 });
    }
    let embree = run.embree_geometry(&geometry)?;
    let naive = NaiveAccel::new(&geometry);

    let mut dirs: Vec<Vec3> = Vec::new();
    for k in 0..3 {
        dirs.push(Vec3::AXES[k]);
        dirs.push(-Vec3::AXES[k]);
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        for (a, b) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            dirs.push((a * Vec3::AXES[i] + b * Vec3::AXES[j]).normalize());
        }
    }
    let step = run.by_quality(1.0, 0.5);
    let n = (10.0 / step) as i32;
    let mut rays = Vec::new();
    for d in &dirs {
        for ix in 0..=n {
            for iy in 0..=n {
                for iz in 0..=n {
                    rays.push(Ray::new(Vec3::new(ix as f32, iy as f32, iz as f32) * step - Vec3::splat(5.0), *d));
                }
            }
        }
    }
    let a =
        compare_with_f64(&[&embree as &dyn Accel, &naive], &solids, &rays, |r| float_steps(r.o.length() as f64 + 5.0))?;
    run.add_nonfinite(a.nonfinite);
    Ok(Verdict::new(a.worst_t, 1e-5, "max rel |Δt|", a.summary())
        .require(a.wrong == 0, format!("{} wrong hits or misses", a.wrong)))
}
