//! Which light groups a shading point can see: the choice by importance
//! ([`super::choice`]), weighed by how often each group's light samples got through
//! near that point.
//!
//! The importance of a light at a point ignores occlusion. In a room lit through a window by
//! the sky and the sun, the sky's importance is that of the whole hemisphere, but from inside
//! the room almost every sky sample hits a wall: next-event estimation spends a third of its
//! shadow rays where no light comes from. A short pass of paths from the camera
//! (`crate::integrator`'s `visibility`) traces light samples from their vertices and counts,
//! cell by cell of a grid (and by the side a surface faces), how many of each group's got
//! through. The choice then weighs group g by its importance × V_g, the share that got
//! through, never below [`FLOOR`]: every light that can bring light keeps a share of the
//! samples, so the estimate stays unbiased whatever the counts were, and only its noise
//! depends on them. Cells with few samples of a group leave it at 1.

use super::choice::LOCAL_CHOICE_MAX;
use crate::geometry::Grid;
use glam::Vec3;
use rustc_hash::FxHashMap;

/// The lowest weight a group's visibility gives it.
pub const FLOOR: f32 = 0.1;

/// Light samples of a group a cell needs before its count is trusted.
pub const FEWEST: u32 = 16;

/// A cell of the grid and the side of the surface: the axis its normal is closest to and
/// that axis's sign (0–5), or 6 for no side (glass, lit from both).
pub type CellKey = [i32; 4];

/// Per cell, how many light samples of each group were traced and how many got through.
pub type Counts = [[u32; 2]; LOCAL_CHOICE_MAX];

/// No samples yet.
pub const NO_COUNTS: Counts = [[0; 2]; LOCAL_CHOICE_MAX];

/// The visibility weights of the light groups, cell by cell.
#[derive(Clone, Debug)]
pub struct Visibility {
    grid: Grid,
    cells: FxHashMap<CellKey, [f32; LOCAL_CHOICE_MAX]>,
}

/// The cell of `p` in `grid` on the side `n` faces; `None` where [`Grid::cell`] has none.
#[inline]
pub fn key(grid: &Grid, p: Vec3, n: Vec3) -> Option<CellKey> {
    let [x, y, z] = grid.cell(p)?;
    let side = if n == Vec3::ZERO || !n.is_finite() {
        6
    } else {
        let a = n.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        2 * axis + (n[axis as usize] < 0.0) as i32
    };
    Some([x, y, z, side])
}

