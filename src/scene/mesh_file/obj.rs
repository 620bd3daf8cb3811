//! Wavefront OBJ meshes with their MTL materials, read with tobj (triangulated, one mesh per
//! object/material group, normals and texture coordinates kept). Errors name the file and,
//! where it can be found, the line. tobj's types stay in this file: the door
//! ([`super::MeshFile`]) hands on ember's own.
//!
//! MTL mapping: `Kd` → diffuse colour; `Ks` > 0 with `Ns` → plastic with roughness
//! `(2 / (Ns + 2))^(1/4)` (the Phong-to-Beckmann/GGX convention alpha = sqrt(2 / (Ns + 2)),
//! roughness = sqrt(alpha)); dissolve `d` < 1 or `illum` 4/6/7 → glass with IOR `Ni`;
//! `Ke` → emission, and, following Embree's `cornell_box.mtl`, an ambient `Ka` above 1 is
//! read as emission too.

use super::{FileMesh, MeshFile};
use crate::geometry::TriMesh;
use crate::material::{DiffuseMaterial, GlassMaterial, Material, MaterialKind, PlasticMaterial};
use crate::memory::{self, LoadBudget};
use crate::scene::format::MAX_COORDINATE;
use crate::scene::{SceneError, input};
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::borrow::Cow;
use std::path::Path;

/// Memory to load an OBJ file of `file_len` bytes with `vertices` positions and `triangles`
/// triangles (after fan triangulation): the file's text, tobj's face records and vertex
/// de-duplication map, and the mesh (measured: 218 MB peak for a 37.6 MB file of 501,501
/// vertices and 1,000,000 triangles, 430 MB for twice that).
pub fn memory_bytes(file_len: u64, vertices: u64, triangles: u64) -> u64 {
    file_len
        .saturating_add(vertices.saturating_mul(BYTES_PER_VERTEX))
        .saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE))
}

const BYTES_PER_VERTEX: u64 = 100;
const BYTES_PER_TRIANGLE: u64 = 140;

/// Memory to read and parse an MTL file, per byte of it (the text, a lossless copy, tobj's
/// maps: measured 3.15 GB peak for a 1 GB file).
const MTL_BYTES_PER_BYTE: u64 = 4;

/// Loads an OBJ file and the MTL files it names (relative to the OBJ's folder), within
/// `budget`.
pub fn load(path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let len = input::regular_file_len(path)?;
    // Refuse a file too large to read before reading it; `parse_obj` checks the whole load.
    budget
        .admit(format!("OBJ file of {}", memory::format_bytes(len)), memory_bytes(len, 0, 0))
        .map_err(|e| SceneError::new(path, None, e.to_string()))?;
    let bytes = input::read(path)?;
    let read_mtl = |mtl: &Path| {
        // Named inside the OBJ: read only where a model's files may be (`input::named_file`).
        let folder = path.parent().unwrap_or(Path::new(""));
        let name = mtl.strip_prefix(folder).unwrap_or(mtl).to_string_lossy();
        std::fs::metadata(mtl)?; // a missing library: `no such file`
        let mtl = input::named_file(path, &name, budget.external_files()).map_err(std::io::Error::other)?;
        let (file, len) = crate::regular_file::open(&mtl)?;
        let what = format!("MTL file {} of {}", mtl.display(), memory::format_bytes(len));
        budget
            .admit(what, len.saturating_mul(MTL_BYTES_PER_BYTE))
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::OutOfMemory, e.to_string()))?;
        crate::regular_file::read_opened(file, len)
    };
    parse_obj(&bytes, path, &read_mtl, budget)
}

