//! A sweep's plan: every point's scene written out in full, so that a point runs from the plan
//! alone (on this machine or a cluster's node, today or on `resume`), whatever became of the
//! sweep file since. `DIR/plan.json` holds it; [`Layout`] says where everything else goes.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::run::prepare::{Request, SceneSource};
use crate::run::select::{BackendKind, Device};
use crate::scene::LoadedScene;
use crate::state::fnv1a;

use super::apply::apply;
use super::file::{Key, Setting, SweepFileError, SweepSpec};
use crate::scene::SceneOrigin;

/// The version of `plan.json`'s format.
const FORMAT: u32 = 2;

/// One varied value of a point, as the sweep file gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    pub name: String,
    pub value: String,
}

/// What a point's error is measured against: the same scene under the reference's solver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedReference {
    pub solver: ReferenceSolver,
    pub scene_toml: String,
    /// Names the reference's cached end (`references/KEY.json`): points that share a scene and
    /// solver share it.
    pub key: String,
}

/// How a reference's end is computed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ReferenceSolver {
    /// The scene as its solver section says, on a backend ("cpu" or "gpu"): a sweep file's
    /// `[reference]`.
    Run { backend: String },
    /// Classic RK4 in double precision at this step, over the scene's duration
    /// ([`crate::accuracy::reference`]): `bench accuracy`'s, free of f32 round-off.
    F64Rk4 { dt_secs: f64 },
}

