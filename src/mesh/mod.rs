//! Triangle meshes a user brings (OBJ, glTF/GLB): read with the `tobj` and `gltf` crates into one
//! welded [`TriMesh`], their edges and their fill with a lattice. The data layer: the scene reads
//! a body's mesh with [`read`], the model builds springs and masses from it.

mod edges;
mod guard;
mod lattice;
mod order;
mod read;
mod tri_mesh;

pub use edges::{Edge, Edges};
pub use lattice::{Embedded, Lattice, LatticeNodes, cells_for};
pub use order::morton_order;
pub use read::{Format, MAX_TRIANGLES, MeshError, read};
pub use tri_mesh::TriMesh;