/// Parses the text of an OBJ file within `budget`. `path` names the file in messages and its
/// folder is where MTL files are looked for; `read_mtl` reads one (given that folder joined
/// with the name the OBJ gives): a library it cannot read is a warning (the meshes get
/// default materials), unless it was refused for memory (`ErrorKind::OutOfMemory`), which is
/// an error, as is any bad line in a library. [`load`] is this with the file system.
pub fn parse_obj(
    bytes: &[u8],
    path: &Path,
    read_mtl: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
    budget: &LoadBudget,
) -> Result<MeshFile, SceneError> {
    // Some editors start a UTF-8 file with a byte-order mark: not part of the first line.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let text = String::from_utf8_lossy(bytes);
    // tobj reports no line numbers; check the lines ourselves first so the message can name one.
    let counts = scan(&text).map_err(|(line, problem)| SceneError::new(path, Some(line), problem))?;
    budget
        .admit(
            format!("mesh of {} vertices and {} triangles", counts.vertices, counts.triangles),
            memory_bytes(bytes.len() as u64, counts.vertices, counts.triangles),
        )
        .map_err(|e| SceneError::new(path, None, e.to_string()))?;
    // tobj reads a `#` after the values of a `v`, `vt`, `vn` or `f` line as one more value;
    // hand it those lines without the comment, as `scan` read them.
    let text = strip_value_comments(text);
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // A library that cannot be read is a warning (the meshes get default materials); a bad
    // line in one, or one refused for memory, is an error.
    let mtl_unread = std::cell::RefCell::new(Vec::new());
    let mtl_error = std::cell::RefCell::new(None);
    // Each library is read once: tobj would append its materials again for every repeated
    // `mtllib` (a file repeating it n times made n copies, and n reads).
    let mtl_seen = std::cell::RefCell::new(std::collections::HashSet::new());
    let mtl_read = std::cell::RefCell::new(Vec::new());
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| {
        let full = dir.join(mtl);
        if !mtl_seen.borrow_mut().insert(full.clone()) {
            return Ok((Vec::new(), Default::default()));
        }
        let bytes = read_mtl(&full).map_err(|e| {
            if e.kind() == std::io::ErrorKind::OutOfMemory {
                *mtl_error.borrow_mut() = Some(SceneError::new(&full, None, e.to_string()));
            } else {
                let why = SceneError::io(&full, &e).message;
                mtl_unread.borrow_mut().push(format!("{}: {why}; using default materials", full.display()));
            }
            tobj::LoadError::OpenFileFailed
        })?;
        mtl_read.borrow_mut().push(full.clone());
        let mtl_text = String::from_utf8_lossy(bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes));
        // tobj panics on some malformed lines (`Kd 1 0`) and names none: check them first.
        if let Some((line, problem)) = first_bad_mtl_line(&mtl_text) {
            *mtl_error.borrow_mut() = Some(SceneError::new(&full, Some(line), problem));
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut mtl_text.as_bytes())
    })
    .map_err(|e| SceneError::new(path, None, format!("malformed OBJ: {e}")))?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let mut warnings = mtl_unread.into_inner();
    let materials = match materials {
        Ok(m) => m,
        Err(e) if warnings.is_empty() => {
            warnings.push(format!("{}: material library not loaded ({e}); using default materials", path.display()));
            Vec::new()
        }
        Err(_) => Vec::new(),
    };
    let mut meshes = Vec::new();
    for m in models {
        let mesh = m.mesh;
        if mesh.indices.is_empty() {
            warnings.push(format!("{}: object {:?} has no faces; skipped", path.display(), m.name));
            continue;
        }
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let normals: Vec<Vec3> = mesh.normals.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let uvs: Vec<Vec2> = mesh.texcoords.chunks_exact(2).map(|p| Vec2::new(p[0], p[1])).collect();
        let indices: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let material = mesh.material_id.filter(|&i| i < materials.len());
        let mut tri = TriMesh::new(m.name, positions, indices, normals, uvs)
            .map_err(|e| SceneError::new(path, None, e.to_string()))?;
        let dropped = tri.remove_degenerate();
        if !dropped.is_empty() {
            warnings.push(degenerate_warning(path, &tri.name, &dropped, tri.triangle_count()));
            if tri.triangle_count() == 0 {
                continue;
            }
        }
        budget.keep(tri.heap_bytes());
        budget.keep_primitives(tri.triangle_count() as u64, 0);
        meshes.push(FileMesh { mesh: tri, instances: Vec::new(), material, colors: Vec::new() });
    }
    if meshes.is_empty() {
        return Err(SceneError::new(path, None, "no triangles: the file has no faces (or only degenerate ones)"));
    }
    let materials = mtl_materials(path, &materials);
    let inputs = mtl_read.into_inner();
    Ok(MeshFile { meshes, materials, camera: None, point_lights: Vec::new(), warnings, inputs })
}

