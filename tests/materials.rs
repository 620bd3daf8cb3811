//! Statistical and robustness checks of the BSDFs in `ember::material`.
//!
//! Every estimate uses a fixed seed, so the tests are deterministic; every tolerance is stated
//! next to its assertion, and the Monte Carlo comparisons also assert that their own standard
//! error is small enough for the tolerance to be meaningful (≥ 4σ).
//!
//! Reference estimators deliberately avoid the code under test: they only call `eval`/`pdf`
//! and draw directions themselves (stratified uniform, or an independent cosine + GGX-NDF
//! mixture for narrow lobes), never through `sample`.

use ember::material::{Bsdf, BsdfModel, MIN_COS, PbrBsdf, fresnel_dielectric};
use ember::sampler::Rng;
use glam::{Vec2, Vec3};

use std::f64::consts::PI;

/// Polar angles (degrees) of the outgoing directions used by the furnace tests.
const ANGLES: [f32; 3] = [0.0, 45.0, 80.0];
/// Roughnesses of the consistency tests.
const ROUGHNESSES: [f32; 4] = [0.05, 0.3, 0.6, 1.0];

/// A unit direction at polar angle `theta_deg`, with an azimuth off the axes (so that no
/// estimator benefits from x = 0 or y = 0 symmetries). Negative angles are not needed: pass
/// 180° − θ for the lower hemisphere.
fn dir(theta_deg: f32) -> Vec3 {
    let (s, c) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = 0.7f32.sin_cos();
    Vec3::new(s * cp, s * sp, c)
}

/// The mean of the colour channels, in f64.
fn gray(v: Vec3) -> f64 {
    (v.x as f64 + v.y as f64 + v.z as f64) / 3.0
}

/// Running mean and standard error of independent samples.
#[derive(Default, Clone, Copy)]
struct Stats {
    n: u64,
    sum: f64,
    sum2: f64,
}

impl Stats {
    fn push(&mut self, x: f64) {
        self.n += 1;
        self.sum += x;
        self.sum2 += x * x;
    }

    fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }

    /// Standard error of the mean.
    fn se(&self) -> f64 {
        let n = self.n as f64;
        let var = (self.sum2 / n - self.mean().powi(2)).max(0.0) * n / (n - 1.0);
        (var / n).sqrt()
    }
}

/// What `sample` produces from one `wo`.
struct Sampled {
    /// E[f |cos θi| / pdf] over all lobes (failed samples count as 0).
    albedo: Stats,
    /// The same restricted to non-delta samples (delta samples count as 0).
    non_delta_albedo: Stats,
    /// The probability that a sample is non-delta and succeeds.
    non_delta_probability: Stats,
}

fn sample_many(bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64) -> Sampled {
    let mut rng = Rng::new(seed, 1);
    let mut out = Sampled {
        albedo: Stats::default(),
        non_delta_albedo: Stats::default(),
        non_delta_probability: Stats::default(),
    };
    for _ in 0..n {
        let (u, uc) = (rng.next_2d(), rng.next_f32());
        let (weight, non_delta) = match bsdf.sample(wo, u, uc) {
            Some(s) => (gray(s.f) * s.wi.z.abs() as f64 / s.pdf as f64, !s.delta),
            None => (0.0, false),
        };
        out.albedo.push(weight);
        out.non_delta_albedo.push(if non_delta { weight } else { 0.0 });
        out.non_delta_probability.push(if non_delta { 1.0 } else { 0.0 });
    }
    out
}

/// ∫ g(w) dw over the upper hemisphere (or the whole sphere) by jittered stratified uniform
/// sampling: `replicas` independent runs over a k × k grid in (cos θ, φ), which is
/// area-preserving. The returned Stats hold one value per replica, so their standard error is
/// an honest estimate for the stratified estimator.
fn uniform_integral(g: impl Fn(Vec3) -> f64, k: usize, sphere: bool, seed: u64) -> Stats {
    const REPLICAS: usize = 8;
    let (z_lo, area) = if sphere { (-1.0, 4.0 * PI) } else { (0.0, 2.0 * PI) };
    let mut rng = Rng::new(seed, 2);
    let mut replicas = Stats::default();
    for _ in 0..REPLICAS {
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let u = rng.next_2d();
                let z = z_lo + (1.0 - z_lo) * ((i as f64 + u.x as f64) / k as f64);
                let phi = 2.0 * PI * (j as f64 + u.y as f64) / k as f64;
                let r = (1.0 - z * z).max(0.0).sqrt();
                sum += g(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
            }
        }
        replicas.push(sum * area / (k * k) as f64);
    }
    replicas
}

/// GGX normal distribution D(wm) in f64 (Walter et al. 2007, eq. 33), written independently
/// of the library's version.
fn ggx_d(wm: Vec3, alpha: f64) -> f64 {
    let cos2 = (wm.z as f64).powi(2);
    if cos2 <= 0.0 {
        return 0.0;
    }
    let tan2 = (1.0 - cos2) / cos2;
    let a2 = alpha * alpha;
    a2 / (PI * cos2 * cos2 * (a2 + tan2).powi(2))
}

