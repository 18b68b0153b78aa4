//! A wait's deadline and its last reason, and the wait set against a simple
//! reference model under random starts, checks, cancels and expiries.

use proptest::prelude::*;

use super::*;
use crate::text::abridge;
use crate::time::ms;

const C: &str = "`LT-3` > 10";

fn timed_out(wait: WaitId, timeout: u64, reason: Option<&str>) -> TimedOut {
    TimedOut {
        wait,
        reason: reason.map(str::to_owned),
        message: timeout_message(C, ms(timeout), reason),
    }
}

#[test]
fn a_timed_out_wait_is_worded_with_its_condition_timeout_and_last_reason() {
    assert_eq!(
        timeout_message("`LT-3` >= 100", ms(600), Some("values {\"LT-3\":50}")),
        "condition `LT-3` >= 100 did not hold within 0.6 s (last check: values {\"LT-3\":50})"
    );
    assert_eq!(
        timeout_message("`LT-3` < 50", ms(60_000), None),
        "condition `LT-3` < 50 did not hold within 60 s (last check: it was never checked)"
    );
    assert_eq!(TIMEOUT_CODE.name(), "CONDITION_TIMEOUT");
}

#[test]
fn a_wait_times_out_at_its_deadline_saying_why_it_last_did_not_hold() {
    let mut waits = Waits::default();
    let a = waits.start(C, ms(5_000), ms(1_000)).unwrap();
    let b = waits.start(C, ms(2_000), ms(1_500)).unwrap();
    assert_eq!(waits.deadline(a), Some(ms(6_000)));
    assert_eq!(waits.next_deadline(), Some(ms(3_500)), "the earliest one");
    assert_eq!(
        waits.checked(a, Some("LT-3 is stale".into()), ms(2_000)),
        Checked::Waiting
    );
    assert!(
        waits.expire(ms(3_499)).is_empty(),
        "nothing before its deadline"
    );
    assert_eq!(
        waits.expire(ms(3_500)),
        vec![timed_out(b, 2_000, None)],
        "never checked"
    );
    assert_eq!(waits.next_deadline(), Some(ms(6_000)));
    assert_eq!(
        waits.expire(ms(7_000)),
        vec![timed_out(a, 5_000, Some("LT-3 is stale"))]
    );
    assert!(waits.is_empty());
    assert_eq!(waits.next_deadline(), None, "no timer while nothing waits");
}

#[test]
fn a_condition_holding_by_the_deadline_counts_and_after_it_times_out() {
    let mut waits = Waits::default();
    let a = waits.start(C, ms(1_000), ms(0)).unwrap();
    assert_eq!(
        waits.checked(a, None, ms(1_000)),
        Checked::Met,
        "at the deadline itself"
    );
    assert_eq!(
        waits.checked(a, None, ms(1_000)),
        Checked::Unknown,
        "it ended"
    );
    assert!(waits.expire(ms(5_000)).is_empty());
    let b = waits.start(C, ms(1_000), ms(0)).unwrap();
    waits.checked(b, Some("values {\"L\":1}".into()), ms(10));
    // The timer came late: a sample after the deadline does not let it pass.
    assert_eq!(
        waits.checked(b, None, ms(1_001)),
        Checked::TimedOut(timed_out(b, 1_000, Some("values {\"L\":1}")))
    );
    assert_eq!(waits.next_deadline(), None);
}

#[test]
fn a_cancelled_wait_never_times_out_and_a_carried_deadline_stays() {
    let mut waits = Waits::default();
    let a = waits.start(C, ms(1_000), ms(0)).unwrap();
    assert!(waits.cancel(a));
    assert!(!waits.cancel(a));
    assert!(waits.expire(ms(2_000)).is_empty());
    let b = waits.until(C, ms(300), ms(700)).unwrap();
    assert_eq!(waits.deadline(b), Some(ms(700)));
    assert_ne!(a, b, "a new wait gets a new number");
    assert_eq!(waits.expire(ms(700)).len(), 1);
}

#[test]
fn a_wait_past_the_most_one_plant_keeps_is_refused_started_or_carried_over() {
    let mut waits = Waits::default();
    for _ in 0..MAX_WAITS {
        waits.start(C, ms(1_000), ms(0)).unwrap();
    }
    assert_eq!(waits.start(C, ms(1_000), ms(0)), Err(TooManyWaits));
    assert_eq!(waits.until(C, ms(1_000), ms(500)), Err(TooManyWaits));
    assert_eq!(waits.len(), MAX_WAITS, "nothing of them kept");
    assert_eq!(TooManyWaits.code(), Code::QueueFull);
    assert_eq!(
        TooManyWaits.to_string(),
        "more than 100000 msgs wait on conditions of one plant; refused"
    );
    // One ended makes room again.
    assert_eq!(waits.expire(ms(1_000)).len(), MAX_WAITS);
    assert!(waits.until(C, ms(1_000), ms(2_000)).is_ok());
}

