//! Reading a mesh file into a [`TriMesh`]: OBJ through `tobj`, glTF and GLB through `gltf`.
//! Faces of many corners are split into fans; vertices at the same position are welded, so a
//! seam the exporter split (by normals or texture coordinates) is one edge again.

use std::collections::HashMap;

use glam::{Mat4, Vec3};

use super::guard::{AccessorProblem, check_accessors, node_cycle, without_panics};
use super::tri_mesh::TriMesh;

/// The formats read, from a file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Obj,
    /// glTF 2.0, as JSON (`.gltf`) or binary (`.glb`): `gltf` tells them apart by their bytes.
    Gltf,
}

impl Format {
    pub fn of_path(path: &str) -> Option<Self> {
        let ext = std::path::Path::new(path)
            .extension()?
            .to_string_lossy()
            .to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(Format::Obj),
            "gltf" | "glb" => Some(Format::Gltf),
            _ => None,
        }
    }
}

/// What can be wrong with a mesh file.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("the OBJ reader refused it: {0}")]
    Obj(#[from] tobj::LoadError),
    #[error("the glTF reader refused it: {0}")]
    Gltf(#[from] gltf::Error),
    #[error("its buffer {index} ('{uri}') could not be read: {source}")]
    Buffer {
        index: usize,
        uri: String,
        source: std::io::Error,
    },
    #[error("its buffer {index} is a data URI that is not base64: {source}")]
    DataUri {
        index: usize,
        source: base64::DecodeError,
    },
    #[error("its mesh {mesh} reads accessor {accessor}, but {problem}")]
    BadAccessor {
        mesh: usize,
        accessor: usize,
        problem: AccessorProblem,
    },
    #[error(
        "its node {node} is its own ancestor (or has two parents): glTF's nodes form trees; fix \
         the `children` lists"
    )]
    NodeCycle { node: usize },
    #[error(
        "the {reader} reader failed inside (a panic, caught): the file is malformed in a way it \
         does not check; re-export it"
    )]
    ReaderPanicked { reader: &'static str },
    #[error("its buffer {index} is the GLB's binary chunk, but the file has none")]
    NoBinaryChunk { index: usize },
    #[error("it has no triangles: {0}")]
    NoTriangles(Faceless),
    #[error("a coordinate of vertex {vertex} is not finite ({value:?})")]
    NotFinite { vertex: usize, value: [f32; 3] },
    #[error("it has {count} triangles, more than the {max} a body may have")]
    TooLarge { count: usize, max: usize },
}

/// Why a file gave no triangles: the first part of it that gave none, and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Faceless {
    #[error("a body needs faces (OBJ `f` lines, glTF primitives in TRIANGLES mode)")]
    NoFaces,
    #[error("the file holds no mesh")]
    NoMeshes,
    #[error(
        "its scene places none of its {meshes} mesh(es) on a node; give a node of the scene \
         `\"mesh\": 0`"
    )]
    NotPlaced { meshes: usize },
    #[error(
        "mesh {mesh}'s primitive {primitive} is in mode {mode}, and only TRIANGLES make a \
         surface; export it as triangles"
    )]
    NotTriangles {
        mesh: usize,
        primitive: usize,
        mode: String,
    },
    #[error(
        "mesh {mesh}'s primitive {primitive} has indices up to {index}, past its {vertices} \
         vertices"
    )]
    IndexPastVertices {
        mesh: usize,
        primitive: usize,
        index: u32,
        vertices: usize,
    },
}

/// The most triangles one mesh body may have (a million: a cloth of about 500 000 masses, past
/// what a scene may hold anyway).
pub const MAX_TRIANGLES: usize = 1 << 20;

fn bad_accessor((mesh, accessor, problem): (usize, usize, AccessorProblem)) -> MeshError {
    MeshError::BadAccessor {
        mesh,
        accessor,
        problem,
    }
}

/// Read `bytes` as `format`; `external` reads a glTF's other files (its buffers) by their URI.
pub fn read(
    bytes: &[u8],
    format: Format,
    external: &dyn Fn(&str) -> std::io::Result<Vec<u8>>,
) -> Result<TriMesh, MeshError> {
    let mut w = Welder::default();
    let (reader, read) = match format {
        Format::Obj => ("tobj", without_panics(|| read_obj(bytes, &mut w))),
        Format::Gltf => (
            "gltf",
            without_panics(|| read_gltf(bytes, external, &mut w)),
        ),
    };
    read.ok_or(MeshError::ReaderPanicked { reader })??;
    w.finish()
}

/// Gathers faces from every part of a file into one mesh, a vertex per distinct position.
#[derive(Default)]
struct Welder {
    index_of: HashMap<[u32; 3], u32>,
    mesh: TriMesh,
    /// The first part of the file that gave no faces, and why: what a file without triangles
    /// is told.
    faceless: Option<Faceless>,
}