/// ∫ g(wi) dwi over the upper hemisphere by importance sampling an *independent* mixture:
/// half cosine-weighted, half "GGX normal with density D(wm) cos θm, reflected about wo"
/// (Walter et al. 2007, eqs. 35–36; not the visible-normal sampling used by the library).
/// Needed for narrow lobes, where uniform sampling would need billions of samples.
fn mixture_integral(g: impl Fn(Vec3) -> f64, wo: Vec3, alpha: f64, n: usize, seed: u64) -> Stats {
    let mut rng = Rng::new(seed, 3);
    let mut stats = Stats::default();
    let wo64 = wo.as_dvec3();
    for _ in 0..n {
        let (u, uc) = (rng.next_2d(), rng.next_f32());
        let phi = 2.0 * PI * u.y as f64;
        let wi = if uc < 0.5 {
            let r = (u.x as f64).sqrt();
            glam::DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x as f64).sqrt())
        } else {
            let tan2 = alpha * alpha * u.x as f64 / (1.0 - u.x as f64);
            let cos_m = 1.0 / (1.0 + tan2).sqrt();
            let sin_m = (1.0 - cos_m * cos_m).max(0.0).sqrt();
            let wm = glam::DVec3::new(sin_m * phi.cos(), sin_m * phi.sin(), cos_m);
            2.0 * wo64.dot(wm) * wm - wo64
        };
        if wi.z <= 0.0 {
            stats.push(0.0);
            continue;
        }
        let wm = (wo64 + wi).normalize();
        let ndf_pdf = ggx_d(wm.as_vec3(), alpha) * wm.z / (4.0 * wo64.dot(wm));
        let pdf = 0.5 * wi.z / PI + 0.5 * ndf_pdf;
        stats.push(g(wi.as_vec3()) / pdf);
    }
    stats
}

/// An independent estimate of ∫ h(wi) dwi over the upper hemisphere for a BSDF quantity h:
/// stratified uniform for broad lobes, the cosine + NDF mixture for narrow ones.
fn reference_integral(h: impl Fn(Vec3) -> f64, wo: Vec3, roughness: f32, seed: u64) -> Stats {
    if roughness >= 0.3 {
        uniform_integral(h, 400, false, seed)
    } else {
        mixture_integral(h, wo, (roughness as f64).powi(2).max(1e-3), 1_000_000, seed)
    }
}

/// Asserts |a − b| ≤ rel · |b| and that the combined standard error is ≤ rel/4 · |b|.
fn assert_consistent(what: &str, a: Stats, b: Stats, rel: f64) {
    let (ma, mb) = (a.mean(), b.mean());
    let se = (a.se().powi(2) + b.se().powi(2)).sqrt();
    println!("{what}: {ma:.5} vs {mb:.5} (σ {se:.1e})");
    assert!((ma - mb).abs() <= rel * mb.abs(), "{what}: {ma} vs {mb} (σ {se:.2e})");
    assert!(se <= 0.25 * rel * mb.abs(), "{what}: test too noisy, σ = {se:.2e}");
}

/// glTF's material under a clear coat (`KHR_materials_clearcoat`) of weight `coat`.
fn coated(base: Vec3, metallic: f32, roughness: f32, coat: f32, coat_roughness: f32) -> Bsdf {
    Bsdf::Pbr(PbrBsdf::new(base, metallic, roughness, 1.5, 1.0, Vec3::ONE).with_clearcoat(coat, coat_roughness))
}

/// [`coated`] with the coat's own normal (a coat normal map's), tilted 20° from the shading
/// normal.
fn coat_tilted(base: Vec3, metallic: f32, roughness: f32, coat: f32, coat_roughness: f32) -> Bsdf {
    let (s, c) = 20f32.to_radians().sin_cos();
    let n = Vec3::new(-0.6 * s, 0.8 * s, c);
    Bsdf::Pbr(
        PbrBsdf::new(base, metallic, roughness, 1.5, 1.0, Vec3::ONE)
            .with_clearcoat(coat, coat_roughness)
            .with_coat_normal(n),
    )
}

/// glTF's material with a sheen (`KHR_materials_sheen`) of colour `color`, under no coat.
fn sheened(base: Vec3, metallic: f32, roughness: f32, color: Vec3, sheen_roughness: f32) -> Bsdf {
    Bsdf::Pbr(PbrBsdf::new(base, metallic, roughness, 1.5, 1.0, Vec3::ONE).with_sheen(color, sheen_roughness))
}

fn non_delta_bsdfs(roughness: f32) -> [(String, Bsdf); 7] {
    [
        (format!("conductor r={roughness}"), Bsdf::conductor(Vec3::ONE, roughness)),
        (format!("plastic r={roughness}"), Bsdf::plastic(Vec3::ONE, roughness)),
        (format!("pbr dielectric r={roughness}"), Bsdf::pbr(Vec3::new(0.8, 0.5, 0.2), 0.0, roughness)),
        (format!("pbr metal r={roughness}"), Bsdf::pbr(Vec3::new(0.9, 0.6, 0.3), 1.0, roughness)),
        (format!("pbr half metal r={roughness}"), Bsdf::pbr(Vec3::ONE, 0.5, roughness)),
        (format!("pbr coated r={roughness}"), coated(Vec3::new(0.8, 0.5, 0.2), 0.0, roughness, 0.7, roughness)),
        (
            format!("pbr sheen r={roughness}"),
            sheened(Vec3::new(0.1, 0.2, 0.6), 0.0, roughness, Vec3::new(1.0, 0.9, 0.8), 0.5),
        ),
    ]
}

