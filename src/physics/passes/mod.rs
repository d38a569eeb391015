//! The passes of one step as data: what each reads from ghosts and what it writes, and the
//! order a scene runs them in. The step loop (`sim`) refreshes before each pass exactly the
//! ghost fields the pass reads that an earlier pass has written since the last exchange, and
//! `hsph plan` walks the same schedule to count the step's exchanges, so the two cannot drift
//! apart.
//!
//! **A pass is one row**, a file of this directory implementing [`Row`]: its name, the shared
//! fields of neighbours it reads (refreshed on ghosts first), the fields it writes, the
//! condition under which a model runs it, its gather kernel and, if it has one, its pair
//! kernel. The list below is the only place passes are listed, in step order; the step walks
//! it ([`Pass::run`]), `hsph plan` counts its exchanges ([`exchanges`]), and pair mode runs the
//! pair kernel of the rows that have one. Each kernel is monomorphised over the neighbour
//! source and the dimension: one match per pass call, no dynamic dispatch per pair. A kernel
//! sees the step through [`Ctx`], the place a particle subset (the interior while ghosts are
//! in flight) or per-pair smoothing lengths will arrive.
//!
//! Adding a pass: a file here with a `Row`, and one line in `passes!` at its place in the step.

mod continuity;
mod density_gradient;
mod density_update;
mod kick;
mod momentum;
mod shift;
mod solid_correction;
mod solid_momentum;
mod solid_rates;
mod solid_update;
mod viscous_moment;
mod wall_extrapolation;

pub use density_update::update_pressure;
pub use kick::half_kick;

use super::pairs::PairScratch;
use super::solid::dynamics::SolidScratch;
use super::Model;
use crate::boundary::images::ImageSpace;
use crate::cells::{HalfView, Neighbours};
use crate::particles::{Fields, Particles};

/// What a pass's kernels work on: the particles (owned, then ghosts), the model, the image
/// space, the step dt (s; 0 at the set-up) and the step's reusable scratch.
pub struct Ctx<'a, const D: usize> {
    /// Owned particles, then ghosts.
    pub p: &'a mut Particles<D>,
    /// The physics of the scene.
    pub model: &'a Model<D>,
    /// Periodic box and mirror planes.
    pub space: &'a ImageSpace<D>,
    /// Step (s).
    pub dt: f64,
    /// Pair mode's accumulators and the gather passes' per-particle buffer.
    pub pair: &'a mut PairScratch<D>,
    /// The solid passes' scratch (σ/ρ², artificial stress R, rates).
    pub solid: &'a mut SolidScratch<D>,
}

/// One pass of the step after the ghosts and neighbour lists are built.
pub trait Row {
    /// Name in logs and in `hsph plan`'s exchange list.
    const NAME: &'static str;
    /// True if the pass walks the neighbour lists (its time counts as force time, its list
    /// entries as pair interactions).
    const NEIGHBOURS: bool;
    /// True if the pass has a pair kernel ([`Row::pair`]) that pair mode runs instead of the
    /// gather kernel.
    const PAIR: bool = false;
    /// True if the pass can run in pair mode, where integrated particles have half lists
    /// only: with a pair kernel, or walking no neighbours. A pass that gathers over an
    /// integrated particle's full list cannot; a scene that runs one is refused pair mode
    /// ([`check_pair_mode`]).
    const IN_PAIR_MODE: bool = Self::PAIR || !Self::NEIGHBOURS;

    /// Shared fields of neighbours (ghosts included) the pass reads.
    fn reads() -> Fields;

    /// Shared fields the pass writes on owned particles (stale on ghosts afterwards).
    fn writes() -> Fields;

    /// True if a model runs this pass.
    fn runs<const D: usize>(m: &Model<D>) -> bool;

    /// True if the gather kernel may run over a part of the particles and then the rest
    /// ([`crate::cells::Subset`]: the interior while ghosts are in flight) with the bits of one
    /// run: it walks neighbours and reads no field it writes (else the second part would read
    /// what the first wrote).
    fn splits() -> bool {
        Self::NEIGHBOURS && !Self::reads().has(Self::writes())
    }

