//! Particle files a `Points` node reads: PLY (ASCII, or binary of either
//! endianness), plain text XYZ or CSV (`x y z [radius]` a line, `#`
//! comments), and NumPy `.npy` arrays (N×3, or N×4 whose fourth column is
//! the radius). Every error names the file and the line (text) or the
//! point's index (binary).

use std::path::Path;
use std::sync::Arc;

use rayon::prelude::*;

use glam::Vec3;

use super::desc::MAX_PRIMITIVES;
use crate::frame::srgb8_to_linear;

/// Points read from a file, with what each may carry of its own.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// Centres.
    pub positions: Vec<Vec3>,
    /// Support radii, where the file gives them.
    pub radius: Option<Vec<f32>>,
    /// Weights, where the file gives them.
    pub weight: Option<Vec<f32>>,
    /// Linear RGB colours, where the file gives them.
    pub color: Option<Vec<Vec3>>,
}

/// A point cloud read once and shared by every copy of the description holding it.
#[derive(Clone, Debug, Default)]
pub struct LoadedCloud(pub Option<Arc<PointCloud>>);

impl PartialEq for LoadedCloud {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b) || a == b,
            (None, None) => true,
            _ => false,
        }
    }
}

/// The largest particle file read: ten million points (the most a scene
/// builds) of text lines up to about 100 bytes each.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Reads the particle file at `path`, choosing the format by its extension;
/// a file larger than [`MAX_FILE_BYTES`] is refused before it is read.
pub fn read_points(path: &Path) -> Result<PointCloud, String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let size = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if size > MAX_FILE_BYTES {
        return Err(format!(
            "{} MB, more than the {} MB a particle file may hold (the most a scene builds is ten million points)",
            size >> 20,
            MAX_FILE_BYTES >> 20
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let cloud = match ext.as_str() {
        "ply" => read_ply(&bytes)?,
        "xyz" | "csv" | "txt" => read_text(&bytes)?,
        "npy" => read_npy(&bytes)?,
        _ => return Err(format!("unknown particle format \".{ext}\": use .ply, .xyz, .csv, .txt or .npy")),
    };
    check(&cloud)?;
    Ok(cloud)
}

/// Refuses values no primitive can take: non-finite numbers, radii that are not positive.
fn check(cloud: &PointCloud) -> Result<(), String> {
    if cloud.positions.is_empty() {
        return Err("holds no point".into());
    }
    for (i, p) in cloud.positions.iter().enumerate() {
        if !p.is_finite() || p.abs().max_element() > crate::field::MAX_MAGNITUDE {
            return Err(format!("point {i}: position {p} is not finite or beyond 1e6"));
        }
    }
    let bad = |values: &Option<Vec<f32>>, what: &str, ok: fn(f32) -> bool| {
        let found = values.as_ref().and_then(|v| v.iter().position(|&x| !ok(x)));
        found.map_or(Ok(()), |i| Err(format!("point {i}: {what} {} is refused", values.as_ref().unwrap()[i])))
    };
    bad(&cloud.radius, "radius (must be > 0 and finite)", |r| r.is_finite() && r > 0.0)?;
    bad(&cloud.weight, "weight (must be finite)", f32::is_finite)?;
    Ok(())
}

/// Refuses more points than a scene may build, before anything is sized for them.
fn check_count(n: usize, what: &str) -> Result<(), String> {
    if n as u64 > MAX_PRIMITIVES {
        return Err(format!("{what} {n} points, more than the {MAX_PRIMITIVES} a scene may hold"));
    }
    Ok(())
}

/// Plain text: `x y z [radius]` a line, separated by spaces, tabs or commas.
fn read_text(bytes: &[u8]) -> Result<PointCloud, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?;
    let mut cloud = PointCloud::default();
    let (mut radii, mut with_radius) = (vec![], None);
    for (n, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        let fields: Vec<&str> = content.split([' ', '\t', ',']).filter(|f| !f.is_empty()).collect();
        if fields.is_empty() {
            continue;
        }
        let at = |k: usize| line.find(fields[k]).map_or(1, |c| c + 1);
        if !(3..=4).contains(&fields.len()) {
            return Err(format!("line {}:{}: expected x y z [radius], found {} values", n + 1, at(0), fields.len()));
        }
        let has_radius = fields.len() == 4;
        match with_radius {
            Some(true) if !has_radius => {
                return Err(format!("line {}: no radius, where the lines before have one", n + 1));
            }
            Some(false) if has_radius => {
                return Err(format!("line {}: a radius, where the lines before have none", n + 1));
            }
            _ => with_radius = Some(has_radius),
        }
        let mut values = [0.0f32; 4];
        for (k, f) in fields.iter().enumerate() {
            values[k] = f.parse().map_err(|_| format!("line {}:{}: \"{f}\" is not a number", n + 1, at(k)))?;
        }
        cloud.positions.push(Vec3::new(values[0], values[1], values[2]));
        if has_radius {
            radii.push(values[3]);
        }
    }
    cloud.radius = (with_radius == Some(true)).then_some(radii);
    Ok(cloud)
}

/// A PLY property's scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// The value at the start of `b`, in `big` or little endian order.
    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let a: [u8; $n] = b[..$n].try_into().expect("sized");
                f64::from(if big { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) })
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => num!(i16, 2),
            Scalar::U16 => num!(u16, 2),
            Scalar::I32 => num!(i32, 4),
            Scalar::U32 => num!(u32, 4),
            Scalar::F32 => num!(f32, 4),
            Scalar::F64 => {
                let a: [u8; 8] = b[..8].try_into().expect("sized");
                if big { f64::from_be_bytes(a) } else { f64::from_le_bytes(a) }
            }
        }
    }
}