// ---------------------------------------------------------------------------------------------
// 1. White furnace

#[test]
fn diffuse_white_furnace_is_one() {
    let bsdf = Bsdf::diffuse(Vec3::ONE);
    for (k, theta) in ANGLES.into_iter().enumerate() {
        let a = sample_many(&bsdf, dir(theta), 200_000, 10 + k as u64).albedo;
        println!("diffuse θo={theta}: albedo {:.6}", a.mean());
        assert!((a.mean() - 1.0).abs() < 0.01, "θo={theta}: {}", a.mean()); // 1 %
    }
}

#[test]
fn mirror_conductor_reflects_everything() {
    // Roughness 0 and 0.02 (alpha 4e-4 < 1e-3) are both perfect mirrors.
    for roughness in [0.0, 0.02] {
        let bsdf = Bsdf::conductor(Vec3::ONE, roughness);
        assert!(bsdf.is_delta());
        for (k, theta) in ANGLES.into_iter().enumerate() {
            let wo = dir(theta);
            let a = sample_many(&bsdf, wo, 200_000, 20 + k as u64).albedo;
            println!("mirror r={roughness} θo={theta}: albedo {:.7}", a.mean());
            assert!((a.mean() - 1.0).abs() < 1e-4, "θo={theta}: {}", a.mean());
            let s = bsdf.sample(wo, Vec2::splat(0.5), 0.5).unwrap();
            assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
            assert_eq!(bsdf.eval(wo, s.wi), Vec3::ZERO);
            assert_eq!(bsdf.pdf(wo, s.wi), 0.0);
        }
    }
    // Coloured mirror at normal incidence reflects exactly F0 (Schlick at cos = 1).
    let color = Vec3::new(0.9, 0.5, 0.1);
    let s = Bsdf::conductor(color, 0.0).sample(Vec3::Z, Vec2::ZERO, 0.0).unwrap();
    assert!((s.f * s.wi.z / s.pdf - color).abs().max_element() < 1e-6);
}

#[test]
fn rough_conductor_loses_energy_but_never_gains() {
    // Single-scattering GGX loses the light that scatters more than once between microfacets.
    // Derived value: at normal incidence with alpha = 1, visible normals are cosine-distributed,
    // wi = 2θm off the normal, only θm < 45° stays above the horizon and the weight G2/G1 is
    // cos 2θm / cos²θm; ∫₀^{π/4} (cos 2θ / cos²θ) 2 cos θ sin θ dθ = 1 − ln 2 ≈ 0.3069.
    let derived = 1.0 - std::f64::consts::LN_2;
    // Other lower bounds: the values measured with these seeds (0.991 0.985 0.904 /
    // 0.824 0.797 0.838 / 0.306 0.377 0.669) minus 0.02, a regression guard; the consistency
    // tests below are the real check of these numbers.
    let lower: [[f64; 3]; 3] = [[0.97, 0.965, 0.88], [0.80, 0.77, 0.81], [0.28, 0.35, 0.64]];
    for (r, roughness) in [0.3f32, 0.6, 1.0].into_iter().enumerate() {
        let bsdf = Bsdf::conductor(Vec3::ONE, roughness);
        for (k, theta) in ANGLES.into_iter().enumerate() {
            let a = sample_many(&bsdf, dir(theta), 200_000, 30 + 10 * r as u64 + k as u64);
            let m = a.albedo.mean();
            println!("conductor r={roughness} θo={theta}: albedo {m:.4} ± {:.1e}", a.albedo.se());
            assert!(m <= 1.01, "r={roughness} θo={theta}: {m} creates energy"); // 1 %
            assert!(m >= lower[r][k], "r={roughness} θo={theta}: {m} < {}", lower[r][k]);
            if roughness == 1.0 && theta == 0.0 {
                // 1 % relative; the standard error is ~0.2 %.
                assert!((m - derived).abs() <= 0.01 * derived, "{m} vs 1 − ln 2 = {derived}");
            }
        }
    }
}

#[test]
fn plastic_white_furnace_is_between_half_and_one() {
    for (r, roughness) in [0.0f32, 0.05, 0.3, 0.6, 1.0].into_iter().enumerate() {
        let bsdf = Bsdf::plastic(Vec3::ONE, roughness);
        for (k, theta) in ANGLES.into_iter().enumerate() {
            let a = sample_many(&bsdf, dir(theta), 200_000, 50 + 10 * r as u64 + k as u64);
            let m = a.albedo.mean();
            println!("plastic r={roughness} θo={theta}: albedo {m:.4} ± {:.1e}", a.albedo.se());
            assert!(m <= 1.01, "r={roughness} θo={theta}: {m} creates energy"); // 1 %
            assert!(m > 0.5, "r={roughness} θo={theta}: {m} too dark");
        }
    }
}

