//! The look of an 8-bit image: an exposure (a scale of 2^EV on the linear radiance) and a tone
//! curve that maps the scaled radiance into [0, 1] before the sRGB encoding. Only 8-bit output
//! has a look; OpenEXR output stays linear and radiometric (unscaled, no curve), so an EXR can
//! be tone mapped later in any way, and the checkpoint does not depend on the look.
//!
//! The curves:
//!
//! - `clamp`: values above 1 become 1 (what ember always did; the default);
//! - `aces`: Krzysztof Narkowicz's fit of the ACES RRT+ODT, "ACES Filmic Tone Mapping Curve"
//!   (2016): `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`, clamped to [0, 1]. A luminance-only
//!   fit per channel (it saturates bright colours), pre-exposed so that 1 maps to about 0.8;
//!   its output is linear, so the sRGB encoding follows as for the other curves;
//! - `neutral`: the Khronos PBR Neutral tone mapper (Khronos ToneMapping repository,
//!   `PBR_Neutral/README.md`, "PBR Neutral Specification"): base colours between 0.08 and 0.8
//!   lit by unit white come out exactly, minus 0.04 (the Fresnel reflection of a dielectric
//!   facing the camera); brighter colours are compressed towards white without hue shifts.

/// A tone curve (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tonemap {
    /// Values clamped to [0, 1].
    #[default]
    Clamp,
    /// Narkowicz's ACES fit.
    Aces,
    /// Khronos PBR Neutral.
    Neutral,
}

impl Tonemap {
    pub const ALL: [Tonemap; 3] = [Tonemap::Clamp, Tonemap::Aces, Tonemap::Neutral];

    /// The name used on the command line and in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Tonemap::Clamp => "clamp",
            Tonemap::Aces => "aces",
            Tonemap::Neutral => "neutral",
        }
    }

    /// The curve applied to one linear RGB colour (already exposed): each component of the
    /// result is in [0, 1] (NaN stays NaN).
    pub fn apply(self, c: [f32; 3]) -> [f32; 3] {
        match self {
            Tonemap::Clamp => c.map(|x| x.clamp(0.0, 1.0)),
            Tonemap::Aces => c.map(aces),
            Tonemap::Neutral => pbr_neutral(c),
        }
    }
}

crate::choice::named_choice!(Tonemap, "tone curve");

/// The exposures accepted, in stops: 2^±64 covers any radiance scale a scene may use.
pub const MAX_EXPOSURE: f32 = 64.0;

/// Checks an exposure in stops: finite and within ±[`MAX_EXPOSURE`].
pub fn check_exposure(ev: f32) -> Result<f32, String> {
    if ev.is_finite() && ev.abs() <= MAX_EXPOSURE {
        Ok(ev)
    } else {
        Err(format!("exposure must be a number of stops between -{MAX_EXPOSURE} and {MAX_EXPOSURE}, found {ev}"))
    }
}

/// How linear radiance becomes an 8-bit image: exposure, then the tone curve, then sRGB.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Look {
    /// Stops: linear values are multiplied by 2^exposure before the curve.
    pub exposure: f32,
    pub tonemap: Tonemap,
}

impl Look {
    /// The colour shown for linear radiance `c`, linear and in [0, 1] (before sRGB encoding).
    #[inline]
    pub fn display_linear(&self, c: [f32; 3]) -> [f32; 3] {
        // 2^0 = 1 exactly, and x * 1 = x: the default look is bit for bit the plain clamp.
        let scale = self.exposure.exp2();
        self.tonemap.apply(c.map(|x| x * scale))
    }

    /// Whether this is the identity on [0, 1] (no exposure, clamp).
    pub fn is_default(&self) -> bool {
        *self == Look::default()
    }
}

