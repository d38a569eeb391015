//! Reading a run directory: `summary.json`, `diagnostics.csv`, `traffic.csv`.

use crate::error::{Error, Location, Result};
use crate::sim::PHASES;
use std::path::{Path, PathBuf};

/// `diagnostics.csv`: one row per output step, columns by name.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics {
    /// Column names, as in the header.
    pub header: Vec<String>,
    /// Rows of numbers (one per output step).
    pub rows: Vec<Vec<f64>>,
}

impl Diagnostics {
    /// The column `name`, if present.
    pub fn col(&self, name: &str) -> Option<Vec<f64>> {
        let k = self.header.iter().position(|h| h == name)?;
        Some(self.rows.iter().map(|r| r[k]).collect())
    }
}

/// One row of `traffic.csv`: messages sent from `src_rank` to `dst_rank` in `phase` during the
/// output interval ending at `step`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrafficRow {
    /// Output step that ends the interval.
    pub step: u64,
    /// Phase name (`halo`, `migration`, `balance`, `output`, `other`).
    pub phase: String,
    /// Sending rank.
    pub src_rank: usize,
    /// Receiving rank.
    pub dst_rank: usize,
    /// Node of the sender.
    pub src_node: usize,
    /// Node of the receiver.
    pub dst_node: usize,
    /// Payload bytes.
    pub bytes: u64,
    /// Messages.
    pub messages: u64,
}

/// A finished run directory, read.
#[derive(Debug, Clone)]
pub struct Run {
    /// The directory.
    pub dir: PathBuf,
    /// How the run is named in comparisons: the directory as given.
    pub label: String,
    /// `summary.json`.
    pub summary: serde_json::Value,
    /// `diagnostics.csv`.
    pub diag: Diagnostics,
    /// `traffic.csv`, when the run has one.
    pub traffic: Option<Vec<TrafficRow>>,
}

fn missing(dir: &Path, file: &str, what: &str) -> Error {
    Error::Input {
        at: Some(Location {
            file: dir.join(file),
            line: None,
        }),
        key: String::new(),
        message: what.to_string(),
    }
}

fn bad_line(path: &Path, line: usize, what: String) -> Error {
    Error::Input {
        at: Some(Location {
            file: path.to_path_buf(),
            line: Some(line),
        }),
        key: String::new(),
        message: what,
    }
}

/// Rows of a CSV file, each with its 1-based line number.
type Lines = Vec<(usize, Vec<String>)>;

/// Header and rows of a CSV file of plain fields (no quoting), with the 1-based line numbers,
/// read through the bounded reader ([`crate::limits::read_lines`]).
fn read_csv(path: &Path) -> Result<(Vec<String>, Lines)> {
    let key = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let mut header: Option<Vec<String>> = None;
    let mut rows = Vec::new();
    crate::limits::read_lines(path, &key, |n, l| {
        if l.trim().is_empty() {
            return Ok(());
        }
        let f: Vec<String> = l.split(',').map(|s| s.trim().to_string()).collect();
        match &header {
            None => header = Some(f),
            Some(h) if f.len() != h.len() => {
                return Err(bad_line(
                    path,
                    n,
                    format!("{} fields, the header has {}", f.len(), h.len()),
                ))
            }
            Some(_) => rows.push((n, f)),
        }
        Ok(())
    })?;
    let Some(header) = header else {
        return Err(bad_line(path, 1, "empty file: expected a header line".into()));
    };
    Ok((header, rows))
}