    /// The gather kernel: each owned particle sums over its own neighbours (a pass without
    /// neighbours ignores `nb`).
    fn gather<const D: usize, N: Neighbours>(c: &mut Ctx<'_, D>, nb: &N);

    /// The pair kernel over the half lists (each pair once), if [`Row::PAIR`].
    fn pair<const D: usize>(_c: &mut Ctx<'_, D>, _h: &HalfView<'_, D>) {
        unreachable!("{} has no pair kernel", Self::NAME)
    }
}

/// Position, kind and mass: what every pass that walks neighbours reads.
fn geometry() -> Fields {
    Fields::X.or(Fields::KIND).or(Fields::MASS)
}

/// The passes in step order (Störmer–Verlet with (x, ρ) as coordinates: continuity and the
/// density update come before the forces; see `sim/step.rs`), each `Variant => row type`.
macro_rules! passes {
    ($($variant:ident => $row:ty),* $(,)?) => {
        /// One pass of the step; its row says what it is.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Pass {
            $(
                #[doc = concat!("[`", stringify!($row), "`]")]
                $variant,
            )*
        }

        /// Every pass, in step order.
        pub const ALL: &[Pass] = &[$(Pass::$variant),*];

        impl Pass {
            /// [`Row::reads`].
            pub fn reads(self) -> Fields {
                match self { $(Pass::$variant => <$row>::reads(),)* }
            }

            /// [`Row::writes`].
            pub fn writes(self) -> Fields {
                match self { $(Pass::$variant => <$row>::writes(),)* }
            }

            /// [`Row::NAME`].
            pub fn name(self) -> &'static str {
                match self { $(Pass::$variant => <$row>::NAME,)* }
            }

            /// [`Row::NEIGHBOURS`].
            pub fn walks_neighbours(self) -> bool {
                match self { $(Pass::$variant => <$row>::NEIGHBOURS,)* }
            }

            /// [`Row::PAIR`].
            pub fn has_pair_kernel(self) -> bool {
                match self { $(Pass::$variant => <$row>::PAIR,)* }
            }

            /// [`Row::IN_PAIR_MODE`].
            pub fn in_pair_mode(self) -> bool {
                match self { $(Pass::$variant => <$row>::IN_PAIR_MODE,)* }
            }

            /// [`Row::runs`].
            pub fn runs<const D: usize>(self, m: &Model<D>) -> bool {
                match self { $(Pass::$variant => <$row>::runs(m),)* }
            }

            /// [`Row::splits`].
            pub fn splits(self) -> bool {
                match self { $(Pass::$variant => <$row>::splits(),)* }
            }

            /// Run the pass: its pair kernel over `half` (pair mode) if it has one, else its
            /// gather kernel over `nb`.
            pub fn run<const D: usize, N: Neighbours>(
                self,
                c: &mut Ctx<'_, D>,
                nb: &N,
                half: Option<&HalfView<'_, D>>,
            ) {
                match self {
                    $(Pass::$variant => match half {
                        Some(h) if <$row>::PAIR => <$row>::pair(c, h),
                        _ => <$row>::gather(c, nb),
                    },)*
                }
            }
        }
    };
}

passes! {
    DensityGradient => density_gradient::DensityGradient,
    Continuity => continuity::Continuity,
    ViscousMoment => viscous_moment::ViscousMoment,
    SolidCorrection => solid_correction::SolidCorrection,
    SolidRates => solid_rates::SolidRates,
    DensityUpdate => density_update::DensityUpdate,
    SolidUpdate => solid_update::SolidUpdate,
    WallExtrapolation => wall_extrapolation::WallExtrapolation,
    Momentum => momentum::Momentum,
    SolidMomentum => solid_momentum::SolidMomentum,
    Kick => kick::Kick,
    Shift => shift::Shift,
}

/// The passes a model runs, in step order. A scene without fluid runs no fluid pass, one
/// without solids no solid pass.
pub fn schedule<const D: usize>(model: &Model<D>) -> Vec<Pass> {
    ALL.iter().copied().filter(|p| p.runs(model)).collect()
}