#[test]
fn pbr_white_furnace_keeps_the_energy_at_every_metalness_and_roughness() {
    // White base: the metal (Schlick F = 1) and the dielectric layer over its base both
    // reflect all the light, single scattering's loss put back by the multiple-scattering
    // compensation and the base weighted by what the layer leaves (albedo scaling). What is
    // left is the tables' interpolation and quadrature error: 2 %.
    for (r, roughness) in [0.0f32, 0.05, 0.3, 0.6, 1.0].into_iter().enumerate() {
        for (k, metallic) in [0.0f32, 0.5, 1.0].into_iter().enumerate() {
            let bsdf = Bsdf::pbr(Vec3::ONE, metallic, roughness);
            for (j, theta) in ANGLES.into_iter().enumerate() {
                let seed = 500 + 100 * r as u64 + 10 * k as u64 + j as u64;
                let a = sample_many(&bsdf, dir(theta), 100_000, seed).albedo;
                let m = a.mean();
                println!("pbr r={roughness} m={metallic} θo={theta}: albedo {m:.4} ± {:.1e}", a.se());
                assert!((m - 1.0).abs() < 0.02, "r={roughness} m={metallic} θo={theta}: {m}");
            }
        }
    }
    // A black dielectric reflects only its specular layer: exactly F0 = 4 % at normal
    // incidence when smooth; less when rough, where single scattering sends much of the light
    // below the horizon and the compensation gives back only F0 times it (at roughness 1
    // about 1.4 %).
    let black = |roughness: f32| sample_many(&Bsdf::pbr(Vec3::ZERO, 0.0, roughness), Vec3::Z, 100_000, 590);
    assert!((black(0.0).albedo.mean() - 0.04).abs() < 1e-4);
    let (a3, a1) = (black(0.3).albedo.mean(), black(1.0).albedo.mean());
    println!("black pbr: albedo {a3:.4} at roughness 0.3, {a1:.4} at 1");
    assert!(a3 <= 0.0405 && a3 > 0.035 && a1 < a3 && a1 > 0.01, "{a3} {a1}");
}

#[test]
fn a_clear_coat_takes_from_the_layers_under_it_what_it_reflects() {
    // A white base reflects everything; a coat over it reflects its share and leaves the rest
    // to the base: still everything, within the tables' 2 %, for smooth and rough coats over
    // smooth and rough bases, dielectric or metal.
    for (i, (roughness, coat_roughness)) in
        [(0.0f32, 0.0f32), (0.6, 0.0), (0.0, 0.3), (0.5, 0.1), (1.0, 1.0)].into_iter().enumerate()
    {
        for (k, metallic) in [0.0f32, 1.0].into_iter().enumerate() {
            let bsdf = coated(Vec3::ONE, metallic, roughness, 1.0, coat_roughness);
            for (j, theta) in ANGLES.into_iter().enumerate() {
                let a =
                    sample_many(&bsdf, dir(theta), 100_000, 5000 + 100 * i as u64 + 10 * k as u64 + j as u64).albedo;
                println!("coated r={roughness} coat r={coat_roughness} m={metallic} θo={theta}: {:.4}", a.mean());
                assert!(
                    (a.mean() - 1.0).abs() < 0.02,
                    "r={roughness} coat {coat_roughness} m={metallic} θo={theta}: {}",
                    a.mean()
                );
            }
        }
    }
    // Over black, only the coat reflects: its Fresnel, 4 % at normal incidence when smooth,
    // plus the base's own specular layer (4 % of the 96 % the coat lets through).
    let black = sample_many(&coated(Vec3::ZERO, 0.0, 0.0, 1.0, 0.0), Vec3::Z, 100_000, 5900).albedo.mean();
    assert!((black - (0.04 + 0.96 * 0.04)).abs() < 1e-3, "{black}");
    // Weight 0 is no coat at all.
    let (a, b) = (coated(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4, 0.0, 0.1), Bsdf::pbr(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4));
    let (wo, wi) = (dir(30.0), Vec3::new(-0.5, 0.2, 0.8).normalize());
    assert_eq!((a.eval(wo, wi), a.pdf(wo, wi)), (b.eval(wo, wi), b.pdf(wo, wi)));
}

