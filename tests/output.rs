//! Parallel output (issue 10, items 1–2): every rank writes its own snapshot piece (VTK `.vtu`
//! or netCDF `.nc`), rank 0 only the index (`.pvtu` + `.pvd`, `series.json`); the pieces
//! together are the gathered state, with the same bits on any rank count; the netCDF files
//! hold `final.csv`'s values; above `output.gather_limit` `final.csv` is written per rank.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const SCENE: &str = "inputs/dam_break_2d.toml";

/// `hsph run SCENE` to t = 0.02 s, output every 0.01 s (3 snapshots) on `ranks`.
fn run(tag: &str, ranks: &str, extra: &[&str]) -> PathBuf {
    let out = common::temp_dir(tag).join("run");
    let scene = common::repo_path(SCENE);
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--ranks",
        ranks,
        "--set",
        "time.t_end=0.02",
        "--set",
        "output.interval=0.01",
    ];
    args.extend(extra);
    let (code, _, err) = common::hsph(&args);
    assert_eq!(code, 0, "{err}");
    out
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Snapshot `k` of a VTK run, merged from its pieces: id → (x y z, density, pressure).
fn merged_vtk(run: &Path, k: usize, ranks: usize) -> BTreeMap<u64, Vec<String>> {
    let snaps = run.join("snapshots");
    let index = read(&snaps.join(format!("snapshot_{k:05}.pvtu")));
    let mut all = BTreeMap::new();
    for r in 0..ranks {
        let name = format!("snapshot_{k:05}/rank_{r:04}.vtu");
        assert!(
            index.contains(&format!("<Piece Source=\"{name}\"/>")),
            "the index lacks {name}:\n{index}"
        );
        let text = read(&snaps.join(&name));
        let ids = common::vtu_array(&text, "id");
        let points = { common::vtu_points(&text) };
        let rho = common::vtu_array(&text, "density");
        let p = common::vtu_array(&text, "pressure");
        assert_eq!(points.len(), 3 * ids.len());
        let mut last = None;
        for (j, id) in ids.iter().enumerate() {
            let id: u64 = id.parse().unwrap();
            assert!(last.is_none_or(|l| l < id), "piece {name} is not in id order");
            last = Some(id);
            let mut v = points[3 * j..3 * j + 3].to_vec();
            v.push(rho[j].clone());
            v.push(p[j].clone());
            assert!(all.insert(id, v).is_none(), "particle {id} in two pieces");
        }
    }
    assert_eq!(
        index.matches("<Piece ").count(),
        ranks,
        "the index lists exactly one piece per rank"
    );
    all
}

#[test]
fn every_rank_writes_its_piece_and_the_pieces_are_the_whole_state_on_any_rank_count() {
    let one = run("out-vtk1", "1", &[]);
    let four = run("out-vtk4", "4", &[]);
    let pvd = read(&four.join("snapshots/series.pvd"));
    for k in 0..3 {
        assert!(pvd.contains(&format!("file=\"snapshot_{k:05}.pvtu\"")), "{pvd}");
        // no piece holds every particle: rank 0 writes only its own
        let sizes: Vec<usize> = (0..4)
            .map(|r| {
                let t = read(&four.join(format!("snapshots/snapshot_{k:05}/rank_{r:04}.vtu")));
                common::vtu_array(&t, "id").len()
            })
            .collect();
        let a = merged_vtk(&one, k, 1);
        let b = merged_vtk(&four, k, 4);
        assert_eq!(sizes.iter().sum::<usize>(), a.len());
        assert!(sizes.iter().all(|&s| s > 0 && s < a.len()), "{sizes:?}");
        assert!(
            a == b,
            "snapshot {k}: the 4 pieces differ from the 1-rank snapshot"
        );
    }
    assert_eq!(read(&one.join("snapshots/series.pvd")), pvd);
}

/// A netCDF variable of a piece as floats.
fn nc_f64(r: &mut netcdf3::FileReader, name: &str) -> Vec<f64> {
    match r.read_var(name).unwrap() {
        netcdf3::DataVector::F64(v) => v,
        netcdf3::DataVector::I32(v) => v.into_iter().map(f64::from).collect(),
        netcdf3::DataVector::I8(v) => v.into_iter().map(f64::from).collect(),
        other => panic!("{name}: unexpected type {:?}", other.data_type()),
    }
}

