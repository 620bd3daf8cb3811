//! The TOML scene format (documented in `docs/scene-format.md`). Values are checked while they
//! are read, so a bad value is reported at its own line.

use serde::Deserialize;
use serde::de::{self, Deserializer};
use std::collections::BTreeMap;
use toml::Spanned;

/// A finite number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f32);

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = f64::deserialize(d)?;
        if !v.is_finite() || v.abs() > f32::MAX as f64 {
            return Err(de::Error::custom(format!("{v} is not a finite number")));
        }
        Ok(Num(v as f32))
    }
}

/// Three finite numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3(pub glam::Vec3);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = <Vec<Num>>::deserialize(d)?;
        if v.len() != 3 {
            return Err(de::Error::custom(format!("expected 3 numbers, found {}", v.len())));
        }
        Ok(V3(glam::Vec3::new(v[0].0, v[1].0, v[2].0)))
    }
}

/// The largest magnitude of a coordinate or length a scene may use. Embree refuses (asserts
/// on) rays whose origin or direction has a component beyond ~1.8e18, and ember's shadow rays
/// span the difference of two points; intersection tests square coordinates (1e30 here, far
/// from f32's 3.4e38). A scene a million times larger than the Earth's orbit fits.
pub const MAX_COORDINATE: f32 = 1e15;

/// Refuses a coordinate or length beyond ±[`MAX_COORDINATE`].
fn within_range<E: de::Error>(v: f32, what: &str) -> Result<f32, E> {
    if v.abs() > MAX_COORDINATE {
        return Err(E::custom(format!(
            "{what} must be between -{MAX_COORDINATE:e} and {MAX_COORDINATE:e}, found {v:e}"
        )));
    }
    Ok(v)
}

/// A point (or an offset between points): three finite numbers within ±[`MAX_COORDINATE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point(pub glam::Vec3);

impl<'de> Deserialize<'de> for Point {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let V3(v) = V3::deserialize(d)?;
        for c in v.to_array() {
            within_range::<D::Error>(c, "coordinates")?;
        }
        Ok(Point(v))
    }
}

/// A length: a number > 0 and at most [`MAX_COORDINATE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Length(pub f32);

impl<'de> Deserialize<'de> for Length {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Positive(v) = Positive::deserialize(d)?;
        Ok(Length(within_range::<D::Error>(v, "a length")?))
    }
}

/// A lens radius: 0 (a pinhole) to [`MAX_COORDINATE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture(pub f32);

impl<'de> Deserialize<'de> for Aperture {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Num(v) = Num::deserialize(d)?;
        if v < 0.0 {
            return Err(de::Error::custom(format!("camera aperture must not be negative, found {v}")));
        }
        Ok(Aperture(within_range::<D::Error>(v, "the aperture")?))
    }
}

/// A colour: three finite, non-negative numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rgb(pub glam::Vec3);

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let V3(v) = V3::deserialize(d)?;
        if v.min_element() < 0.0 {
            return Err(de::Error::custom("colour components must not be negative"));
        }
        Ok(Rgb(v))
    }
}

/// A number > 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Positive(pub f32);

impl<'de> Deserialize<'de> for Positive {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Num(v) = Num::deserialize(d)?;
        if v <= 0.0 {
            return Err(de::Error::custom(format!("must be greater than 0, found {v}")));
        }
        Ok(Positive(v))
    }
}

/// A number in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit(pub f32);

impl<'de> Deserialize<'de> for Unit {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Num(v) = Num::deserialize(d)?;
        if !(0.0..=1.0).contains(&v) {
            return Err(de::Error::custom(format!("must be between 0 and 1, found {v}")));
        }
        Ok(Unit(v))
    }
}

/// `rr_depth`: a number of bounces, `"off"` or `"auto"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrDepthValue(pub crate::settings::RrDepth);

