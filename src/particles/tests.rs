//! The field table's promise: one entry (`tag`, declared under `#[cfg(test)]` in the table) is
//! enough for a field to survive migration, halo builds and refreshes (periodic images and
//! other ranks' ghosts), the gather for output, `final.csv` and snapshots.

use super::*;
use crate::boundary::ImageSpace;
use crate::comm::local::run_local;
use crate::comm::Comm;
use crate::decomp::Decomposition;
use crate::halo::{migrate, pack_owned, unpack_owned, HaloPlan, Ranks};
use crate::physics::Model;
use crate::sim::View;

/// The tag a particle of id `id` carries in round `round`.
fn tag(id: u64, round: u64) -> f64 {
    id as f64 * 0.25 + 1000.0 * round as f64 + 0.125
}

/// An 8 × 8 lattice in [0, 1)², all on rank 0, tagged for round 0: fluid particles, and a
/// dummy wall particle every fourth id.
fn lattice(rank: usize) -> Particles<2> {
    let mut p = Particles::<2>::default();
    if rank == 0 {
        for k in 0..64u64 {
            let x = Vector::<2>::new(
                (k / 8) as f64 / 8.0 + 1.0 / 16.0,
                (k % 8) as f64 / 8.0 + 1.0 / 16.0,
            );
            p.push_owned(Record {
                tag: tag(k, 0),
                ..Record::new(k, kind_of(k), 0, 0, x, Vector::zeros(), 1.0, 1000.0)
            });
        }
    }
    p
}

fn kind_of(id: u64) -> Kind {
    if id.is_multiple_of(4) {
        Kind::Dummy
    } else {
        Kind::Fluid
    }
}

#[test]
fn a_field_added_in_the_table_travels_everywhere() {
    let space = ImageSpace::<2> {
        min: Vector::zeros(),
        max: Vector::repeat(1.0),
        periodic: [false, true],
        planes: Vec::new(),
    };
    let map = Ranks::new(Decomposition::uniform(space.min, space.max, [2, 1]), vec![0, 1]);
    let support = 0.2;
    let gathered = run_local(2, 1, |comm| {
        let mut p = lattice(comm.rank());
        migrate(&mut p, &map, &map.boxes(), comm)?;
        // every owned particle is in this rank's half and kept its tag through migration
        assert_eq!(p.n_owned, 32);
        for i in 0..p.n_owned {
            assert_eq!(map.owner(&p.x[i], p.id[i]), comm.rank());
            assert_eq!(p.tag[i], tag(p.id[i], 0), "migrated id {}", p.id[i]);
        }
        let mut halo = HaloPlan::default();
        halo.build(&mut p, &space, &map, &map.boxes(), support, Fields::ALL, comm)?;
        // ghosts from the other rank and periodic images (along y) from this rank too
        assert!(halo.remote() > 0 && p.len() > p.n_owned + halo.remote());
        for g in p.n_owned..p.len() {
            assert_eq!(p.tag[g], tag(p.id[g], 0), "ghost key {}", p.key[g]);
        }
        for i in 0..p.n_owned {
            p.tag[i] = tag(p.id[i], 1);
        }
        halo.refresh(&mut p, &space, (Fields::TAG, Kinds::ALL), comm)?;
        for g in p.n_owned..p.len() {
            assert_eq!(p.tag[g], tag(p.id[g], 1), "refreshed ghost key {}", p.key[g]);
        }
        // a refresh of one class reaches that class's ghosts only, and the next the others
        for (round, class) in [(2, Kinds::FLUID), (3, Kinds::OTHER)] {
            for i in 0..p.n_owned {
                p.tag[i] = tag(p.id[i], round);
            }
            halo.refresh(&mut p, &space, (Fields::TAG, class), comm)?;
            for g in p.n_owned..p.len() {
                let fluid = kind_of(p.id[g]) == Kind::Fluid;
                let want = match (round, fluid) {
                    (2, true) | (3, true) => 2,
                    (2, false) => 1,
                    _ => 3,
                };
                assert_eq!(
                    p.tag[g],
                    tag(p.id[g], want),
                    "round {round}, ghost key {}",
                    p.key[g]
                );
            }
        }
        for i in 0..p.n_owned {
            p.tag[i] = tag(p.id[i], 1);
        }
        // the output gather: whole records to rank 0
        p.truncate_ghosts();
        let bytes = pack_owned(&p);
        let mut all = Particles::<2>::default();
        unpack_owned(&bytes, &mut all)?;
        Ok(all)
    })
    .unwrap();
    let mut all = Particles::<2>::default();
    for p in &gathered {
        for i in 0..p.n_owned {
            all.push_owned(p.record(i));
        }
    }
    let mut perm: Vec<usize> = (0..all.n_owned).collect();
    perm.sort_unstable_by_key(|&i| all.id[i]);
    all.permute_owned(&perm);
    assert_eq!(all.n_owned, 64);
    written_to_output(all);
}

