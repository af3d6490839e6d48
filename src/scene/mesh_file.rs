//! A mesh body's file: beside the scene file (its path is relative to the scene's folder), or
//! compiled in for a built-in scene, read into the body's `surface` before validation.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::builtin;
use super::error::SceneOrigin;
use super::format::Scene;
use crate::mesh::{self, Format};

/// Read every mesh body's file; on failure the field and what is wrong.
pub(super) fn read_meshes(scene: &mut Scene, origin: &SceneOrigin) -> Result<(), (String, String)> {
    for (i, body) in scene.bodies.iter_mut().enumerate() {
        // A body with a grid too is refused by validation, which says so: nothing to read.
        let Some(name) = body.mesh.clone().filter(|_| body.grid.is_empty()) else {
            continue;
        };
        let field = format!("bodies[{i}].mesh");
        let Some(format) = Format::of_path(&name) else {
            return Err((
                field,
                format!("'{name}' is neither OBJ nor glTF: give a .obj, .gltf or .glb file"),
            ));
        };
        let source = Source::of(origin);
        let bytes = source.read(&name).map_err(|e| {
            (
                field.clone(),
                format!(
                    "cannot read the mesh file {}: {e}; {}",
                    source.shown(&name),
                    source.hint()
                ),
            )
        })?;
        let dir = Path::new(&name)
            .parent()
            .map(Path::to_owned)
            .unwrap_or_default();
        let external = |uri: &str| source.read(&dir.join(uri).to_string_lossy());
        let surface = mesh::read(&bytes, format, &external).map_err(|e| {
            (
                field.clone(),
                format!("the mesh file {}: {e}", source.shown(&name)),
            )
        })?;
        body.surface = Some(Arc::new(surface));
    }
    Ok(())
}

/// Where a scene's mesh paths lead.
enum Source {
    /// Relative to this folder.
    Folder(PathBuf),
    /// The meshes compiled in beside the built-in scenes.
    BuiltIn,
}

impl Source {
    fn of(origin: &SceneOrigin) -> Self {
        match origin {
            SceneOrigin::File(p) => {
                Source::Folder(p.parent().map(Path::to_owned).unwrap_or_default())
            }
            SceneOrigin::BuiltIn(_) => Source::BuiltIn,
            SceneOrigin::Text => Source::Folder(PathBuf::new()),
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        match self {
            Source::Folder(dir) => dir.join(name),
            Source::BuiltIn => Path::new("examples/scenes").join(name),
        }
    }

    fn read(&self, name: &str) -> std::io::Result<Vec<u8>> {
        match self {
            Source::Folder(_) => std::fs::read(self.path(name)),
            Source::BuiltIn => builtin::mesh(name).map(<[u8]>::to_vec).ok_or_else(|| {
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such built-in mesh")
            }),
        }
    }

    fn shown(&self, name: &str) -> String {
        format!("'{}'", self.path(name).display())
    }

    fn hint(&self) -> String {
        match self {
            Source::Folder(dir) if dir.as_os_str().is_empty() => {
                "the path is taken relative to the current folder".to_owned()
            }
            Source::Folder(dir) => format!(
                "the path is taken relative to the scene file's folder ({})",
                dir.display()
            ),
            Source::BuiltIn => "the built-in scenes' meshes are under examples/meshes/".to_owned(),
        }
    }
}
