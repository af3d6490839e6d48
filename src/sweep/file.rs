//! The sweep file: a base scene, the values every point shares (`[set]`), and either the axes of
//! a full grid (`[axes]`) or a list of points (`[[points]]`), with an optional reference
//! (`[reference]`) for an error column and `repeat` for timing. Every problem is one message
//! naming the file, its line and column, the key, and what would fix it.
//!
//! ```toml
//! scene = "cloth-64"
//! [axes]
//! integrator = ["semi-implicit", "verlet"]
//! dt_secs = ["1/6000", 2e-4]
//! "bodies.cloth.springs.structural.stiffness_n_per_m" = [100.0, 400.0]
//! ```

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::de::{DeTable, DeValue};

use crate::scene::line_col;

/// A 1-based line and column.
type LineCol = (usize, usize);

/// A problem with a sweep file, where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}{}: {message}", file.display(), at.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
pub struct SweepFileError {
    pub file: PathBuf,
    /// 1-based line and column, where known.
    pub at: Option<(usize, usize)>,
    pub message: String,
}

/// What one key of a point sets: a solver value Hooke knows by name, the backend, or any value
/// of the scene by its dotted path.
#[derive(Debug, Clone, PartialEq)]
pub enum Key {
    Integrator,
    /// `dt_secs`: a number of seconds or a fraction such as `"1/60"`.
    Dt,
    Substeps,
    Backend,
    /// A path into the scene, `bodies.cloth.springs.structural.stiffness_n_per_m`: a segment
    /// after an array of tables (`bodies`, `colliders`) picks its element by `name`, or by index.
    Scene(String),
}

impl Key {
    fn of(text: &str) -> Self {
        match text {
            "integrator" => Key::Integrator,
            "dt_secs" => Key::Dt,
            "substeps" => Key::Substeps,
            "backend" => Key::Backend,
            path => Key::Scene(path.to_owned()),
        }
    }
}

/// One value a point takes, and where the sweep file gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    /// As written in the file: `integrator`, `bodies.cloth.mass_kg`.
    pub name: String,
    pub key: Key,
    pub value: toml::Value,
    pub at: Option<(usize, usize)>,
}

/// A sweep file read and its points expanded, not yet applied to the scene (`plan` does that).
#[derive(Debug, Clone)]
pub struct SweepSpec {
    pub file: PathBuf,
    /// The base scene: a built-in name, or a path made absolute from the sweep file's folder.
    pub scene: String,
    /// Timed runs of each point; `None`: the sweep does not time (one run, its time kept).
    pub repeat: Option<u32>,
    /// Whether each point is recorded before it is timed (`record = false` saves the time and
    /// the disk when only the numbers matter).
    pub record: bool,
    /// Applied to every point, before its own values.
    pub set: Vec<Setting>,
    /// Each point's own values, in the grid's order (the first axis varies slowest).
    pub points: Vec<Vec<Setting>>,
    /// The names of what varies, in the file's order.
    pub varied: Vec<String>,
    /// The solver values of the reference every point's error is measured against.
    pub reference: Option<Vec<Setting>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    scene: String,
    #[serde(default)]
    repeat: Option<u32>,
    #[serde(default)]
    record: Option<bool>,
    #[serde(default)]
    set: Option<toml::Table>,
    #[serde(default)]
    axes: Option<toml::Table>,
    #[serde(default)]
    points: Option<Vec<toml::Table>>,
    #[serde(default)]
    reference: Option<toml::Table>,
}

/// The most points one sweep holds: a grid past it is almost always a mistake in an axis.
pub const MOST_POINTS: usize = 100_000;

/// Read and check the sweep file at `path`.
pub fn read(path: &Path) -> Result<SweepSpec, SweepFileError> {
    let text = std::fs::read_to_string(path).map_err(|e| SweepFileError {
        file: path.to_owned(),
        at: None,
        message: format!("cannot read the sweep file: {e}"),
    })?;
    parse(&text, path)
}