/// How a PLY file stores its vertices.
struct PlyHeader {
    format: PlyFormat,
    count: usize,
    properties: Vec<(String, Scalar)>,
    /// Where the body starts.
    body: usize,
}

#[derive(Clone, Copy, PartialEq)]
enum PlyFormat {
    Ascii,
    Binary { big: bool },
}

fn read_ply_header(bytes: &[u8]) -> Result<PlyHeader, String> {
    let end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or("no \"end_header\" line: not a PLY file, or its header is cut short")?;
    let body = end + 10 + bytes[end + 10..].iter().position(|&b| b == b'\n').map_or(0, |p| p + 1);
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| "the header is not text")?;
    let mut lines = header.lines().enumerate();
    if lines.next().map(|(_, l)| l.trim()) != Some("ply") {
        return Err("line 1: a PLY file starts with \"ply\"".into());
    }
    let (mut format, mut count, mut properties, mut element) = (None, None, vec![], None::<String>);
    for (n, line) in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        let here = |msg: String| format!("line {}: {msg}", n + 1);
        match words.as_slice() {
            ["format", "ascii", _] => format = Some(PlyFormat::Ascii),
            ["format", "binary_little_endian", _] => format = Some(PlyFormat::Binary { big: false }),
            ["format", "binary_big_endian", _] => format = Some(PlyFormat::Binary { big: true }),
            ["format", ..] => return Err(here(format!("unknown format \"{line}\""))),
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, n_items] => {
                if count.is_some() && element.as_deref() == Some("vertex") {
                    // Elements after the vertices (faces) are not read.
                    element = Some((*name).to_string());
                    continue;
                }
                if *name != "vertex" {
                    return Err(here(format!("element \"{name}\" before the vertices: the vertices must come first")));
                }
                count = Some(n_items.parse::<usize>().map_err(|_| here(format!("\"{n_items}\" is no count")))?);
                element = Some((*name).to_string());
            }
            ["property", "list", ..] if element.as_deref() == Some("vertex") => {
                return Err(here("a list property on the vertices is not supported".into()));
            }
            ["property", ty, name] if element.as_deref() == Some("vertex") => {
                let scalar = Scalar::parse(ty).ok_or_else(|| here(format!("unknown property type \"{ty}\"")))?;
                properties.push(((*name).to_string(), scalar));
            }
            ["property", ..] => {}
            _ => return Err(here(format!("unexpected header line \"{line}\""))),
        }
    }
    let format = format.ok_or("the header names no format")?;
    let count = count.ok_or("the header has no \"element vertex\"")?;
    check_count(count, "the header declares")?;
    for axis in ["x", "y", "z"] {
        if !properties.iter().any(|(n, _)| n == axis) {
            return Err(format!("the vertices have no \"{axis}\" property"));
        }
    }
    Ok(PlyHeader { format, count, properties, body })
}

