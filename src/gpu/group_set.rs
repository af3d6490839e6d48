//! Bind group 0 of each kernel group of a run, made as the run's buffers are: those every run
//! binds, the fused steps', and plasticity's and tearing's.

use super::bindings::{GroupBuffers, bind_group, buffers};
use super::buffers::{Alloc, Bufs};
use super::links::Links;
use super::pipelines::Layouts;
use crate::model::Model;

/// Bind group 0 of each kernel group, as they are made.
pub(super) struct GroupSet<'a> {
    pub(super) device: &'a wgpu::Device,
    pub(super) layouts: &'a Layouts,
    pub(super) groups: Vec<Option<wgpu::BindGroup>>,
}

impl GroupSet<'_> {
    /// Bind `buffers` as their group.
    pub(super) fn set<'b, G: GroupBuffers<'b>>(&mut self, buffers: G) {
        let g = G::GROUP;
        // A group no kernel of the run uses has no layout, and is never bound.
        self.groups[g as usize] = self
            .layouts
            .group(g)
            .map(|layout| bind_group(self.device, layout, &buffers));
    }

    /// The groups every run binds.
    pub(super) fn common(&mut self, b: &Bufs) {
        self.set(b.forces_model());
        self.set(buffers::Integrate {
            params: &b.params,
            x: &b.x,
            v: &b.v,
            xt: &b.xt,
            vt: &b.vt,
            deriv: &b.deriv,
            mass: &b.mass,
            sums: &b.sums,
            ledger: &b.ledger,
            counters: &b.counters,
        });
        self.set(buffers::Collide {
            params: &b.params,
            colliders: &b.colliders,
            mass: &b.mass,
            x: &b.x,
            v: &b.v,
            ledger: &b.ledger,
            counters: &b.counters,
        });
        self.set(buffers::Reduce {
            params: &b.params,
            springs: &b.springs,
            colliders: &b.colliders,
            mass: &b.mass,
            x: &b.x,
            v: &b.v,
            ledger: &b.ledger,
            strain: &b.strain,
            partials: &b.partials,
        });
    }

    /// The fused steps: their model groups (the compact links), and the state flows, by
    /// [`Flow`]. RK4's middle stages also read the step's start, and alternate B with a third
    /// state, C.
    pub(super) fn fused(
        &mut self,
        a: &mut Alloc<'_>,
        b: &Bufs,
        model: &Model,
        stage_c: bool,
        links: &Links,
    ) -> Vec<Option<wgpu::BindGroup>> {
        let kinds = a.uniform("spring kinds", bytemuck::bytes_of(links.kinds.as_ref()));
        let stencils = a.uniform(
            "grid stencils",
            bytemuck::bytes_of(links.stencils.table.as_ref()),
        );
        let entries = a.model("links", bytemuck::cast_slice(&links.entries));
        let fused = || buffers::Fused {
            params: &b.params,
            kinds: &kinds,
            stencils: &stencils,
            offsets: &b.offsets,
            links: &entries,
            colliders: &b.colliders,
            mass: &b.mass,
            deriv: &b.deriv,
            sums: &b.sums,
            ledger: &b.ledger,
            counters: &b.counters,
        };
        self.set(fused());
        self.set(buffers::FusedFrame {
            base: fused(),
            x_in: &b.x,
            v_in: &b.v,
            x_out: &b.xt,
            v_out: &b.vt,
        });
        let c = stage_c.then(|| {
            let n = model.mass_count();
            (a.zeros("x2", 16 * n), a.zeros("v2", 16 * n))
        });
        if c.is_some() {
            self.set(buffers::FusedMid {
                base: fused(),
                x_base: &b.x,
                v_base: &b.v,
            });
        }
        let flow = |from: (&wgpu::Buffer, &wgpu::Buffer), to: (&wgpu::Buffer, &wgpu::Buffer)| {
            let flow = buffers::Flow {
                x_in: from.0,
                v_in: from.1,
                x_out: to.0,
                v_out: to.1,
            };
            bind_group(self.device, &self.layouts.flow, &flow)
        };
        let (pa, pb) = ((&b.x, &b.v), (&b.xt, &b.vt));
        let mut flows = vec![Some(flow(pa, pb)), Some(flow(pb, pa))];
        flows.extend(match &c {
            Some((x2, v2)) => [Some(flow(pb, (x2, v2))), Some(flow((x2, v2), pb))],
            None => [None, None],
        });
        flows
    }

    /// Plasticity and tearing: each spring's limits, and the energy it let go since the last
    /// snapshot.
    /// Returns the released energy's buffer.
    pub(super) fn springs(
        &mut self,
        a: &mut Alloc<'_>,
        b: &Bufs,
        model: &Model,
        dt_secs: f64,
    ) -> wgpu::Buffer {
        let limits = a.model(
            "spring limits",
            bytemuck::cast_slice(&model.spring_limits(dt_secs)),
        );
        let released = a.zeros("released", 4 * model.spring_count());
        self.set(buffers::Springs {
            params: &b.params,
            springs: &b.springs,
            limits: &limits,
            x: &b.x,
            released: &released,
            partials: &b.partials,
        });
        released
    }
}