/// Check `text`, the sweep file at `path` (which relative scene paths start from).
pub fn parse(text: &str, path: &Path) -> Result<SweepSpec, SweepFileError> {
    let spans = DeTable::parse(text).map_err(|e| SweepFileError {
        file: path.to_owned(),
        at: e.span().map(|s| line_col(text, s.start)),
        message: e.message().trim().to_owned(),
    })?;
    let raw: Raw = toml::from_str(text).map_err(|e| SweepFileError {
        file: path.to_owned(),
        at: e.span().map(|s| line_col(text, s.start)),
        message: format!(
            "{} (a sweep file holds scene, repeat, record, [set], [axes] or [[points]], and [reference])",
            e.message().trim()
        ),
    })?;
    let place = Place {
        text,
        file: path,
        root: spans.get_ref(),
    };
    let fail = |at: Option<(usize, usize)>, message: String| SweepFileError {
        file: path.to_owned(),
        at,
        message,
    };
    let scene = match crate::scene::BUILT_IN.iter().any(|b| b.name == raw.scene) {
        true => raw.scene.clone(),
        false => {
            let p = path
                .parent()
                .unwrap_or(Path::new("."))
                .join(&raw.scene)
                .canonicalize()
                .map_err(|e| {
                    fail(
                        place.at(&["scene"], None),
                        format!(
                            "scene = \"{}\" is neither a built-in scene (`hooke scenes` lists them) nor a file next to the sweep file ({e})",
                            raw.scene
                        ),
                    )
                })?;
            p.to_string_lossy().into_owned()
        }
    };
    if raw.repeat == Some(0) {
        return Err(fail(
            place.at(&["repeat"], None),
            "repeat = 0 times nothing: give at least 1 (the median of the repeats is the point's time)".into(),
        ));
    }
    let set = match &raw.set {
        Some(t) => place.settings("set", t)?,
        None => Vec::new(),
    };
    let (points, varied) = match (&raw.axes, &raw.points) {
        (Some(_), Some(_)) => {
            return Err(fail(
                place.at(&["points"], None),
                "a sweep has [axes] (a full grid) or [[points]] (a list), not both: move the points' values into axes, or the axes into points".into(),
            ));
        }
        (Some(axes), None) => place.grid(axes)?,
        (None, Some(list)) => place.list(list)?,
        (None, None) => (vec![Vec::new()], Vec::new()),
    };
    if points.is_empty() {
        return Err(fail(
            place.at(&["points"], None),
            "the sweep has no points: give [axes] or at least one [[points]]".into(),
        ));
    }
    let reference = match &raw.reference {
        Some(t) => {
            let settings = place.settings("reference", t)?;
            if let Some(s) = settings.iter().find(|s| matches!(s.key, Key::Scene(_))) {
                return Err(fail(
                    s.at,
                    format!(
                        "[reference] sets only integrator, dt_secs, substeps and backend: '{}' would change the scene the error is measured on; vary it as an axis instead",
                        s.name
                    ),
                ));
            }
            Some(settings)
        }
        None => None,
    };
    Ok(SweepSpec {
        file: path.to_owned(),
        scene,
        repeat: raw.repeat,
        record: raw.record.unwrap_or(true),
        set,
        points,
        varied,
        reference,
    })
}

/// Where things are in the sweep file's text.
struct Place<'a> {
    text: &'a str,
    file: &'a Path,
    root: &'a DeTable<'a>,
}