/// Pair mode (`performance.interactions = "pairs"`) is open to a model whose every pass can run
/// in it ([`Row::IN_PAIR_MODE`]); otherwise an input error naming the first pass that cannot.
pub fn check_pair_mode<const D: usize>(model: &Model<D>, pair_mode: bool) -> crate::error::Result<()> {
    if !pair_mode {
        return Ok(());
    }
    let Some(pass) = schedule(model).into_iter().find(|p| !p.in_pair_mode()) else {
        return Ok(());
    };
    Err(crate::error::Error::input(
        "performance.interactions",
        format!(
            "interactions = \"pairs\" runs the passes that have a pair kernel, and this scene runs the \
             pass `{}` (solid bodies' passes and physics.shifting gather over full neighbour lists); \
             use interactions = \"gather\"",
            pass.name()
        ),
    ))
}

/// The fields a step's ghost build sends: [`Fields::IDENTITY`] and every field a pass of
/// `schedule` reads before an earlier pass of the step writes it. Any other field is written on
/// the owners before its first reader, which gets it by a refresh ([`Freshness`]): sent in
/// the build it would be overwritten unread.
pub fn build_fields(schedule: &[Pass]) -> Fields {
    let mut written = Fields::NONE;
    let mut first = Fields::IDENTITY;
    for &pass in schedule {
        first = first.or(pass.reads().without(written));
        written = written.or(pass.writes());
    }
    first
}

/// Which ghost fields are out of date: after a ghost build every field it did not send; a
/// pass makes what it writes stale; a refresh makes fresh what it sends.
#[derive(Debug, Clone, Copy, Default)]
pub struct Freshness {
    stale: Fields,
}

impl Freshness {
    /// The ghosts were just built with the fields `sent` ([`build_fields`]).
    pub fn built(&mut self, sent: Fields) {
        self.stale = Fields::ALL.without(sent);
    }

    /// The fields `pass` needs refreshed before it runs (possibly none); they count as fresh
    /// from now on.
    pub fn before(&mut self, pass: Pass) -> Fields {
        let need = pass.reads().and(self.stale);
        self.stale = self.stale.without(need);
        need
    }

    /// `pass` ran: what it wrote is stale on ghosts.
    pub fn after(&mut self, pass: Pass) {
        self.stale = self.stale.or(pass.writes());
    }
}

/// The ghost exchanges of one step: the build (records of [`build_fields`]), then one refresh
/// per pass that needs one, with the fields each sends (`hsph plan` counts these).
pub fn exchanges(schedule: &[Pass]) -> Vec<(&'static str, Option<Fields>)> {
    let mut out = vec![("build", None)];
    let mut f = Freshness::default();
    f.built(build_fields(schedule));
    for &pass in schedule {
        let need = f.before(pass);
        if !need.is_empty() {
            out.push((pass.name(), Some(need)));
        }
        f.after(pass);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dam break with dummy walls and Antuono's δ-SPH: its build sends what a ghost is and
    /// where, its velocity and density (read before anything writes them), and not the
    /// pressure, the walls' velocity or the density gradient, which passes write before they are
    /// read; those arrive by refreshes, one before each first reader.
    #[test]
    fn a_build_sends_only_what_is_read_before_it_is_written() {
        let (scene, _) =
            crate::scene::load_scene(std::path::Path::new("inputs/dam_break_2d.toml"), &[]).unwrap();
        let s = schedule(&Model::<2>::new(&scene));
        let sent = build_fields(&s);
        for f in [Fields::IDENTITY, Fields::V, Fields::RHO] {
            assert!(sent.and(f) == f, "{:?} not sent", f.names::<2>());
        }
        for f in [Fields::P, Fields::VW, Fields::GRAD_RHO] {
            assert!(!sent.has(f), "{:?} sent", f.names::<2>());
        }
        let refreshed = exchanges(&s)
            .into_iter()
            .filter_map(|(_, f)| f)
            .fold(Fields::NONE, Fields::or);
        assert!(
            refreshed.and(Fields::P.or(Fields::VW).or(Fields::GRAD_RHO))
                == Fields::P.or(Fields::VW).or(Fields::GRAD_RHO)
        );
    }
}
