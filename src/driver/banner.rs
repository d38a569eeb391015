//! What a run says as it starts: the banner, the layout it got (and where it differs from the
//! job script's plan), the layout's and the scene's set-up warnings.

use super::provenance::features;
use super::rank::RankRun;
use crate::error::Result;
use crate::layout::RunLayout;
use crate::scene::Scene;

/// The layout's and the scene's set-up warnings, on rank 0's standard error.
pub(super) fn print_warnings<const D: usize>(layout: &RunLayout, scene: &Scene) {
    for w in layout.warnings.iter().chain(&crate::scene::warnings::<D>(scene)) {
        eprintln!("hsph: warning: {w}");
    }
}

impl<'a, const D: usize> RankRun<'a, D> {
    /// The run's first log line: version, scene, particles, layout, dt₀, where the output goes.
    pub(super) fn banner(&self) {
        if !self.quiet {
            eprintln!(
            "hsph {} ({}{}): {} ({}D), {} particles, {} rank(s) × {} thread(s) [{}], dt₀ = {:.3e} s, output in {}",
            env!("CARGO_PKG_VERSION"),
            env!("HSPH_GIT_COMMIT"),
            features().iter().map(|f| format!(", {f}")).collect::<String>(),
            self.scene.name,
            D,
            self.n_total,
            self.comm.size(),
            rayon::current_num_threads(),
            self.layout.backend.name(),
            self.sim.step_length(),
            self.dir.display()
        );
        }
    }

    /// Collective when it has something to say: print the layout the run got (nodes, ranks
    /// per node, threads, CPU sets) and warn where it differs from the job script's plan
    /// (`HSPH_JOB_PLAN`, [`crate::joblayout`]).
    pub(super) fn report_layout(&self) -> Result<()> {
        use crate::joblayout::{self as jl, Plan, RankLayout};
        let plan_text = std::env::var(jl::PLAN_VAR).ok();
        if self.opts.quiet && plan_text.is_none() {
            return Ok(());
        }
        let me = RankLayout {
            node: self.layout.node_of[self.comm.rank()],
            threads: rayon::current_num_threads(),
            cpus: jl::cpus_allowed(),
        };
        let all = self.comm.all_gather_bytes(me.encode())?;
        if self.comm.rank() != 0 {
            return Ok(());
        }
        let ranks: Vec<RankLayout> = all.iter().filter_map(|b| RankLayout::decode(b)).collect();
        if !self.opts.quiet {
            eprintln!("hsph: {}", jl::describe(&ranks));
        }
        match plan_text.as_deref().map(|t| (t, Plan::parse(t))) {
            Some((_, Some(plan))) => {
                for d in jl::differences(&plan, &ranks) {
                    eprintln!("hsph: warning: {d}");
                }
            }
            Some((t, None)) => eprintln!(
                "hsph: warning: {}=`{t}` is not of the form {}",
                jl::PLAN_VAR,
                Plan {
                    nodes: 2,
                    ranks_per_node: 4,
                    threads_per_rank: 6
                }
                .encode()
            ),
            None => {}
        }
        Ok(())
    }
}
