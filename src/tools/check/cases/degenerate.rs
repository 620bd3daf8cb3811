//! Degenerate triangles in a mesh: one with the same vertex three times (zero area), one
//! with three collinear corners, one with a repeated corner, one with a NaN corner, among six
//! good ones. Loading must drop exactly those four with a warning; rendering must never crash
//! or produce NaN, whether the four were dropped (as loaded) or kept (a mesh built directly,
//! through Embree and through the naive loop), and the images must be bit-identical to the
//! render of the six good triangles alone (the degenerate corners lie inside the good
//! triangles' bounds, so even the light choice, which depends on the scene's bounds, is
//! unchanged).

use super::super::scenes::CaseSceneBuilder;
use super::{CaseRun, CheckError, Verdict};
use crate::film::Film;
use crate::geometry::TriMesh;
use crate::light::Background;
use crate::scene::Scene;
use crate::scene::mesh_file::obj::parse_obj;
use glam::Vec3;
use std::path::Path;

const OBJ: &str = "\
# a ground quad and a tetrahedron (six good triangles), then four degenerate ones
v -4 0 -4
v 4 0 -4
v 4 0 4
v -4 0 4
v 0 0.5 0
v 1 0.5 0
v 0 1.5 0
v 0 0.5 1
v 0.5 0.5 0.5
v 0.75 0.75 0.75
v 1 1 1
v nan 0 0
f 1 2 3
f 1 3 4
f 5 6 7
f 5 7 8
f 5 8 6
f 6 8 7
f 9 9 9
f 9 10 11
f 5 5 6
f 12 1 2
";

fn scene(mesh: TriMesh) -> Scene {
    let mut builder = CaseSceneBuilder::new("degenerate");
    let m = builder.diffuse(0.6);
    builder.mesh(mesh, m);
    builder.point_light(Vec3::new(2.0, 5.0, 3.0), 40.0);
    builder.background(Background::Constant(Vec3::splat(0.3)));
    builder.camera(Vec3::new(3.0, 4.0, 5.0), Vec3::new(0.3, 0.5, 0.3), Vec3::Y, 45.0);
    builder.build()
}

/// Largest relative difference between two images (0 when bit-identical).
fn max_rel(a: &Film, b: &Film) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            let e = (*p - *q).abs().max_element() as f64 / (q.max_element() as f64).max(1e-30);
            if e.is_nan() { f64::INFINITY } else { e }
        })
        .fold(0.0, f64::max)
}

pub fn check(run: &CaseRun) -> Result<Verdict, CheckError> {
    let path = Path::new("degenerate.obj (built in)");
    let no_mtl = |_: &std::path::Path| Err(std::io::Error::other("no MTL files here"));
    let obj = parse_obj(OBJ.as_bytes(), path, &no_mtl, &crate::memory::LoadBudget::unlimited())?;
    let loaded = obj.meshes[0].mesh.clone();
    let warned = obj.warnings.iter().any(|w| w.contains("skipped 4 degenerate triangle(s)"));

    // The same data without the loader's filtering, and the six good triangles alone.
    let positions: Vec<Vec3> = [
        [-4.0, 0.0, -4.0],
        [4.0, 0.0, -4.0],
        [4.0, 0.0, 4.0],
        [-4.0, 0.0, 4.0],
        [0.0, 0.5, 0.0],
        [1.0, 0.5, 0.0],
        [0.0, 1.5, 0.0],
        [0.0, 0.5, 1.0],
        [0.5, 0.5, 0.5],
        [0.75, 0.75, 0.75],
        [1.0, 1.0, 1.0],
        [f32::NAN, 0.0, 0.0],
    ]
    .map(Vec3::from_array)
    .to_vec();
    let all: Vec<[u32; 3]> = vec![
        [0, 1, 2],
        [0, 2, 3],
        [4, 5, 6],
        [4, 6, 7],
        [4, 7, 5],
        [5, 7, 6],
        [8, 8, 8],
        [8, 9, 10],
        [4, 4, 5],
        [11, 0, 1],
    ];
    let raw = TriMesh::new("raw", positions.clone(), all.clone(), vec![], vec![])
        .map_err(|e| CheckError::Other(e.to_string()))?;
    let good = TriMesh::new("good", positions, all[..6].to_vec(), vec![], vec![])
        .map_err(|e| CheckError::Other(e.to_string()))?;
    let flagged = (0..raw.triangle_count()).filter(|&i| raw.is_degenerate(i)).collect::<Vec<_>>();

    let (w, h, spp) = run.by_quality((24, 24, 4), (48, 48, 8));
    let s = crate::integrator::RenderSettings { max_depth: 3, ..run.settings(w, h, spp) };
    let reference = run.render(&scene(good.clone()), &s)?;
    let reference_naive = run.render_naive(&scene(good), &s)?;
    let as_loaded = run.render(&scene(loaded.clone()), &s)?;
    let raw_embree = run.render(&scene(raw.clone()), &s)?;
    let raw_naive = run.render_naive(&scene(raw), &s)?;
    let worst = max_rel(&as_loaded, &reference)
        .max(max_rel(&raw_embree, &reference))
        .max(max_rel(&raw_naive, &reference_naive));
    Ok(Verdict::new(
        worst,
        1e-6,
        "max rel diff",
        format!("loaded {} of 10 triangles; warnings: {:?}", loaded.triangle_count(), obj.warnings),
    )
    .require(warned, "no warning names the 4 skipped triangles")
    .require(loaded.triangle_count() == 6, format!("{} triangles kept, want 6", loaded.triangle_count()))
    .require(flagged == vec![6, 7, 8, 9], format!("degenerate triangles found: {flagged:?}, want [6, 7, 8, 9]")))
}