fn parse_diagnostics(path: &Path) -> Result<Diagnostics> {
    use crate::limits::{FileNumbers, Number, MAX_STEPS};
    let (header, rows) = read_csv(path)?;
    for need in ["step", "t", "ghost_fraction", "imbalance"] {
        if !header.iter().any(|h| h == need) {
            return Err(bad_line(path, 1, format!("no `{need}` column in the header")));
        }
    }
    // every column is a finite number, the step a count within the step limit
    let rows = rows
        .into_iter()
        .map(|(line, f)| {
            let at = FileNumbers::at(path, line);
            f.iter()
                .zip(&header)
                .map(|(v, h)| match h.as_str() {
                    "step" => at
                        .count(h, Number::Text(v), (0, MAX_STEPS as u64))
                        .map(|s| s as f64),
                    _ => at.real(h, Number::Text(v), (f64::MIN, f64::MAX)),
                })
                .collect::<Result<Vec<f64>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Diagnostics { header, rows })
}

const TRAFFIC_HEADER: [&str; 8] = [
    "step", "phase", "src_rank", "dst_rank", "src_node", "dst_node", "bytes", "messages",
];

/// `traffic.csv`: every rank and node below `ranks` (the summary's, else the rank limit),
/// steps within the step limit, bytes and messages within the traffic limit.
fn parse_traffic(path: &Path, ranks: Option<u64>) -> Result<Vec<TrafficRow>> {
    use crate::limits::{FileNumbers, Number, MAX_RANKS, MAX_STEPS, MAX_TRAFFIC_BYTES};
    let (header, rows) = read_csv(path)?;
    if header != TRAFFIC_HEADER {
        return Err(bad_line(
            path,
            1,
            format!("header must be `{}`", TRAFFIC_HEADER.join(",")),
        ));
    }
    let below = ranks.unwrap_or(MAX_RANKS as u64).max(1) - 1;
    rows.into_iter()
        .map(|(line, f)| {
            let at = FileNumbers::at(path, line);
            let n = |k: usize, hi: u64| at.count(TRAFFIC_HEADER[k], Number::Text(&f[k]), (0, hi));
            Ok(TrafficRow {
                step: n(0, MAX_STEPS as u64)?,
                phase: f[1].clone(),
                src_rank: n(2, below)? as usize,
                dst_rank: n(3, below)? as usize,
                src_node: n(4, below)? as usize,
                dst_node: n(5, below)? as usize,
                bytes: n(6, MAX_TRAFFIC_BYTES)?,
                messages: n(7, MAX_TRAFFIC_BYTES)?,
            })
        })
        .collect()
}

impl Run {
    /// Read the run directory `dir`. A missing directory, `summary.json` (the run did not
    /// finish) or `diagnostics.csv` is an input error naming the path.
    pub fn load(dir: &Path) -> Result<Run> {
        if !dir.is_dir() {
            return Err(Error::Input {
                at: Some(Location {
                    file: dir.to_path_buf(),
                    line: None,
                }),
                key: String::new(),
                message: "no such run directory".into(),
            });
        }
        let sp = dir.join("summary.json");
        if !sp.is_file() {
            return Err(missing(
                dir,
                "summary.json",
                "missing: not a finished hsph run directory (summary.json is written last; the run \
                 may still be going, or it failed)",
            ));
        }
        // every number the report reads, checked against the limits before anything is
        // sized by it (a `ranks` of 10⁹ would size the heat map's tables)
        let summary = crate::limits::read_summary(&sp)?;
        let dp = dir.join("diagnostics.csv");
        if !dp.is_file() {
            return Err(missing(
                dir,
                "diagnostics.csv",
                "missing: the run directory is incomplete",
            ));
        }
        let diag = parse_diagnostics(&dp)?;
        let tp = dir.join("traffic.csv");
        let traffic = if tp.is_file() {
            Some(parse_traffic(
                &tp,
                summary.get("ranks").and_then(|r| r.as_f64()).map(|r| r as u64),
            )?)
        } else {
            None
        };
        Ok(Run {
            dir: dir.to_path_buf(),
            label: dir.display().to_string(),
            summary,
            diag,
            traffic,
        })
    }

    /// A number from `summary.json`.
    pub fn num(&self, key: &str) -> Option<f64> {
        self.summary.get(key).and_then(|v| v.as_f64())
    }

    /// Number of ranks: `summary.json` `ranks`, else one more than the largest rank in
    /// `traffic.csv`, else 1.
    pub fn ranks(&self) -> usize {
        if let Some(r) = self.num("ranks") {
            return (r as usize).max(1);
        }
        self.traffic
            .as_ref()
            .and_then(|t| t.iter().map(|r| r.src_rank.max(r.dst_rank) + 1).max())
            .unwrap_or(1)
    }

    /// Number of nodes: `summary.json` `nodes`, else the distinct nodes of `traffic.csv`.
    pub fn nodes(&self) -> Option<f64> {
        self.num("nodes").or_else(|| {
            let t = self.traffic.as_ref()?;
            let mut s: Vec<usize> = t.iter().flat_map(|r| [r.src_node, r.dst_node]).collect();
            s.sort_unstable();
            s.dedup();
            Some(s.len() as f64)
        })
    }

    /// Node of each rank as `traffic.csv` reports it; ranks it never names get the node of
    /// consecutive blocks of `ranks / nodes` (how virtual nodes are laid out).
    pub fn rank_nodes(&self) -> Vec<usize> {
        let p = self.ranks();
        let per = p.div_ceil(self.nodes().unwrap_or(1.0).max(1.0) as usize).max(1);
        let mut node: Vec<Option<usize>> = vec![None; p];
        for r in self.traffic.iter().flatten() {
            if r.src_rank < p {
                node[r.src_rank] = Some(r.src_node);
            }
            if r.dst_rank < p {
                node[r.dst_rank] = Some(r.dst_node);
            }
        }
        node.iter()
            .enumerate()
            .map(|(r, n)| n.unwrap_or(r / per))
            .collect()
    }

    /// Total seconds per phase over ranks, `[min, mean, max]`: `summary.json` `timers`, else
    /// the last row of `diagnostics.csv`.
    pub fn phase_totals(&self) -> Vec<(String, [f64; 3])> {
        let timers = self.summary.get("timers");
        let last = self.diag.rows.len().checked_sub(1);
        PHASES
            .iter()
            .filter_map(|p| {
                let from_summary = timers.and_then(|t| t.get(format!("{p}_s"))).and_then(|t| {
                    Some([
                        t.get("min")?.as_f64()?,
                        t.get("mean")?.as_f64()?,
                        t.get("max")?.as_f64()?,
                    ])
                });
                let v = from_summary.or_else(|| {
                    let l = last?;
                    let g = |s: &str| self.diag.col(&format!("{p}_s_{s}")).map(|c| c[l]);
                    Some([g("min")?, g("mean")?, g("max")?])
                })?;
                Some((p.to_string(), v))
            })
            .collect()
    }
}
