use super::*;
use crate::comm::{selftest, Phase, TrafficEntry};
use std::time::{Duration, Instant};

/// Run `f` on another thread and fail the test if it takes longer than `secs` (a hang).
fn within<T: Send + 'static>(secs: u64, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = crossbeam::channel::bounded(1);
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(secs))
        .expect("run_local hung (no result within the time limit)")
}

#[test]
fn selftest_passes_on_1_to_8_ranks_with_1_and_2_threads() {
    for ranks in 1..=8 {
        for threads in 1..=2 {
            let r = within(60, move || run_local(ranks, threads, |c| selftest::run(c)));
            assert!(r.is_ok(), "{ranks} ranks x {threads} threads: {r:?}");
        }
    }
}

#[test]
fn each_rank_has_its_own_pool_and_thread() {
    for threads in 1..=2 {
        let names = run_local(3, threads, |c| {
            assert_eq!(rayon::current_num_threads(), threads);
            let sum: u64 = {
                use rayon::prelude::*;
                (0..1000u64).into_par_iter().sum()
            };
            assert_eq!(sum, 499_500);
            let name = std::thread::current().name().unwrap_or("").to_string();
            assert!(name.starts_with(&format!("rank {} worker", c.rank())), "{name}");
            Ok(name)
        })
        .unwrap();
        assert_eq!(names.len(), 3);
    }
}

#[test]
fn results_in_rank_order_and_bad_sizes_rejected() {
    let r = run_local(5, 1, |c| Ok(c.rank() * 10)).unwrap();
    assert_eq!(r, vec![0, 10, 20, 30, 40]);
    assert!(matches!(run_local(0, 1, |_| Ok(())), Err(Error::Input { .. })));
    assert!(matches!(run_local(2, 0, |_| Ok(())), Err(Error::Input { .. })));
}

#[test]
fn exchange_all_to_all_and_sparse_patterns() {
    for ranks in 1..=8 {
        // All-to-all, received in rank order.
        let got = run_local(ranks, 1, |c| {
            let sends = (0..c.size())
                .map(|d| (d, vec![c.rank() as u8, d as u8]))
                .collect();
            let from: Vec<usize> = (0..c.size()).collect();
            c.exchange(sends, &from, 1)
        })
        .unwrap();
        for (me, msgs) in got.iter().enumerate() {
            let want: Vec<Vec<u8>> = (0..ranks).map(|s| vec![s as u8, me as u8]).collect();
            assert_eq!(*msgs, want);
        }
        // Sparse: only even ranks send, to the next odd rank; odd ranks receive.
        let got = run_local(ranks, 2, |c| {
            let me = c.rank();
            let sends = if me % 2 == 0 && me + 1 < c.size() {
                vec![(me + 1, vec![7; me + 1])]
            } else {
                vec![]
            };
            let from = if me % 2 == 1 { vec![me - 1] } else { vec![] };
            c.exchange(sends, &from, 2)
        })
        .unwrap();
        for (me, msgs) in got.iter().enumerate() {
            if me % 2 == 1 {
                assert_eq!(*msgs, vec![vec![7; me]]);
            } else {
                assert!(msgs.is_empty());
            }
        }
    }
}

#[test]
fn messages_of_one_source_and_tag_stay_in_order() {
    let got = run_local(4, 1, |c| {
        let me = c.rank();
        if me != 0 {
            for k in 0..50u8 {
                c.send(0, 5 + (k % 2) as Tag, vec![me as u8, k])?;
            }
            return Ok(vec![]);
        }
        // Rank 0 receives in a fixed peer order, tag 6 first, whatever the arrival order.
        let mut seen = Vec::new();
        for src in [3, 1, 2] {
            for tag in [6, 5] {
                for _ in 0..25 {
                    seen.push(c.recv(src, tag)?);
                }
            }
        }
        Ok(seen)
    })
    .unwrap();
    let mut want = Vec::new();
    for src in [3u8, 1, 2] {
        for parity in [1u8, 0] {
            for k in (0..50u8).filter(|k| k % 2 == parity) {
                want.push(vec![src, k]);
            }
        }
    }
    assert_eq!(got[0], want);
}

#[test]
fn collectives_give_identical_bits_on_every_rank() {
    for ranks in [2, 3, 7] {
        let got = run_local(ranks, 2, |c| {
            let r = c.rank() as f64;
            let mut mx = [r.sqrt() * 0.1, -r, f64::MIN_POSITIVE * r];
            let mut mn = mx;
            c.all_reduce_max_f64(&mut mx)?;
            c.all_reduce_min_f64(&mut mn)?;
            let mut s = [c.rank() as i64 - 3, i64::MAX];
            c.all_reduce_sum_i64(&mut s)?;
            let bits: Vec<u64> = mx
                .iter()
                .chain(&mn)
                .map(|x| x.to_bits())
                .chain(s.iter().map(|&x| x as u64))
                .collect();
            Ok(bits)
        })
        .unwrap();
        assert!(got.iter().all(|b| *b == got[0]), "{got:?}");
        let p = ranks as i64;
        assert_eq!(got[0][6] as i64, p * (p - 1) / 2 - 3 * p);
        assert_eq!(f64::from_bits(got[0][1]), 0.0);
        assert_eq!(f64::from_bits(got[0][4]), -(p as f64 - 1.0));
    }
}

