//! A welded triangle surface, as read from a file.

use glam::Vec3;

/// A surface of triangles whose corners are shared between faces (welded by position).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    /// Corners counter-clockwise as the file gives them.
    pub triangles: Vec<[u32; 3]>,
    /// The file's four-sided faces, corners in order: both diagonals are shear springs when the
    /// body asks for them (the triangles split each along its (0, 2) diagonal).
    pub quads: Vec<[u32; 4]>,
    /// Named vertex sets: an OBJ group or object, a glTF node (or its mesh), with the vertices of
    /// its faces.
    pub groups: Vec<(String, Vec<u32>)>,
}

impl TriMesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The vertices of the group named `name`.
    pub fn group(&self, name: &str) -> Option<&[u32]> {
        self.groups
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// Each triangle's area (in f64: large coordinates would overflow f32's products).
    pub fn areas(&self, positions: &[Vec3]) -> Vec<f64> {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| positions[v as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .collect()
    }
}
