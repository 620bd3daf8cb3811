//! Writes `scenes/sky.exr`, the HDR environment of `scenes/gltf-sky.toml`: a procedural clear
//! sky with a sun, equirectangular (ember's mapping: the image's centre is −Z, its top row
//! +Y), 1024×512, linear RGB half floats, ZIP compressed. Deterministic: running it again writes
//! the same bytes.
//!
//!     cargo run --release --example make_sky -- scenes/sky.exr
//!
//! The model is made up, not measured — plausible colours and a sun bright enough to cast
//! shadows, in ember's relative radiance units:
//! - sky: a blue zenith (0.10, 0.22, 0.55) blending to a pale horizon (0.65, 0.74, 0.88) as
//!   (1 − elevation's sine)³, plus a glow around the sun, e^(−γ/0.1) + 0.25 e^(−γ/0.6) times the
//!   sun's colour (γ the angle from the sun, radians);
//! - ground below the horizon: (0.20, 0.18, 0.15), hazing into the horizon colour within a few
//!   degrees;
//! - sun: a disc of angular radius 0.75° (a real sun's is 0.27°; 4.3 texels across here),
//!   elevation 35°, azimuth 0 at −X (the image's left quarter), radiance 9,000 × (1, 0.93, 0.82)
//!   with limb darkening (mean 0.8 over the disc), so its irradiance (luminance) at normal
//!   incidence is about 3.6, and 2.1 on the ground, against 1.0 from the sky: two thirds of the
//!   light on the ground, half of the sky's luminance over the sphere (checked by integrating
//!   this model numerically at 4096×2048);
//! - each texel is the average of 4 × 4 directions within it (the sun's edge antialiased).

use exr::prelude::*;
use std::f64::consts::PI;

const WIDTH: usize = 1024;
const HEIGHT: usize = 512;
const SUN_ELEVATION: f64 = 35.0;
const SUN_RADIUS: f64 = 0.75;
const SUN_RADIANCE: f64 = 9000.0;
const SUN_COLOUR: [f64; 3] = [1.0, 0.93, 0.82];

type Rgb = [f64; 3];

fn mix(a: Rgb, b: Rgb, t: f64) -> Rgb {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

/// Unit direction of image position (u, v) in [0, 1]² (v = 0 the top row): θ = πv from +Y,
/// φ = 2π(u − ½), d = (sin θ sin φ, cos θ, −sin θ cos φ).
fn direction(u: f64, v: f64) -> [f64; 3] {
    let (theta, phi) = (PI * v, 2.0 * PI * (u - 0.5));
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

fn radiance(d: [f64; 3], sun: [f64; 3]) -> Rgb {
    let cos_gamma = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2]).clamp(-1.0, 1.0);
    let gamma = cos_gamma.acos();
    let horizon = [0.65, 0.74, 0.88];
    let mut c = if d[1] >= 0.0 {
        let sky = mix([0.10, 0.22, 0.55], horizon, (1.0 - d[1]).powi(3));
        let glow = (-gamma / 0.1).exp() + 0.25 * (-gamma / 0.6).exp();
        [sky[0] + glow * SUN_COLOUR[0], sky[1] + glow * SUN_COLOUR[1], sky[2] + glow * SUN_COLOUR[2]]
    } else {
        mix(horizon, [0.20, 0.18, 0.15], 1.0 - (d[1] * 12.0).exp())
    };
    let r = SUN_RADIUS.to_radians();
    if gamma < r {
        // Limb darkening: 1 − 0.6 (1 − μ), μ the cosine across the disc.
        let mu = (1.0 - (gamma / r).powi(2)).sqrt();
        let l = SUN_RADIANCE * (1.0 - 0.6 * (1.0 - mu));
        c = [l * SUN_COLOUR[0], l * SUN_COLOUR[1], l * SUN_COLOUR[2]];
    }
    c
}

fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| "scenes/sky.exr".to_string());
    let e = SUN_ELEVATION.to_radians();
    // Azimuth 0: toward −X, i.e. u = ¼ (φ = −π/2).
    let sun = [-e.cos(), e.sin(), 0.0];
    let n = 4;
    let mut pixels = vec![[0.0f32; 3]; WIDTH * HEIGHT];
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let mut sum = [0.0f64; 3];
            for j in 0..n {
                for i in 0..n {
                    let u = (x as f64 + (i as f64 + 0.5) / n as f64) / WIDTH as f64;
                    let v = (y as f64 + (j as f64 + 0.5) / n as f64) / HEIGHT as f64;
                    let c = radiance(direction(u, v), sun);
                    for k in 0..3 {
                        sum[k] += c[k] / (n * n) as f64;
                    }
                }
            }
            pixels[y * WIDTH + x] = [sum[0] as f32, sum[1] as f32, sum[2] as f32];
        }
    }
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p: [f32; 3] = pixels[y * WIDTH + x];
        (f16::from_f32(p[0]), f16::from_f32(p[1]), f16::from_f32(p[2]))
    });
    let layer = Layer::new((WIDTH, HEIGHT), LayerAttributes::named("sky"), Encoding::SMALL_LOSSLESS, channels);
    Image::from_layer(layer).write().non_parallel().to_file(&out).unwrap_or_else(|e| panic!("{out}: {e}"));
    eprintln!("wrote {out}: {WIDTH}x{HEIGHT}, sun at elevation {SUN_ELEVATION}°, radius {SUN_RADIUS}°");
}