#[test]
fn a_sheen_takes_from_the_layers_under_it_what_it_reflects() {
    // A white sheen over a white base: the base keeps 1 − E_sheen(μo), the sheen reflects
    // E_sheen(μo) — all the light, within the table's interpolation (2 %), at every sheen
    // roughness, over smooth and rough bases, and with a coat over both.
    for (i, sheen_roughness) in [0.0f32, 0.3, 0.7, 1.0].into_iter().enumerate() {
        for (k, roughness) in [0.0f32, 0.5].into_iter().enumerate() {
            let plain = sheened(Vec3::ONE, 0.0, roughness, Vec3::ONE, sheen_roughness);
            let with_coat = Bsdf::Pbr(
                PbrBsdf::new(Vec3::ONE, 0.0, roughness, 1.5, 1.0, Vec3::ONE)
                    .with_sheen(Vec3::ONE, sheen_roughness)
                    .with_clearcoat(1.0, 0.2),
            );
            for (c, bsdf) in [plain, with_coat].iter().enumerate() {
                for (j, theta) in ANGLES.into_iter().enumerate() {
                    let seed = 7000 + 100 * i as u64 + 20 * k as u64 + 10 * c as u64 + j as u64;
                    let a = sample_many(bsdf, dir(theta), 100_000, seed).albedo.mean();
                    println!("sheen r={sheen_roughness} base r={roughness} coat {c} θo={theta}: {a:.4}");
                    assert!(
                        (a - 1.0).abs() < 0.02,
                        "sheen r={sheen_roughness} base r={roughness} coat {c} θo={theta}: {a}"
                    );
                }
            }
        }
    }
    // A black sheen is no sheen.
    let (a, b) =
        (sheened(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4, Vec3::ZERO, 0.5), Bsdf::pbr(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.4));
    let (wo, wi) = (dir(30.0), Vec3::new(-0.5, 0.2, 0.8).normalize());
    assert_eq!((a.eval(wo, wi), a.pdf(wo, wi)), (b.eval(wo, wi), b.pdf(wo, wi)));
}

#[test]
fn plastic_never_creates_energy_even_at_grazing_angles() {
    // A denser sweep than the furnace test, down to 89.4°: energy conservation of the
    // (1 − F)(1 − F) base weighting is checked numerically, not proven. Tolerance 1 %.
    let mut max = (0.0, 0.0, 0.0);
    for roughness in [0.0f32, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0] {
        let bsdf = Bsdf::plastic(Vec3::ONE, roughness);
        for cos_o in [0.003f32, 0.01, 0.03, 0.1, 0.2, 0.4, 0.7] {
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let m = sample_many(&bsdf, wo, 50_000, 70).albedo.mean();
            assert!(m <= 1.01, "r={roughness} cos θo={cos_o}: {m} creates energy");
            if m > max.0 {
                max = (m, roughness, cos_o);
            }
        }
    }
    println!("plastic: max albedo {:.4} at roughness {}, cos θo {}", max.0, max.1, max.2);
}

// ---------------------------------------------------------------------------------------------
// 1b. Consistency of sample() with eval()/pdf() against independent estimators

/// IS estimate (through `sample`) of the non-delta albedo vs an independent estimate of
/// ∫ eval(wo, wi) cos θi dwi. Tolerance 1 %.
fn check_albedo_consistency(name: &str, bsdf: &Bsdf, roughness: f32, seed: u64) {
    for (k, theta) in ANGLES.into_iter().enumerate() {
        let wo = dir(theta);
        let sampled = sample_many(bsdf, wo, 400_000, seed + k as u64).non_delta_albedo;
        let h = |wi: Vec3| gray(bsdf.eval(wo, wi)) * wi.z.abs() as f64;
        let reference = reference_integral(h, wo, roughness, seed + 100 + k as u64);
        assert_consistent(&format!("{name} θo={theta} albedo"), sampled, reference, 0.01);
    }
}

#[test]
fn diffuse_sampling_matches_eval() {
    let bsdf = Bsdf::diffuse(Vec3::new(0.8, 0.5, 0.2));
    check_albedo_consistency("diffuse", &bsdf, 1.0, 200);
}

#[test]
fn smooth_plastic_diffuse_lobe_matches_eval() {
    let bsdf = Bsdf::plastic(Vec3::ONE, 0.0);
    check_albedo_consistency("plastic r=0", &bsdf, 1.0, 300);
}

#[test]
fn rough_sampling_matches_eval() {
    for (r, roughness) in ROUGHNESSES.into_iter().enumerate() {
        for (m, (name, bsdf)) in non_delta_bsdfs(roughness).iter().enumerate() {
            check_albedo_consistency(name, bsdf, roughness, 1000 + 100 * (2 * r + m) as u64);
        }
    }
}

/// ∫ pdf(wo, wi) dwi over the sphere vs the probability that `sample` returns a non-delta
/// direction. Tolerance 1 % (relative).
fn check_pdf_normalisation(name: &str, bsdf: &Bsdf, roughness: f32, seed: u64) {
    for (k, theta) in ANGLES.into_iter().enumerate() {
        let wo = dir(theta);
        let sampled = sample_many(bsdf, wo, 400_000, seed + k as u64).non_delta_probability;
        let pdf = |wi: Vec3| bsdf.pdf(wo, wi) as f64;
        let integral = if roughness >= 0.3 {
            uniform_integral(pdf, 560, true, seed + 100 + k as u64)
        } else {
            // Opaque BSDFs: the lower hemisphere contributes nothing; checked separately.
            let mut rng = Rng::new(seed, 9);
            for _ in 0..1000 {
                let u = rng.next_2d();
                let below = Vec3::new(u.x - 0.5, u.y - 0.5, -0.3).normalize();
                assert_eq!(bsdf.pdf(wo, below), 0.0);
            }
            let alpha = (roughness as f64).powi(2).max(1e-3);
            mixture_integral(pdf, wo, alpha, 1_000_000, seed + 100 + k as u64)
        };
        assert_consistent(&format!("{name} θo={theta} ∫pdf"), integral, sampled, 0.01);
    }
}