impl<'de> Deserialize<'de> for RrDepthValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl de::Visitor<'_> for Visitor {
            type Value = RrDepthValue;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number of bounces, \"off\" or \"auto\"")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RrDepthValue, E> {
                u32::try_from(v)
                    .map(|n| RrDepthValue(crate::settings::RrDepth::After(n)))
                    .map_err(|_| E::custom(format!("expected a number of bounces, \"off\" or \"auto\", found {v}")))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RrDepthValue, E> {
                match v {
                    "off" | "auto" => v.parse().map(RrDepthValue).map_err(E::custom),
                    _ => Err(E::custom(format!("expected a number of bounces, \"off\" or \"auto\", found {v:?}"))),
                }
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// `exposure`: stops, within ±[`crate::film::MAX_EXPOSURE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure(pub f32);

impl<'de> Deserialize<'de> for Exposure {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Num(v) = Num::deserialize(d)?;
        crate::film::check_exposure(v).map(Exposure).map_err(de::Error::custom)
    }
}

/// A setting written as a string and read by its type's `FromStr`, whose error is the
/// message: `tonemap` (`"clamp"`, `"aces"` or `"neutral"`), `filter` (`"box"` or
/// `"gaussian"`), `sampler` (`"sobol"` or `"independent"`), `light_vertices` (`"auto"`,
/// `"on"` or `"off"`), `caustics` (`"auto"` or `"off"`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Named<T>(pub T);

impl<'de, T: std::str::FromStr> Deserialize<'de> for Named<T>
where
    T::Err: std::fmt::Display,
{
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map(Named).map_err(de::Error::custom)
    }
}

/// Largest accepted image side.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// An image side: 1 ..= 16384.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side(pub u32);

impl<'de> Deserialize<'de> for Side {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = i64::deserialize(d)?;
        if v < 1 || v > MAX_IMAGE_SIDE as i64 {
            return Err(de::Error::custom(format!("must be between 1 and {MAX_IMAGE_SIDE}, found {v}")));
        }
        Ok(Side(v as u32))
    }
}

/// A count ≥ 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Count(pub u32);

impl<'de> Deserialize<'de> for Count {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = i64::deserialize(d)?;
        if v < 1 || v > u32::MAX as i64 {
            return Err(de::Error::custom(format!("must be at least 1, found {v}")));
        }
        Ok(Count(v as u32))
    }
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    #[serde(default)]
    pub render: RenderSection,
    pub camera: Option<CameraSection>,
    pub background: Option<Spanned<BackgroundSection>>,
    #[serde(default)]
    pub materials: BTreeMap<String, Spanned<MaterialSection>>,
    #[serde(default)]
    pub meshes: Vec<MeshSection>,
    #[serde(default)]
    pub spheres: Vec<SphereSection>,
    #[serde(default)]
    pub cylinders: Vec<CylinderSection>,
    #[serde(default)]
    pub quads: Vec<QuadSection>,
    #[serde(default)]
    pub lights: Vec<LightSection>,
}

#[derive(Debug, Deserialize, Default, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct RenderSection {
    pub width: Option<Side>,
    pub height: Option<Side>,
    pub spp: Option<Count>,
    pub max_depth: Option<u32>,
    pub rr_depth: Option<RrDepthValue>,
    pub seed: Option<u64>,
    /// Denoise the image with Open Image Denoise (as `--denoise`).
    pub denoise: Option<bool>,
    /// Stops of exposure for 8-bit output.
    pub exposure: Option<Exposure>,
    /// The tone curve of 8-bit output.
    pub tonemap: Option<Named<crate::film::Tonemap>>,
    /// The pixel reconstruction filter.
    pub filter: Option<Named<crate::film::PixelFilter>>,
    pub sampler: Option<Named<crate::settings::SamplerKind>>,
    /// Light vertices: `"auto"`, `"on"` or `"off"` (as `--light-vertices`).
    pub light_vertices: Option<Named<crate::settings::LightVertices>>,
    /// Caustic light paths: `"auto"` or `"off"` (as `--caustics`).
    pub caustics: Option<Named<crate::settings::Caustics>>,
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// `"perspective"` (the default) or `"orthographic"`.
    #[serde(rename = "type")]
    pub kind: Option<Spanned<Named<Projection>>>,
    pub position: Spanned<Point>,
    pub look_at: Point,
    pub up: Option<V3>,
    /// Vertical field of view, degrees (perspective).
    pub fov: Option<Spanned<Positive>>,
    /// Lens radius (0 = pinhole; perspective).
    pub aperture: Option<Spanned<Aperture>>,
    pub focus_distance: Option<Spanned<Length>>,
    /// The view's width in world units (orthographic).
    pub width: Option<Spanned<Length>>,
}

