//! One entry for a prepared run: a scene (a built-in name or a file, or one already in hand) and
//! the command line's overrides become the settings, the model and the backend that steps it.
//! `run`, `check`, the benchmarks and `--dt auto` all start here, so the way a scene becomes a
//! run is written once.

use std::sync::Arc;

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::model::{self, Model};
use crate::run::auto_dt::{self, AutoDt};
use crate::run::select::Device;
use crate::scene::compare_entry::CompareEntry;
use crate::scene::settings::{Overrides, Settings, SettingsNote};
use crate::scene::{LoadedScene, Scene, SceneOrigin};
use crate::stability::{
    Limit, Modes, NearResolution, Refusal, StepWarning, SweepWarning, stable_step_with,
};

/// Where the scene comes from.
#[derive(Debug, Clone)]
pub enum SceneSource {
    /// A built-in name or a path to a TOML file, as the user gave it.
    Named(String),
    /// A variant of a loaded scene made in code (a benchmark's scene less one effect): it has
    /// no text of its own.
    Variant(Box<Scene>),
    /// A scene already loaded from text made in code (a sweep's point): its text is what the
    /// recording shows.
    Loaded(Box<LoadedScene>),
}

/// How the time step is chosen.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum DtChoice {
    /// The scene's, as the overrides change it.
    #[default]
    AsGiven,
    /// `--dt auto`: substeps measured to keep the RMS position error within `tolerance_m`.
    Auto { tolerance_m: f64 },
}

/// What to prepare.
#[derive(Debug, Clone)]
pub struct Request {
    pub scene: SceneSource,
    pub overrides: Overrides,
    pub dt: DtChoice,
    pub device: Device,
}

impl Request {
    /// The scene named `scene` as it is, on `device`.
    pub fn named(scene: &str, device: Device) -> Self {
        Self {
            scene: SceneSource::Named(scene.to_owned()),
            overrides: Overrides::default(),
            dt: DtChoice::AsGiven,
            device,
        }
    }
}

/// What the user should know about how their values were applied, in the order it happened.
#[derive(Debug, Clone)]
pub enum Notice {
    /// A value was applied otherwise than given (a dt rounded to whole substeps per frame, …),
    /// of a comparison's `entry` where it is one.
    Note {
        entry: Option<String>,
        note: SettingsNote,
    },
    /// What `--dt auto` chose, and why.
    AutoDt(AutoDt),
    /// The step is above the estimated stable limit of the integrator (of a comparison's
    /// `entry`, as the user named it, where it is one).
    AboveStableLimit {
        entry: Option<String>,
        warning: StepWarning,
    },
    /// XPBD's or VBD's sweeps cannot converge the springs at the step (stable, but wrong).
    SweepsShort {
        entry: Option<String>,
        warning: Box<SweepWarning>,
    },
    /// The step is so small that slow masses cannot move in f32.
    SmallStep {
        entry: Option<String>,
        warning: NearResolution,
    },
}

impl std::fmt::Display for Notice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Notice::Note { entry, note } => write!(f, "note: {}{note}", of_entry(entry)),
            Notice::AutoDt(auto) => write!(f, "{auto}"),
            Notice::AboveStableLimit { entry, warning } => {
                write!(f, "warning: {}{warning}", of_entry(entry))
            }
            Notice::SweepsShort { entry, warning } => {
                write!(f, "warning: {}{warning}", of_entry(entry))
            }
            Notice::SmallStep { entry, warning } => {
                write!(f, "warning: {}{warning}", of_entry(entry))
            }
        }
    }
}

/// "ENTRY: " before a comparison entry's warning.
fn of_entry(entry: &Option<String>) -> String {
    entry.as_ref().map(|e| format!("{e}: ")).unwrap_or_default()
}

/// A scene loaded, its settings resolved and its model built: all a run needs but a backend.
#[derive(Debug, Clone)]
pub struct Planned {
    pub loaded: LoadedScene,
    pub settings: Settings,
    pub model: Arc<Model>,
}