#[test]
fn pdf_integrates_to_non_delta_probability() {
    check_pdf_normalisation("diffuse", &Bsdf::diffuse(Vec3::ONE), 1.0, 400);
    let smooth_plastic = Bsdf::plastic(Vec3::new(0.7, 0.2, 0.1), 0.0);
    check_pdf_normalisation("plastic r=0", &smooth_plastic, 1.0, 500);
    for (r, roughness) in ROUGHNESSES.into_iter().enumerate() {
        for (m, (name, bsdf)) in non_delta_bsdfs(roughness).iter().enumerate() {
            check_pdf_normalisation(name, bsdf, roughness, 2000 + 100 * (2 * r + m) as u64);
        }
    }
}

#[test]
fn a_coat_with_its_own_normal_samples_as_it_evaluates() {
    // A coat normal tilted 20° (a coat normal map): sampling matches eval and the pdf, whose
    // integral is at most 1 (coat samples leaving below the coat's plane are lost), over rough
    // and smooth bases, rough coats only (the reference estimators are uniform).
    for (i, (roughness, coat_roughness)) in [(0.3f32, 0.3f32), (0.0, 0.4), (0.8, 0.6)].into_iter().enumerate() {
        let bsdf = coat_tilted(Vec3::new(0.8, 0.5, 0.2), 0.0, roughness, 0.8, coat_roughness);
        let name = format!("pbr tilted coat r={roughness} coat r={coat_roughness}");
        let seed = 9000 + 1000 * i as u64;
        // The coat's lobe reaches below the shading plane: the reference integrates over the
        // whole sphere.
        for (k, theta) in ANGLES.into_iter().enumerate() {
            let wo = dir(theta);
            let sampled = sample_many(&bsdf, wo, 400_000, seed + k as u64).non_delta_albedo;
            let h = |wi: Vec3| gray(bsdf.eval(wo, wi)) * wi.z.abs() as f64;
            let reference = uniform_integral(h, 400, true, seed + 100 + k as u64);
            assert_consistent(&format!("{name} θo={theta} albedo"), sampled, reference, 0.01);
        }
        check_pdf_normalisation(&name, &bsdf, 0.3, seed + 500);
        for theta in ANGLES {
            let p = sample_many(&bsdf, dir(theta), 100_000, seed + 900).non_delta_probability.mean();
            assert!(p <= 1.0, "{name} θo={theta}: {p}");
        }
    }
    // A white base under a white tilted coat still keeps no more than it receives.
    let bsdf = coat_tilted(Vec3::ONE, 0.0, 0.5, 1.0, 0.3);
    for (j, theta) in ANGLES.into_iter().enumerate() {
        let a = sample_many(&bsdf, dir(theta), 100_000, 9900 + j as u64).albedo.mean();
        println!("white under a tilted coat θo={theta}: {a:.4}");
        assert!(a <= 1.02, "θo={theta}: {a}");
    }
}

// ---------------------------------------------------------------------------------------------
// 1c. Dielectric

#[test]
fn fresnel_at_normal_incidence_is_four_percent() {
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-4);
    assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-4);
    assert_eq!(fresnel_dielectric(0.5, 1.0), 0.0);
    // Beyond the critical angle (41.8° for IOR 1.5) from inside: total internal reflection.
    assert_eq!(fresnel_dielectric(-dir(45.0).z, 1.5), 1.0);
}

#[test]
fn dielectric_conserves_energy_and_picks_lobes_by_fresnel() {
    // From outside (θ), and from inside (180° − θ): 45° and 80° are TIR for IOR 1.5,
    // 30°, 45° and 80° for IOR 3 (critical angle 19.5°).
    let thetas = [0.0, 45.0, 80.0, 89.9, 180.0, 150.0, 135.0, 100.0, 170.0];
    for ior in [1.5f32, 3.0] {
        let bsdf = Bsdf::dielectric(ior, Vec3::ONE);
        for (k, theta) in thetas.into_iter().enumerate() {
            let wo = dir(theta);
            let fr = fresnel_dielectric(wo.z, ior) as f64;
            let mut rng = Rng::new(600 + k as u64, ior as u64);
            let (mut energy, mut reflected) = (Stats::default(), Stats::default());
            for _ in 0..200_000 {
                let s = bsdf.sample(wo, rng.next_2d(), rng.next_f32()).expect("glass never fails");
                assert!(s.delta);
                assert!((s.wi.length() - 1.0).abs() < 1e-5);
                energy.push(gray(s.f) * s.wi.z.abs() as f64 / s.pdf as f64);
                let is_reflection = s.wi.z * wo.z > 0.0;
                reflected.push(if is_reflection { 1.0 } else { 0.0 });
            }
            let (e, p) = (energy.mean(), reflected.mean());
            println!("glass ior={ior} θo={theta}: F={fr:.4} P(reflect)={p:.4} energy={e:.6}");
            assert!((e - 1.0).abs() < 1e-3, "ior={ior} θo={theta}: energy {e}");
            // Reflection frequency = F, within 5σ of a binomial proportion.
            let tol = 5.0 * (fr * (1.0 - fr) / 200_000.0).sqrt() + 1e-9;
            assert!((p - fr).abs() <= tol, "ior={ior} θo={theta}: P(reflect) {p} vs F {fr}");
        }
    }
    // TIR from inside at 45° for IOR 1.5.
    assert_eq!(fresnel_dielectric(dir(135.0).z, 1.5), 1.0);
}

