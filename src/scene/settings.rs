//! The time-stepping plan of a run: the scene's solver section with command-line overrides applied.

use crate::integrator::{
    DEFAULT_VBD_ITERATIONS, DEFAULT_XPBD_ITERATIONS, Integrator, Over, Preconditioner, Step,
    StepOptions, Unsupported,
};
use crate::scene::MOST_SWEEPS;
use crate::scene::Scene;

/// A value the run cannot use, and what would fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SettingsError {
    #[error("invalid setting: --dt must be a positive number of seconds, got {0}")]
    Dt(f64),
    #[error(
        "invalid setting: --integrator {} does not support {} ([{}] in this scene): use {}",
        integrator.name(), why.effect(), why.scene_field(), why.instead("")
    )]
    Unsupported {
        integrator: Integrator,
        why: Unsupported,
    },
    #[error(
        "invalid setting: --xpbd-iterations must be at least 1 (each substep projects every spring that many times)"
    )]
    NoXpbdIterations,
    #[error(
        "invalid setting: --vbd-iterations must be at least 1 (each step sweeps every mass that many times)"
    )]
    NoVbdIterations,
    #[error(
        "invalid setting: {flag} {given} is more than {most} sweeps a step; one step would take about {given} times a sweep's work and could not be stopped in time. Ask for at most {most} (a converged reference rarely needs more than 10 000)"
    )]
    TooManySweeps {
        flag: &'static str,
        given: u32,
        most: u32,
    },
    #[error("invalid setting: --substeps must be at least 1")]
    NoSubsteps,
    #[error(
        "invalid setting: --dt {dt_secs} s and --substeps {substeps} disagree: at {frame_rate_hz} frames/s, {substeps} substeps means dt = {:.6e} s; give only one",
        1.0 / frame_rate_hz / f64::from(*substeps)
    )]
    DtAndSubsteps {
        dt_secs: f64,
        substeps: u32,
        frame_rate_hz: f64,
    },
    #[error(
        "invalid setting: {given_by} = {dt_secs:.3e} s would need {substeps:.3e} steps a frame, \
         more than the {} a frame may take: give a step of at least {:.3e} s",
        u32::MAX,
        smallest_dt_secs
    )]
    TooManySubsteps {
        /// Where the step came from: `--dt`, or the scene's `solver.dt_secs`.
        given_by: &'static str,
        dt_secs: f64,
        substeps: f64,
        smallest_dt_secs: f64,
    },
    #[error("invalid setting: --frames must be at least 1")]
    NoFrames,
    #[error("invalid setting: --duration must be a positive number of seconds, got {0}")]
    Duration(f64),
}

type Result<T> = std::result::Result<T, SettingsError>;

/// Values given on the command line; each replaces the scene's.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    pub integrator: Option<Integrator>,
    pub dt_secs: Option<f64>,
    pub substeps: Option<u32>,
    pub frames: Option<u64>,
    pub duration_secs: Option<f64>,
    pub xpbd_iterations: Option<u32>,
    pub vbd_iterations: Option<u32>,
    pub preconditioner: Option<crate::integrator::Preconditioner>,
}

/// How a run steps: `frames` frames of `substeps` steps of `dt_secs`.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub integrator: Integrator,
    pub frame_rate_hz: f64,
    pub substeps: u32,
    pub dt_secs: f64,
    pub frames: u64,
    /// What the integrator needs beyond its name and step.
    pub options: StepOptions,
    /// Things the user should know about how their values were applied.
    pub notes: Vec<SettingsNote>,
}

/// How a value the user gave was applied, where they should know.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SettingsNote {
    /// The step does not divide the frame: `substeps` a frame, each a little shorter.
    DtRounded {
        dt_secs: f64,
        frame_rate_hz: f64,
        substeps: u32,
    },
    /// A preconditioner asked of an integrator with no conjugate gradients.
    PreconditionerIgnored {
        preconditioner: Preconditioner,
        integrator: Integrator,
    },
    /// Sweeps set for `owner`, asked of an integrator that has none.
    SweepsIgnored {
        owner: Integrator,
        integrator: Integrator,
    },
}

impl std::fmt::Display for SettingsNote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            SettingsNote::DtRounded {
                dt_secs,
                frame_rate_hz,
                substeps,
            } => write!(
                f,
                "dt = {dt_secs} s does not divide the frame time 1/{frame_rate_hz} s; using \
                 {substeps} substeps of {:.6e} s",
                1.0 / frame_rate_hz / f64::from(substeps)
            ),
            SettingsNote::PreconditionerIgnored {
                preconditioner,
                integrator,
            } => write!(
                f,
                "the preconditioner ({}) serves implicit Euler's and BDF2's solves; {integrator} \
                 has none and ignores it",
                preconditioner.name()
            ),
            SettingsNote::SweepsIgnored { owner, integrator } => {
                let flag = owner.scheme().sweeps().map_or("", |s| s.flag);
                write!(
                    f,
                    "{flag} sets {owner}'s sweeps; {integrator} has none and ignores it"
                )
            }
        }
    }
}

