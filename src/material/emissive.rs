//! A surface that only emits (scene files: `type = "emissive"`): it reflects and transmits
//! nothing, so it needs no BSDF of its own; its light is the material's `emission`.

use super::{Lambert, Lobes, MaterialModel};
use crate::hash::Fingerprint;
use crate::texture::TexCoords;

/// Emits (the material's `emission`) and reflects nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct EmissiveMaterial;

impl MaterialModel for EmissiveMaterial {
    type Bsdf = Lambert;
    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, _at: &TexCoords) -> Lambert {
        Lambert::BLACK
    }
    fn albedo(&self) -> f32 {
        0.0
    }
    fn scatters(&self) -> bool {
        false
    }
    fn lobes(&self) -> Lobes {
        Lobes::default()
    }
    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("emissive");
    }
}