impl Welder {
    /// Note why a part gave no faces, unless an earlier part's reason is noted.
    fn faceless_because(&mut self, why: Faceless) {
        self.faceless.get_or_insert(why);
    }

    fn vertex(&mut self, p: [f32; 3]) -> Result<u32, MeshError> {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(MeshError::NotFinite {
                vertex: self.mesh.positions.len(),
                value: p,
            });
        }
        // +0 and −0 are one point.
        let key = p.map(|c| (c + 0.0).to_bits());
        let next = self.mesh.positions.len() as u32;
        let v = *self.index_of.entry(key).or_insert(next);
        if v == next {
            self.mesh.positions.push(Vec3::from(p));
        }
        Ok(v)
    }

    /// A face of any number of corners: a triangle, a quad (kept for its diagonals), or a fan.
    fn face(&mut self, corners: &[u32], group: &mut Vec<u32>) -> Result<(), MeshError> {
        if corners.len() < 3 {
            return Ok(());
        }
        if self.mesh.triangles.len() + corners.len() - 2 > MAX_TRIANGLES {
            return Err(MeshError::TooLarge {
                count: self.mesh.triangles.len() + corners.len() - 2,
                max: MAX_TRIANGLES,
            });
        }
        for k in 1..corners.len() - 1 {
            self.mesh
                .triangles
                .push([corners[0], corners[k], corners[k + 1]]);
        }
        if let [a, b, c, d] = *corners {
            self.mesh.quads.push([a, b, c, d]);
        }
        group.extend_from_slice(corners);
        Ok(())
    }

    fn group(&mut self, name: String, mut vertices: Vec<u32>) {
        if name.is_empty() || vertices.is_empty() {
            return;
        }
        vertices.sort_unstable();
        vertices.dedup();
        match self.mesh.groups.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => {
                v.extend(vertices);
                v.sort_unstable();
                v.dedup();
            }
            None => self.mesh.groups.push((name, vertices)),
        }
    }

    /// The mesh, without the vertices no triangle uses (a glTF primitive may hold some): a mass
    /// there would have no area, so no mass.
    fn finish(self) -> Result<TriMesh, MeshError> {
        let mut mesh = self.mesh;
        if mesh.triangles.is_empty() {
            let why = self.faceless.unwrap_or(Faceless::NoFaces);
            return Err(MeshError::NoTriangles(why));
        }
        const UNUSED: u32 = u32::MAX;
        let mut new_of = vec![UNUSED; mesh.positions.len()];
        let mut positions = Vec::with_capacity(mesh.positions.len());
        for t in &mut mesh.triangles {
            for v in t.iter_mut() {
                let n = &mut new_of[*v as usize];
                if *n == UNUSED {
                    *n = positions.len() as u32;
                    positions.push(mesh.positions[*v as usize]);
                }
                *v = *n;
            }
        }
        mesh.positions = positions;
        for q in &mut mesh.quads {
            *q = q.map(|v| new_of[v as usize]);
        }
        for (_, vertices) in &mut mesh.groups {
            vertices.retain(|&v| new_of[v as usize] != UNUSED);
            for v in vertices.iter_mut() {
                *v = new_of[*v as usize];
            }
            vertices.sort_unstable();
        }
        mesh.groups.retain(|(_, v)| !v.is_empty());
        Ok(mesh)
    }
}

fn read_obj(bytes: &[u8], w: &mut Welder) -> Result<(), MeshError> {
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are the renderer's business: none is read.
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &options, |_| {
        Ok(Default::default())
    })?;
    for model in models {
        let m = &model.mesh;
        let vertices: Vec<u32> = m
            .positions
            .chunks_exact(3)
            .map(|p| w.vertex([p[0], p[1], p[2]]))
            .collect::<Result<_, _>>()?;
        let corner = |i: &u32| vertices.get(*i as usize).copied();
        let mut group = Vec::new();
        let mut at = 0usize;
        let arities: Vec<u32> = if m.face_arities.is_empty() {
            vec![3; m.indices.len() / 3]
        } else {
            m.face_arities.clone()
        };
        for arity in arities {
            let end = at + arity as usize;
            let Some(face) = m.indices.get(at..end) else {
                break;
            };
            let corners: Option<Vec<u32>> = face.iter().map(corner).collect();
            at = end;
            let Some(corners) = corners else {
                return Err(MeshError::Obj(tobj::LoadError::FaceVertexOutOfBounds));
            };
            w.face(&corners, &mut group)?;
        }
        w.group(model.name, group);
    }
    Ok(())
}

