//! A mesh's fingerprint that ignores how its vertices and triangles are
//! numbered: two meshes with the same triangles (each as the exact bits of
//! its corners, orientation kept) and the same vertices (position, normal and
//! colour bits) share it, in whatever order they list them. Tests hold the
//! polygonizer's meshes to fingerprints recorded before its stores changed.

use super::Mesh;

/// FNV-1a, 64 bits: stable across platforms and compiler versions, unlike
/// the standard library's hasher.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn words(&mut self, words: impl IntoIterator<Item = u32>) {
        for w in words {
            for byte in w.to_le_bytes() {
                self.0 = (self.0 ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
}

impl Mesh {
    /// The fingerprint of the set of triangles and the set of vertices.
    #[must_use]
    pub fn digest(&self) -> u64 {
        let mut fnv = Fnv::new();
        fnv.words([self.triangles.len() as u32, self.positions.len() as u32]);
        for t in self.triangle_set() {
            fnv.words(t.into_iter().flatten());
        }
        let bits = |v: Option<&glam::Vec3>| v.map_or([u32::MAX; 3], |v| v.to_array().map(f32::to_bits));
        let mut vertices: Vec<[[u32; 3]; 3]> = (0..self.positions.len())
            .map(|i| {
                let colour = self.colors.as_ref().and_then(|c| c.get(i));
                [bits(self.positions.get(i)), bits(self.normals.get(i)), bits(colour)]
            })
            .collect();
        vertices.sort_unstable();
        for v in vertices {
            fnv.words(v.into_iter().flatten());
        }
        fnv.0
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn mesh() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            normals: vec![Vec3::Z; 4],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Mesh::default()
        }
    }

    #[test]
    fn renumbering_keeps_the_digest_and_any_change_moves_it() {
        let m = mesh();
        // Vertices numbered backwards, triangles listed the other way round and rotated.
        let renumbered = Mesh {
            positions: m.positions.iter().rev().copied().collect(),
            normals: m.normals.clone(),
            triangles: vec![[1, 0, 3], [2, 1, 3]],
            ..Mesh::default()
        };
        assert_eq!(m.digest(), renumbered.digest());
        let mut flipped = m.clone();
        flipped.triangles[0] = [0, 2, 1];
        assert_ne!(m.digest(), flipped.digest(), "orientation counts");
        let mut moved = m.clone();
        moved.positions[3].z = f32::from_bits(1.0f32.to_bits() + 1);
        assert_ne!(m.digest(), moved.digest(), "one bit of one position counts");
        let mut turned = m.clone();
        turned.normals[2] = Vec3::X;
        assert_ne!(m.digest(), turned.digest(), "normals count");
    }
}
