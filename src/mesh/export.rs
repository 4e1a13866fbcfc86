//! Mesh files: binary PLY (positions, normals, colours), Wavefront OBJ, and
//! binary STL (through `stl_io`). Written atomically, like every output.

use std::fmt::Write as _;
use std::path::Path;

use super::Mesh;
use crate::frame::linear_to_srgb8;
use crate::output::write_atomic;

/// A mesh file format, chosen by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Binary little-endian PLY with normals and, when present, 8-bit colours.
    Ply,
    /// Wavefront OBJ with normals (and colours as the common `v x y z r g b` extension).
    Obj,
    /// Binary STL: facet normals only.
    Stl,
}

impl MeshFormat {
    /// The format named by `path`'s extension (`.ply`, `.obj` or `.stl`).
    pub fn from_path(path: &Path) -> Result<Self, String> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("ply") => Ok(MeshFormat::Ply),
            Some("obj") => Ok(MeshFormat::Obj),
            Some("stl") => Ok(MeshFormat::Stl),
            _ => Err(format!("{}: unknown mesh format; use .ply, .obj or .stl", path.display())),
        }
    }
}

/// Writes `mesh` to `path` in `format`.
pub fn write_mesh(path: &Path, mesh: &Mesh, format: MeshFormat) -> std::io::Result<()> {
    let bytes = match format {
        MeshFormat::Ply => ply_bytes(mesh),
        MeshFormat::Obj => obj_text(mesh).into_bytes(),
        MeshFormat::Stl => stl_bytes(mesh)?,
    };
    write_atomic(path, &bytes)
}

fn ply_bytes(mesh: &Mesh) -> Vec<u8> {
    let colors = mesh.colors.as_deref();
    let mut header = String::from("ply\nformat binary_little_endian 1.0\ncomment written by blobtrace\n");
    let _ = writeln!(header, "element vertex {}", mesh.positions.len());
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        let _ = writeln!(header, "property float {p}");
    }
    if colors.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    let errors = mesh.error.as_deref();
    if errors.is_some() {
        header.push_str("property float error\n");
    }
    let _ = writeln!(header, "element face {}", mesh.triangles.len());
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = header.into_bytes();
    for (i, (p, n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
        for v in p.to_array().into_iter().chain(n.to_array()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(c) = colors {
            out.extend(c[i].to_array().map(linear_to_srgb8));
        }
        if let Some(e) = errors {
            out.extend_from_slice(&e[i].to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out
}

fn obj_text(mesh: &Mesh) -> String {
    let mut s = String::from("# written by blobtrace\n");
    for (i, p) in mesh.positions.iter().enumerate() {
        let _ = write!(s, "v {} {} {}", p.x, p.y, p.z);
        if let Some(c) = &mesh.colors {
            let _ = write!(s, " {} {} {}", c[i].x, c[i].y, c[i].z);
        }
        s.push('\n');
    }
    for n in &mesh.normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    s
}

fn stl_bytes(mesh: &Mesh) -> std::io::Result<Vec<u8>> {
    let triangles = (0..mesh.triangles.len()).map(|t| {
        let [a, b, c] = mesh.corners(t);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        stl_io::Triangle {
            normal: stl_io::Vector::new(normal.to_array()),
            vertices: [a, b, c].map(|v| stl_io::Vector::new(v.to_array())),
        }
    });
    let mut out = vec![];
    stl_io::write_stl(&mut out, triangles)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tetrahedron() -> Mesh {
        let mut m = Mesh::default();
        for p in [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z] {
            m.push_vertex(p, p.normalize_or_zero(), Some(Vec3::new(1.0, 0.5, 0.0)));
        }
        m.triangles = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        m
    }

    #[test]
    fn files_hold_every_vertex_and_triangle() {
        let m = tetrahedron();
        let ply = ply_bytes(&m);
        let header_end = ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert!(String::from_utf8_lossy(&ply[..header_end]).contains("element face 4"));
        // 4 vertices × (6 floats + 3 bytes) + 4 faces × (1 + 3 ints).
        assert_eq!(ply.len() - header_end, 4 * (24 + 3) + 4 * 13);
        let obj = obj_text(&m);
        assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), 4);
        assert!(obj.contains("f 1//1 3//3 2//2"));
        let stl = stl_bytes(&m).unwrap();
        let back = stl_io::read_stl(&mut std::io::Cursor::new(stl)).unwrap();
        assert_eq!(back.faces.len(), 4);
        assert_eq!(back.vertices.len(), 4);
        assert_eq!(MeshFormat::from_path(Path::new("a/b.PLY")), Ok(MeshFormat::Ply));
        assert!(MeshFormat::from_path(Path::new("a.gltf")).is_err());
    }
}
