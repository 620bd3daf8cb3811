//! Ray by ray: do an accelerator's answers (which shape, at what distance) agree with double
//! precision (the f64 shapes of [`super::analytic`])?
//!
//! f32 arithmetic decides hit or miss correctly only for rays farther from a silhouette,
//! edge or face plane than its rounding error. So each ray is also traced, in double
//! precision, from origins moved by ±δ along two generic directions (δ a few dozen float
//! steps of the scale involved): if the five answers disagree on the shape hit, the ray is
//! ambiguous and only needs a finite answer (so is a ray with a hit within 2δ of its origin,
//! which starts on a surface); otherwise the accelerator must hit the same
//! shape (or miss), `occluded` must agree, and its distance must lie within the range of the
//! five (grazing rays make that range wide, as it should be).

use super::analytic::{Solid, first_hit};
use crate::accel::{Accel, AccelError};
use crate::geometry::Ray;
use glam::DVec3;

/// How far the accelerators' answers agree with the f64 reference ([`compare_with_f64`]).
#[derive(Clone, Debug, Default)]
pub struct AgreementWithF64 {
    pub checked: u64,
    pub ambiguous: u64,
    pub wrong: u64,
    /// Largest distance error outside the allowed range, relative to the distance.
    pub worst_t: f64,
    /// Hits with a non-finite distance or normal.
    pub nonfinite: u64,
    /// A few wrong answers, for the report.
    pub examples: Vec<String>,
    /// Per accelerator: (name, wrong answers, worst distance error).
    pub by_accel: Vec<(&'static str, u64, f64)>,
}

impl AgreementWithF64 {
    pub fn summary(&self) -> String {
        let each: Vec<String> = self.by_accel.iter().map(|(n, w, t)| format!("{n} {w} wrong, {t:.1e}")).collect();
        format!(
            "{} answers checked, {} ambiguous (finite only), {} wrong, worst distance error {:.1e} ({}){}",
            self.checked,
            self.ambiguous,
            self.wrong,
            self.worst_t,
            each.join("; "),
            if self.examples.is_empty() { String::new() } else { format!(", e.g. {}", self.examples.join("; ")) }
        )
    }
}

/// Compares `accels` (geometry i is `solids[i]`) on `rays`; `delta(ray)` is the origin
/// perturbation that covers f32 rounding for that ray.
pub fn compare_with_f64(
    accels: &[&dyn Accel],
    solids: &[Solid],
    rays: &[Ray],
    delta: impl Fn(&Ray) -> f64,
) -> Result<AgreementWithF64, AccelError> {
    let jiggles = [DVec3::new(0.7, 0.5, 0.3).normalize(), DVec3::new(-0.3, 0.8, -0.5).normalize()];
    let mut a = AgreementWithF64 {
        by_accel: accels.iter().map(|x| (x.name(), 0, 0.0)).collect(),
        ..AgreementWithF64::default()
    };
    for ray in rays {
        let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let dl = delta(ray);
        let want = first_hit(solids, o, d).map(|(i, h)| (i, h.t));
        let mut answers = vec![want];
        for j in jiggles {
            for s in [dl, -dl] {
                answers.push(first_hit(solids, o + s * j, d).map(|(i, h)| (i, h.t)));
            }
        }
        let (tlo, thi) =
            answers.iter().flatten().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), h| (lo.min(h.1), hi.max(h.1)));
        // Starting on a surface (a hit within δ of the origin) is ambiguous too: the hit at the
        // origin may be reported or not (Embree's range includes tmin).
        let near = 2.0 * dl / d.length();
        let stable = answers.iter().all(|x| x.map(|h| h.0) == want.map(|h| h.0)) && !(tlo < near);
        for (k, accel) in accels.iter().enumerate() {
            let got = accel.intersect(ray, 0.0, f32::INFINITY)?;
            let occluded = accel.occluded(ray, 0.0, f32::INFINITY)?;
            if got.is_some_and(|h| !(h.t.is_finite() && h.ng.is_finite())) {
                a.nonfinite += 1;
            }
            if !stable || got.is_some_and(|h| (h.t as f64) < near) {
                a.ambiguous += 1;
                continue;
            }
            a.checked += 1;
            let ok = match (got, want) {
                (None, None) => !occluded,
                (Some(h), Some((i, t))) => {
                    let t32 = h.t as f64;
                    let out = if t32 < tlo {
                        tlo - t32
                    } else if t32 > thi {
                        t32 - thi
                    } else {
                        0.0
                    };
                    a.worst_t = a.worst_t.max(out / t.max(1e-30));
                    a.by_accel[k].2 = a.by_accel[k].2.max(out / t.max(1e-30));
                    h.geom as usize == i && occluded
                }
                _ => false,
            };
            if !ok {
                a.wrong += 1;
                a.by_accel[k].1 += 1;
                if a.examples.len() < 2 {
                    a.examples.push(format!(
                        "{} o={} d={}: got {:?}, want {:?}",
                        accel.name(),
                        ray.o,
                        ray.d,
                        got.map(|h| (h.geom, h.t)),
                        want
                    ));
                }
            }
        }
    }
    Ok(a)
}

/// 32 float steps (2⁻²⁴ each) of `scale`.
pub fn float_steps(scale: f64) -> f64 {
    32.0 * scale * (2.0f64).powi(-24)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::NaiveAccel;
    use crate::geometry::{Geometry, Hit, Sphere};
    use glam::Vec3;

    /// The naive loop with every distance 1% long.
    struct Long(NaiveAccel);

    impl Accel for Long {
        fn name(&self) -> &'static str {
            "long"
        }
        fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
            self.0.intersect_deferred(ray, tmin, tmax).map(|h| Hit { t: h.t * 1.01, ..h })
        }
        fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
            self.0.occluded_deferred(ray, tmin, tmax)
        }
        fn deferred_error(&self) -> Result<(), AccelError> {
            Ok(())
        }
    }

    #[test]
    fn right_answers_agree_and_wrong_ones_do_not() {
        let geometry = vec![Geometry::Spheres(vec![Sphere::new(Vec3::new(0.0, 0.0, -5.0), 1.0)].into())];
        let solids = [Solid::Sphere { center: DVec3::new(0.0, 0.0, -5.0), radius: 1.0 }];
        let rays: Vec<Ray> = (0..41).map(|i| Ray::new(Vec3::new(i as f32 * 0.05 - 1.0, 0.3, 0.0), -Vec3::Z)).collect();
        let naive = NaiveAccel::new(&geometry);
        let a = compare_with_f64(&[&naive], &solids, &rays, |_| float_steps(6.0)).unwrap();
        assert_eq!((a.wrong, a.nonfinite), (0, 0), "{}", a.summary());
        assert!(a.checked >= 39 && a.worst_t < 1e-6, "{}", a.summary());
        let long = Long(NaiveAccel::new(&geometry));
        let b = compare_with_f64(&[&long], &solids, &rays, |_| float_steps(6.0)).unwrap();
        assert!(b.worst_t > 0.009, "{}", b.summary());
        // Against the wrong shape: every hit is wrong.
        let elsewhere = [Solid::Sphere { center: DVec3::new(0.0, 0.0, -5.0), radius: 0.5 }];
        let c = compare_with_f64(&[&naive], &elsewhere, &rays, |_| float_steps(6.0)).unwrap();
        assert!(c.wrong > 10, "{}", c.summary());
    }
}