/// The command-line values that are wrong whatever the scene's solver section says.
fn check_overrides(scene: &Scene, o: &Overrides) -> Result<()> {
    if let Some(dt) = o.dt_secs
        && !(dt.is_finite() && dt > 0.0)
    {
        return Err(SettingsError::Dt(dt));
    }
    if let Some(i) = o.integrator
        && let Err(why) = i.supports(&scene.effects)
    {
        return Err(SettingsError::Unsupported { integrator: i, why });
    }
    if o.xpbd_iterations == Some(0) {
        return Err(SettingsError::NoXpbdIterations);
    }
    if o.vbd_iterations == Some(0) {
        return Err(SettingsError::NoVbdIterations);
    }
    for (given, flag) in [
        (o.xpbd_iterations, "--xpbd-iterations"),
        (o.vbd_iterations, "--vbd-iterations"),
    ] {
        if let Some(given) = given.filter(|&n| n > MOST_SWEEPS) {
            return Err(SettingsError::TooManySweeps {
                flag,
                given,
                most: MOST_SWEEPS,
            });
        }
    }
    if o.substeps == Some(0) {
        return Err(SettingsError::NoSubsteps);
    }
    Ok(())
}

/// Simulated time when neither the scene nor the command line says.
pub const DEFAULT_DURATION_SECS: f64 = 5.0;

impl Settings {
    pub fn resolve(scene: &Scene, o: &Overrides) -> Result<Self> {
        let s = &scene.solver;
        let fps = s.frame_rate_hz;
        let frame_secs = 1.0 / fps;
        let mut notes = Vec::new();
        check_overrides(scene, o)?;
        // The command line wins; within one source, dt and substeps are two views of one value.
        let (dt_req, sub_req) = match (o.dt_secs, o.substeps) {
            (None, None) => (s.dt_secs, s.substeps),
            other => other,
        };
        let substeps = match (dt_req, sub_req) {
            (Some(dt), Some(n)) => {
                if ((dt * fps * f64::from(n)) - 1.0).abs() > 1e-6 {
                    return Err(SettingsError::DtAndSubsteps {
                        dt_secs: dt,
                        substeps: n,
                        frame_rate_hz: fps,
                    });
                }
                n
            }
            (None, Some(n)) => n,
            (Some(dt), None) => {
                let exact = frame_secs / dt;
                let n = (exact - 1e-9).ceil().max(1.0);
                if n > f64::from(u32::MAX) {
                    return Err(SettingsError::TooManySubsteps {
                        given_by: match o.dt_secs {
                            Some(_) => "--dt",
                            None => "the scene's solver.dt_secs",
                        },
                        dt_secs: dt,
                        substeps: n,
                        smallest_dt_secs: frame_secs / f64::from(u32::MAX),
                    });
                }
                let n = n as u32;
                if (exact - f64::from(n)).abs() > 1e-6 * exact {
                    notes.push(SettingsNote::DtRounded {
                        dt_secs: dt,
                        frame_rate_hz: fps,
                        substeps: n,
                    });
                }
                n
            }
            (None, None) => 1,
        };
        let frames = match (o.frames, o.duration_secs, s.frames, s.duration_secs) {
            (Some(f), _, _, _) => f,
            (None, Some(d), _, _) => duration_frames(d, fps)?,
            (None, None, Some(f), _) => f,
            (None, None, None, Some(d)) => duration_frames(d, fps)?,
            (None, None, None, None) => duration_frames(DEFAULT_DURATION_SECS, fps)?,
        };
        if frames == 0 {
            return Err(SettingsError::NoFrames);
        }
        let integrator = o.integrator.unwrap_or(s.integrator);
        let preconditioner = o.preconditioner.or(s.preconditioner);
        if let Some(p) = preconditioner
            && !integrator.newton()
        {
            notes.push(SettingsNote::PreconditionerIgnored {
                preconditioner: p,
                integrator,
            });
        }
        for owner in Integrator::ALL {
            let Some(of) = owner.scheme().sweeps() else {
                continue;
            };
            let given = match of.over {
                Over::Springs => o.xpbd_iterations,
                Over::Masses => o.vbd_iterations,
            };
            if given.is_some() && integrator != owner {
                notes.push(SettingsNote::SweepsIgnored { owner, integrator });
            }
        }
        Ok(Self {
            integrator,
            frame_rate_hz: fps,
            substeps,
            dt_secs: frame_secs / f64::from(substeps),
            frames,
            options: StepOptions {
                xpbd_iterations: o
                    .xpbd_iterations
                    .or(s.xpbd_iterations)
                    .unwrap_or(DEFAULT_XPBD_ITERATIONS),
                vbd_iterations: o
                    .vbd_iterations
                    .or(s.vbd_iterations)
                    .unwrap_or(DEFAULT_VBD_ITERATIONS),
                preconditioner,
            },
            notes,
        })
    }

    /// The backends' view: integrator, dt and options.
    pub fn step(&self) -> Step {
        Step::new(self.integrator, self.dt_secs).with_options(self.options)
    }

    pub fn duration_secs(&self) -> f64 {
        self.frames as f64 / self.frame_rate_hz
    }
}

fn duration_frames(d: f64, fps: f64) -> Result<u64> {
    if !(d.is_finite() && d > 0.0) {
        return Err(SettingsError::Duration(d));
    }
    Ok((d * fps).round().max(1.0) as u64)
}