#[test]
fn dielectric_tint_scales_transmission_only() {
    let tint = Vec3::new(0.5, 0.25, 1.0);
    let bsdf = Bsdf::dielectric(1.5, tint);
    let wo = dir(30.0);
    let reflect = bsdf.sample(wo, Vec2::ZERO, 0.0).unwrap(); // uc = 0 < F: reflection
    let refract = bsdf.sample(wo, Vec2::ZERO, 0.999).unwrap();
    assert!(reflect.wi.z > 0.0 && refract.wi.z < 0.0);
    let throughput = |s: ember::material::BsdfSample| s.f * s.wi.z.abs() / s.pdf;
    assert!((throughput(reflect) - Vec3::ONE).abs().max_element() < 1e-5);
    assert!((throughput(refract) - tint).abs().max_element() < 1e-5);
}

#[test]
fn dielectric_with_index_one_passes_straight_through() {
    let bsdf = Bsdf::dielectric(1.0, Vec3::ONE);
    let mut rng = Rng::new(700, 0);
    for _ in 0..10_000 {
        let wo = random_unit(&mut rng);
        if wo.z.abs() <= MIN_COS {
            continue; // In the surface plane: sampling fails by design.
        }
        let s = bsdf.sample(wo, rng.next_2d(), rng.next_f32()).unwrap();
        assert!((s.wi + wo).abs().max_element() <= 1e-6, "{wo} → {}", s.wi);
        assert!(s.delta && s.f.is_finite() && s.pdf == 1.0);
    }
}

// ---------------------------------------------------------------------------------------------
// 2. sample() agrees with eval() and pdf()

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn sample_returns_eval_and_pdf() {
    let mut bsdfs = vec![Bsdf::diffuse(Vec3::new(0.8, 0.4, 0.1))];
    for roughness in [0.0f32, 0.05, 0.3, 0.6, 1.0] {
        bsdfs.push(Bsdf::conductor(Vec3::new(0.9, 0.6, 0.3), roughness));
        bsdfs.push(Bsdf::plastic(Vec3::new(0.2, 0.5, 0.9), roughness));
        bsdfs.push(coated(Vec3::new(0.2, 0.5, 0.9), 0.3, roughness, 0.8, 0.1));
        bsdfs.push(coated(Vec3::new(0.2, 0.5, 0.9), 0.0, 0.4, 0.8, roughness));
        bsdfs.push(coat_tilted(Vec3::new(0.2, 0.5, 0.9), 0.0, 0.4, 0.8, roughness));
        bsdfs.push(coat_tilted(Vec3::new(0.2, 0.5, 0.9), 0.3, roughness, 0.8, 0.0));
        bsdfs.push(sheened(Vec3::new(0.2, 0.5, 0.9), 0.0, roughness, Vec3::new(0.9, 0.8, 0.7), 0.4));
    }
    let mut rng = Rng::new(800, 0);
    for bsdf in &bsdfs {
        let mut checked = 0;
        for _ in 0..50_000 {
            let mut wo = random_unit(&mut rng);
            wo.z = wo.z.abs();
            let Some(s) = bsdf.sample(wo, rng.next_2d(), rng.next_f32()) else { continue };
            if s.delta {
                continue;
            }
            let (f, pdf) = (bsdf.eval(wo, s.wi), bsdf.pdf(wo, s.wi));
            let f_ok = (0..3).all(|c| close(s.f[c], f[c], 1e-3));
            assert!(f_ok && close(s.pdf, pdf, 1e-3), "{bsdf:?} wo={wo}: {s:?} vs {f}, {pdf}");
            checked += 1;
        }
        // Conductor mirrors are all-delta; everything else must have been exercised.
        assert!(bsdf.is_delta() || checked > 10_000, "{bsdf:?}: only {checked} samples");
    }
}

#[test]
fn opaque_bsdfs_are_reciprocal() {
    let bsdfs = [
        Bsdf::diffuse(Vec3::ONE),
        Bsdf::conductor(Vec3::new(0.9, 0.6, 0.3), 0.4),
        Bsdf::plastic(Vec3::new(0.2, 0.5, 0.9), 0.4),
        Bsdf::plastic(Vec3::new(0.2, 0.5, 0.9), 0.0),
    ];
    let mut rng = Rng::new(900, 0);
    for bsdf in &bsdfs {
        for _ in 0..10_000 {
            let (mut wo, mut wi) = (random_unit(&mut rng), random_unit(&mut rng));
            (wo.z, wi.z) = (wo.z.abs(), wi.z.abs());
            let (a, b) = (bsdf.eval(wo, wi), bsdf.eval(wi, wo));
            assert!((0..3).all(|c| close(a[c], b[c], 1e-4)), "{bsdf:?}: {a} vs {b}");
        }
    }
}

