//! Refusing, before loading the accelerator or rendering, what would not fit in memory: the
//! scene's data, the BVH and the film, with the estimate in the message.

use crate::accel::AccelKind;
use crate::memory::{self, MemoryLimit};
use crate::scene::Scene;
use std::path::Path;

/// Refuses a render of `scene` (loaded from `path`) through `accel` at `film` (width,
/// height), or, without a film, the BVH alone (`ember info`).
pub fn check(
    path: &Path,
    scene: &Scene,
    accel: AccelKind,
    film: Option<(u32, u32)>,
    limit: &MemoryLimit,
) -> anyhow::Result<()> {
    let at = |e: memory::LimitError| anyhow::anyhow!("{}: {e}", path.display());
    let film_bytes = match film {
        Some((w, h)) => {
            let bytes = memory::film_bytes(w, h);
            limit.check(format!("image {w}x{h}"), "of film memory", bytes).map_err(at)?;
            bytes
        }
        None => 0,
    };
    let (tris, spheres, cylinders) = scene.primitive_counts();
    let (bvh, accel_name) = match accel {
        AccelKind::Embree => (memory::embree_bytes(tris as u64, (spheres + cylinders) as u64), "Embree BVH"),
        AccelKind::Naive => (0, "naive accel"),
    };
    let data = scene.data_bytes();
    let f = memory::format_bytes;
    let shapes = spheres + cylinders;
    let (what, parts) = match film {
        Some((w, h)) => (
            format!("rendering {tris} triangles, {shapes} spheres and cylinders at {w}x{h}"),
            format!("(scene data {}, {accel_name} {}, film {})", f(data), f(bvh), f(film_bytes)),
        ),
        None => (
            format!("a BVH over {tris} triangles, {shapes} spheres and cylinders"),
            format!("(scene data {}, {accel_name} {})", f(data), f(bvh)),
        ),
    };
    limit.check(what, &parts, data + bvh + film_bytes).map_err(at)
}