/// A run ready to step.
pub struct Prepared {
    pub loaded: LoadedScene,
    pub settings: Settings,
    pub model: Arc<Model>,
    pub backend: Box<dyn Backend>,
}

/// Load, resolve and build what `request` names, telling `say` what the user should know.
pub fn plan(request: &Request, say: &mut dyn FnMut(Notice)) -> Result<Planned> {
    let loaded = match &request.scene {
        SceneSource::Named(name) => crate::scene::load(name)?,
        SceneSource::Variant(scene) => LoadedScene {
            scene: scene.as_ref().clone(),
            origin: SceneOrigin::Text,
            text: String::new(),
        },
        SceneSource::Loaded(loaded) => loaded.as_ref().clone(),
    };
    let mut settings = Settings::resolve(&loaded.scene, &request.overrides)?;
    for &note in &settings.notes {
        say(Notice::Note { entry: None, note });
    }
    // Before anything that grows with the scene is allocated.
    let on_gpu = request.device.kind == crate::run::select::BackendKind::Gpu;
    crate::model::memory_need::check(&loaded.scene, on_gpu)?;
    let model = Arc::new(model::build(&loaded.scene));
    if let Some(b) = model::buried(&model) {
        return Err(b.into());
    }
    if let DtChoice::Auto { tolerance_m } = request.dt {
        if !(tolerance_m.is_finite() && tolerance_m > 0.0) {
            return Err(Error::Tolerance(tolerance_m));
        }
        let auto = auto_dt::choose(&model, &settings, &request.device, tolerance_m)?;
        settings.substeps = auto.substeps;
        settings.dt_secs = auto.dt_secs;
        say(Notice::AutoDt(auto));
    }
    if let Some(warning) = crate::stability::check_resolution(&model, settings.dt_secs)? {
        say(Notice::SmallStep {
            entry: None,
            warning,
        });
    }
    Ok(Planned {
        loaded,
        settings,
        model,
    })
}

/// One entry of a comparison, ready to step.
pub struct PreparedEntry {
    pub entry: CompareEntry,
    /// Its name in the recording (`world/<name>/…`), unique among the entries.
    pub name: String,
    /// As the user wrote it, with `(2)`, `(3)` … on a repeat: its copy's label in 3D and its
    /// lines' names in the plots.
    pub label: String,
    pub settings: Settings,
    pub backend: Box<dyn Backend>,
}

/// A comparison ready to step: one scene and model, and each entry's settings and backend, the
/// reference first.
pub struct PreparedComparison {
    pub loaded: LoadedScene,
    pub model: Arc<Model>,
    pub entries: Vec<PreparedEntry>,
}