/// ember's materials for the MTL materials of the OBJ file `obj` (see the module
/// documentation), named `file.obj:name`.
fn mtl_materials(obj: &Path, mtls: &[tobj::Material]) -> Vec<Material> {
    let file = obj.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned());
    mtls.iter()
        .map(|m| {
            let kd = m.diffuse.map_or(Vec3::splat(0.8), Vec3::from_array);
            let ks = m.specular.map_or(Vec3::ZERO, Vec3::from_array);
            let ka = m.ambient.map_or(Vec3::ZERO, Vec3::from_array);
            let ke = m.emissive.map_or(Vec3::ZERO, Vec3::from_array);
            let emission = if ke.max_element() > 0.0 {
                ke
            } else if ka.max_element() > 1.0 {
                ka
            } else {
                Vec3::ZERO
            };
            let glass = m.dissolve.is_some_and(|d| d < 1.0) || matches!(m.illumination_model, Some(4 | 6 | 7));
            let kind = if glass {
                MaterialKind::Glass(GlassMaterial::clear(
                    m.optical_density.filter(|&n| n > 0.0).unwrap_or(1.5),
                    Vec3::ONE,
                ))
            } else if ks.max_element() > 0.0 {
                let ns = m.shininess.unwrap_or(10.0).max(0.0);
                MaterialKind::Plastic(PlasticMaterial {
                    color: Texture::Constant(kd),
                    roughness: (2.0 / (ns + 2.0)).powf(0.25),
                })
            } else {
                MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(kd) })
            };
            Material { name: format!("{file}:{}", m.name), kind, emission: Texture::Constant(emission) }
        })
        .collect()
}

/// The warning for triangles dropped by [`TriMesh::remove_degenerate`]: how many, which (the
/// first few, counted from 1 within the object) and what is left.
pub(crate) fn degenerate_warning(path: &Path, object: &str, dropped: &[usize], left: usize) -> String {
    let mut which: Vec<String> = dropped.iter().take(5).map(|i| (i + 1).to_string()).collect();
    if dropped.len() > 5 {
        which.push("...".into());
    }
    let rest = if left == 0 { "nothing left; object skipped".to_string() } else { format!("{left} kept") };
    format!(
        "{}: object {object:?}: skipped {} degenerate triangle(s) (zero area or a NaN/infinite corner): {} ({rest})",
        path.display(),
        dropped.len(),
        which.join(", ")
    )
}

/// What an OBJ file's text declares.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Counts {
    vertices: u64,
    /// After fan triangulation of the faces.
    triangles: u64,
}

/// Counts the vertices and triangles, or finds the first line tobj would reject (or silently
/// misread), with a message saying why. Checks the statements that carry geometry: `v`, `vt`,
/// `vn` and `f`, with relative (negative) indices resolved against the elements read so far.
fn scan(text: &str) -> Result<Counts, (usize, String)> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    let mut triangles = 0u64;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tok = line.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let args: Vec<&str> = tok.collect();
        // The counts tobj accepts.
        // Non-finite positions are allowed here: the triangles using them are dropped with a
        // warning after loading (a degenerate triangle must not stop a render); non-finite
        // texture coordinates and normals have no such remedy and are errors.
        let floats = |counts: &[usize], what: &str, finite: bool| -> Result<(), String> {
            if !counts.contains(&args.len()) {
                let allowed: Vec<String> = counts.iter().map(usize::to_string).collect();
                let (last, rest) = allowed.split_last().expect("at least one count");
                let allowed = if rest.is_empty() { last.clone() } else { format!("{} or {last}", rest.join(", ")) };
                return Err(format!("{what} needs {allowed} numbers, found {}", args.len()));
            }
            for (i, a) in args.iter().enumerate() {
                let x = a.parse::<f32>().map_err(|_| format!("{what}: {a:?} is not a number"))?;
                if finite && !x.is_finite() {
                    return Err(format!("{what}: {a:?} is not a finite number"));
                }
                // Positions (the first three numbers of `v`) must be within range; non-finite
                // ones are dropped with their triangles, as degenerate.
                if kw == "v" && i < 3 && x.is_finite() && x.abs() > MAX_COORDINATE {
                    return Err(format!("{what}: {x:e} is beyond ±{MAX_COORDINATE:e}, the range ember renders"));
                }
            }
            Ok(())
        };
        let r = match kw {
            // x y z, x y z w (w not 0), or x y z r g b (vertex colours)
            "v" => floats(&[3, 4, 6], "vertex position", false).and_then(|_| match args.get(3) {
                Some(w) if args.len() == 4 && w.parse::<f32>() == Ok(0.0) => {
                    Err("vertex position: w must not be 0".into())
                }
                _ => {
                    nv += 1;
                    Ok(())
                }
            }),
            "vt" => floats(&[2, 3], "texture coordinate", true).map(|_| nt += 1),
            "vn" => floats(&[3], "vertex normal", true).map(|_| nn += 1),
            "f" => check_face(&args, nv, nt, nn).map(|_| triangles += args.len() as u64 - 2),
            _ => Ok(()),
        };
        if let Err(e) = r {
            return Err((line_no, e));
        }
    }
    Ok(Counts { vertices: nv as u64, triangles })
}

