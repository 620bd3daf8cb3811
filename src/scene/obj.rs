//! OBJ/MTL loading with tobj (triangulated, one mesh per object/material group, normals and
//! texture coordinates kept). Errors name the file and, where it can be found, the line.

use super::SceneError;
use crate::geometry::TriMesh;
use glam::{Vec2, Vec3};
use std::path::Path;

/// One mesh of an OBJ file with the index of its MTL material, if any.
#[derive(Clone, Debug)]
pub struct ObjMesh {
    pub mesh: TriMesh,
    pub material: Option<usize>,
}

/// What an OBJ file holds.
#[derive(Clone, Debug, Default)]
pub struct ObjFile {
    pub meshes: Vec<ObjMesh>,
    pub materials: Vec<tobj::Material>,
    /// Non-fatal problems (missing MTL file, empty objects), for the user to see.
    pub warnings: Vec<String>,
}

impl ObjFile {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.mesh.triangle_count()).sum()
    }
}

/// Loads an OBJ file and the MTL files it names (relative to the OBJ's folder).
pub fn load_obj(path: &Path) -> Result<ObjFile, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, &e))?;
    parse_obj(&bytes, path, &|mtl| std::fs::read(mtl))
}

/// Parses the text of an OBJ file. `path` names the file in messages and its folder is where
/// MTL files are looked for; `read_mtl` reads one (given that folder joined with the name the
/// OBJ gives). [`load_obj`] is this with the file system.
pub fn parse_obj(
    bytes: &[u8],
    path: &Path,
    read_mtl: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>,
) -> Result<ObjFile, SceneError> {
    let text = String::from_utf8_lossy(bytes);
    // tobj reports no line numbers; check the lines ourselves first so the message can name one.
    if let Some((line, problem)) = first_bad_line(&text) {
        return Err(SceneError::new(path, Some(line), problem));
    }
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut warnings = Vec::new();
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| {
        match read_mtl(&dir.join(mtl)) {
            Ok(b) => tobj::load_mtl_buf(&mut &b[..]),
            Err(_) => Err(tobj::LoadError::OpenFileFailed),
        }
    })
    .map_err(|e| SceneError::new(path, None, format!("malformed OBJ: {e}")))?;
    let materials = match materials {
        Ok(m) => m,
        Err(e) => {
            warnings.push(format!("{}: material library not loaded ({e}); using default materials", path.display()));
            Vec::new()
        }
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
        let tri = TriMesh::new(m.name, positions, indices, normals, uvs)
            .map_err(|e| SceneError::new(path, None, e.to_string()))?;
        meshes.push(ObjMesh { mesh: tri, material });
    }
    if meshes.is_empty() {
        return Err(SceneError::new(path, None, "no triangles: the file has no faces"));
    }
    Ok(ObjFile { meshes, materials, warnings })
}

/// Finds the first line tobj would reject (or silently misread), with a message saying why.
/// Checks the statements that carry geometry: `v`, `vt`, `vn` and `f`, with relative
/// (negative) indices resolved against the elements read so far.
fn first_bad_line(text: &str) -> Option<(usize, String)> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut tok = line.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let args: Vec<&str> = tok.collect();
        let floats = |min: usize, max: usize, what: &str| -> Result<(), String> {
            if args.len() < min || args.len() > max {
                return Err(format!("{what} needs {min} to {max} numbers, found {}", args.len()));
            }
            for a in &args {
                a.parse::<f32>().map_err(|_| format!("{what}: {a:?} is not a number"))?;
            }
            Ok(())
        };
        let r = match kw {
            // x y z [w], optionally followed by r g b vertex colours
            "v" => floats(3, 7, "vertex position").map(|_| nv += 1),
            "vt" => floats(1, 3, "texture coordinate").map(|_| nt += 1),
            "vn" => floats(3, 3, "vertex normal").map(|_| nn += 1),
            "f" => check_face(&args, nv, nt, nn),
            _ => Ok(()),
        };
        if let Err(e) = r {
            return Some((line_no, e));
        }
    }
    None
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

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