#[test]
fn traffic_log_counts_exactly_the_bytes_sent() {
    let logs = run_local(4, 1, |c| {
        let me = c.rank();
        c.set_phase(Phase::Migration);
        for d in 0..c.size() {
            c.send(d, 3, vec![0; 10 * me + d])?;
            c.send(d, 3, vec![0; 1])?;
        }
        for s in 0..c.size() {
            c.recv(s, 3)?;
            c.recv(s, 3)?;
        }
        let step1 = c.end_traffic_step();
        c.set_phase(Phase::Balance);
        let mut v = [1u64, 2, 3];
        c.all_reduce_sum_u64(&mut v)?;
        let step2 = c.end_traffic_step();
        Ok((step1, step2, c.traffic()))
    })
    .unwrap();
    for (me, (step1, step2, log)) in logs.iter().enumerate() {
        let want: Vec<TrafficEntry> = (0..4)
            .map(|d| TrafficEntry {
                phase: Phase::Migration,
                src: me,
                dst: d,
                bytes: (10 * me + d + 1) as u64,
                messages: 2,
            })
            .collect();
        assert_eq!(*step1, want);
        // All-reduce model: non-root ranks send 24 bytes to rank 0, rank 0 to each other.
        let dsts: Vec<usize> = step2.iter().map(|e| e.dst).collect();
        if me == 0 {
            assert_eq!(dsts, vec![1, 2, 3]);
        } else {
            assert_eq!(dsts, vec![0]);
        }
        assert!(step2
            .iter()
            .all(|e| e.phase == Phase::Balance && e.bytes == 24 && e.messages == 1));
        assert!(log.step().is_empty());
        let (b, n) = log.total_of(Some(Phase::Migration));
        assert_eq!((b, n), ((40 * me + 6 + 4) as u64, 8));
    }
}

/// Run 4 ranks where `bad` fails through `fail` after a barrier while the others block in a
/// receive from it (rank 0) or in an all-reduce (the rest); check the error and the time.
fn check_failure(fail: fn(&LocalComm) -> Result<()>, want: &'static str) {
    let t0 = Instant::now();
    let r = within(20, move || {
        run_local(4, 1, move |c| {
            c.barrier()?;
            match c.rank() {
                2 => {
                    std::thread::sleep(Duration::from_millis(50));
                    fail(c)
                }
                0 => c.recv(2, 9).map(|_| ()),
                _ => c.all_reduce_sum_u64(&mut [1]),
            }
        })
    });
    let e = r.expect_err("a failing rank must fail the run");
    let msg = e.to_string();
    assert!(matches!(e, Error::Run(_)), "{msg}");
    assert!(msg.contains("rank 2 failed"), "{msg}");
    assert!(msg.contains(want), "{msg}");
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
}

#[test]
fn panicking_rank_stops_the_run_naming_it() {
    check_failure(|_| panic!("injected panic at step 7"), "injected panic at step 7");
}

#[test]
fn err_returning_rank_stops_the_run_naming_it() {
    check_failure(
        |_| Err(Error::run("particle 42 left the domain at step 3")),
        "particle 42 left the domain at step 3",
    );
}

#[test]
fn abort_stops_the_run_naming_the_rank() {
    check_failure(|c| Err(c.abort("NaN in density")), "NaN in density");
}

#[test]
fn waiting_for_a_finished_rank_is_an_error_not_a_hang() {
    let r = within(20, || {
        run_local(2, 1, |c| {
            if c.rank() == 0 {
                c.recv(1, 0)?;
            }
            Ok(())
        })
    });
    let msg = r.unwrap_err().to_string();
    assert!(
        msg.contains("rank 0 failed") && msg.contains("rank 1 has finished"),
        "{msg}"
    );
}

#[test]
fn eight_single_threaded_ranks_on_two_cores_do_not_deadlock() {
    let r = within(60, || {
        run_local(8, 1, |c| {
            let (me, p) = (c.rank(), c.size());
            let mut total = 0u64;
            for step in 0..200u64 {
                let sends = vec![
                    ((me + 1) % p, step.to_le_bytes().to_vec()),
                    ((me + p - 1) % p, step.to_le_bytes().to_vec()),
                ];
                let got = c.exchange(sends, &[(me + p - 1) % p, (me + 1) % p], 4)?;
                assert!(got.iter().all(|b| *b == step.to_le_bytes()));
                let mut v = [step];
                c.all_reduce_sum_u64(&mut v)?;
                total += v[0];
            }
            Ok(total)
        })
    });
    let totals = r.unwrap();
    assert!(totals.iter().all(|&t| t == 8 * 199 * 200 / 2));
}