fn check_face(args: &[&str], nv: i64, nt: i64, nn: i64) -> Result<(), String> {
    if args.len() < 3 {
        return Err(format!("a face needs at least 3 vertices, found {}", args.len()));
    }
    for a in args {
        let parts: Vec<&str> = a.split('/').collect();
        if parts.len() > 3 {
            return Err(format!("face vertex {a:?} is malformed"));
        }
        for (k, (&p, (count, what))) in
            parts.iter().zip([(nv, "vertex"), (nt, "texture coordinate"), (nn, "normal")]).enumerate()
        {
            if p.is_empty() && k > 0 {
                continue;
            }
            let idx: i64 = p.parse().map_err(|_| format!("face vertex {a:?}: {p:?} is not an index"))?;
            let resolved = if idx < 0 { count + idx + 1 } else { idx };
            if idx == 0 || resolved < 1 || resolved > count {
                return Err(format!("face {what} index {idx} is out of range (1 to {count} defined so far)"));
            }
        }
    }
    Ok(())
}

/// `text` with comments cut from the end of `v`, `vt`, `vn` and `f` lines (copied only when
/// there are such comments).
fn strip_value_comments(text: Cow<'_, str>) -> Cow<'_, str> {
    let has_comment = |l: &str| l.contains('#') && matches!(l.split_whitespace().next(), Some("v" | "vt" | "vn" | "f"));
    if !text.lines().any(has_comment) {
        return text;
    }
    let mut out = String::with_capacity(text.len());
    for l in text.lines() {
        out.push_str(if has_comment(l) { l.split('#').next().unwrap_or("") } else { l });
        out.push('\n');
    }
    Cow::Owned(out)
}

/// Finds the first MTL line tobj would reject or panic on, with a message saying why.
fn first_bad_mtl_line(text: &str) -> Option<(usize, String)> {
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        let mut tok = line.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let args: Vec<&str> = tok.collect();
        let numbers = |n: usize| -> Result<(), String> {
            if args.len() < n {
                return Err(format!("{kw} needs {n} number{}, found {}", if n == 1 { "" } else { "s" }, args.len()));
            }
            for a in &args[..n] {
                match a.parse::<f32>() {
                    Err(_) => return Err(format!("{kw}: {a:?} is not a number")),
                    Ok(x) if !x.is_finite() => return Err(format!("{kw}: {a:?} is not a finite number")),
                    Ok(x) if x < 0.0 => return Err(format!("{kw}: {a:?} is negative")),
                    Ok(_) => {}
                }
            }
            Ok(())
        };
        let r = match kw {
            "Ka" | "Kd" | "Ks" | "Ke" => numbers(3),
            "Ns" | "Ni" | "d" => numbers(1),
            "illum" => match args.first() {
                Some(a) if a.parse::<u8>().is_ok() => Ok(()),
                Some(a) => Err(format!("illum: {a:?} is not an illumination model (0 to 10)")),
                None => Err("illum needs an illumination model number".to_string()),
            },
            "newmtl" | "map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns" | "map_NS"
            | "bump" | "map_d"
                if args.is_empty() =>
            {
                Err(format!("{kw} needs a name"))
            }
            _ => Ok(()),
        };
        if let Err(e) = r {
            return Some((i + 1, e));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_bad_line(text: &str) -> Option<(usize, String)> {
        scan(text).err()
    }

    #[test]
    fn vertices_and_triangles_are_counted() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 1 2 4 3\nvt 0 0\nl 1 2\n";
        assert_eq!(scan(text), Ok(Counts { vertices: 4, triangles: 3 }));
    }

    #[test]
    fn bad_lines_are_located() {
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), None);
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"), None);
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n").map(|x| x.0), Some(4));
        assert_eq!(first_bad_line("v 0 0\n").map(|x| x.0), Some(1));
        assert_eq!(first_bad_line("v 0 0 0\nv 1 x 0\n").map(|x| x.0), Some(2));
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n").map(|x| x.0), Some(5));
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n").map(|x| x.0), Some(4));
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").map(|x| x.0), Some(4));
        assert_eq!(first_bad_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"), None);
        // Counts tobj accepts: 3, 4 (w) or 6 (colours) for v, 2 or 3 for vt.
        assert_eq!(first_bad_line("v 0 0 0 1\nv 1 0 0 1 1 1\nvt 0 0\nvt 0 0 0\n"), None);
        assert_eq!(
            first_bad_line("v 0 0 0 1 1\n"),
            Some((1, "vertex position needs 3, 4 or 6 numbers, found 5".into()))
        );
        assert_eq!(first_bad_line("v 0 0 0 0\n").map(|x| x.0), Some(1));
        assert_eq!(first_bad_line("v 0 0 0\nvt 0.5\n").map(|x| x.0), Some(2));
        // Every number must be finite (1e39 overflows f32).
        // ... except positions: their triangles are dropped as degenerate, with a warning.
        assert_eq!(first_bad_line("v 0 0 0\nv nan 0 0\n"), None);
        assert_eq!(
            first_bad_line("v 0 0 0\nvn 0 nan 1\n"),
            Some((2, "vertex normal: \"nan\" is not a finite number".into()))
        );
        assert_eq!(first_bad_line("vn 0 inf 0\n").map(|x| x.0), Some(1));
        assert_eq!(first_bad_line("v 0 0 0\nvt 0 0\nvt -1e39 0\n").map(|x| x.0), Some(3));
    }

    #[test]
    fn comments_after_values_are_ignored() {
        let text = "v 0 0 0 # origin\nv 1 0 0\nv 0 1 0#\nvt 0 0 # uv\nf 1 2 3 # the triangle\n";
        let obj = parse_obj(
            text.as_bytes(),
            Path::new("c.obj"),
            &|_| Err(std::io::ErrorKind::NotFound.into()),
            &LoadBudget::unlimited(),
        )
        .unwrap();
        assert_eq!(obj.triangle_count(), 1);
        assert_eq!(obj.meshes[0].mesh.positions[2], Vec3::new(0.0, 1.0, 0.0));
        assert!(matches!(strip_value_comments(Cow::Borrowed("v 0 0 0\n# c\no a#b\n")), Cow::Borrowed(_)));
    }

    #[test]
    fn bad_mtl_lines_are_located() {
        assert_eq!(first_bad_mtl_line("newmtl a\nKd 1 1 1\nKs 0 0 0\nNs 10\nillum 2\nmap_Kd x.png\n"), None);
        assert_eq!(first_bad_mtl_line("newmtl a\nKd 1 0\n"), Some((2, "Kd needs 3 numbers, found 2".into())));
        assert_eq!(first_bad_mtl_line("newmtl a\nKa 1 x 0\n").map(|x| x.0), Some(2));
        assert_eq!(first_bad_mtl_line("newmtl a\n\nNs\n").map(|x| x.0), Some(3));
        assert_eq!(first_bad_mtl_line("newmtl a\nillum 300\n").map(|x| x.0), Some(2));
        assert_eq!(first_bad_mtl_line("newmtl\n").map(|x| x.0), Some(1));
    }
}
