//! Reading a scene: file → `--set` overrides → typed [`Scene`] → validation, with every error
//! located by file, line and dotted key.

use super::{Interactions, NeighbourMode, Overlap, Scene};
use crate::error::{Error, Location, Result};
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml_edit::{DocumentMut, ImDocument, Item, TableLike, Value};

/// The text a scene was read from, kept to locate keys when reporting errors.
#[derive(Debug, Clone)]
pub struct SceneSource {
    /// File name shown in messages.
    pub file: PathBuf,
    /// Text after `--set` overrides.
    pub text: String,
    /// Dotted keys changed by `--set` (their errors point at the command line).
    pub overridden: Vec<String>,
    /// The file's own text, before overrides: line numbers refer to it.
    pub original: String,
    /// Dotted keys set by typed flags ([`SceneFlags`]), with the flag (their errors name it).
    pub flagged: Vec<(String, &'static str)>,
}

/// Typed command-line flags that set scene keys: `--interactions` (`performance.interactions`),
/// `--neighbours` (`performance.neighbours`) and `--overlap` (`performance.overlap`). They reach the scene as values — nothing is
/// formatted as text and parsed again — and are written into the scene's text, so that the run
/// directory's `scene.toml` (and a restart from it) keeps them; an error about such a key
/// names the flag.
/// The one declaration of these flags: `hsph run` and `hsph bench` flatten it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::Args)]
pub struct SceneFlags {
    /// Pair loops: `gather` (each particle sums all its neighbours in a fixed order: the same
    /// bits on any number of ranks and threads) or `pairs` (each pair of fluid particles once,
    /// fewer kernel evaluations; also the same bits on any number of ranks and threads — its
    /// own, equal to gather's to round-off). Default: the scene's `[performance]
    /// interactions`, else gather.
    #[arg(long, value_enum)]
    pub interactions: Option<Interactions>,
    /// Neighbour search: `lists` (stored once per step, 4 B per pair), `cells` (no lists,
    /// each pass scans the cells again: the lean-memory mode, same bits) or `verlet` (lists to
    /// the support·(1 + skin), kept until the ghosts are built again). Default: the scene's
    /// `[performance] neighbours`, else lists.
    #[arg(long, value_enum)]
    pub neighbours: Option<NeighbourMode>,
    /// Halo refreshes overlapped with the interior's compute: `on` (the ghosts' fields travel
    /// while the particles no ghost reaches are computed) or `off`; the same bits either way.
    /// Default: the scene's `[performance] overlap`, else off.
    #[arg(long, value_enum)]
    pub overlap: Option<Overlap>,
}

impl SceneFlags {
    /// Give the flags' values to `scene` and to its text in `src`.
    pub fn apply(&self, scene: &mut Scene, src: &mut SceneSource) -> Result<()> {
        let mut given: Vec<(&'static str, &'static str, &'static str)> = Vec::new();
        if let Some(i) = self.interactions {
            scene.performance.interactions = i;
            given.push(("--interactions", "performance.interactions", i.name()));
        }
        if let Some(m) = self.neighbours {
            scene.performance.neighbours = m;
            given.push(("--neighbours", "performance.neighbours", m.name()));
        }
        if let Some(o) = self.overlap {
            scene.performance.overlap = o;
            given.push(("--overlap", "performance.overlap", o.name()));
        }
        if given.is_empty() {
            return Ok(());
        }
        // a flag's value meets the scene's other keys here, after the scene's own checks
        super::validate::check_verlet(scene).map_err(|e| match e {
            Error::Input { key, message, .. } => {
                let flag = given.iter().find(|g| g.1 == key).map_or("--neighbours", |g| g.0);
                Error::Input {
                    at: Some(Location {
                        file: PathBuf::from(flag),
                        line: None,
                    }),
                    key,
                    message,
                }
            }
            other => other,
        })?;
        let mut doc: DocumentMut = src
            .text
            .parse()
            .map_err(|_| Error::run("the scene's text no longer parses"))?;
        for (flag, key, value) in given {
            set_path(doc.as_table_mut(), &parse_path(key), Value::from(value)).map_err(|why| {
                Error::Input {
                    at: Some(Location {
                        file: PathBuf::from(flag),
                        line: None,
                    }),
                    key: key.to_string(),
                    message: format!("cannot set it: {why}"),
                }
            })?;
            src.flagged.push((key.to_string(), flag));
        }
        src.text = doc.to_string();
        Ok(())
    }
}

/// One step of a key path: a table key or an array index.
#[derive(Debug, Clone, PartialEq)]
enum Seg {
    Key(String),
    Index(usize),
}

/// Parse `fluid.0.min` or `fluid[0].min` into segments.
fn parse_path(path: &str) -> Vec<Seg> {
    path.replace('[', ".")
        .replace(']', "")
        .split('.')
        .filter(|s| !s.is_empty())
        .map(|s| match s.parse::<usize>() {
            Ok(i) => Seg::Index(i),
            Err(_) => Seg::Key(s.to_string()),
        })
        .collect()
}

/// Display segments as `fluid[0].min`.
fn display_path(segs: &[Seg]) -> String {
    let mut s = String::new();
    for seg in segs {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Seg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// Read and validate a scene file, applying `--set key.path=value` overrides.
pub fn load_scene(path: &Path, overrides: &[String]) -> Result<(Scene, SceneSource)> {
    let text = crate::limits::read_text(path, "SCENE")?;
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
        .to_string();
    load_scene_str(&text, path, &stem, overrides)
}

/// Parse scene text (as if read from `file`), apply overrides, deserialise and validate.
pub fn load_scene_str(
    text_in: &str,
    file: &Path,
    default_name: &str,
    overrides: &[String],
) -> Result<(Scene, SceneSource)> {
    let at_file = |line: Option<usize>| {
        Some(Location {
            file: file.to_path_buf(),
            line,
        })
    };
    let text = text_in;
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| Error::Input {
        at: at_file(e.span().map(|s| line_of(text, s.start))),
        key: String::new(),
        message: format!("not valid TOML: {}", first_line(e.message())),
    })?;
    let mut overridden = Vec::new();
    for o in overrides {
        overridden.push(apply_override(&mut doc, o)?);
    }
    let text = if overrides.is_empty() {
        text.to_string()
    } else {
        doc.to_string()
    };
    let src = SceneSource {
        file: file.to_path_buf(),
        text,
        overridden,
        original: text_in.to_string(),
        flagged: Vec::new(),
    };
    let mut scene: Scene = toml::from_str(&src.text).map_err(|e| src.serde_error(&e))?;
    if scene.name.is_empty() {
        scene.name = default_name.to_string();
    }
    super::outline_file::read_outlines(&mut scene, file).map_err(|e| src.locate(e))?;
    super::mesh_file::read_meshes(&mut scene, file).map_err(|e| src.locate(e))?;
    // duplicate body names, the later in the file named (validation alone knows only kinds)
    super::validate::check_body_names(&scene, Some(&body_positions(&src.text))).map_err(|e| src.locate(e))?;
    super::validate(&mut scene).map_err(|e| src.locate(e))?;
    Ok((scene, src))
}

/// Where each body starts in scene `text`: `fluid[i]`, `solid[i]`, `wall[i]` to a byte offset
/// (arrays of tables or inline arrays alike). One parse, however many bodies.
fn body_positions(text: &str) -> std::collections::HashMap<String, usize> {
    let mut at = std::collections::HashMap::new();
    let Ok(doc) = ImDocument::parse(text.to_string()) else {
        return at;
    };
    for kind in ["fluid", "solid", "wall"] {
        let starts: Vec<Option<usize>> = match doc.as_table().get(kind) {
            Some(Item::ArrayOfTables(a)) => a.iter().map(|t| t.span().map(|s| s.start)).collect(),
            Some(Item::Value(Value::Array(a))) => a.iter().map(|v| v.span().map(|s| s.start)).collect(),
            _ => continue,
        };
        for (i, start) in starts.into_iter().enumerate() {
            if let Some(start) = start {
                at.insert(format!("{kind}[{i}]"), start);
            }
        }
    }
    at
}

/// Apply one `key.path=value` override; returns the dotted key.
fn apply_override(doc: &mut DocumentMut, o: &str) -> Result<String> {
    let at_set = Some(Location {
        file: PathBuf::from("--set"),
        line: None,
    });
    let Some((key, raw)) = o.split_once('=') else {
        return Err(Error::Input {
            at: at_set,
            key: o.trim().to_string(),
            message: format!("`{o}` is not key.path=value; e.g. --set time.t_end=0.5"),
        });
    };
    let key = key.trim();
    let segs = parse_path(key);
    let value: Value = raw
        .trim()
        .parse::<Value>()
        .unwrap_or_else(|_| Value::from(raw.trim().to_string()));
    set_path(doc.as_table_mut(), &segs, value).map_err(|why| Error::Input {
        at: at_set,
        key: display_path(&segs),
        message: format!("cannot set it: {why}"),
    })?;
    Ok(display_path(&segs))
}

/// Set the value at `segs` below table `t`, creating missing tables on the way.
fn set_path(t: &mut dyn TableLike, segs: &[Seg], value: Value) -> std::result::Result<(), String> {
    let Some((Seg::Key(k), rest)) = segs.split_first() else {
        return Err("a key path starts with a key, e.g. fluid.0.min".into());
    };
    if rest.is_empty() {
        t.insert(k, Item::Value(value));
        return Ok(());
    }
    if t.get(k).is_none() {
        t.insert(k, Item::Table(toml_edit::Table::new()));
    }
    let item = t.get_mut(k).ok_or("missing parent")?;
    match (item, &rest[0]) {
        (Item::ArrayOfTables(a), Seg::Index(i)) => {
            let len = a.len();
            let tab = a
                .get_mut(*i)
                .ok_or(format!("index {i} is past the end of `{k}` (length {len})"))?;
            set_path(tab, &rest[1..], value)
        }
        (Item::Value(Value::Array(arr)), Seg::Index(i)) if rest.len() == 1 => {
            let len = arr.len();
            let slot = arr
                .get_mut(*i)
                .ok_or(format!("index {i} is past the end of `{k}` (length {len})"))?;
            *slot = value;
            Ok(())
        }
        (Item::Table(tab), Seg::Key(_)) => set_path(tab, rest, value),
        (Item::Value(Value::InlineTable(tab)), Seg::Key(_)) => set_path(tab, rest, value),
        _ => Err(format!("`{k}` cannot be indexed that way")),
    }
}

impl SceneSource {
    /// Attach file and line to an error produced by validation (which knows only the key).
    /// A conflict between a key of the file and a key a typed flag set (`--interactions
    /// pairs` against `time.stepping = "local"`), whose message names the flag's key, is
    /// blamed on the flag: the file alone was valid.
    pub fn locate(&self, e: Error) -> Error {
        match e {
            Error::Input {
                at: None,
                key,
                message,
            } => {
                let by_flag = self
                    .flagged
                    .iter()
                    .find(|(k, _)| message.contains(k.as_str()))
                    .map(|(_, flag)| Location {
                        file: PathBuf::from(flag),
                        line: None,
                    });
                let at = by_flag.or_else(|| self.location_of(&key, None));
                Error::Input { at, key, message }
            }
            other => other,
        }
    }

    /// True if `key` is, or lies below, a key set by `--set`.
    /// A key the file does not have but an override created (`--set nosuch.x=1` makes
    /// `nosuch`) counts too: the flag, not the file, is to blame.
    fn is_overridden(&self, key: &str) -> bool {
        let below = |k: &str, parent: &str| {
            k.strip_prefix(parent)
                .is_some_and(|rest| rest.starts_with('.') || rest.starts_with('['))
        };
        self.overridden.iter().any(|o| {
            key == o
                || below(key, o)
                || (!key.is_empty() && below(o, key) && span_of(&self.original, &parse_path(key)).is_none())
        })
    }

    /// `--set` for an overridden key, else the file and the line of the key (or of its
    /// nearest existing ancestor) in the file's own text, else `fallback_line`.
    fn location_of(&self, key: &str, fallback_line: Option<usize>) -> Option<Location> {
        if let Some((_, flag)) = self.flagged.iter().find(|(k, _)| k == key) {
            return Some(Location {
                file: PathBuf::from(flag),
                line: None,
            });
        }
        if self.is_overridden(key) {
            return Some(Location {
                file: PathBuf::from("--set"),
                line: None,
            });
        }
        let line = span_of(&self.original, &parse_path(key))
            .map(|s| line_of(&self.original, s.start))
            .or(fallback_line);
        Some(Location {
            file: self.file.clone(),
            line,
        })
    }

    /// Turn a deserialisation error into a located input error naming the key.
    fn serde_error(&self, e: &toml::de::Error) -> Error {
        let span = e.span();
        // a span over the whole document is the top-level table itself
        let whole =
            |s: &std::ops::Range<usize>| s.start == 0 && (s.end == 0 || s.end >= self.text.trim_end().len());
        let mut key = span
            .clone()
            .filter(|s| !whole(s))
            .and_then(|s| ImDocument::parse(self.text.clone()).ok().map(|d| key_at(&d, &s)))
            .unwrap_or_default();
        let mut message = plain_types(first_line(e.message()));
        // inside a tagged table (a probe's kind) the parser can only point at the array; find
        // the entry that holds the offending value instead
        let mut span = span;
        if let Some(found) = message
            .strip_prefix("unknown variant `")
            .and_then(|r| r.split('`').next())
            .and_then(|v| key_holding(&self.text, &key, v))
        {
            key = found;
            span = None;
        }
        // a tagged table (a probe of a kind, the reference, a wall's motion law) is read as a
        // whole before its kind is known, so the parser points at the table, or at the first
        // entry of an array of them: find the entry and the key the message is about
        if let Some(found) = self.in_tagged_table(&key, &message) {
            key = found;
            span = None;
        }
        if message.contains("string or table") {
            // an enum's value that is not a string: name the valid ones, which the parser
            // gives for a string it does not know (the value put back as one, parsed again)
            if let Some(values) = span.clone().and_then(|s| self.variants_at(s)) {
                message = format!("expected {values}, in quotes");
            }
        }
        if let Some(range) = key_range(&key) {
            // a key with a narrower range than its integer type: say the range, not the type's
            if let Some((head, _)) = message.split_once("expected a whole number from 0 to ") {
                message = format!("{head}expected {range}; e.g. level = 1");
            }
        }
        if let Some(field) = message
            .strip_prefix("missing field `")
            .and_then(|r| r.split('`').next())
        {
            // name the missing key itself, not only the table it is missing from; the required
            // top-level keys belong to no table (the span of the root table is its first entry)
            key = if key.is_empty() || ["dimension", "domain", "discretisation", "time"].contains(&field) {
                field.to_string()
            } else {
                format!("{key}.{field}")
            };
            message.push_str(" (see README, 'Scene files', for every key and its default)");
        }
        // the span is in the text after overrides; without overrides it is the file's own
        let fallback = if self.overridden.is_empty() {
            span.map(|s| line_of(&self.text, s.start))
        } else {
            None
        };
        Error::Input {
            at: self.location_of(&key, fallback),
            key,
            message,
        }
    }
}

impl SceneSource {
    /// The key a deserialisation error `message` is about when the parser could only name the
    /// table `key` holding it: for an array of tables (`probe`, or its `probe[0]`) the first
    /// entry that fails alone with the same message (a prefix of the array parsed at a time,
    /// halving), then the key inside that table the message names (`unknown field`) or whose
    /// value it quotes (`invalid type: integer `3``). `None` if `key` names a value, or no
    /// table.
    fn in_tagged_table(&self, key: &str, message: &str) -> Option<String> {
        let doc = ImDocument::parse(self.text.clone()).ok()?;
        let segs = parse_path(key);
        let (base, table): (String, &dyn TableLike) = match segs.as_slice() {
            [Seg::Key(k)] | [Seg::Key(k), Seg::Index(_)]
                if matches!(doc.as_table().get(k), Some(Item::ArrayOfTables(_))) =>
            {
                let Some(Item::ArrayOfTables(a)) = doc.as_table().get(k) else {
                    return None;
                };
                let guess = match segs.get(1) {
                    Some(Seg::Index(i)) => Some(*i),
                    _ => None,
                };
                let j = self.first_failing_entry(k, a.len(), message).or(guess)?;
                (format!("{k}[{j}]"), a.get(j)?)
            }
            _ => (key.to_string(), table_at(doc.as_table(), &segs)?),
        };
        Some(match field_named(table, message) {
            Some(f) => format!("{base}.{f}"),
            None => base,
        })
    }

    /// The first entry of the top-level array of tables `name` (of `len` entries) such that
    /// the scene with the entries up to it alone fails to deserialise with `message`.
    fn first_failing_entry(&self, name: &str, len: usize, message: &str) -> Option<usize> {
        let fails = |upto: usize| -> bool {
            let Ok(mut doc) = self.text.parse::<DocumentMut>() else {
                return false;
            };
            if let Some(Item::ArrayOfTables(a)) = doc.as_table_mut().get_mut(name) {
                while a.len() > upto + 1 {
                    a.remove(a.len() - 1);
                }
            }
            match toml::from_str::<Scene>(&doc.to_string()) {
                Err(e) => plain_types(first_line(e.message())) == message,
                Ok(_) => false,
            }
        };
        if len == 0 || !fails(len - 1) {
            return None;
        }
        let (mut lo, mut hi) = (0, len - 1);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if fails(mid) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        Some(lo)
    }

    /// The valid values of the enum whose value sits at `span` of the text: the text parsed
    /// again with a string no enum holds there, whose refusal lists them.
    fn variants_at(&self, span: std::ops::Range<usize>) -> Option<String> {
        const PROBE: &str = r"\u0001";
        let text =
            self.text.get(..span.start)?.to_string() + "\"" + PROBE + "\"" + self.text.get(span.end..)?;
        let e = toml::from_str::<Scene>(&text).err()?;
        let m = first_line(e.message());
        m.strip_prefix("unknown variant `\u{1}`, expected ")
            .map(str::to_string)
    }
}

/// The table at `segs` below `t` (a table, an inline table or an entry of an array of tables).
fn table_at<'a>(t: &'a dyn TableLike, segs: &[Seg]) -> Option<&'a dyn TableLike> {
    let Some((Seg::Key(k), rest)) = segs.split_first() else {
        return Some(t);
    };
    match (t.get(k)?, rest.first()) {
        (Item::ArrayOfTables(a), Some(Seg::Index(i))) => table_at(a.get(*i)?, &rest[1..]),
        (Item::Table(tab), _) => table_at(tab, rest),
        (Item::Value(Value::InlineTable(tab)), _) => table_at(tab, rest),
        _ => None,
    }
}

/// The key of table `t` a deserialisation message is about: the field it names (`unknown
/// field `f``), else the first key whose value is what it quotes (`invalid type: integer
/// `3`, expected …`: the same value, else a value of the same type; `invalid length 1`: an
/// array of that length).
fn field_named(t: &dyn TableLike, message: &str) -> Option<String> {
    // an unknown field of this table (not the table itself, unknown to its parent)
    if let Some(f) = message
        .strip_prefix("unknown field `")
        .and_then(|r| r.split('`').next())
    {
        return t.contains_key(f).then(|| f.to_string());
    }
    let values: Vec<(String, Value)> = t
        .iter()
        .filter_map(|(k, v)| Some((k.to_string(), v.as_value()?.clone())))
        .collect();
    if let Some(n) = message
        .strip_prefix("invalid length ")
        .and_then(|r| r.split(',').next())
        .and_then(|n| n.parse::<usize>().ok())
    {
        return values
            .iter()
            .find(|(_, v)| v.as_array().is_some_and(|a| a.len() == n))
            .map(|(k, _)| k.clone());
    }
    let quoted = message
        .strip_prefix("invalid type: ")
        .or_else(|| message.strip_prefix("invalid value: "))?
        .split(", expected")
        .next()?;
    let (exact, kind): (Vec<_>, Vec<_>) = values
        .iter()
        .map(|(k, v)| {
            let (word, shown) = match v {
                Value::Integer(i) => ("integer", format!("integer `{}`", i.value())),
                Value::Float(x) => ("floating point", format!("floating point `{}`", x.value())),
                Value::String(s) => ("string", format!("string {:?}", s.value())),
                Value::Boolean(b) => ("boolean", format!("boolean `{}`", b.value())),
                Value::Array(_) => ("sequence", "sequence".to_string()),
                Value::InlineTable(_) => ("map", "map".to_string()),
                Value::Datetime(_) => ("datetime", "datetime".to_string()),
            };
            ((k, shown == quoted), (k, quoted.starts_with(word)))
        })
        .unzip();
    let first = |v: Vec<(&String, bool)>| v.into_iter().find(|(_, ok)| *ok).map(|(k, _)| k.clone());
    first(exact).or_else(|| first(kind))
}

/// First line of a parser message, trimmed.
pub(crate) fn first_line(s: &str) -> &str {
    s.lines().next().unwrap_or(s).trim()
}

/// 1-based line of byte offset `pos`.
pub(crate) fn line_of(text: &str, pos: usize) -> usize {
    text.as_bytes()[..pos.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Span of the dotted `key` (e.g. `node.count`, `fluid[0].min`), or of its nearest existing
/// ancestor, in TOML `text`.
pub(crate) fn span_of_key(text: &str, key: &str) -> Option<Range<usize>> {
    span_of(text, &parse_path(key))
}

/// Span of the key at `path` (or of its nearest existing ancestor).
fn span_of(text: &str, path: &[Seg]) -> Option<Range<usize>> {
    let doc = ImDocument::parse(text.to_string()).ok()?;
    let mut best = None;
    span_in(doc.as_table(), path, &mut best);
    best
}

fn span_in(t: &dyn TableLike, path: &[Seg], best: &mut Option<Range<usize>>) {
    let Some((Seg::Key(k), rest)) = path.split_first() else {
        return;
    };
    let Some((key, item)) = t.get_key_value(k) else {
        return;
    };
    if let Some(s) = key.span().or_else(|| item.span()) {
        *best = Some(s);
    }
    match (item, rest.first()) {
        (Item::ArrayOfTables(a), Some(Seg::Index(i))) => {
            if let Some(tab) = a.get(*i) {
                if let Some(s) = tab.span() {
                    *best = Some(s);
                }
                span_in(tab, &rest[1..], best);
            }
        }
        (Item::Value(Value::Array(arr)), Some(Seg::Index(i))) => {
            if let Some(s) = arr.get(*i).and_then(|v| v.span()) {
                *best = Some(s);
            }
        }
        (Item::Table(tab), Some(Seg::Key(_))) => span_in(tab, rest, best),
        (Item::Value(Value::InlineTable(tab)), Some(Seg::Key(_))) => span_in(tab, rest, best),
        _ => {}
    }
}

/// The parser's message with Rust's type names said as a scene's author reads them:
/// "expected u32" becomes "expected a whole number from 0 to 4294967295", "expected f64"
/// "expected a number".
fn plain_types(message: &str) -> String {
    let words: [(&str, String); 6] = [
        ("expected f64", "expected a number".into()),
        ("expected u8", whole(u8::MAX.into())),
        ("expected u16", whole(u16::MAX.into())),
        ("expected u32", whole(u32::MAX.into())),
        ("expected u64", whole(u64::MAX)),
        ("expected usize", whole(usize::MAX as u64)),
    ];
    for (rust, plain) in words {
        if let Some(head) = message.strip_suffix(rust) {
            return format!("{head}{plain}");
        }
    }
    message.to_string()
}

/// The valid values of an integer key whose range is narrower than its type's, for the
/// message of a value its type refuses (a negative or fractional `level`).
fn key_range(key: &str) -> Option<&'static str> {
    (key.starts_with("refine[") && key.ends_with(".level")).then_some(super::refine::LEVELS)
}

/// "expected a whole number from 0 to `max`".
fn whole(max: u64) -> String {
    format!("expected a whole number from 0 to {max}")
}

/// The key `array[i].k` of the first entry of the array of tables named by `at` (for example
/// `probe[0]` or `probe`) whose key `k` holds the string `value`.
fn key_holding(text: &str, at: &str, value: &str) -> Option<String> {
    let name = at.split('[').next()?;
    let doc = ImDocument::parse(text.to_string()).ok()?;
    let Item::ArrayOfTables(a) = doc.as_table().get(name)? else {
        return None;
    };
    let found = a.iter().enumerate().find_map(|(i, t)| {
        t.iter()
            .find(|(_, v)| v.as_str() == Some(value))
            .map(|(k, _)| format!("{name}[{i}].{k}"))
    });
    found
}

/// The dotted key path of the deepest item whose span contains `span`.
pub(crate) fn key_at(doc: &ImDocument<String>, span: &Range<usize>) -> String {
    fn walk(item: &Item, span: &Range<usize>, path: &mut Vec<Seg>, best: &mut Vec<Seg>) {
        let contains = |s: Option<Range<usize>>| {
            s.map(|s| s.start <= span.start && span.start < s.end.max(s.start + 1))
                .unwrap_or(false)
        };
        if let Some(t) = item.as_table_like() {
            for (k, v) in t.iter() {
                path.push(Seg::Key(k.to_string()));
                let key_span = t.get_key_value(k).and_then(|(key, _)| key.span());
                if contains(v.span()) || contains(key_span) {
                    *best = path.clone();
                }
                walk(v, span, path, best);
                path.pop();
            }
        } else if let Item::ArrayOfTables(a) = item {
            for (i, t) in a.iter().enumerate() {
                path.push(Seg::Index(i));
                if contains(t.span()) {
                    *best = path.clone();
                }
                walk(&Item::Table(t.clone()), span, path, best);
                path.pop();
            }
        } else if let Item::Value(Value::Array(arr)) = item {
            for (i, v) in arr.iter().enumerate() {
                path.push(Seg::Index(i));
                if contains(v.span()) {
                    *best = path.clone();
                }
                path.pop();
            }
        }
    }
    let mut best = Vec::new();
    walk(doc.as_item(), span, &mut Vec::new(), &mut best);
    display_path(&best)
}