impl Place<'_> {
    /// The line and column of the value at `path` (of its `index`-th element, for an array),
    /// or of its key where the value has no span of its own.
    fn at(&self, path: &[&str], index: Option<usize>) -> Option<(usize, usize)> {
        self.span(path, index).map(|s| line_col(self.text, s.start))
    }

    fn span(&self, path: &[&str], index: Option<usize>) -> Option<Range<usize>> {
        let mut table = self.root;
        let mut found = None;
        for (depth, seg) in path.iter().enumerate() {
            let (k, v) = table.iter().find(|(k, _)| k.get_ref().as_ref() == *seg)?;
            found = Some((k.span(), v));
            if depth + 1 < path.len() {
                match v.get_ref() {
                    DeValue::Table(t) => table = t,
                    _ => return None,
                }
            }
        }
        let (key_span, value) = found?;
        match (index, value.get_ref()) {
            (Some(i), DeValue::Array(items)) => items.get(i).map(|item| item.span()),
            _ => Some(key_span),
        }
    }

    /// The span of `[[points]]`' `n`-th table's `key` (or of the table).
    fn point_at(&self, n: usize, key: Option<&str>) -> Option<(usize, usize)> {
        let (_, v) = self
            .root
            .iter()
            .find(|(k, _)| k.get_ref().as_ref() == "points")?;
        let DeValue::Array(items) = v.get_ref() else {
            return None;
        };
        let item = items.get(n)?;
        let span = match (key, item.get_ref()) {
            (Some(key), DeValue::Table(t)) => t
                .iter()
                .find(|(k, _)| k.get_ref().as_ref() == key)
                .map(|(k, _)| k.span())
                .unwrap_or(item.span()),
            _ => item.span(),
        };
        Some(line_col(self.text, span.start))
    }

    fn error(&self, at: Option<(usize, usize)>, message: String) -> SweepFileError {
        SweepFileError {
            file: self.file.to_owned(),
            at,
            message,
        }
    }

    /// A table of single values (`[set]`, `[reference]`, one of `[[points]]`).
    fn settings(
        &self,
        table_name: &str,
        table: &toml::Table,
    ) -> Result<Vec<Setting>, SweepFileError> {
        let mut out: Vec<Setting> = table
            .iter()
            .map(|(name, value)| {
                let at = self.at(&[table_name, name], None);
                setting(name, value.clone(), at).map_err(|m| self.error(at, m))
            })
            .collect::<Result<_, _>>()?;
        out.sort_by_key(|s| s.at);
        Ok(out)
    }

    /// `[axes]` as a full grid, the first axis in the file varying slowest.
    fn grid(&self, axes: &toml::Table) -> Result<(Vec<Vec<Setting>>, Vec<String>), SweepFileError> {
        let mut columns: Vec<(Option<LineCol>, Vec<Setting>)> = Vec::new();
        for (name, value) in axes {
            let key_at = self.at(&["axes", name], None);
            let toml::Value::Array(values) = value else {
                return Err(self.error(
                    key_at,
                    format!(
                        "axis '{name}' is one value, {value}; an axis is a list: write {name} = [{value}] (or put a value every point shares in [set])"
                    ),
                ));
            };
            if values.is_empty() {
                return Err(self.error(
                    key_at,
                    format!("axis '{name}' is empty: give it at least one value, or leave it out"),
                ));
            }
            let column = values
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    let at = self.at(&["axes", name], Some(i)).or(key_at);
                    setting(name, v.clone(), at).map_err(|m| self.error(at, m))
                })
                .collect::<Result<Vec<_>, _>>()?;
            columns.push((key_at, column));
        }
        // The file's order, which the table (sorted by name) has lost.
        columns.sort_by_key(|(at, _)| *at);
        let count = columns
            .iter()
            .try_fold(1usize, |n, (_, c)| n.checked_mul(c.len()))
            .filter(|&n| n <= MOST_POINTS);
        let Some(count) = count else {
            return Err(self.error(
                self.at(&["axes"], None),
                format!(
                    "the axes make more than {MOST_POINTS} points: split the sweep, or shorten an axis"
                ),
            ));
        };
        let varied = columns.iter().map(|(_, c)| c[0].name.clone()).collect();
        let points = (0..count)
            .map(|mut n| {
                let mut point = Vec::with_capacity(columns.len());
                for (_, column) in columns.iter().rev() {
                    point.push(column[n % column.len()].clone());
                    n /= column.len();
                }
                point.reverse();
                point
            })
            .collect();
        Ok((points, varied))
    }

    /// `[[points]]` as they are listed.
    fn list(
        &self,
        list: &[toml::Table],
    ) -> Result<(Vec<Vec<Setting>>, Vec<String>), SweepFileError> {
        let mut varied: Vec<String> = Vec::new();
        let mut points = Vec::new();
        for (n, table) in list.iter().enumerate() {
            let mut point = Vec::new();
            for (name, value) in table {
                let at = self.point_at(n, Some(name));
                point.push(setting(name, value.clone(), at).map_err(|m| self.error(at, m))?);
                if !varied.contains(name) {
                    varied.push(name.clone());
                }
            }
            point.sort_by_key(|s| s.at);
            points.push(point);
        }
        Ok((points, varied))
    }
}

/// One `name = value`, its value checked for the kinds a key takes (what the scene itself
/// takes is checked when the value is applied to it).
fn setting(name: &str, value: toml::Value, at: Option<(usize, usize)>) -> Result<Setting, String> {
    let key = Key::of(name);
    let kind_ok = match (&key, &value) {
        (Key::Integrator, toml::Value::String(s)) => crate::integrator::Integrator::ALL
            .iter()
            .any(|i| i.name() == s),
        (Key::Integrator, _) => false,
        (Key::Dt, toml::Value::Float(f)) => f.is_finite() && *f > 0.0,
        (Key::Dt, toml::Value::Integer(i)) => *i > 0,
        (Key::Dt, toml::Value::String(s)) => {
            crate::scene::compare_entry::seconds(s).is_some_and(|f| f.is_finite() && f > 0.0)
        }
        (Key::Dt, _) => false,
        (Key::Substeps, toml::Value::Integer(i)) => *i >= 1 && *i <= i64::from(u32::MAX),
        (Key::Substeps, _) => false,
        (Key::Backend, toml::Value::String(s)) => matches!(s.as_str(), "cpu" | "gpu"),
        (Key::Backend, _) => false,
        (Key::Scene(path), _) if path.split('.').any(str::is_empty) => {
            return Err(format!(
                "'{name}' is not a path into the scene: write its keys joined by dots, e.g. \"bodies.cloth.mass_kg\""
            ));
        }
        // What the scene takes there is checked when the value is applied to it.
        (Key::Scene(_), _) => true,
    };
    if !kind_ok {
        let wants = match key {
            Key::Integrator => format!(
                "one of {}",
                crate::integrator::Integrator::ALL
                    .iter()
                    .map(|i| i.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Key::Dt => "a positive number of seconds, or a fraction such as \"1/60\"".into(),
            Key::Substeps => "a whole number of substeps per frame, at least 1".into(),
            Key::Backend => "\"cpu\" or \"gpu\"".into(),
            Key::Scene(_) => String::new(),
        };
        return Err(format!("{name} = {value} is not {wants}"));
    }
    Ok(Setting {
        name: name.to_owned(),
        key,
        value,
        at,
    })
}
