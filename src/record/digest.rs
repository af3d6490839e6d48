//! The digest stage: the reductions over every spring that a frame's recording draws from (the
//! histogram, the most strained spring, a reduced surface's block strains), made on the
//! simulation thread as each snapshot is collected, so that the recorder thread's work per frame
//! follows the surface it draws and not the springs behind it. On a GPU run the simulation
//! thread mostly waits for the device, so this work is taken off the recorder for free; a
//! snapshot without a digest (a comparison's entries, a test's) is digested by the recorder
//! itself, with the same functions.

use crate::backend::{Backend, Then};
use crate::state::{Snapshot, StrainDigest};

use super::recorder::Recorder;
use super::strain_summary::StrainSummary;
use super::surface_strain::BlockStrain;

/// Makes a snapshot's [`StrainDigest`] for one recorder's options and surfaces.
#[derive(Debug, Clone)]
pub struct Digester {
    strain_range: f32,
    /// The springs the label is taken from ([`super::strain_summary::labelled_springs`]).
    labelled: Option<std::sync::Arc<[bool]>>,
    /// Per body, its reduced surface's block strains.
    surfaces: Vec<Option<BlockStrain>>,
}

impl Digester {
    pub fn digest(&self, snap: &mut Snapshot) {
        let summary = StrainSummary::of(&snap.strain, self.strain_range, self.labelled.as_deref());
        let surfaces = self
            .surfaces
            .iter()
            .map(|b| {
                let mut out = Vec::new();
                if let Some(b) = b {
                    b.of(&snap.strain, &mut out);
                }
                out
            })
            .collect();
        snap.digest = Some(Box::new(StrainDigest {
            most: summary.most,
            histogram: summary.counts,
            surfaces,
        }));
    }
}

impl Recorder {
    /// What makes this recorder's digests, to run where the snapshots are made.
    pub fn digester(&self) -> Digester {
        Digester {
            strain_range: self.strain_range,
            labelled: self.labelled.clone(),
            surfaces: self
                .bodies
                .iter()
                .map(|b| b.surface.as_ref().and_then(|s| s.surface.block_strain()))
                .collect(),
        }
    }
}

/// `inner`, its snapshots digested by `digester` as they are collected.
pub fn digesting(inner: Box<dyn Backend>, digester: Digester) -> Box<dyn Backend> {
    Box::new(Then::new(inner, move |s: &mut Snapshot| {
        digester.digest(s);
        Ok(())
    }))
}