/// `request`'s scene under each of `entries` (the first the reference), each with its own step
/// when it gives one: every entry is checked before any backend opens, and refused with the
/// reason when its integrator cannot simulate the scene or its step is above the integrator's
/// estimated stable step. A scheme with no step stable for sure (forward Euler, RK2) is warned
/// about, as a single run is.
pub fn prepare_comparison(
    request: &Request,
    entries: &[CompareEntry],
    say: &mut dyn FnMut(Notice),
) -> Result<PreparedComparison> {
    let Planned { loaded, model, .. } = plan(request, say)?;
    let modes = Modes::of(&model);
    let mut planned = Vec::with_capacity(entries.len());
    for (i, entry) in entries.iter().enumerate() {
        let refuse = |why| Error::CompareRefused {
            entry: entry.to_string(),
            position: i + 1,
            why,
        };
        entry
            .integrator
            .supports(&loaded.scene.effects)
            .map_err(|e| refuse(Refusal::Unsupported(e)))?;
        let overrides = Overrides {
            integrator: Some(entry.integrator),
            dt_secs: entry.dt_secs.or(request.overrides.dt_secs),
            substeps: entry.dt_secs.map_or(request.overrides.substeps, |_| None),
            ..request.overrides.clone()
        };
        let settings = Settings::resolve(&loaded.scene, &overrides)?;
        for &note in &settings.notes {
            say(Notice::Note {
                entry: Some(entry.to_string()),
                note,
            });
        }
        if let Some(warning) = crate::stability::check_resolution(&model, settings.dt_secs)? {
            say(Notice::SmallStep {
                entry: Some(entry.to_string()),
                warning,
            });
        }
        let stable = stable_step_with(&modes, entry.integrator, &settings.options);
        // Sweeps that stop converging give a soft body, not a blow-up: what a comparison is
        // for showing, so warned about below rather than refused.
        let sweeps_bind = matches!(stable.limit, Some(Limit::Sweeps(_)));
        match stable.dt_secs {
            Some(limit) if settings.dt_secs > limit && !sweeps_bind => {
                return Err(refuse(Refusal::AboveStableStep {
                    integrator: entry.integrator,
                    dt_secs: settings.dt_secs,
                    limit_secs: limit,
                    limit: stable.limit,
                }));
            }
            Some(_) if !sweeps_bind => {}
            _ => {
                if let Some(warning) = crate::stability::dt_warning(&model, &settings) {
                    say(Notice::AboveStableLimit {
                        entry: Some(entry.to_string()),
                        warning,
                    });
                }
                if let Some(w) = crate::stability::sweep_warning(&model, &settings) {
                    say(Notice::SweepsShort {
                        entry: Some(entry.to_string()),
                        warning: Box::new(w),
                    });
                }
            }
        }
        planned.push((entry.clone(), settings));
    }
    let mut names: Vec<String> = Vec::with_capacity(planned.len());
    let mut prepared = Vec::with_capacity(planned.len());
    for (entry, settings) in planned {
        let base = entry.name();
        let k = (1..)
            .find(|&k| !names.contains(&numbered(&base, k)))
            .unwrap_or(1);
        let name = numbered(&base, k);
        names.push(name.clone());
        let backend = request.device.create(model.clone(), settings.step())?;
        prepared.push(PreparedEntry {
            label: match k {
                1 => entry.to_string(),
                _ => format!("{entry} ({k})"),
            },
            entry,
            name,
            settings,
            backend,
        });
    }
    Ok(PreparedComparison {
        loaded,
        model,
        entries: prepared,
    })
}

/// An entry's name on its `k`-th use: `base`, then `base_2`, `base_3` …
fn numbered(base: &str, k: u32) -> String {
    match k {
        1 => base.to_owned(),
        _ => format!("{base}_{k}"),
    }
}

/// The scene `scene` (a built-in name or a TOML file) as it is: loaded, its settings resolved
/// and its model built, what is noted along the way left unsaid. The one way examples, tests and
/// benchmarks that need no backend (or make their own) get a scene ready.
pub fn planned(scene: &str) -> Result<Planned> {
    plan(&Request::named(scene, Device::cpu()), &mut |_| {})
}

/// [`plan`], a warning when the step looks unstable, and the backend. The backend comes before
/// anything is written: a missing GPU or a scene beyond its limits fails first.
pub fn prepare(request: &Request, say: &mut dyn FnMut(Notice)) -> Result<Prepared> {
    let Planned {
        loaded,
        settings,
        model,
    } = plan(request, say)?;
    if let Some(warning) = crate::stability::dt_warning(&model, &settings) {
        say(Notice::AboveStableLimit {
            entry: None,
            warning,
        });
    }
    if let Some(w) = crate::stability::sweep_warning(&model, &settings) {
        say(Notice::SweepsShort {
            entry: None,
            warning: Box::new(w),
        });
    }
    let backend = request.device.create(model.clone(), settings.step())?;
    Ok(Prepared {
        loaded,
        settings,
        model,
        backend,
    })
}