#[test]
fn a_condition_text_is_kept_to_the_longest_read_both_ways() {
    let long = format!("`LT-3` > {}", "1".repeat(3 * MAX_CHARS));
    let mut waits = Waits::default();
    let a = waits.start(&long, ms(1_000), ms(0)).unwrap();
    let b = waits.until(&long, ms(1_000), ms(1_000)).unwrap();
    for (wait, out) in [a, b].into_iter().zip(waits.expire(ms(1_000))) {
        assert_eq!(out.wait, wait);
        let kept = abridge(&long, MAX_CHARS);
        assert_eq!(kept.chars().count(), MAX_CHARS);
        assert_eq!(out.message, timeout_message(&kept, ms(1_000), None));
    }
}

fn timeout_of(timeouts: &[(WaitId, u64)], wait: WaitId) -> u64 {
    timeouts
        .iter()
        .rev()
        .find(|(w, _)| *w == wait)
        .map_or(0, |(_, t)| *t)
}

#[derive(Clone, Debug)]
enum Op {
    Start(u64),
    Check(usize, bool),
    Cancel(usize),
    Expire,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        (0u64..3_000).prop_map(Op::Start),
        (0usize..8, any::<bool>()).prop_map(|(k, met)| Op::Check(k, met)),
        (0usize..8).prop_map(Op::Cancel),
        Just(Op::Expire),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// The reference: a list of (id, deadline, last reason), read literally.
    #[test]
    fn waits_match_the_reference(ops in prop::collection::vec((op(), 0u64..800), 1..80)) {
        let mut waits = Waits::default();
        let mut model: Vec<(WaitId, u64, Option<String>)> = Vec::new();
        let mut timeouts: Vec<(WaitId, u64)> = Vec::new();
        let mut started: Vec<WaitId> = Vec::new();
        let mut now = 0u64;
        for (step, (op, gap)) in ops.into_iter().enumerate() {
            now += gap;
            match op {
                Op::Start(timeout) => {
                    let id = waits.start(C, ms(timeout), ms(now)).unwrap();
                    prop_assert!(model.iter().all(|(w, _, _)| *w != id));
                    model.push((id, now + timeout, None));
                    timeouts.push((id, timeout));
                    started.push(id);
                }
                Op::Check(k, met) => {
                    let Some(&id) = started.get(k) else { continue };
                    let reason = (!met).then(|| format!("check {step}"));
                    let got = waits.checked(id, reason.clone(), ms(now));
                    let want = match model.iter().position(|(w, _, _)| *w == id) {
                        None => Checked::Unknown,
                        Some(i) if now > model[i].1 => {
                            let (wait, _, reason) = model.remove(i);
                            Checked::TimedOut(timed_out(wait, timeout_of(&timeouts, wait), reason.as_deref()))
                        }
                        Some(i) if met => {
                            model.remove(i);
                            Checked::Met
                        }
                        Some(i) => {
                            model[i].2 = reason;
                            Checked::Waiting
                        }
                    };
                    prop_assert_eq!(got, want);
                }
                Op::Cancel(k) => {
                    let Some(&id) = started.get(k) else { continue };
                    let had = model.iter().position(|(w, _, _)| *w == id).map(|i| model.remove(i));
                    prop_assert_eq!(waits.cancel(id), had.is_some());
                }
                Op::Expire => {
                    let mut due: Vec<_> = model.iter().filter(|(_, at, _)| *at <= now).cloned().collect();
                    due.sort_by_key(|(w, at, _)| (*at, *w));
                    model.retain(|(_, at, _)| *at > now);
                    let want: Vec<_> = due.into_iter().map(|(wait, _, reason)| timed_out(wait, timeout_of(&timeouts, wait), reason.as_deref())).collect();
                    prop_assert_eq!(waits.expire(ms(now)), want);
                }
            }
            prop_assert_eq!(waits.len(), model.len());
            prop_assert_eq!(waits.next_deadline(), model.iter().map(|(_, at, _)| ms(*at)).min());
        }
    }
}