fn read_ply(bytes: &[u8]) -> Result<PointCloud, String> {
    let h = read_ply_header(bytes)?;
    let values: Vec<f64> = match h.format {
        PlyFormat::Ascii => ascii_rows(bytes, &h)?,
        PlyFormat::Binary { big } => binary_rows(bytes, &h, big)?,
    };
    let rows = || values.chunks_exact(h.properties.len());
    let column = |name: &str| h.properties.iter().position(|(n, _)| n == name);
    let take = |k: usize| rows().map(|r| r[k] as f32).collect::<Vec<f32>>();
    let (x, y, z) = (column("x").unwrap(), column("y").unwrap(), column("z").unwrap());
    let positions = rows().map(|r| Vec3::new(r[x] as f32, r[y] as f32, r[z] as f32)).collect();
    let color = match (column("red"), column("green"), column("blue")) {
        (Some(r), Some(g), Some(b)) => {
            let byte = h.properties[r].1 == Scalar::U8;
            let channel = |v: f64| if byte { srgb8_to_linear(v as u8) } else { v as f32 };
            Some(rows().map(|row| Vec3::new(channel(row[r]), channel(row[g]), channel(row[b]))).collect())
        }
        _ => None,
    };
    Ok(PointCloud { positions, radius: column("radius").map(take), weight: column("weight").map(take), color })
}

/// The vertex table of an ASCII body, row after row, one value a property.
fn ascii_rows(bytes: &[u8], h: &PlyHeader) -> Result<Vec<f64>, String> {
    let body = std::str::from_utf8(&bytes[h.body..]).map_err(|_| "the body is not text")?;
    let header_lines = bytes[..h.body].iter().filter(|&&b| b == b'\n').count();
    let mut lines = body.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let width = h.properties.len();
    // A value takes two bytes of text at the least: a header claiming more
    // vertices than its body holds reserves no more than the body could fill.
    let mut table = Vec::with_capacity((h.count * width).min(body.len() / 2));
    for i in 0..h.count {
        let Some((n, line)) = lines.next() else {
            return Err(format!("vertex {i}: the file ends after {i} of its {} vertices", h.count));
        };
        let start = table.len();
        for value in line.split_whitespace() {
            let value = value.parse::<f64>();
            table.push(value.map_err(|_| format!("line {}: a value is not a number", header_lines + n + 1))?);
        }
        let found = table.len() - start;
        if found < width {
            return Err(format!("line {}: {found} values where the header declares {width}", header_lines + n + 1));
        }
        // Values past the declared properties are not read.
        table.truncate(start + width);
    }
    Ok(table)
}

/// The vertex table of a binary body, row after row, one value a property
/// (one flat table read in parallel: a list a vertex took a million
/// allocations and 56 MB for a million points).
fn binary_rows(bytes: &[u8], h: &PlyHeader, big: bool) -> Result<Vec<f64>, String> {
    let stride: usize = h.properties.iter().map(|(_, s)| s.size()).sum();
    let body = &bytes[h.body..];
    let need = stride.checked_mul(h.count).ok_or("the vertex count overflows")?;
    if body.len() < need {
        let whole = body.len() / stride.max(1);
        return Err(format!("vertex {whole}: the body ends after {whole} of the header's {} vertices", h.count));
    }
    let width = h.properties.len();
    let mut table = vec![0.0; h.count * width];
    table.par_chunks_mut(width.max(1)).zip(body[..need].par_chunks_exact(stride.max(1))).for_each(|(out, row)| {
        let mut at = 0;
        for (value, (_, s)) in out.iter_mut().zip(&h.properties) {
            *value = s.read(&row[at..], big);
            at += s.size();
        }
    });
    Ok(table)
}