impl PlannedReference {
    /// A reference of `solver` on `scene_toml`, keyed by both.
    pub fn new(solver: ReferenceSolver, scene_toml: String) -> Self {
        let tag = match &solver {
            ReferenceSolver::Run { backend } => backend.clone(),
            ReferenceSolver::F64Rk4 { dt_secs } => format!("f64-rk4 {dt_secs:e}"),
        };
        let key = format!(
            "{:016x}",
            fnv1a(format!("{tag}\n{scene_toml}").into_bytes())
        );
        Self {
            solver,
            scene_toml,
            key,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedPoint {
    pub index: usize,
    /// What varies across the sweep, this point's values: its label.
    pub params: Vec<Param>,
    /// "cpu" or "gpu".
    pub backend: String,
    pub scene_toml: String,
    pub reference: Option<PlannedReference>,
}

impl PlannedPoint {
    /// `integrator=rk4 dt_secs=1e-4 …`, or `base` for a sweep of one point with nothing varied.
    pub fn label(&self) -> String {
        if self.params.is_empty() {
            return "base".to_owned();
        }
        self.params
            .iter()
            .map(|p| format!("{}={}", short_name(&p.name), p.value))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A scene path's last key (`stiffness_n_per_m`), what a label has room for.
pub fn short_name(name: &str) -> &str {
    name.rsplit('.').next().unwrap_or(name)
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    pub format: u32,
    /// What the plan was made from: a sweep file (its absolute path), or the command that made
    /// it (`bench accuracy hair`).
    pub made_from: String,
    /// Unique to this plan: the points' recordings are named by it in a dataset.
    pub id: String,
    /// The base scene: a built-in name, or an absolute path (its meshes are found from there).
    pub scene: String,
    /// Timed runs of each point (1 where the sweep does not time).
    pub repeat: u32,
    /// Runs after the first only for a point whose first run took less than this (s): short
    /// points are noisy, long ones not worth timing again. `None`: every point `repeat` times.
    pub repeat_under_secs: Option<f64>,
    /// Whether the sweep file asked for timing (`repeat`): its points are then run alone.
    pub timed: bool,
    /// Whether each point is recorded (`DIR/points/NNNN.rrd`) before its timed runs.
    pub record: bool,
    /// The GPU adapter GPU points use (the first whose name contains this), and when they probe
    /// it against the CPU reference.
    pub adapter: Option<String>,
    pub verify: crate::conformance::Verify,
    /// The names of what varies, in the file's order.
    pub varied: Vec<String>,
    pub points: Vec<PlannedPoint>,
}

impl Plan {
    /// The origin a point's scene text is loaded as: its meshes resolve as the base scene's do.
    pub fn origin(&self) -> SceneOrigin {
        match crate::scene::BUILT_IN.iter().any(|b| b.name == self.scene) {
            true => SceneOrigin::BuiltIn(self.scene.clone()),
            false => SceneOrigin::File(PathBuf::from(&self.scene)),
        }
    }

    /// The device a planned backend ("cpu" or "gpu") names.
    pub fn device(&self, backend: &str) -> Device {
        match backend {
            "cpu" => Device::cpu(),
            _ => Device {
                kind: BackendKind::Gpu,
                adapter: self.adapter.clone(),
                verify: self.verify,
            },
        }
    }

    /// How many times a point is timed, and when only once.
    pub fn repeats(&self) -> crate::accuracy::Repeats {
        crate::accuracy::Repeats {
            most: self.repeat,
            while_first_under_secs: self.repeat_under_secs,
        }
    }
}

/// Where a sweep's files are.
#[derive(Debug, Clone)]
pub struct Layout {
    pub dir: PathBuf,
}

impl Layout {
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_owned(),
        }
    }
    pub fn plan(&self) -> PathBuf {
        self.dir.join("plan.json")
    }
    /// `DIR/points`: each point's folder, and its recording beside it (a folder of `.rrd`
    /// files is what `rerun server -d` serves as one dataset; it does not look into folders).
    pub fn points(&self) -> PathBuf {
        self.dir.join("points")
    }
    pub fn point(&self, index: usize) -> PathBuf {
        self.points().join(format!("{index:04}"))
    }
    pub fn recording(&self, index: usize) -> PathBuf {
        self.points().join(format!("{index:04}.rrd"))
    }
    pub fn result(&self, index: usize) -> PathBuf {
        self.point(index).join("result.json")
    }
    pub fn reference(&self, key: &str) -> PathBuf {
        self.dir.join("references").join(format!("{key}.json"))
    }
    pub fn slurm(&self) -> PathBuf {
        self.dir.join("slurm")
    }
}

/// Every point of `spec` applied to its base scene and checked by the scene loader: a value the
/// scene cannot take is an error naming the sweep file's line.
pub fn make(spec: &SweepSpec) -> Result<Plan, SweepFileError> {
    let loaded = crate::scene::load(&spec.scene).map_err(|e| SweepFileError {
        file: spec.file.clone(),
        at: None,
        message: format!("its scene '{}': {e}", spec.scene),
    })?;
    let base: toml::Table = toml::from_str(&loaded.text).map_err(|e| SweepFileError {
        file: spec.file.clone(),
        at: None,
        message: format!("its scene '{}': {}", spec.scene, e.message()),
    })?;
    let origin = loaded.origin.clone();
    let fail = |s: Option<&Setting>, message: String| SweepFileError {
        file: spec.file.clone(),
        at: s.and_then(|s| s.at),
        message,
    };
    // Each value on its own first, so that a bad one is blamed on its own line.
    for s in spec.set.iter().chain(spec.points.iter().flatten()) {
        let mut scene = base.clone();
        apply(&mut scene, s).map_err(|m| fail(Some(s), format!("{}: {m}", s.name)))?;
        check_scene(&scene, &origin)
            .map_err(|m| fail(Some(s), format!("{} = {}: {m}", s.name, s.value)))?;
    }
    let with = |settings: &[&Setting]| -> Result<(toml::Table, String), SweepFileError> {
        let mut scene = base.clone();
        let mut backend = "gpu".to_owned();
        for s in settings {
            apply(&mut scene, s).map_err(|m| fail(Some(s), format!("{}: {m}", s.name)))?;
            if let (Key::Backend, Some(b)) = (&s.key, s.value.as_str()) {
                backend = b.to_owned();
            }
        }
        Ok((scene, backend))
    };
    let mut points = Vec::with_capacity(spec.points.len());
    for (index, own) in spec.points.iter().enumerate() {
        let settings: Vec<&Setting> = spec.set.iter().chain(own).collect();
        let (scene, backend) = with(&settings)?;
        let scene_toml =
            toml::to_string(&scene).map_err(|e| fail(None, format!("point {index}: {e}")))?;
        check_scene(&scene, &origin).map_err(|m| {
            fail(
                own.first().or(spec.set.first()),
                format!("point {index} ({}): {m}", describe(own)),
            )
        })?;
        let reference = match &spec.reference {
            Some(r) => {
                let settings: Vec<&Setting> = settings.iter().copied().chain(r).collect();
                let (scene, backend) = with(&settings)?;
                let text = toml::to_string(&scene)
                    .map_err(|e| fail(None, format!("the reference: {e}")))?;
                Some(PlannedReference::new(
                    ReferenceSolver::Run { backend },
                    text,
                ))
            }
            None => None,
        };
        points.push(PlannedPoint {
            index,
            params: own
                .iter()
                .map(|s| Param {
                    name: s.name.clone(),
                    value: display(&s.value),
                })
                .collect(),
            backend,
            scene_toml,
            reference,
        });
    }
    let made_from = spec
        .file
        .canonicalize()
        .unwrap_or_else(|_| spec.file.clone())
        .display()
        .to_string();
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or_default();
    Ok(Plan {
        format: FORMAT,
        id: format!(
            "{:012x}",
            fnv1a(format!("{made_from}{stamp}{}", std::process::id()).into_bytes())
                & 0xffff_ffff_ffff
        ),
        made_from,
        scene: spec.scene.clone(),
        repeat: spec.repeat.unwrap_or(1),
        repeat_under_secs: None,
        timed: spec.repeat.is_some(),
        record: spec.record,
        adapter: None,
        verify: Default::default(),
        varied: spec.varied.clone(),
        points,
    })
}

fn describe(own: &[Setting]) -> String {
    own.iter()
        .map(|s| format!("{} = {}", s.name, s.value))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A value as a label shows it: a string without its quotes.
fn display(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// What the scene loader says of `scene`, without the position in the generated text (the
/// caller knows the sweep file's).
fn check_scene(scene: &toml::Table, origin: &SceneOrigin) -> Result<(), String> {
    let text = toml::to_string(scene).map_err(|e| e.to_string())?;
    crate::scene::from_toml(&text, origin.clone())
        .map(|_| ())
        .map_err(|e| match e.field.is_empty() {
            true => e.message,
            false => format!("{}: {}", e.field, e.message),
        })
}

/// Write `value` as JSON to `path` atomically: a reader finds the whole file or none (written
/// beside it, made durable, then renamed into place).
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> std::io::Result<()> {
    use std::io::Write as _;
    let text = serde_json::to_string_pretty(value).map_err(std::io::Error::other)?;
    let partial = path.with_extension("json.partial");
    {
        let mut f = std::fs::File::create(&partial)?;
        f.write_all(text.as_bytes())?;
        f.write_all(b"\n")?;
        f.sync_all()?;
    }
    std::fs::rename(&partial, path)
}

/// The plan in `dir`, with a message that says what to do where there is none.
pub fn read(dir: &Path) -> Result<Plan> {
    let path = Layout::new(dir).plan();
    let text = std::fs::read_to_string(&path).map_err(|e| {
        Error::Sweep(format!(
            "{}: {e}: is {} a sweep's folder? `hooke sweep run FILE --out DIR` makes one",
            path.display(),
            dir.display()
        ))
    })?;
    let plan: Plan = serde_json::from_str(&text)
        .map_err(|e| Error::Sweep(format!("{}: {e}", path.display())))?;
    if plan.format != FORMAT {
        return Err(Error::Sweep(format!(
            "{}: written by another version of hooke (format {}, this one reads {FORMAT}): run the sweep again into a new folder",
            path.display(),
            plan.format
        )));
    }
    Ok(plan)
}

/// The request for a planned scene's text.
pub fn request(plan: &Plan, scene_toml: &str, backend: &str) -> Result<Request> {
    let origin = plan.origin();
    let scene =
        crate::scene::from_toml(scene_toml, origin.clone()).map_err(|e| Error::Scene(e.into()))?;
    Ok(Request {
        scene: SceneSource::Loaded(Box::new(LoadedScene {
            scene,
            origin,
            text: scene_toml.to_owned(),
        })),
        overrides: Default::default(),
        dt: Default::default(),
        device: plan.device(backend),
    })
}

/// Read the sweep file at `file` and plan it.
pub fn from_file(file: &Path) -> Result<Plan> {
    let spec = super::file::read(file).map_err(|e| Error::Sweep(e.to_string()))?;
    make(&spec).map_err(|e| Error::Sweep(e.to_string()))
}

/// Make the sweep's folder `dir` with its plan. A folder that holds another sweep is refused:
/// `resume` finishes that one.
pub fn start(plan: &Plan, dir: &Path) -> Result<()> {
    let layout = Layout::new(dir);
    if layout.plan().exists() {
        return Err(Error::Sweep(format!(
            "{} already holds a sweep: `hooke sweep resume {}` finishes it, `hooke sweep status {}` says where it stands; or give another --out",
            dir.display(),
            dir.display(),
            dir.display()
        )));
    }
    let io = |e: std::io::Error| Error::Sweep(format!("cannot write {}: {e}", dir.display()));
    std::fs::create_dir_all(layout.points()).map_err(io)?;
    write_json_atomic(&layout.plan(), plan).map_err(io)
}