impl Visibility {
    /// The weights of `counts`, cell by cell. A group's share of samples
    /// that got through in a cell, (through + ½) / (traced + ½), is trusted where it had
    /// [`FEWEST`] samples; its weight is the largest share among the cell and its 26
    /// neighbours on the same side, at least [`FLOOR`], or 1 where none has a trusted share. A
    /// light is weighed down only where it is blocked all around: at the edge of a shadow,
    /// where a cell's points see it or not, a visible light keeps its share. `None` if no cell
    /// weighs any group below 1.
    pub fn of(grid: Grid, counts: impl IntoIterator<Item = (CellKey, Counts)>) -> Option<Visibility> {
        let shares: FxHashMap<CellKey, [Option<f32>; LOCAL_CHOICE_MAX]> = counts
            .into_iter()
            .map(|(key, c)| {
                let mut share = [None; LOCAL_CHOICE_MAX];
                for (s, [traced, through]) in share.iter_mut().zip(c) {
                    if traced >= FEWEST {
                        *s = Some((through as f32 + 0.5) / (traced as f32 + 0.5));
                    }
                }
                (key, share)
            })
            .collect();
        let mut cells = FxHashMap::default();
        for &[x, y, z, side] in shares.keys() {
            let mut most = [None::<f32>; LOCAL_CHOICE_MAX];
            for (dx, dy, dz) in (-1..=1).flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |c| (a, b, c)))) {
                if let Some(share) = shares.get(&[x + dx, y + dy, z + dz, side]) {
                    for (m, s) in most.iter_mut().zip(share) {
                        *m = match (*m, *s) {
                            (Some(a), Some(b)) => Some(a.max(b)),
                            (a, b) => a.or(b),
                        };
                    }
                }
            }
            let w = most.map(|m| m.map_or(1.0, |m| m.max(FLOOR)));
            if w.iter().any(|&w| w < 1.0) {
                cells.insert([x, y, z, side], w);
            }
        }
        (!cells.is_empty()).then_some(Visibility { grid, cells })
    }

    /// The weights at `p` on the side `n` faces, if its cell has any.
    #[inline]
    pub fn at(&self, p: Vec3, n: Vec3) -> Option<&[f32; LOCAL_CHOICE_MAX]> {
        self.cells.get(&key(&self.grid, p, n)?)
    }

    /// How many cells weigh some group below 1.
    pub fn cells(&self) -> usize {
        self.cells.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cells 0.1 wide.
    fn grid() -> Grid {
        Grid::over(&crate::geometry::Sphere::new(Vec3::ZERO, 1.0), 10.0)
    }

    #[test]
    fn a_key_is_the_cell_and_the_side_the_normal_faces() {
        let p = Vec3::new(0.05, 0.15, -0.05);
        assert_eq!(key(&grid(), p, Vec3::Y), Some([0, 1, -1, 2]));
        assert_eq!(key(&grid(), p, -Vec3::Y), Some([0, 1, -1, 3]));
        assert_eq!(key(&grid(), p, Vec3::new(0.2, 0.1, -0.9)), Some([0, 1, -1, 5]));
        assert_eq!(key(&grid(), p, Vec3::ZERO), Some([0, 1, -1, 6]));
        // Both faces of a thin wall are different cells.
        assert_ne!(key(&grid(), p, Vec3::X), key(&grid(), p, -Vec3::X));
        assert_eq!(key(&grid(), Vec3::NAN, Vec3::Y), None);
        assert_eq!(key(&grid(), Vec3::splat(1e30), Vec3::Y), None);
    }

    #[test]
    fn a_group_weighs_the_share_of_its_samples_that_got_through_never_below_the_floor() {
        let cell = |c: &[[u32; 2]]| {
            let mut counts = [[0; 2]; LOCAL_CHOICE_MAX];
            counts[..c.len()].copy_from_slice(c);
            counts
        };
        let k = key(&grid(), Vec3::splat(0.05), Vec3::Y).unwrap();
        let v = Visibility::of(grid(), [(k, cell(&[[99, 49], [100, 0], [3, 0]]))]).unwrap();
        let w = v.at(Vec3::splat(0.05), Vec3::Y).unwrap();
        assert_eq!(w[0], 49.5 / 99.5, "half got through");
        assert_eq!(w[1], FLOOR, "none got through: the floor keeps it chosen");
        assert_eq!(w[2], 1.0, "too few samples to judge");
        assert_eq!(v.cells(), 1);
        assert!(v.at(Vec3::splat(0.05), -Vec3::Y).is_none(), "the other side has no counts");
        // Every group seen through everywhere: nothing to weigh.
        assert!(Visibility::of(grid(), [(k, cell(&[[100, 100], [50, 50]]))]).is_none());
        // At a shadow's edge a neighbour that sees the light keeps its weight at 1; two cells
        // on, out of its reach, the light is weighed down; another side is another neighbourhood.
        let at = |x: f32, n: Vec3| key(&grid(), Vec3::new(x, 0.05, 0.05), n).unwrap();
        let blocked = cell(&[[100, 0]]);
        let v = Visibility::of(
            grid(),
            [
                (at(0.05, Vec3::Y), cell(&[[100, 100]])),
                (at(0.15, Vec3::Y), blocked),
                (at(0.25, Vec3::Y), blocked),
                (at(0.15, -Vec3::Y), blocked),
            ],
        )
        .unwrap();
        assert!(v.at(Vec3::new(0.15, 0.05, 0.05), Vec3::Y).is_none(), "beside a lit cell");
        assert_eq!(v.at(Vec3::new(0.25, 0.05, 0.05), Vec3::Y).unwrap()[0], FLOOR);
        assert_eq!(v.at(Vec3::new(0.15, 0.05, 0.05), -Vec3::Y).unwrap()[0], FLOOR);
    }
}
