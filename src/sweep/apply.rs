//! A point's values applied to the base scene's TOML: the scene a point runs is the base scene's
//! text with its values set, checked by the same loader as any scene file.

use super::file::{Key, Setting};

/// Set `setting` in `scene` (the scene file as a table). The backend is not a scene value and
/// leaves it as it is.
pub fn apply(scene: &mut toml::Table, setting: &Setting) -> Result<(), String> {
    match &setting.key {
        Key::Backend => Ok(()),
        Key::Integrator => {
            solver_table(scene)?.insert("integrator".into(), setting.value.clone());
            Ok(())
        }
        Key::Dt => {
            let dt = seconds_of(&setting.value)
                .ok_or_else(|| format!("{} is not a number of seconds", setting.value))?;
            let s = solver_table(scene)?;
            // A step replaces the scene's substeps (a scene gives one or the other).
            s.remove("substeps");
            s.insert("dt_secs".into(), toml::Value::Float(dt));
            Ok(())
        }
        Key::Substeps => {
            let s = solver_table(scene)?;
            s.remove("dt_secs");
            s.insert("substeps".into(), setting.value.clone());
            Ok(())
        }
        Key::Scene(path) => set_path(scene, path, setting.value.clone()),
    }
}

fn solver_table(scene: &mut toml::Table) -> Result<&mut toml::Table, String> {
    match scene
        .entry("solver")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
    {
        toml::Value::Table(t) => Ok(t),
        _ => Err("the scene's 'solver' is not a table".to_owned()),
    }
}

/// The seconds a `dt_secs` value gives: a number, or a string such as "1/60".
pub fn seconds_of(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::String(s) => crate::scene::compare_entry::seconds(s),
        _ => None,
    }
}

/// Set the value at the dotted `path`, making the tables on the way that the scene leaves out
/// (an effect it does not have yet). In an array of tables (`bodies`), a segment picks the
/// element with that `name`, or the one at that index.
fn set_path(scene: &mut toml::Table, path: &str, value: toml::Value) -> Result<(), String> {
    let segments: Vec<&str> = path.split('.').collect();
    let Some((last, ways)) = segments.split_last() else {
        return Err(format!("'{path}' is not a path into the scene"));
    };
    let mut table = scene;
    for (depth, seg) in ways.iter().enumerate() {
        let here = segments[..=depth].join(".");
        let next = table
            .entry(seg.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        table = match next {
            toml::Value::Table(t) => t,
            toml::Value::Array(items) => {
                let Some(pick) = segments.get(depth + 1) else {
                    return Err(format!("'{here}' is a list: name one of its elements"));
                };
                let names: Vec<String> = items
                    .iter()
                    .filter_map(|t| t.get("name").and_then(|n| n.as_str()).map(str::to_owned))
                    .collect();
                let index = match pick.parse::<usize>() {
                    Ok(i) if i < items.len() => i,
                    _ => names.iter().position(|n| n == pick).ok_or_else(|| {
                        format!(
                            "'{here}' has no element named '{pick}': it has {} (or give an index below {})",
                            if names.is_empty() {
                                "no named elements".to_owned()
                            } else {
                                names.join(", ")
                            },
                            items.len()
                        )
                    })?,
                };
                // The segment that picked the element is used up here.
                if depth + 2 > ways.len() {
                    return Err(format!(
                        "'{path}' names a whole element of '{here}': give a value inside it, e.g. {here}.{pick}.name"
                    ));
                }
                match &mut items[index] {
                    toml::Value::Table(t) => {
                        return set_path(t, &segments[depth + 2..].join("."), value)
                            .map_err(|e| format!("{e} (in {here}.{pick})"));
                    }
                    _ => return Err(format!("'{here}.{pick}' is not a table")),
                }
            }
            other => {
                return Err(format!(
                    "'{here}' is a value ({other}), not a table: '{path}' cannot be inside it"
                ));
            }
        };
    }
    if let Some(toml::Value::Array(_)) = table.get(*last)
        && !matches!(value, toml::Value::Array(_))
    {
        return Err(format!(
            "'{path}' is a list in the scene: give each of its values as a list too"
        ));
    }
    table.insert(last.to_string(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setting(name: &str, value: toml::Value) -> Setting {
        Setting {
            name: name.into(),
            key: match name {
                "dt_secs" => Key::Dt,
                _ => Key::Scene(name.into()),
            },
            value,
            at: None,
        }
    }

    #[test]
    fn a_path_through_a_named_body_sets_its_value_and_a_step_replaces_substeps() {
        let mut scene: toml::Table = toml::from_str(
            "[solver]\nsubsteps = 7\n[[bodies]]\nname = \"a\"\n[[bodies]]\nname = \"cloth\"\n[bodies.springs]\nstructural = { stiffness_n_per_m = 1.0 }\n",
        )
        .unwrap();
        let path = "bodies.cloth.springs.structural.stiffness_n_per_m";
        apply(&mut scene, &setting(path, toml::Value::Float(400.0))).unwrap();
        apply(&mut scene, &setting("dt_secs", "1/60".into())).unwrap();
        let bodies = scene["bodies"].as_array().unwrap();
        assert_eq!(
            bodies[1]["springs"]["structural"]["stiffness_n_per_m"].as_float(),
            Some(400.0)
        );
        assert!(bodies[0].get("springs").is_none());
        assert_eq!(scene["solver"]["dt_secs"].as_float(), Some(1.0 / 60.0));
        assert!(scene["solver"].get("substeps").is_none());
        let missing = apply(
            &mut scene,
            &setting("bodies.hat.mass_kg", toml::Value::Float(1.0)),
        );
        assert_eq!(
            missing.unwrap_err(),
            "'bodies' has no element named 'hat': it has a, cloth (or give an index below 2)"
        );
    }
}
