//! Absorbing glass (`attenuation_color` / `attenuation_distance` in a scene file, glTF's
//! `KHR_materials_volume`): light that travels `d` inside keeps `color^(d / distance)` per
//! channel (Beer–Lambert), against a closed form; the glTF extension is read as the
//! specification says.

mod common;

use ember::integrator::RenderSettings;
use ember::material::{GlassMaterial, MaterialKind};
use ember::scene::Scene;
use glam::Vec3;

const COLOR: [f32; 3] = [0.9, 0.5, 0.2];
const DISTANCE: f32 = 0.5;
const RADIUS: f32 = 1.0;
const SIDE: u32 = 32;

/// A glass sphere of index 1 (no refraction, no reflection: every ray goes straight through)
/// that absorbs, in front of a white sky, seen orthographically across its full width.
fn scene() -> Scene {
    let text = format!(
        "[camera]\ntype = \"orthographic\"\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nwidth = {w}\n\n\
         [background]\ntype = \"constant\"\ncolor = [1, 1, 1]\n\n\
         [materials.glass]\ntype = \"glass\"\nior = 1.0\nattenuation_color = [{}, {}, {}]\nattenuation_distance = {DISTANCE}\n\n\
         [[spheres]]\ncenter = [0, 0, 0]\nradius = {RADIUS}\nmaterial = \"glass\"\n",
        COLOR[0],
        COLOR[1],
        COLOR[2],
        w = 2.0 * RADIUS
    );
    Scene::load(&common::write_scene("glass-absorption", "sphere.toml", &text)).unwrap_or_else(|e| panic!("{e}"))
}

/// What a pixel sees: the mean over it (16 × 16 points: the chord changes steeply near the
/// rim) of `color^(chord / distance)`, the chord
/// through the sphere along the view being 2 √(R² − r²) (0 outside it); and whether all of its
/// points are on the sphere (no edge crosses it).
fn closed_form(px: u32, py: u32) -> (Vec3, bool) {
    let size = 2.0 * RADIUS / SIDE as f32;
    let mut sum = Vec3::ZERO;
    let mut inside = true;
    for k in 0..256 {
        let x = -RADIUS + (px as f32 + ((k % 16) as f32 + 0.5) / 16.0) * size;
        let y = RADIUS - (py as f32 + ((k / 16) as f32 + 0.5) / 16.0) * size;
        inside &= x * x + y * y < RADIUS * RADIUS;
        let chord = 2.0 * (RADIUS * RADIUS - x * x - y * y).max(0.0).sqrt();
        sum += Vec3::from(COLOR).powf(chord / DISTANCE);
    }
    (sum / 256.0, inside)
}

#[test]
fn light_through_absorbing_glass_keeps_color_to_the_power_of_distance() {
    // Deterministic paths (index 1: one direction, no reflection), so the only noise is where
    // a pixel's samples land: at 64 spp each channel of a pixel wholly on the sphere within
    // 0.01 of the closed form (measured 0.004), of a pixel the edge crosses within 0.04
    // (measured 0.015), the image's mean within 0.1% (measured 0.015%).
    let scene = scene();
    let settings = RenderSettings { width: SIDE, height: SIDE, spp: 64, adaptive: false, ..RenderSettings::default() };
    let (film, stats) = common::render_embree(&scene, &settings);
    assert_eq!(stats.nonfinite, 0);
    let (mut got, mut want, mut worst_inside, mut worst_edge) = (Vec3::ZERO, Vec3::ZERO, 0.0f32, 0.0f32);
    for y in 0..SIDE {
        for x in 0..SIDE {
            let (g, (w, inside)) = (film.get(x, y), closed_form(x, y));
            got += g;
            want += w;
            let off = (g - w).abs().max_element();
            if inside {
                worst_inside = worst_inside.max(off);
            } else {
                worst_edge = worst_edge.max(off);
            }
        }
    }
    println!("mean {got} against {want}; worst pixel off by {worst_inside} on the sphere, {worst_edge} at its edge");
    assert!(worst_inside < 0.01, "a pixel on the sphere is off by {worst_inside}");
    assert!(worst_edge < 0.04, "a pixel at the edge is off by {worst_edge}");
    for c in 0..3 {
        assert!((got[c] / want[c] - 1.0).abs() < 0.001, "channel {c}: {} against {}", got[c], want[c]);
    }
    // The centre, through the full diameter 2: 0.9⁴, 0.5⁴, 0.2⁴.
    let centre = film.get(SIDE / 2, SIDE / 2);
    assert!((centre - Vec3::new(0.6561, 0.0625, 0.0016)).abs().max_element() < 0.02, "{centre}");
}

#[test]
fn gltf_volume_sets_the_absorption_of_glass() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf/ext_transmission_volume.glb");
    let scene = Scene::load(&path).unwrap();
    let glass = scene
        .materials
        .iter()
        .find_map(|m| match &m.kind {
            MaterialKind::Glass(g) => Some(g.clone()),
            _ => None,
        })
        .expect("the transmissive material is glass");
    // attenuationColor (0.9, 0.5, 0.2) after attenuationDistance 0.5.
    let want = GlassMaterial::absorption_for(Vec3::from(COLOR), 0.5);
    assert!((glass.absorption - want).abs().max_element() < 1e-5, "{} vs {want}", glass.absorption);
    assert!((want - Vec3::new(0.2107, 1.3863, 3.2189)).abs().max_element() < 1e-3, "{want}");
    assert!((glass.ior - 1.33).abs() < 1e-6);
}
