//! Roughness exactly 0 and exactly 1 for metal (white, F0 = 1) and plastic (white base), each
//! a sphere alone under a uniform sky of 1, rendered with the default estimator (NEE + MIS).
//!
//! - Metal at roughness 0 is a perfect mirror reflecting everything: every pixel exactly 1.
//! - The others may lose energy but never gain it: over 8 seeds, every pixel's mean must be
//!   at most 1 + 4 standard errors + 1%.
//! - Metal at roughness 1, seen head-on, reflects 1 − ln 2 ≈ 0.3069 (the single-scattering
//!   albedo of GGX with α = 1 at normal incidence, see `src/material/conductor.rs`): the
//!   centre pixel must hold that within 4 standard errors + 1%.

use super::super::stage::Stage;
use super::{CheckError, Lab, Verdict, worst_abs};
use crate::integrator::RenderSettings;
use crate::light::Background;
use crate::scene::{MaterialKind, Scene};
use crate::texture::Texture;
use glam::Vec3;

fn sphere(kind: MaterialKind) -> Scene {
    let mut st = Stage::new("roughness");
    let m = st.material(kind, Vec3::ZERO);
    st.sphere(Vec3::new(0.1, -0.2, 0.3), 1.0, m);
    st.background(Background::Constant(Vec3::ONE));
    st.camera(Vec3::new(0.1, -0.2, 4.3), Vec3::new(0.1, -0.2, 0.3), Vec3::Y, 35.0);
    st.build()
}

pub fn run(lab: &Lab) -> Result<Verdict, CheckError> {
    let white = || Texture::Constant(Vec3::ONE);
    let (w, h, spp, seeds) = lab.pick((25, 25, 8, 4), (45, 45, 16, 8));
    let s = RenderSettings { max_depth: 2, ..lab.settings(w, h, spp) };
    let mirror = lab.render(&sphere(MaterialKind::Metal { color: white(), roughness: 0.0 }), &s)?;
    let mirror_err = worst_abs(&mirror, 1.0);
    let mut v = Verdict::new(mirror_err, 1e-4, "max |px − 1|", "metal r=0: every pixel 1");
    let bounded = [
        ("metal r=1", MaterialKind::Metal { color: white(), roughness: 1.0 }),
        ("plastic r=0", MaterialKind::Plastic { color: white(), roughness: 0.0 }),
        ("plastic r=1", MaterialKind::Plastic { color: white(), roughness: 1.0 }),
    ];
    for (i, (name, kind)) in bounded.into_iter().enumerate() {
        let (mean, se) = lab.render_seeds(&sphere(kind), &s, seeds)?;
        let (mut worst, mut at) = (f64::NEG_INFINITY, 0);
        for (k, p) in mean.pixels.iter().enumerate() {
            let excess = (super::super::pixel::grey(*p) - 1.0) / (4.0 * se[k] + 0.01);
            if excess > worst {
                (worst, at) = (excess, k);
            }
        }
        v.detail.push_str(&format!("; {name}: max (px − 1)/(4SE + 1%) = {worst:.2}"));
        v = v.require(
            worst <= 1.0,
            format!("{name} gains energy: pixel {at} = {:.4}", super::super::pixel::grey(mean.pixels[at])),
        );
        if i == 0 {
            let c = (h / 2 * w + w / 2) as usize;
            let (got, want) = (super::super::pixel::grey(mean.pixels[c]), 1.0 - std::f64::consts::LN_2);
            v.detail.push_str(&format!(", centre {got:.4} (1 − ln 2 = {want:.4})"));
            v = v.require(
                (got - want).abs() <= 4.0 * se[c] + 0.01 * want,
                format!("metal r=1 head-on reflects {got:.4}, want 1 − ln 2 = {want:.4}"),
            );
        }
    }
    Ok(v)
}