/// A camera's projection (`[camera] type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    Perspective,
    Orthographic,
}

impl std::str::FromStr for Projection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "perspective" => Ok(Projection::Perspective),
            "orthographic" => Ok(Projection::Orthographic),
            _ => Err(format!("unknown camera type {s:?} (expected \"perspective\" or \"orthographic\")")),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum BackgroundSection {
    Constant {
        color: Rgb,
    },
    Gradient {
        zenith: Rgb,
        horizon: Rgb,
        ground: Option<Rgb>,
    },
    /// Not `Spanned`: serde buffers tagged enums, losing spans; errors point at the section.
    Image {
        file: String,
        /// Multiplies the image's radiance; `scale` is its older name.
        #[serde(alias = "scale")]
        strength: Option<Positive>,
        /// Degrees about +Y.
        rotate: Option<Num>,
    },
}

/// Where a material's colour comes from.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ColorSource {
    pub color: Option<Rgb>,
    /// Not `Spanned`: serde's `flatten` cannot carry spans; errors point at the material.
    pub texture: Option<String>,
    pub checker: Option<CheckerSection>,
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct CheckerSection {
    pub a: Rgb,
    pub b: Rgb,
    pub scale: Positive,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialSection {
    Diffuse {
        #[serde(flatten)]
        color: ColorSource,
        emission: Option<Rgb>,
    },
    Metal {
        #[serde(flatten)]
        color: ColorSource,
        roughness: Option<Unit>,
        emission: Option<Rgb>,
    },
    Plastic {
        #[serde(flatten)]
        color: ColorSource,
        roughness: Option<Unit>,
        emission: Option<Rgb>,
    },
    Glass {
        ior: Option<Positive>,
        tint: Option<Rgb>,
        /// With `attenuation_distance`: the colour light keeps after that distance inside.
        attenuation_color: Option<Rgb>,
        attenuation_distance: Option<Positive>,
    },
    Emissive {
        emission: Rgb,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSection {
    pub file: Spanned<String>,
    /// A material of the scene for the file's meshes: see [`Override`].
    pub material: Option<Spanned<String>>,
    /// Which of the file's meshes `material` replaces the material of.
    #[serde(default, rename = "override")]
    pub scope: Override,
    pub scale: Option<Spanned<ScaleSpec>>,
    /// Rotation in degrees about x, then y, then z.
    pub rotate: Option<V3>,
    pub translate: Option<Point>,
    /// Compute smooth vertex normals when the file has none.
    #[serde(default)]
    pub smooth: bool,
}

/// Which meshes of a file a `[[meshes]]` `material` replaces the material of.
#[derive(Debug, Deserialize, Clone, Copy, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Override {
    /// Those whose material in the file has no texture map: a textured asset keeps the look
    /// its author painted, and the rest takes the scene's material.
    #[default]
    Untextured,
    /// Every mesh, textured or not.
    All,
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(untagged)]
pub enum ScaleSpec {
    Uniform(Num),
    PerAxis(V3),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSection {
    pub center: Point,
    pub radius: Length,
    pub material: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSection {
    pub p0: Point,
    pub p1: Point,
    pub radius: Length,
    pub material: Spanned<String>,
}

/// A parallelogram: `corner`, `corner + edge1`, `corner + edge1 + edge2`, `corner + edge2`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadSection {
    pub corner: Point,
    pub edge1: Point,
    pub edge2: Point,
    pub material: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightSection {
    /// Radiant intensity in W/sr per channel.
    Point { position: Point, intensity: Rgb },
}
