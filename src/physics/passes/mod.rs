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
mod momentum_gradient;
mod shift;
mod solid_correction;
mod solid_momentum;
mod solid_rates;
mod solid_update;
mod viscous_moment;
mod wall_extrapolation;
mod wall_volume;

pub use density_update::update_pressure;
pub use kick::half_kick;

use super::pairs::PairScratch;
use super::solid::dynamics::SolidScratch;
use super::Model;
use crate::boundary::images::ImageSpace;
use crate::cells::{HalfView, Neighbours};
use crate::particles::{Fields, Kinds, Particles};

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

    /// The classes of particles whose [`Row::writes`] fields the pass can change: the others
    /// keep their values (a pass may store a constant, such as a zero gradient, in them), so
    /// their ghosts kept between builds need no refresh of those fields.
    fn writes_kinds() -> Kinds {
        Kinds::ALL
    }

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

        /// The number of passes (`Pass as usize` indexes them in the order of [`ALL`]).
        pub const COUNT: usize = ALL.len();

        impl Pass {
            /// [`Row::reads`].
            pub fn reads(self) -> Fields {
                match self { $(Pass::$variant => <$row>::reads(),)* }
            }

            /// [`Row::writes`].
            pub fn writes(self) -> Fields {
                match self { $(Pass::$variant => <$row>::writes(),)* }
            }

            /// [`Row::writes_kinds`].
            pub fn writes_kinds(self) -> Kinds {
                match self { $(Pass::$variant => <$row>::writes_kinds(),)* }
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
    WallVolume => wall_volume::WallVolume,
    Momentum => momentum::Momentum,
    MomentumGradient => momentum_gradient::MomentumGradient,
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
/// in it ([`Row::IN_PAIR_MODE`]), the set-up relaxation's shifting row included; otherwise an
/// input error naming the first pass that cannot.
pub fn check_pair_mode<const D: usize>(model: &Model<D>, pair_mode: bool) -> crate::error::Result<()> {
    if !pair_mode {
        return Ok(());
    }
    if model.difference_pressure {
        return Err(crate::error::Error::input(
            "physics.pressure_gradient",
            "\"difference\" is built for interactions = \"gather\" only (each particle's sum \
             needs its whole support at once); use interactions = \"gather\", or remove \
             pressure_gradient"
                .to_string(),
        ));
    }
    let relaxation = model.relaxation.map(|_| Pass::Shift);
    let Some(pass) = schedule(model)
        .into_iter()
        .chain(relaxation)
        .find(|p| !p.in_pair_mode())
    else {
        return Ok(());
    };
    Err(crate::error::Error::input(
        "performance.interactions",
        format!(
            "interactions = \"pairs\" runs the passes that have a pair kernel, and this scene runs the \
             pass `{}` (physics.shifting and discretisation.relax gather over \
             full neighbour lists); use interactions = \"gather\"",
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

/// Which ghost fields are out of date, per class of particle ([`Kinds`]): after a ghost build
/// every field it did not send; a pass makes what it writes stale on the classes it writes; a
/// refresh makes fresh what it sends. On ghosts kept since an earlier step's build a refresh
/// goes only to the classes that need it; in a build's step every refresh goes to every ghost
/// (so `hsph plan`'s set-up step counts ghosts, not classes).
#[derive(Debug, Clone, Copy, Default)]
pub struct Freshness {
    /// Stale fields of fluid ghosts and of the others.
    stale: [Fields; 2],
    /// Ghosts built this step: refreshes go to every ghost.
    built: bool,
}

impl Freshness {
    /// The ghosts were just built with the fields `sent` ([`build_fields`]).
    pub fn built(&mut self, sent: Fields) {
        self.stale = [Fields::ALL.without(sent); 2];
        self.built = true;
    }

    /// Code outside the passes (the drift, wall motion) wrote `fields` on owned particles.
    pub fn wrote(&mut self, fields: Fields) {
        for s in &mut self.stale {
            *s = s.or(fields);
        }
    }

    /// A step begins on the ghosts kept since an earlier build: what they got before and
    /// nobody wrote since is still fresh, and refreshes go only to the classes that need them.
    pub fn kept(&mut self) {
        self.built = false;
    }

    /// The fields `pass` needs refreshed before it runs and the classes of ghosts to refresh
    /// (possibly none); they count as fresh from now on.
    pub fn before(&mut self, pass: Pass) -> (Fields, Kinds) {
        self.needs(pass.reads())
    }

    /// Which of the fields `reads` need a refresh before they are read, and on which classes
    /// of ghosts (possibly none); they count as fresh from now on.
    pub fn needs(&mut self, reads: Fields) -> (Fields, Kinds) {
        let need = self.stale.map(|s| reads.and(s));
        let fields = need[0].or(need[1]);
        let mut kinds = Kinds::NONE;
        for (c, n) in Kinds::CLASSES.iter().zip(need) {
            if self.built || !n.is_empty() {
                kinds = kinds.or(*c);
            }
        }
        if fields.is_empty() {
            return (fields, Kinds::NONE);
        }
        for (s, c) in self.stale.iter_mut().zip(Kinds::CLASSES) {
            if kinds.covers(c) {
                *s = s.without(fields);
            }
        }
        (fields, kinds)
    }

    /// `pass` ran: what it wrote is stale on the ghosts of the classes it writes.
    pub fn after(&mut self, pass: Pass) {
        for (s, c) in self.stale.iter_mut().zip(Kinds::CLASSES) {
            if pass.writes_kinds().covers(c) {
                *s = s.or(pass.writes());
            }
        }
    }
}

/// The ghost exchanges of one step: the build (records of [`build_fields`]), then one refresh
/// per pass that needs one, with the fields each sends (`hsph plan` counts these).
pub fn exchanges(schedule: &[Pass]) -> Vec<(&'static str, Option<Fields>)> {
    let mut out = vec![("build", None)];
    let mut f = Freshness::default();
    f.built(build_fields(schedule));
    for &pass in schedule {
        let (need, _) = f.before(pass);
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

    /// On ghosts kept between builds, the dam break's refreshes go only to the class whose
    /// fields changed: x and v (moved by the drift) to all, ∇ρ and the EOS's ρ, p to fluid
    /// ghosts, the walls' extrapolated p, ρ, v_w to wall ghosts; in a build's step every
    /// refresh goes to every ghost.
    #[test]
    fn kept_ghosts_are_refreshed_by_class() {
        let (scene, _) =
            crate::scene::load_scene(std::path::Path::new("inputs/dam_break_2d.toml"), &[]).unwrap();
        let s = schedule(&Model::<2>::new(&scene));
        let sent = build_fields(&s);
        let mut f = Freshness::default();
        let step = |f: &mut Freshness| -> Vec<(Pass, Fields, Kinds)> {
            let mut out = Vec::new();
            for &pass in &s {
                let (need, kinds) = f.before(pass);
                if !need.is_empty() {
                    out.push((pass, need, kinds));
                }
                f.after(pass);
            }
            out
        };
        f.built(sent);
        let built = step(&mut f);
        assert!(built.iter().all(|e| e.2 == Kinds::ALL), "{built:?}");
        for _ in 0..2 {
            f.wrote(Fields::X.or(Fields::V));
            f.kept();
            // ρ has not changed since the refresh before the last step's momentum
            let start = f.needs(sent.without(Fields::CONSTANT));
            assert_eq!(start, (Fields::X.or(Fields::V), Kinds::ALL));
            let kept = step(&mut f);
            let to = |p: Pass| kept.iter().find(|e| e.0 == p).map(|e| (e.1, e.2));
            assert_eq!(to(Pass::Continuity), Some((Fields::GRAD_RHO, Kinds::FLUID)));
            assert_eq!(
                to(Pass::WallExtrapolation),
                Some((Fields::RHO.or(Fields::P), Kinds::FLUID))
            );
            assert_eq!(
                to(Pass::Momentum),
                Some((Fields::P.or(Fields::RHO).or(Fields::VW), Kinds::OTHER))
            );
            assert_eq!(kept.len(), built.len(), "{kept:?}");
        }
    }
}
