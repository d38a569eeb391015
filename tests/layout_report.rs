//! At start a run prints the layout it got and warns where it differs from the job script's
//! plan (`HSPH_JOB_PLAN`, written by `hsph jobscript`; issue 10, item 5).

use crate::common;

fn run_with_plan(tag: &str, plan: &str, extra: &[&str]) -> (i32, String) {
    let out = common::temp_dir(tag).join("run");
    let mut args = vec![
        "run",
        "inputs/dam_break_2d.toml",
        "-q",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "time.max_steps=2",
    ];
    args.extend(extra);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_hsph"))
        .args(&args)
        .current_dir(common::repo_path(""))
        .env("HSPH_JOB_PLAN", plan)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn a_run_warns_where_its_layout_differs_from_the_job_plan() {
    let plan = "nodes=2,ranks_per_node=2,threads_per_rank=1";
    // the planned layout: 4 ranks, 2 per node, 1 thread each: no warning
    let (code, err) = run_with_plan(
        "plan-ok",
        plan,
        &["--ranks", "4", "--ranks-per-node", "2", "--threads", "1"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("job script planned"), "{err}");
    // all four ranks on one node and two threads each: three warnings, the run goes on
    let (code, err) = run_with_plan("plan-off", plan, &["--ranks", "4", "--threads", "2"]);
    assert_eq!(code, 0, "{err}");
    for w in [
        "planned 2 node(s), the run found 1",
        "planned 2 rank(s) per node, the run has 4 per node",
        "planned 1 thread(s) per rank, rank 0 runs 2",
    ] {
        assert!(err.contains(w), "missing `{w}` in\n{err}");
    }
    // a malformed plan is named, not fatal
    let (code, err) = run_with_plan("plan-bad", "nodes=two", &["--ranks", "2"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("HSPH_JOB_PLAN=`nodes=two` is not of the form"),
        "{err}"
    );
}