/// A NumPy array: `float32` or `float64`, C order, shape `(N, 3)` or `(N, 4)`.
fn read_npy(bytes: &[u8]) -> Result<PointCloud, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a NumPy .npy file (no magic string)".into());
    }
    let (len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        v => return Err(format!("unknown .npy version {v}")),
    };
    let header = bytes.get(start..start + len).ok_or("the header is cut short")?;
    let header = std::str::from_utf8(header).map_err(|_| "the header is not text")?;
    let descr = dict_value(header, "descr").ok_or("the header has no 'descr'")?;
    let (scalar, big) = match descr.trim_matches(['\'', '"']) {
        "<f4" => (Scalar::F32, false),
        ">f4" => (Scalar::F32, true),
        "<f8" => (Scalar::F64, false),
        ">f8" => (Scalar::F64, true),
        d => return Err(format!("dtype {d}: only float32 and float64 arrays are read")),
    };
    if dict_value(header, "fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err("a Fortran-order array: save it in C order".into());
    }
    let shape = dict_value(header, "shape").ok_or("the header has no 'shape'")?;
    let dims: Vec<usize> =
        shape.trim_start_matches('(').split([',', ')']).filter_map(|d| d.trim().parse().ok()).collect();
    let [n, width] = dims[..] else { return Err(format!("shape {shape}: expected (N, 3) or (N, 4)")) };
    check_count(n, "the shape holds")?;
    if width != 3 && width != 4 {
        return Err(format!("shape ({n}, {width}): expected (N, 3) or (N, 4)"));
    }
    let data = &bytes[start + len..];
    let need = n * width * scalar.size();
    if data.len() < need {
        let whole = data.len() / (width * scalar.size());
        return Err(format!("point {whole}: the data ends after {whole} of the shape's {n} points"));
    }
    let value = |i: usize, k: usize| scalar.read(&data[(i * width + k) * scalar.size()..], big) as f32;
    let positions = (0..n).map(|i| Vec3::new(value(i, 0), value(i, 1), value(i, 2))).collect();
    let radius = (width == 4).then(|| (0..n).map(|i| value(i, 3)).collect());
    Ok(PointCloud { positions, radius, weight: None, color: None })
}

