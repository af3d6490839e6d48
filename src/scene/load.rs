//! Where a scene comes from: a built-in name or a TOML file, parsed and then validated, so that
//! what comes out can be trusted by the model builder.

use std::path::Path;

use super::builtin;
use super::error::{LoadError, SceneError, SceneOrigin};
use super::format::Scene;
use super::locate;
use super::mesh_file;
use super::validate;

/// A scene plus the text it came from, so later checks can still point at lines.
#[derive(Debug, Clone)]
pub struct LoadedScene {
    pub scene: Scene,
    pub origin: SceneOrigin,
    pub text: String,
}

/// Parse and validate scene text.
pub fn from_toml(text: &str, origin: SceneOrigin) -> Result<Scene, SceneError> {
    let mut scene: Scene =
        toml::from_str(text).map_err(|e| locate::from_toml_error(&e, text, &origin))?;
    let located = |(field, message): (String, String)| SceneError {
        position: locate::position_of(text, &field),
        origin: origin.clone(),
        field,
        message,
    };
    mesh_file::read_meshes(&mut scene, &origin).map_err(located)?;
    validate::validate(&scene).map_err(located)?;
    Ok(scene)
}

/// Load a built-in scene by name, or a TOML file by path.
pub fn load(name_or_path: &str) -> Result<LoadedScene, LoadError> {
    if let Some(b) = builtin::find(name_or_path) {
        return loaded(b.toml.to_owned(), SceneOrigin::BuiltIn(b.name.to_owned()));
    }
    let path = Path::new(name_or_path);
    if !path.exists() {
        return Err(LoadError::UnknownScene {
            name: name_or_path.to_owned(),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|source| LoadError::ReadScene {
        path: path.to_owned(),
        source,
    })?;
    loaded(text, SceneOrigin::File(path.to_owned()))
}

fn loaded(text: String, origin: SceneOrigin) -> Result<LoadedScene, LoadError> {
    let scene = from_toml(&text, origin.clone())?;
    Ok(LoadedScene {
        scene,
        origin,
        text,
    })
}
