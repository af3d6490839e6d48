//! `hooke scenes`: the built-in scenes, one line each.

use hooke::scene;

/// `hooke scenes`: each built-in scene and its one-line description.
pub fn scenes() -> anyhow::Result<()> {
    for b in scene::BUILT_IN {
        let s = scene::from_toml(b.toml, scene::SceneOrigin::BuiltIn(b.name.into()))?;
        println!("{:<14} {}", b.name, s.description);
    }
    println!(
        "\nEach is also a file under examples/scenes/; `hooke run FILE.toml` runs a copy you edit."
    );
    Ok(())
}