/// The text after `'key':` in a NumPy header's dictionary, up to the next key.
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header.find(&format!("'{key}'"))? + key.len() + 2;
    let rest = header[at..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') { rest.find(')')? + 1 } else { rest.find([',', '}'])? };
    Some(rest[..end].trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ply(format: &str, body: &[u8], properties: &str, n: usize) -> Vec<u8> {
        let mut out = format!("ply\nformat {format} 1.0\ncomment test\nelement vertex {n}\n{properties}end_header\n")
            .into_bytes();
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn ply_in_ascii_and_either_endianness_reads_the_same_points() {
        let points = [[1.0f32, 2.0, 3.0, 0.5], [-4.0, 5.5, 6.25, 0.75]];
        let props = "property float x\nproperty float y\nproperty float z\nproperty float radius\n";
        let ascii: String = points.iter().map(|p| format!("{} {} {} {}\n", p[0], p[1], p[2], p[3])).collect();
        let le: Vec<u8> = points.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let be: Vec<u8> = points.iter().flatten().flat_map(|v| v.to_be_bytes()).collect();
        let read = |bytes: Vec<u8>| read_ply(&bytes).unwrap();
        let a = read(ply("ascii", ascii.as_bytes(), props, 2));
        assert_eq!(a.positions, vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 5.5, 6.25)]);
        assert_eq!(a.radius, Some(vec![0.5, 0.75]));
        assert_eq!(read(ply("binary_little_endian", &le, props, 2)), a);
        assert_eq!(read(ply("binary_big_endian", &be, props, 2)), a);
    }

    #[test]
    fn ply_colours_as_bytes_are_srgb_and_as_floats_linear() {
        let bytes_props = "property double x\nproperty double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n";
        let mut body = vec![];
        for v in [0.0f64, 1.0, 2.0] {
            body.extend_from_slice(&v.to_le_bytes());
        }
        body.extend_from_slice(&[255, 128, 0]);
        let c = read_ply(&ply("binary_little_endian", &body, bytes_props, 1)).unwrap();
        let color = c.color.unwrap()[0];
        assert_eq!(color.x, 1.0);
        assert!((color.y - 0.2158605).abs() < 1e-5, "sRGB 128 is linear 0.216, not 0.5: {color}");
        let float_props = "property float x\nproperty float y\nproperty float z\nproperty float red\nproperty float green\nproperty float blue\n";
        let c = read_ply(&ply("ascii", b"0 1 2 0.5 0.25 1\n", float_props, 1)).unwrap();
        assert_eq!(c.color.unwrap()[0], Vec3::new(0.5, 0.25, 1.0));
    }

    #[test]
    fn bad_ply_files_say_where() {
        let props = "property float x\nproperty float y\nproperty float z\n";
        let err = |bytes: Vec<u8>| read_ply(&bytes).unwrap_err();
        let short = err(ply("binary_little_endian", &[0u8; 12 * 2 + 5], props, 3));
        assert!(short.contains("vertex 2") && short.contains("of the header's 3"), "{short}");
        let no_z = err(ply("ascii", b"1 2\n", "property float x\nproperty float y\n", 1));
        assert!(no_z.contains("no \"z\""), "{no_z}");
        let few = err(ply("ascii", b"1 2 3\n4 5\n", props, 2));
        assert!(few.contains("line 10") && few.contains("2 values"), "{few}");
        let missing = err(ply("ascii", b"1 2 3\n", props, 2));
        assert!(missing.contains("vertex 1: the file ends"), "{missing}");
        assert!(err(b"ply\nformat ascii 1.0\n".to_vec()).contains("end_header"));
    }

    #[test]
    fn text_points_take_spaces_commas_comments_and_radii() {
        let c = read_text(b"# a comment\n1 2 3\n4,5,6 # trailing\n\n7\t8\t9\n").unwrap();
        assert_eq!(c.positions.len(), 3);
        assert_eq!(c.positions[1], Vec3::new(4.0, 5.0, 6.0));
        assert!(c.radius.is_none());
        let r = read_text(b"1 2 3 0.5\n4 5 6 0.25\n").unwrap();
        assert_eq!(r.radius, Some(vec![0.5, 0.25]));
        let bad = read_text(b"1 2 3\n4 x 6\n").unwrap_err();
        assert_eq!(bad, "line 2:3: \"x\" is not a number");
        assert!(read_text(b"1 2 3\n4 5 6 7\n").unwrap_err().starts_with("line 2: a radius, where"));
        assert!(read_text(b"1 2\n").unwrap_err().starts_with("line 1:1: expected x y z"));
    }

    fn npy(descr: &str, shape: &str, data: &[u8]) -> Vec<u8> {
        let header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn npy_arrays_of_three_or_four_columns_in_either_precision() {
        let data: Vec<u8> = [1.0f64, 2.0, 3.0, 0.5, 4.0, 5.0, 6.0, 0.25].iter().flat_map(|v| v.to_le_bytes()).collect();
        let c = read_npy(&npy("<f8", "(2, 4)", &data)).unwrap();
        assert_eq!(c.positions[1], Vec3::new(4.0, 5.0, 6.0));
        assert_eq!(c.radius, Some(vec![0.5, 0.25]));
        let data: Vec<u8> = [1.0f32, 2.0, 3.0].iter().flat_map(|v| v.to_be_bytes()).collect();
        let c = read_npy(&npy(">f4", "(1, 3)", &data)).unwrap();
        assert_eq!(c.positions, vec![Vec3::new(1.0, 2.0, 3.0)]);
        assert!(read_npy(&npy("<f4", "(2, 3)", &data)).unwrap_err().starts_with("point 1: the data ends"));
        assert!(read_npy(&npy("<i4", "(1, 3)", &data)).unwrap_err().contains("only float32 and float64"));
        assert!(read_npy(&npy("<f4", "(1, 5)", &data)).unwrap_err().contains("expected (N, 3) or (N, 4)"));
    }

    #[test]
    fn counts_past_a_scenes_limit_are_refused_before_anything_is_sized() {
        let props = "property float x\nproperty float y\nproperty float z\n";
        let err = read_ply(&ply("ascii", b"1 2 3\n", props, 1 << 40)).unwrap_err();
        assert!(err.contains("1099511627776 points, more than"), "{err}");
        let err = read_npy(&npy("<f4", "(99999999999, 3)", &[])).unwrap_err();
        assert!(err.contains("more than"), "{err}");
    }

    #[test]
    fn refused_values_name_their_point() {
        let nan = PointCloud { positions: vec![Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)], ..Default::default() };
        assert!(check(&nan).unwrap_err().starts_with("point 1: position"));
        let zero = PointCloud { positions: vec![Vec3::ZERO; 2], radius: Some(vec![1.0, 0.0]), ..Default::default() };
        assert!(check(&zero).unwrap_err().starts_with("point 1: radius"));
    }
}