/// `final.csv` as a header and rows of floats.
fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = read(path);
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn netcdf_pieces_hold_the_final_state_and_the_series_mirror_the_csv() {
    let run = run(
        "out-nc",
        "3",
        &[
            "--set",
            "output.format=\"netcdf\"",
            "--set",
            "output.fields=[\"velocity\",\"density\",\"pressure\",\"mass\",\"kind\"]",
        ],
    );
    let manifest: serde_json::Value =
        serde_json::from_str(&read(&run.join("snapshots/series.json"))).unwrap();
    let snaps = manifest["snapshots"].as_array().unwrap();
    assert_eq!(snaps.len(), 3);
    let last = snaps.last().unwrap();
    let pieces = last["pieces"].as_array().unwrap();
    assert_eq!(pieces.len(), 3);
    // the last snapshot, merged by id, against final.csv (column by column, exact)
    let (header, rows) = csv_rows(&run.join("final.csv"));
    let col = |h: &str| header.iter().position(|c| c == h).unwrap();
    let pairs = [
        ("x", "x"),
        ("y", "y"),
        ("velocity_x", "vx"),
        ("velocity_y", "vy"),
        ("density", "rho"),
        ("pressure", "p"),
        ("mass", "mass"),
        ("kind", "kind"),
    ];
    let mut merged: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
    for piece in pieces {
        let path = run.join("snapshots").join(piece.as_str().unwrap());
        let mut r = netcdf3::FileReader::open(&path).unwrap();
        assert_eq!(r.version(), netcdf3::Version::Offset64Bit);
        let t = nc_f64(&mut r, "time")[0];
        assert_eq!(t, last["t"].as_f64().unwrap());
        {
            let ds = r.data_set();
            let units = ds.get_var_attr("velocity_x", "units").unwrap().get_as_string();
            assert_eq!(units.as_deref(), Some("m s-1"));
            let conv = ds.get_global_attr("Conventions").unwrap().get_as_string();
            assert_eq!(conv.as_deref(), Some("CF-1.8"));
        }
        let ids = nc_f64(&mut r, "id");
        let cols: Vec<Vec<f64>> = pairs.iter().map(|(v, _)| nc_f64(&mut r, v)).collect();
        for (j, id) in ids.iter().enumerate() {
            let values = cols.iter().map(|c| c[j]).collect();
            assert!(merged.insert(*id as u64, values).is_none());
        }
    }
    assert_eq!(merged.len(), rows.len());
    for (row, (id, values)) in rows.iter().zip(&merged) {
        assert_eq!(row[col("id")] as u64, *id);
        for ((_, c), v) in pairs.iter().zip(values) {
            assert_eq!(row[col(c)], *v, "particle {id}, {c}");
        }
    }
    // timeseries.nc and the probes' files hold every CSV row
    for (csv, nc) in [
        ("timeseries.csv", "timeseries.nc"),
        ("probes/front.csv", "probes/front.nc"),
    ] {
        let (head, rows) = csv_rows(&run.join(csv));
        let mut r = netcdf3::FileReader::open(run.join(nc)).unwrap();
        assert_eq!(r.data_set().num_records(), Some(rows.len()), "{nc}");
        for (k, h) in head.iter().enumerate() {
            let name = if h == "t" { "time" } else { h.as_str() };
            let v = nc_f64(&mut r, name);
            let want: Vec<f64> = rows.iter().map(|row| row[k]).collect();
            assert_eq!(v, want, "{nc}: {name}");
        }
    }
}

#[test]
fn above_the_gather_limit_every_rank_writes_its_own_final_rows() {
    let gathered = run("out-final1", "1", &[]);
    let split = run("out-final3", "3", &["--set", "output.gather_limit=100"]);
    assert!(!split.join("final.csv").exists());
    let (head, all) = csv_rows(&gathered.join("final.csv"));
    let mut merged = Vec::new();
    for r in 0..3 {
        let (h, rows) = csv_rows(&split.join(format!("final/rank_{r:04}.csv")));
        assert_eq!(h, head);
        assert!(!rows.is_empty() && rows.len() < all.len());
        assert!(
            rows.windows(2).all(|w| w[0][0] < w[1][0]),
            "rank {r}: not in id order"
        );
        merged.extend(rows);
    }
    merged.sort_by(|a, b| a[0].total_cmp(&b[0]));
    assert!(merged == all, "the per-rank rows differ from final.csv");
    let summary = read(&split.join("summary.json"));
    assert!(summary.contains("\"complete\": true"), "{summary}");
}

/// `summary.json`'s `pass_timers`: one entry per pass the run ran, named after its row, and the
/// passes that walk neighbours add up to the `forces` phase (each pass's time is read once from
/// the clock and added to both), the others to no more than the `integrate` phase (which also
/// holds the kicks, the drift and the checks). Two ranks, so the min/mean/max are over ranks.
#[test]
fn pass_timers_name_the_passes_that_ran_and_add_up_to_their_phases() {
    use hsph::physics::passes::ALL;
    let run = run("pass-timers", "2", &["--set", "output.format=\"none\""]);
    let summary: serde_json::Value = serde_json::from_str(&read(&run.join("summary.json"))).unwrap();
    let timers = &summary["timers"];
    let passes = summary["pass_timers"].as_object().expect("pass_timers");
    let (mut forces, mut others) = (0.0, 0.0);
    for (key, v) in passes {
        let pass = ALL
            .iter()
            .find(|p| format!("{}_s", p.name()) == *key)
            .unwrap_or_else(|| panic!("{key} names no pass"));
        let (lo, mean, hi) = (
            v["min"].as_f64().unwrap(),
            v["mean"].as_f64().unwrap(),
            v["max"].as_f64().unwrap(),
        );
        assert!(0.0 <= lo && lo <= mean && mean <= hi && hi > 0.0, "{key}: {v}");
        if pass.walks_neighbours() {
            forces += mean;
        } else {
            others += mean;
        }
    }
    for key in ["continuity_s", "momentum_s", "wall_extrapolation_s", "kick_s"] {
        assert!(passes.contains_key(key), "{key} missing from {passes:?}");
    }
    let phase = |k: &str| timers[k]["mean"].as_f64().unwrap();
    let f = phase("forces_s");
    assert!(
        (forces - f).abs() <= 1e-9 * f,
        "passes {forces} against forces {f}"
    );
    assert!(
        others <= phase("integrate_s") * (1.0 + 1e-9),
        "{others} > integrate"
    );
}