fn read_gltf(
    bytes: &[u8],
    external: &dyn Fn(&str) -> std::io::Result<Vec<u8>>,
    w: &mut Welder,
) -> Result<(), MeshError> {
    let raw = gltf::Gltf::from_slice_without_validation(bytes)?;
    // gltf 1.4's validation indexes the accessors by a primitive's attributes without a bounds
    // check (a panic on a corrupt file): those indices are checked here first.
    check_accessors(raw.as_json(), None).map_err(bad_accessor)?;
    let doc = gltf::Gltf {
        blob: raw.blob,
        document: gltf::Document::from_json(raw.document.into_json())?,
    };
    let buffers = doc
        .buffers()
        .map(|b| buffer_data(&doc, &b, external))
        .collect::<Result<Vec<_>, _>>()?;
    check_accessors(doc.as_json(), Some(&buffers)).map_err(bad_accessor)?;
    // Nodes of the default scene (or the first) with their world transforms; a file with no
    // scene gives its meshes as they are.
    let mut placed: Vec<(gltf::Node, Mat4)> = Vec::new();
    let meshes = doc.meshes().count();
    if meshes == 0 {
        w.faceless_because(Faceless::NoMeshes);
    }
    if let Some(scene) = doc.default_scene().or_else(|| doc.scenes().next()) {
        let children: Vec<Vec<usize>> = doc
            .nodes()
            .map(|n| n.children().map(|c| c.index()).collect())
            .collect();
        let roots: Vec<usize> = scene.nodes().map(|n| n.index()).collect();
        if let Some(node) = node_cycle(&children, &roots) {
            return Err(MeshError::NodeCycle { node });
        }
        let mut stack: Vec<(gltf::Node, Mat4)> =
            scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            stack.extend(node.children().map(|c| (c, world)));
            placed.push((node, world));
        }
        placed.sort_by_key(|(n, _)| n.index());
        if meshes > 0 && placed.iter().all(|(n, _)| n.mesh().is_none()) {
            w.faceless_because(Faceless::NotPlaced { meshes });
        }
        for (node, world) in placed {
            if let Some(mesh) = node.mesh() {
                let name = node.name().or(mesh.name()).unwrap_or_default().to_owned();
                gltf_mesh(&mesh, world, &buffers, name, w)?;
            }
        }
    } else {
        for mesh in doc.meshes() {
            let name = mesh.name().unwrap_or_default().to_owned();
            gltf_mesh(&mesh, Mat4::IDENTITY, &buffers, name, w)?;
        }
    }
    Ok(())
}

fn gltf_mesh(
    mesh: &gltf::Mesh,
    world: Mat4,
    buffers: &[Vec<u8>],
    name: String,
    w: &mut Welder,
) -> Result<(), MeshError> {
    let mut group = Vec::new();
    for (primitive, prim) in mesh.primitives().enumerate() {
        let at = (mesh.index(), primitive);
        if prim.mode() != gltf::mesh::Mode::Triangles {
            w.faceless_because(Faceless::NotTriangles {
                mesh: at.0,
                primitive,
                mode: format!("{:?}", prim.mode()).to_uppercase(),
            });
            continue;
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        // The reader's validation already refused a primitive without POSITION.
        let Some(positions) = reader.read_positions() else {
            continue;
        };
        let vertices: Vec<u32> = positions
            .map(|p| w.vertex(world.transform_point3(Vec3::from(p)).to_array()))
            .collect::<Result<_, _>>()?;
        let indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None => (0..vertices.len() as u32).collect(),
        };
        for t in indices.chunks_exact(3) {
            let corners: Option<Vec<u32>> = t
                .iter()
                .map(|&i| vertices.get(i as usize).copied())
                .collect();
            // An index past the vertices is the file's error; the reader stops at the accessor's
            // end, so a face that reaches past it is left out rather than invented.
            match corners {
                Some(c) => w.face(&c, &mut group)?,
                None => w.faceless_because(Faceless::IndexPastVertices {
                    mesh: at.0,
                    primitive,
                    index: t.iter().copied().max().unwrap_or(0),
                    vertices: vertices.len(),
                }),
            }
        }
    }
    w.group(name, group);
    Ok(())
}

fn buffer_data(
    doc: &gltf::Gltf,
    buffer: &gltf::Buffer,
    external: &dyn Fn(&str) -> std::io::Result<Vec<u8>>,
) -> Result<Vec<u8>, MeshError> {
    use base64::Engine as _;
    let index = buffer.index();
    match buffer.source() {
        gltf::buffer::Source::Bin => doc.blob.clone().ok_or(MeshError::NoBinaryChunk { index }),
        gltf::buffer::Source::Uri(uri) => {
            if let Some(data) = uri.strip_prefix("data:") {
                let payload = data.split_once(";base64,").map_or(data, |(_, p)| p);
                base64::engine::general_purpose::STANDARD
                    .decode(payload)
                    .map_err(|source| MeshError::DataUri { index, source })
            } else {
                external(uri).map_err(|source| MeshError::Buffer {
                    index,
                    uri: uri.to_owned(),
                    source,
                })
            }
        }
    }
}