/// Narkowicz's ACES fit (see the module documentation).
#[inline]
pub fn aces(x: f32) -> f32 {
    // Above ~7.24 the fit exceeds 1 and is clamped; bounding the input keeps x² finite.
    let x = x.clamp(0.0, 1e4);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// Khronos PBR Neutral, as its specification writes it (`F90` = 0.04, `Ks` = 0.8 - F90,
/// `Kd` = 0.15).
pub fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const F90: f32 = 0.04;
    const KS: f32 = 0.8 - F90;
    const KD: f32 = 0.15;
    // The specification is for non-negative input; 1e30 keeps products finite (an infinite
    // channel would give inf / inf).
    let c = c.map(|x| if x.is_nan() { x } else { x.clamp(0.0, 1e30) });
    let x = c[0].min(c[1]).min(c[2]);
    let f = if x <= 2.0 * F90 { x - x * x / (4.0 * F90) } else { F90 };
    let p = (c[0] - f).max(c[1] - f).max(c[2] - f);
    if p <= KS {
        return c.map(|v| v - f);
    }
    let pn = 1.0 - (1.0 - KS) * (1.0 - KS) / (p + 1.0 - 2.0 * KS);
    let g = 1.0 / (KD * (p - pn) + 1.0);
    c.map(|v| ((v - f) * (pn / p) * g + pn * (1.0 - g)).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(t: Tonemap, x: f32) -> f32 {
        t.apply([x; 3])[0]
    }

    #[test]
    fn names_parse_and_print() {
        for t in Tonemap::ALL {
            assert_eq!(t.name().parse::<Tonemap>(), Ok(t));
            assert_eq!(t.to_string(), t.name());
        }
        assert_eq!(
            "filmic".parse::<Tonemap>(),
            Err("unknown tone curve \"filmic\" (expected clamp, aces or neutral)".into())
        );
    }

    #[test]
    fn every_curve_maps_black_to_black_rises_and_stays_in_range() {
        for t in Tonemap::ALL {
            assert_eq!(t.apply([0.0; 3]), [0.0; 3], "{t}");
            let mut last = 0.0;
            for i in 1..=20_000 {
                let x = i as f32 * 1e-3; // 0.001 .. 20
                let y = grey(t, x);
                assert!(y >= last, "{t} falls at {x}: {y} < {last}");
                assert!((0.0..=1.0).contains(&y), "{t}({x}) = {y}");
                last = y;
            }
            // Very bright, infinite and negative input (Neutral approaches 1: 1 - 5.8e-8 at 1e6).
            for (x, want) in [(1e6, 1.0), (f32::INFINITY, 1.0), (f32::MAX, 1.0), (-1.0, 0.0)] {
                assert!((grey(t, x) - want).abs() < 1e-7, "{t}({x}) = {}", grey(t, x));
            }
            assert!(grey(t, f32::NAN).is_nan());
        }
    }

    #[test]
    fn clamp_is_the_identity_on_the_unit_interval() {
        for x in [0.0, 1e-6, 0.18, 0.5, 0.999, 1.0] {
            assert_eq!(grey(Tonemap::Clamp, x), x);
        }
        assert_eq!(grey(Tonemap::Clamp, 1.5), 1.0);
    }

    #[test]
    fn aces_fit_reference_points() {
        // Narkowicz: "1 on input maps to ~0.8 on output": 2.54 / 3.16.
        assert!((aces(1.0) - 2.54 / 3.16).abs() < 1e-6, "{}", aces(1.0));
        // Mid grey 0.18: 0.18 (2.51·0.18 + 0.03) / (0.18 (2.43·0.18 + 0.59) + 0.14).
        let mid = 0.18 * (2.51 * 0.18 + 0.03) / (0.18 * (2.43 * 0.18 + 0.59) + 0.14);
        assert!((aces(0.18) - mid).abs() < 1e-6 && (aces(0.18) - 0.2669).abs() < 1e-4, "{}", aces(0.18));
        // Near black the slope is b / e = 0.03 / 0.14.
        assert!((aces(1e-4) / 1e-4 - 0.03 / 0.14).abs() < 1e-2);
        // The fit reaches 1 where 0.08x² - 0.56x - 0.14 = 0, x ≈ 7.24, and is clamped after.
        assert!(aces(7.2) < 1.0 && aces(7.3) == 1.0, "{} {}", aces(7.2), aces(7.3));
    }

    #[test]
    fn neutral_reference_points() {
        // Below 2·F90 the offset is x - x²/0.16; the darkest channel is shifted by it.
        assert!((grey(Tonemap::Neutral, 0.04) - 0.04 * 0.04 / 0.16).abs() < 1e-7);
        // Grey 0.08 ..= 0.8 comes out exactly 0.04 darker (the specification's first note).
        for x in [0.08, 0.18, 0.5, 0.8] {
            assert!((grey(Tonemap::Neutral, x) - (x - 0.04)).abs() < 1e-6, "{x}");
        }
        // Colours too: each component shifted by the same 0.04, no hue change.
        let c = Tonemap::Neutral.apply([0.7, 0.3, 0.1]);
        for (a, b) in c.iter().zip([0.66, 0.26, 0.06]) {
            assert!((a - b).abs() < 1e-6, "{c:?}");
        }
        // Above Ks = 0.76 the peak is compressed: pn = 1 - 0.24² / (p - 0.52). Grey 1.04 has
        // p = 1.0 and, grey staying grey, comes out at pn = 1 - 0.0576 / 0.48 = 0.88.
        assert!((grey(Tonemap::Neutral, 1.04) - 0.88).abs() < 1e-6, "{}", grey(Tonemap::Neutral, 1.04));
        // A saturated bright red keeps its hue and is pulled towards white by g.
        let [r, g, b] = Tonemap::Neutral.apply([4.0, 0.0, 0.0]);
        let pn = 1.0 - 0.0576 / (4.0 - 0.52);
        let gg = 1.0 / (0.15 * (4.0 - pn) + 1.0);
        assert!((r - pn).abs() < 1e-6 && (g - pn * (1.0 - gg)).abs() < 1e-6 && g == b, "{r} {g} {b}");
    }

    #[test]
    fn exposure_plus_one_doubles_linear_values_before_the_curve() {
        for t in Tonemap::ALL {
            for x in [0.01f32, 0.1, 0.3, 0.7, 2.0] {
                let up = Look { exposure: 1.0, tonemap: t }.display_linear([x; 3]);
                let doubled = Look { exposure: 0.0, tonemap: t }.display_linear([2.0 * x; 3]);
                assert_eq!(up, doubled, "{t} at {x}");
                let down = Look { exposure: -2.0, tonemap: t }.display_linear([x; 3]);
                assert_eq!(down, Look { exposure: 0.0, tonemap: t }.display_linear([x / 4.0; 3]), "{t} at {x}");
            }
        }
        // The default look is the plain clamp, bit for bit.
        for x in [0.0f32, 0.123_456_7, 0.5, 1.0, 3.0] {
            assert_eq!(Look::default().display_linear([x; 3]), [x.clamp(0.0, 1.0); 3]);
        }
    }

    #[test]
    fn exposure_is_checked() {
        assert_eq!(check_exposure(1.5), Ok(1.5));
        assert_eq!(check_exposure(-64.0), Ok(-64.0));
        assert!(check_exposure(65.0).unwrap_err().contains("between -64 and 64, found 65"));
        assert!(check_exposure(f32::NAN).is_err());
    }
}
