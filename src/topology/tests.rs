use super::*;
use std::path::PathBuf;

fn shipped(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("topology")
        .join(name)
}

const GOOD: &str = "\
name = \"t\"
[node]
count = 4
numa_domains = 2
cores_per_domain = 12
ranks = 24
[cost]
intra_node = 1.0
inter_node = 10.0
[latency]
intra_node = 5e-7
inter_node = 2e-6
";

/// Parse `text`, expect an input error; return (key, line, message).
fn bad(text: &str) -> (String, Option<usize>, String) {
    match Topology::from_toml(text, Path::new("bad.toml")) {
        Err(Error::Input { at, key, message }) => {
            let at = at.expect("errors from a file carry the file");
            assert_eq!(at.file, Path::new("bad.toml"));
            (key, at.line, message)
        }
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn topology_shipped_files_load() {
    let t = Topology::load(&shipped("four_nodes_24.toml")).unwrap();
    assert_eq!((t.nodes(), t.ranks_per_node(), t.ranks()), (4, 24, 96));
    assert_eq!(
        (t.tasks_per_node(), t.cpus_per_task(), t.cores_per_node()),
        (24, 1, 24)
    );
    assert_eq!(t.node_of(23), 0);
    assert_eq!(t.node_of(24), 1);
    assert_eq!(t.node_of(95), 3);
    assert_eq!(t.numa_of(11), 0);
    assert_eq!(t.numa_of(12), 1);
    assert_eq!(t.numa_of(24), 0);
    let m = Topology::load(&shipped("this_machine.toml")).unwrap();
    assert_eq!(
        (m.nodes(), m.numa_domains, m.cores_per_node(), m.ranks()),
        (1, 1, 2, 2)
    );
    let s = Topology::load(&shipped("two_socket_48core.toml")).unwrap();
    assert_eq!((s.nodes(), s.numa_domains, s.cores_per_node()), (1, 2, 48));
    assert_eq!((s.tasks_per_node(), s.cpus_per_task()), (2, 24));
    assert_eq!((s.numa_of(0), s.numa_of(1)), (0, 1));
    assert!(t.check_ranks(96).is_ok());
    let e = t.check_ranks(48).unwrap_err();
    assert_eq!(e.exit_code(), 2);
}

#[test]
fn topology_ranks_per_node_override() {
    let t = Topology::from_ranks_per_node(96, 24).unwrap();
    assert_eq!((t.nodes(), t.ranks()), (4, 96));
    assert_eq!(t.ranks_of(2), 48..72);
    let u = Topology::from_ranks_per_node(10, 4).unwrap();
    assert_eq!(u.nodes(), 3);
    assert_eq!((u.node_size(0), u.node_size(2)), (4, 2));
    assert_eq!(u.node_of(9), 2);
    for (ranks, k, key) in [
        (4, 5, "ranks-per-node"),
        (4, 0, "ranks-per-node"),
        (0, 1, "ranks"),
    ] {
        let e = Topology::from_ranks_per_node(ranks, k).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        match e {
            Error::Input { key: k2, message, .. } => {
                assert_eq!(k2, key);
                assert!(!message.is_empty());
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn topology_bad_files_name_key_and_line() {
    assert!(Topology::from_toml(GOOD, Path::new("good.toml")).is_ok());
    // A typo'd key: reported at its own line, with the valid keys listed.
    let (key, line, msg) = bad(&GOOD.replace("numa_domains = 2", "numa_domian = 2"));
    assert_eq!(key, "node.numa_domian");
    assert_eq!(line, Some(4));
    assert!(
        msg.contains("unknown field") && msg.contains("numa_domains"),
        "{msg}"
    );
    // Zero nodes.
    let (key, line, msg) = bad(&GOOD.replace("count = 4", "count = 0"));
    assert_eq!((key.as_str(), line), ("node.count", Some(3)));
    assert!(msg.contains("at least 1"), "{msg}");
    // A missing key.
    let (key, _, msg) = bad(&GOOD.replace("ranks = 24\n", ""));
    assert_eq!(key, "node.ranks");
    assert!(msg.contains("missing"), "{msg}");
    // A negative cost, a NaN latency-free file section, an unknown top-level key.
    let (key, line, _) = bad(&GOOD.replace("inter_node = 10.0", "inter_node = -1.0"));
    assert_eq!((key.as_str(), line), ("cost.inter_node", Some(9)));
    let (key, line, _) = bad(&format!("nodes = 4\n{GOOD}"));
    assert_eq!((key.as_str(), line), ("nodes", Some(1)));
    // More cpus than the node has.
    let (key, _, msg) = bad(&GOOD.replace("ranks = 24", "ranks = 24\ncpus_per_rank = 2"));
    assert_eq!(key, "node.cpus_per_rank");
    assert!(msg.contains("at most 1"), "{msg}");
    // Not TOML at all.
    let (_, line, msg) = bad("[node\ncount = 1");
    assert_eq!(line, Some(1));
    assert!(msg.contains("not valid TOML"));
    // The message a user sees names file, line and key.
    let e = Topology::from_toml(&GOOD.replace("count = 4", "count = 0"), Path::new("bad.toml")).unwrap_err();
    assert_eq!(e.exit_code(), 2);
    assert!(
        e.to_string().starts_with("error: bad.toml:3: key `node.count`"),
        "{e}"
    );
}