#[test]
fn flags() {
    let diffuse = Bsdf::diffuse(Vec3::ONE);
    assert!(!diffuse.is_delta() && !diffuse.is_transmissive());
    let mirror = Bsdf::conductor(Vec3::ONE, 0.0);
    assert!(mirror.is_delta() && !mirror.is_transmissive());
    let metal = Bsdf::conductor(Vec3::ONE, 0.5);
    assert!(!metal.is_delta() && !metal.is_transmissive());
    let plastic = Bsdf::plastic(Vec3::ONE, 0.0);
    assert!(!plastic.is_delta() && !plastic.is_transmissive());
    let glass = Bsdf::dielectric(1.5, Vec3::ONE);
    assert!(glass.is_delta() && glass.is_transmissive());
    assert_eq!(glass.eval(Vec3::Z, -Vec3::Z), Vec3::ZERO);
    assert_eq!(glass.pdf(Vec3::Z, -Vec3::Z), 0.0);
}

// ---------------------------------------------------------------------------------------------
// 3. No NaN or infinity, ever

/// A unit vector, uniform on the sphere most of the time, but one time in four with a
/// troublesome cosine (0, ±tiny, ±1, …) to hit the edge cases.
fn random_unit(rng: &mut Rng) -> Vec3 {
    const SPECIAL_Z: [f32; 12] = [0.0, -0.0, 1e-7, -1e-7, 1e-30, -1e-30, 1e-4, -1e-4, 1.0, -1.0, 1e-9, 2e-9];
    let u = rng.next_2d();
    let z = if rng.next_f32() < 0.25 {
        SPECIAL_Z[(rng.next_u32() % SPECIAL_Z.len() as u32) as usize]
    } else {
        1.0 - 2.0 * u.x
    };
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A uniform number in [0, 1), now and then exactly 0 or the largest f32 below 1.
fn random_u(rng: &mut Rng) -> f32 {
    match rng.next_u32() % 16 {
        0 => 0.0,
        1 => 1.0 - f32::EPSILON / 2.0,
        _ => rng.next_f32(),
    }
}

#[test]
fn never_nan_or_inf() {
    let mut bsdfs = vec![
        Bsdf::diffuse(Vec3::ONE),
        Bsdf::diffuse(Vec3::ZERO),
        Bsdf::dielectric(1.0, Vec3::ONE),
        Bsdf::dielectric(1.5, Vec3::new(0.9, 0.5, 0.1)),
        Bsdf::dielectric(3.0, Vec3::ONE),
        Bsdf::dielectric(0.7, Vec3::ONE),
    ];
    for roughness in [0.0f32, 1e-4, 0.0316, 0.05, 0.3, 1.0] {
        bsdfs.push(Bsdf::conductor(Vec3::ONE, roughness));
        bsdfs.push(Bsdf::conductor(Vec3::new(0.9, 0.0, 0.3), roughness));
        bsdfs.push(Bsdf::plastic(Vec3::ONE, roughness));
        bsdfs.push(Bsdf::plastic(Vec3::ZERO, roughness));
        bsdfs.push(coated(Vec3::ONE, 0.5, roughness, 1.0, roughness));
        bsdfs.push(coated(Vec3::ZERO, 1.0, 0.3, 0.5, roughness));
        bsdfs.push(coat_tilted(Vec3::ONE, 0.5, roughness, 1.0, roughness));
        bsdfs.push(sheened(Vec3::ONE, 0.0, 0.3, Vec3::ONE, roughness));
    }
    let mut rng = Rng::new(1000, 0);
    for bsdf in &bsdfs {
        for _ in 0..100_000 {
            let (wo, wi) = (random_unit(&mut rng), random_unit(&mut rng));
            let u = Vec2::new(random_u(&mut rng), random_u(&mut rng));
            let uc = random_u(&mut rng);
            let (f, pdf) = (bsdf.eval(wo, wi), bsdf.pdf(wo, wi));
            assert!(f.is_finite() && f.min_element() >= 0.0, "{bsdf:?} eval({wo}, {wi}) = {f}");
            assert!(pdf.is_finite() && pdf >= 0.0, "{bsdf:?} pdf({wo}, {wi}) = {pdf}");
            if let Some(s) = bsdf.sample(wo, u, uc) {
                let ok = s.wi.is_finite()
                    && (s.wi.length() - 1.0).abs() < 1e-4
                    && s.f.is_finite()
                    && s.pdf.is_finite()
                    && s.pdf > 0.0
                    && (s.f * s.wi.z.abs() / s.pdf).is_finite();
                assert!(ok, "{bsdf:?} sample({wo}, {u}, {uc}) = {s:?}");
            }
        }
    }
}
