//! A grid of cubic cells over space: where the passes before a render (caustic guiding,
//! light visibility) bin what they learn by where it was.

use super::Sphere;
use glam::Vec3;

/// Cubic cells `1 / inv_cell` wide, one with a corner at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    origin: Vec3,
    inv_cell: f32,
}

impl Grid {
    /// Cells `1 / per_radius` of `sphere`'s radius wide, one with a corner at its centre.
    pub fn over(sphere: &Sphere, per_radius: f32) -> Grid {
        Grid { origin: sphere.center, inv_cell: per_radius / sphere.radius }
    }

    /// The width of a cell.
    pub fn cell_width(&self) -> f32 {
        1.0 / self.inv_cell
    }

    /// The cell of `p`; `None` far outside the grid (where the cell number would not fit) or
    /// at a point that is not finite.
    #[inline]
    pub fn cell(&self, p: Vec3) -> Option<[i32; 3]> {
        let k = ((p - self.origin) * self.inv_cell).floor();
        (k.abs().max_element() < 1e9).then(|| k.as_ivec3().to_array())
    }
}