/// `final.csv` has a `tag` column and snapshots a `tag` array, with the values.
fn written_to_output(all: Particles<2>) {
    // a fluid scene's store of one size: the solid and refinement fields dropped, so no
    // such columns
    let all = all.dropping(Fields::SOLID.or(Fields::LEVEL).or(Fields::H));
    let (scene, _) =
        crate::scene::load_scene(std::path::Path::new("inputs/hydrostatic_2d.toml"), &[]).unwrap();
    let model = Model::<2>::new(&scene);
    let view = View {
        p: std::borrow::Cow::Owned(all),
        t: 0.0,
        step: 0,
        dt: 0.0,
        scene: &scene,
        model: &model,
        memo: Default::default(),
    };
    let dir = std::env::temp_dir().join(format!("hsph-field-table-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    crate::output::write_final(&dir.join("final.csv"), &view.p, &view.by_id()).unwrap();
    let text = std::fs::read_to_string(dir.join("final.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        header,
        ["id", "kind", "body", "x", "y", "vx", "vy", "mass", "rho", "p", "tag"]
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 64);
    for r in &rows {
        assert_eq!(r[10], tag(r[0] as u64, 1));
    }
    let vtu = dir.join("s.vtu");
    crate::output::vtk::write_vtu(&vtu, &view.p, &view.by_id(), &["tag".to_string()]).unwrap();
    let text = std::fs::read_to_string(&vtu).unwrap();
    let at = text.find("Name=\"tag\"").expect("a tag array");
    let values: Vec<f64> = text[at..]
        .lines()
        .nth(1)
        .unwrap()
        .split_whitespace()
        .take_while(|c| *c != "</DataArray>")
        .map(|c| c.parse().unwrap())
        .collect();
    let expect: Vec<f64> = (0..64).map(|id| tag(id, 1)).collect();
    assert_eq!(values, expect);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn record_layout_and_byte_counts_follow_the_table() {
    // id, key, kind|body|mat|level packed in one word, x, v, mass, h, rho, p, vw, grad_rho, lap,
    // the solids' stress and correction (upper triangles), energy, plastic strain and the
    // failure flag (a word of its own), and the test-only tag
    let solid = |d: usize| d * (d + 1) + 3;
    assert_eq!(Record::<2>::words(), 3 + 2 + 2 + 4 + 2 + 2 + 1 + solid(2) + 1);
    assert_eq!(Record::<3>::words(), 3 + 3 + 3 + 4 + 3 + 3 + 1 + solid(3) + 1);
    // a fluid-only run of one size carries none of the solid fields nor level and h, a run
    // with Morris's viscous operator no lattice moment
    let one_size = Fields::LEVEL.or(Fields::H);
    let fluid_only = Fields::SOLID.or(Fields::LAP).or(one_size);
    assert_eq!(Record::<2>::words_carried(fluid_only), 3 + 2 + 2 + 3 + 2 + 2 + 1);
    assert_eq!(Record::<3>::words_carried(fluid_only), 3 + 3 + 3 + 3 + 3 + 3 + 1);
    assert_eq!(
        Record::<2>::words_carried(Fields::SOLID.or(one_size)),
        3 + 2 + 2 + 3 + 2 + 2 + 1 + 1
    );
    // a refined fluid scene adds h (its level shares the packed word)
    assert_eq!(
        Record::<2>::words_carried(Fields::SOLID.or(Fields::LAP)),
        3 + 2 + 2 + 4 + 2 + 2 + 1
    );
    assert_eq!(Particles::<3>::field_words(Fields::RHO.or(Fields::P)), 2);
    assert_eq!(
        Particles::<3>::field_words(Fields::P.or(Fields::RHO).or(Fields::VW)),
        5
    );
    assert_eq!(Particles::<2>::field_words(Fields::GRAD_RHO), 2);
    // shared: 8 + 8 + 1 + 2 + 2 + 4·8·D + 4·8 (+ 8 tag); owned-only: 8 + 8·D; solids add two
    // symmetric tensors of 2·D values (the D(D+1)/2 distinct ones in 3D, 6 instead of 9; 4 in
    // 2D), two f64 and a u16; refinement a u16 level and an f64 h
    let shared = |d: usize| 8 + 8 + 1 + 2 + 2 + 4 * 8 * d + 4 * 8 + 8;
    let solid = |d: usize| 2 * 8 * 2 * d + 2 * 8 + 2;
    assert_eq!(solid(3), 2 * 8 * 6 + 2 * 8 + 2);
    let sizes = 2 + 8;
    let one_size = Fields::LEVEL.or(Fields::H);
    assert_eq!(
        Particles::<2>::bytes_per_ghost_carried(Fields::SOLID.or(one_size)),
        shared(2)
    );
    assert_eq!(Particles::<2>::bytes_per_ghost(), shared(2) + solid(2) + sizes);
    assert_eq!(
        Particles::<3>::bytes_per_particle(),
        shared(3) + solid(3) + sizes + 8 + 24
    );
    let names: Vec<&str> = Particles::<2>::field_table().iter().map(|m| m.name).collect();
    assert_eq!(names.last(), Some(&"tag"));
    assert_eq!(Fields::RHO.or(Fields::TAG).names::<2>(), ["rho", "tag"]);
}

#[test]
fn a_record_round_trips_bit_for_bit() {
    let mut r = Record::<3>::new(
        123_456_789,
        Kind::Repulsive,
        65_535,
        7,
        Vector::<3>::new(0.1, -0.0, 1e300),
        Vector::<3>::new(f64::MIN_POSITIVE, 2.0, -3.0),
        0.5,
        999.0,
    );
    r.p = -12.5;
    r.grad_rho = Vector::<3>::new(1.0, 2.0, 3.0);
    r.tag = 42.0;
    let mut buf = Vec::new();
    r.put(&mut wire::Words::new(&mut buf));
    assert_eq!(buf.len(), Record::<3>::words() * 8);
    let back = Record::<3>::get(&mut Reader::new(&buf)).unwrap();
    assert_eq!(back, r);
    assert_eq!(back.x[1].to_bits(), (-0.0f64).to_bits());
    // a corrupt kind code is an error, not a panic
    buf[16] = 9;
    assert!(Record::<3>::get(&mut Reader::new(&buf)).is_err());
}

/// A symmetric tensor holds its D(D+1)/2 distinct components (6 words in 3D, not 9), gives
/// back the whole tensor to the bit, and its columns list them in the output's order (xx, xy,
/// xz, yy, yz, zz).
#[test]
fn a_symmetric_tensor_keeps_its_distinct_components_only() {
    assert_eq!(std::mem::size_of::<Sym<3>>(), 6 * 8);
    assert_eq!(std::mem::size_of::<Sym<2>>(), 4 * 8);
    let t = crate::Tensor::<3>::from_fn(|r, c| 0.1 + (10 * r.min(c) + r.max(c)) as f64);
    let s = Sym::<3>::from_upper(&t);
    assert_eq!(s.tensor(), t);
    let col = [s];
    let col = Column::Tensor(&col[..]);
    let values: Vec<f64> = (0..6).map(|k| col.value(0, k)).collect();
    assert_eq!(values, [0.1, 1.1, 2.1, 11.1, 12.1, 22.1]);
    let t2 = crate::Tensor::<2>::new(1.0, -2.0, -2.0, 3.0);
    assert_eq!(Sym::<2>::from_upper(&t2).tensor(), t2);
}
