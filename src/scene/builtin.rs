//! The built-in scenes are the TOML files under `examples/scenes/`, compiled in, so that
//! `hooke run NAME` and `hooke run examples/scenes/NAME.toml` run exactly the same thing.

pub struct BuiltIn {
    pub name: &'static str,
    pub toml: &'static str,
}

macro_rules! built_in {
    ($($name:literal),* $(,)?) => {
        &[$(BuiltIn { name: $name, toml: include_str!(concat!("../../examples/scenes/", $name, ".toml")) }),*]
    };
}

pub const BUILT_IN: &[BuiltIn] = built_in![
    "hair",
    "cloth",
    "jello",
    "jello-sphere",
    "tear",
    "ramp",
    "cloth-fold",
    "pile",
    "cloth-64",
    "cloth-256",
    "cloth-1024",
    "flag",
    "tablecloth",
    "blob"
];

pub fn find(name: &str) -> Option<&'static BuiltIn> {
    BUILT_IN.iter().find(|b| b.name == name)
}

/// The built-in scenes' meshes, by the path their scene names them with (from
/// `examples/scenes/`).
pub const BUILT_IN_MESHES: &[(&str, &[u8])] = &[
    (
        "../meshes/flag.obj",
        include_bytes!("../../examples/meshes/flag.obj"),
    ),
    (
        "../meshes/tablecloth.glb",
        include_bytes!("../../examples/meshes/tablecloth.glb"),
    ),
    (
        "../meshes/blob.obj",
        include_bytes!("../../examples/meshes/blob.obj"),
    ),
];

pub fn mesh(path: &str) -> Option<&'static [u8]> {
    BUILT_IN_MESHES
        .iter()
        .find(|(p, _)| *p == path)
        .map(|(_, b)| *b)
}
