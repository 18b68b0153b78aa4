use std::collections::BTreeMap;

use super::*;
use crate::time::ms;

const LINES: [&str; 5] = ["YEL", "GRN", "BLU", "PUR", "RED"];

fn text(s: &str) -> Raw {
    Raw::Text(s.to_owned())
}

/// An engine on the case study's lines, started, with nodes:
/// 1-3 acquire (op 10 prio 20 YEL, op 12 prio 22 YEL, op 18 prio 92 YEL,RED),
/// 4 acquire with a 5 s timeout (op 51 RED), 5 release, 6 cancel, 7 fault,
/// 8 e-stop, 9 clear all, 10 clear (refusals wired).
struct Bench {
    engine: Engine,
    now: u64,
}

impl Bench {
    fn new() -> Self {
        let mut config = InterlockConfig::with_resources(LINES);
        for r in &mut config.resources {
            r.lockout = serde_json::json!({ "valves": { format!("V-{}", r.name): 0 } });
        }
        Self::with(config)
    }

    fn with(config: InterlockConfig) -> Self {
        let mut b = Self::unstarted(config);
        b.run(Input::Start(Saved::First));
        b
    }

    /// The nodes added, the start not yet given.
    fn unstarted(config: InterlockConfig) -> Self {
        let mut engine = Engine::new(config, false).unwrap();
        let nodes = [
            (
                1,
                NodeSpec::acquire(text("10"), Raw::Number(20.0), text("YEL"), ms(0)),
            ),
            (
                2,
                NodeSpec::acquire(text("12"), text("22"), text("YEL"), ms(0)),
            ),
            (
                3,
                NodeSpec::acquire(text("18"), Raw::Number(92.0), text("YEL, RED"), ms(0)),
            ),
            (
                4,
                NodeSpec::acquire(text("51"), Raw::Absent, text("RED"), ms(5000)),
            ),
            (5, NodeSpec::of(NodeKind::Release, Raw::Absent)),
            (6, NodeSpec::of(NodeKind::Cancel, Raw::Absent)),
            (
                7,
                NodeSpec::of(
                    NodeKind::Fault {
                        by_resources: false,
                        fail_msg: false,
                    },
                    Raw::Absent,
                ),
            ),
            (
                8,
                NodeSpec {
                    kind: NodeKind::Fault {
                        by_resources: true,
                        fail_msg: true,
                    },
                    operation: Raw::Absent,
                    priority: Raw::Absent,
                    resources: text("RED"),
                },
            ),
            (
                9,
                NodeSpec::of(
                    NodeKind::Clear {
                        all_faulted: true,
                        refusals_wired: false,
                    },
                    Raw::Absent,
                ),
            ),
            (
                10,
                NodeSpec::of(
                    NodeKind::Clear {
                        all_faulted: false,
                        refusals_wired: true,
                    },
                    Raw::Absent,
                ),
            ),
        ];
        for (node, spec) in nodes {
            engine.handle(
                Input::AddNode {
                    node: NodeId(node),
                    spec,
                },
                ms(0),
            );
        }
        engine.take_outputs();
        Bench { engine, now: 0 }
    }

    fn at(&mut self, t: u64) -> &mut Self {
        self.now = t;
        self
    }

    fn run(&mut self, input: Input) -> Vec<Output> {
        self.engine.handle(input, ms(self.now));
        self.engine.take_outputs()
    }

    fn acquire(&mut self, node: u32, msg: u32) -> Vec<Output> {
        self.run(Input::Acquire {
            node: NodeId(node),
            msg: MsgId(msg),
            fields: MsgFields::default(),
        })
    }

    fn release(&mut self, msg: u32, operation: &str) -> Vec<Output> {
        self.run(Input::Release {
            node: NodeId(5),
            msg: MsgId(msg),
            fields: Fields {
                follow: text(operation),
                ..Fields::default()
            }
            .into(),
        })
    }

    fn tick(&mut self, t: u64) -> Vec<Output> {
        self.now = t;
        self.engine.tick(ms(t));
        self.engine.take_outputs()
    }
}

/// The msgs sent (msg, port) and completed (msg, code) by a batch, in order.
fn answers(out: &[Output]) -> Vec<String> {
    out.iter()
        .filter_map(|o| match o {
            Output::Send { msg, port, .. } => Some(format!("send {} on {port}", msg.0)),
            Output::Complete { msg, refusal } => Some(match refusal {
                Some(r) => format!("fail {} {}", msg.0, r.code.name()),
                None => format!("done {}", msg.0),
            }),
            Output::Emit { msg, port, msgs } => {
                Some(format!("emit {} on {port} x{}", msg.0, msgs.len()))
            }
            _ => None,
        })
        .collect()
}

fn granted_interlock(out: &[Output], msg: u32) -> (String, i32, Vec<String>, u64) {
    out.iter()
        .find_map(|o| match o {
            Output::Send {
                msg: m,
                set:
                    Set::Interlock {
                        operation,
                        priority,
                        resources,
                        waited_ms,
                    },
                ..
            } if m.0 == msg => Some((
                operation.to_string(),
                *priority,
                resources.iter().map(|r| r.to_string()).collect(),
                waited_ms.as_u64(),
            )),
            _ => None,
        })
        .expect("a grant")
}

/// Whether a batch logs the catalog text `key` at `level`.
fn logged(out: &[Output], level: Level, key: &str) -> bool {
    out.iter().any(|o| match o {
        Output::Log { level: l, text } => {
            *l == level && matches!(&**text, Text::Catalog { key: k, .. } if *k == key)
        }
        _ => false,
    })
}

/// The refusal of the first msg completed with one.
fn first_refusal(out: &[Output]) -> Refusal {
    out.iter()
        .find_map(|o| match o {
            Output::Complete {
                refusal: Some(r), ..
            } => Some(r.clone()),
            _ => None,
        })
        .expect("a msg completed with a refusal")
}

fn counts(out: &[Output]) -> Option<Counts> {
    out.iter().rev().find_map(|o| match o {
        Output::Counts(c) => Some(*c),
        _ => None,
    })
}

#[test]
fn a_free_line_is_granted_at_once_after_the_commit() {
    let mut b = Bench::new();
    let out = b.at(5).acquire(1, 100);
    assert!(matches!(out[0], Output::Commit { urgent: false }));
    assert!(
        matches!(out.last(), Some(Output::Counts(_))),
        "the counts last (the host shows them at once)"
    );
    assert_eq!(answers(&out), ["send 100 on 0"]);
    assert_eq!(
        granted_interlock(&out, 100),
        ("10".into(), 20, vec!["YEL".into()], 0)
    );
    assert_eq!(
        counts(&out),
        Some(Counts {
            holding: 1,
            ..Counts::default()
        })
    );
}

#[test]
fn a_release_sends_its_msg_then_the_grants_in_priority_order() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.at(10).acquire(1, 2);
    b.at(20).acquire(2, 3);
    let waiting = b.at(30).acquire(4, 4);
    assert_eq!(
        answers(&waiting),
        Vec::<String>::new(),
        "op 51 waits for RED"
    );
    let out = b.at(100).release(9, "18");
    assert_eq!(
        answers(&out),
        ["send 9 on 0", "send 3 on 0", "send 4 on 0"],
        "the release's own msg first, then op 12 (22 > 20) and op 51"
    );
    assert_eq!(granted_interlock(&out, 3).3, 80, "op 12 waited 80 ms");
    assert_eq!(
        counts(&out),
        Some(Counts {
            holding: 2,
            queued: 1,
            ..Counts::default()
        })
    );
}

#[test]
fn an_acquire_timeout_is_a_deadline_that_withdraws_the_request() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.at(1000).acquire(4, 2);
    assert_eq!(b.engine.next_deadline(), Some(ms(6000)));
    assert_eq!(answers(&b.tick(5999)), Vec::<String>::new());
    let out = b.tick(6000);
    assert_eq!(answers(&out), ["fail 2 ACQUIRE_TIMEOUT"]);
    let refusal = first_refusal(&out);
    assert_eq!(refusal.key(), Some("errors.acquireTimeout"));
    assert_eq!(
        refusal.params(),
        vec![
            ("operation", Param::Text("51".into())),
            ("resources", Param::Text("RED".into())),
            ("seconds", Param::Text("5".into())),
        ]
    );
    assert!(out.contains(&Output::NodeError {
        node: NodeId(4),
        code: Code::AcquireTimeout
    }));
    assert_eq!(b.engine.interlock().counts().queued, 0);
    assert_eq!(b.engine.next_deadline(), None);
    // A grant before the deadline clears it.
    b.at(7000).acquire(4, 3);
    b.release(4, "18");
    assert_eq!(b.engine.next_deadline(), None);
}

#[test]
fn a_grant_nobody_waits_for_is_released_at_once() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.at(10).acquire(1, 2);
    // A hand-over from a state that knows the waiting request but not its msg.
    let mut doc = b.engine.snapshot(ms(20));
    doc.engine = None;
    let mut standby = Engine::new(b.engine.config().clone(), false).unwrap();
    standby.handle(
        Input::AddNode {
            node: NodeId(5),
            spec: NodeSpec::of(NodeKind::Release, Raw::Absent),
        },
        ms(20),
    );
    standby.hand_over(&doc, ms(20)).unwrap();
    standby.take_outputs();
    standby.handle(
        Input::Release {
            node: NodeId(5),
            msg: MsgId(9),
            fields: Fields {
                operation: text("18"),
                ..Fields::default()
            }
            .into(),
        },
        ms(30),
    );
    let out = standby.take_outputs();
    assert_eq!(answers(&out), ["send 9 on 0"]);
    assert!(logged(&out, Level::Warn, "logs.grantedUnclaimed"));
    assert_eq!(
        standby.interlock().counts().holding,
        0,
        "op 10 was released again"
    );
}

#[test]
fn a_drain_holds_waiting_requests_back_and_queues_them_again_in_order() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.at(10).acquire(2, 2);
    b.at(20).acquire(4, 3);
    b.at(30).acquire(1, 4);
    b.run(Input::Life(Step::DrainBegin));
    assert_eq!(b.engine.stage(), Stage::Draining);
    assert_eq!(b.engine.interlock().counts().queued, 0, "out of the queue");
    assert_eq!(b.engine.counts().queued, 3, "still counted as waiting");
    // A release while draining grants nobody; it is not held back itself.
    let out = b.at(40).release(9, "18");
    assert_eq!(answers(&out), ["send 9 on 0"]);
    // The timeout runs on while held back.
    assert_eq!(answers(&b.tick(5020)), ["fail 3 ACQUIRE_TIMEOUT"]);
    let names: Vec<&str> = b.engine.held_back().map(|h| h.0).collect();
    assert_eq!(names, ["12", "10"]);
    // A new request while draining waits too.
    b.run(Input::Acquire {
        node: NodeId(1),
        msg: MsgId(5),
        fields: Fields {
            operation: text("60"),
            resources: text("GRN"),
            ..Fields::default()
        }
        .into(),
    });
    let out = b.at(6000).run(Input::Life(Step::DrainEnd));
    assert_eq!(answers(&out), ["send 2 on 0", "send 5 on 0"]);
    assert_eq!(
        granted_interlock(&out, 2).3,
        5990,
        "waited since it first came"
    );
    assert_eq!(b.engine.counts().queued, 1, "op 10 waits behind op 12");
}

#[test]
fn priorities_default_to_zero_and_names_are_trimmed() {
    let mut b = Bench::new();
    let out = b.run(Input::Acquire {
        node: NodeId(4),
        msg: MsgId(1),
        fields: Fields {
            operation: text("  truck "),
            ..Fields::default()
        }
        .into(),
    });
    assert_eq!(
        granted_interlock(&out, 1),
        ("truck".into(), 0, vec!["RED".into()], 0)
    );
    let out = b.run(Input::Acquire {
        node: NodeId(1),
        msg: MsgId(2),
        fields: Fields {
            operation: text("x"),
            priority: text("urgent"),
            ..Fields::default()
        }
        .into(),
    });
    assert_eq!(answers(&out), ["fail 2 INVALID_PRIORITY"]);
}

#[test]
fn a_clear_is_attributed_to_the_signed_in_user_over_msg_by() {
    let mut b = Bench::new();
    b.run(Input::Fault {
        node: NodeId(8),
        msg: MsgId(1),
        fields: MsgFields::default(),
    });
    let out = b.run(Input::Clear {
        node: NodeId(9),
        msg: MsgId(2),
        fields: Fields {
            who: WhoFields {
                user: SignedIn::username("ann"),
                by: text("bob"),
                reason: text("checked"),
                force: false,
            },
            ..Fields::default()
        }
        .into(),
        names_given: false,
    });
    assert!(out.iter().any(|o| matches!(o,
        Output::Send { msg: MsgId(2), port: 0, set: Set::Cleared(c) }
        if c.cleared == ["RED".to_owned()] && c.by == "ann" && c.reason.as_deref() == Some("checked") && !c.forced)));
    assert!(out.iter().any(|o| matches!(o,
        Output::Journal(j) if j.action == Action::Clear && j.by.as_deref() == Some("ann"))));
    assert_eq!(b.engine.interlock().counts().faulted, 0);
}

#[test]
fn a_fault_locks_out_first_even_unsaved_then_answers_the_queue() {
    let mut b = Bench::new();
    b.acquire(1, 1);
    b.at(10).acquire(2, 2);
    let out = b.at(20).run(Input::Fault {
        node: NodeId(7),
        msg: MsgId(3),
        fields: Fields {
            follow: text("10"),
            error_message: text("pump P1 ran dry"),
            ..Fields::default()
        }
        .into(),
    });
    assert!(matches!(out[0], Output::Commit { urgent: true }));
    assert_eq!(answers(&out), ["emit 3 on 1 x1", "send 3 on 0"]);
    let Output::Emit { msgs, .. } = &out[1] else {
        panic!("{out:?}")
    };
    assert_eq!(msgs[0].topic, "lockout/YEL");
    assert_eq!(msgs[0].operation.as_deref(), Some("10"));
    assert_eq!(msgs[0].note.as_deref(), Some("pump P1 ran dry"));
    assert_eq!(msgs[0].fault_at_ms, ms(20));
    assert_eq!(
        msgs[0].payload,
        serde_json::json!({ "valves": { "V-YEL": 0 } })
    );
    // The waiter's fault drops it: its msg completes unsent.
    let out = b.at(30).run(Input::Fault {
        node: NodeId(7),
        msg: MsgId(4),
        fields: Fields {
            operation: text("12"),
            ..Fields::default()
        }
        .into(),
    });
    assert_eq!(answers(&out), ["emit 4 on 1 x0", "send 4 on 0", "done 2"]);
}

#[test]
fn an_emergency_stop_that_fails_its_msg_says_what_it_stopped() {
    let mut b = Bench::new();
    let out = b.run(Input::Fault {
        node: NodeId(8),
        msg: MsgId(1),
        fields: Fields {
            who: WhoFields {
                reason: text("leak"),
                ..WhoFields::default()
            },
            ..Fields::default()
        }
        .into(),
    });
    assert_eq!(answers(&out), ["emit 1 on 1 x1", "fail 1 FAULTED"]);
    assert!(out.iter().any(|o| matches!(o,
        Output::Complete { refusal: Some(r), .. }
        if matches!(&r.text, Text::Faulted { operation: None, lines, note: Some(note) }
            if lines == &["RED".to_owned()] && note == "leak"))));
    assert!(out
        .iter()
        .any(|o| matches!(o, Output::Journal(j) if j.action == Action::EStop)));
}

#[test]
fn a_lost_state_starts_all_faulted_until_cleared() {
    let (mut engine, out) = started(&LINES, Saved::Lost("state.json is empty".into()), 0);
    assert_eq!(
        counts(&out),
        Some(Counts {
            faulted: 5,
            lost: true,
            ..Counts::default()
        })
    );
    assert!(logged(&out, Level::Error, "logs.stateUnknown"));
    assert_eq!(engine.lost(), Some("state.json is empty"));
    engine.handle(
        Input::Clear {
            node: NodeId(9),
            msg: MsgId(1),
            fields: MsgFields::default(),
            names_given: false,
        },
        ms(10),
    );
    assert_eq!(counts(&engine.take_outputs()), Some(Counts::default()));
    assert_eq!(engine.lost(), None);
}

#[test]
fn inputs_wait_while_starting_and_a_shutdown_completes_held_msgs_unsent() {
    let mut engine = Engine::new(InterlockConfig::with_resources(LINES), false).unwrap();
    engine.handle(
        Input::AddNode {
            node: NodeId(1),
            spec: NodeSpec::acquire(text("10"), Raw::Absent, text("YEL"), ms(0)),
        },
        ms(0),
    );
    for msg in [1, 2] {
        engine.handle(
            Input::Acquire {
                node: NodeId(1),
                msg: MsgId(msg),
                fields: MsgFields::default(),
            },
            ms(0),
        );
    }
    assert!(engine.take_outputs().is_empty(), "nothing before the start");
    engine.handle(Input::Start(Saved::First), ms(5));
    let out = engine.take_outputs();
    assert_eq!(answers(&out), ["send 1 on 0", "fail 2 ALREADY_HOLDING"]);
    engine.handle(
        Input::Acquire {
            node: NodeId(1),
            msg: MsgId(3),
            fields: Fields {
                operation: text("11"),
                ..Fields::default()
            }
            .into(),
        },
        ms(6),
    );
    engine.take_outputs();
    engine.handle(Input::Life(Step::Shutdown), ms(7));
    let out = engine.take_outputs();
    assert_eq!(answers(&out), ["done 3"]);
    assert!(
        !out.iter().any(|o| matches!(o, Output::Commit { .. })),
        "a shutdown changes no state"
    );
    engine.handle(
        Input::Acquire {
            node: NodeId(1),
            msg: MsgId(4),
            fields: MsgFields::default(),
        },
        ms(8),
    );
    assert_eq!(answers(&engine.take_outputs()), ["done 4"]);
    assert_eq!(engine.next_deadline(), None);
}

/// Node 3 (op 18) and node 4 (op 51, 5 s timeout) ask for RED before the start.
fn parked_for_red() -> Bench {
    let mut b = Bench::unstarted(InterlockConfig::with_resources(LINES));
    assert!(b.at(1000).acquire(3, 1).is_empty());
    assert!(b.at(2000).acquire(4, 2).is_empty());
    b.run(Input::Operator {
        msg: MsgId(3),
        action: OperatorAction::EStop {
            lines: vec!["BLU".into()],
        },
        who: WhoFields::default(),
    });
    assert!(b.engine.take_outputs().is_empty(), "all parked");
    b
}

#[test]
fn a_shutdown_or_removal_before_the_start_answers_every_parked_msg() {
    for step in [Step::Shutdown, Step::Retire] {
        let mut b = parked_for_red();
        let out = b.at(3000).run(Input::Life(step));
        assert_eq!(answers(&out), ["done 1", "done 2"], "{step:?}");
        assert!(
            matches!(answer_to(&out, 3), Err(r) if r.code == Code::InterlockStopped),
            "{step:?}: the operator is told"
        );
        assert!(b.engine.take_parked().is_empty());
        // Nothing is left to replay, and nothing after is taken.
        assert_eq!(
            answers(&b.run(Input::Start(Saved::First))),
            Vec::<String>::new()
        );
        assert_eq!(b.engine.interlock().counts().holding, 0);
    }
    // A host that frees its engine unstarted takes the parked inputs to answer them.
    let mut b = parked_for_red();
    let parked = b.engine.take_parked();
    let arrived: Vec<u64> = parked.iter().map(|(_, at)| at.as_u64()).collect();
    assert_eq!(arrived, [1000, 2000, 2000]);
}

#[test]
fn a_parked_requests_timeout_counts_from_its_arrival() {
    // Started before the timeout ran out: it times out 5 s after it arrived.
    let mut b = parked_for_red();
    let out = b.at(4000).run(Input::Start(Saved::First));
    assert_eq!(answers(&out), ["send 1 on 0"], "op 51 waits for RED");
    assert_eq!(b.engine.next_deadline(), Some(ms(7000)));
    assert_eq!(answers(&b.tick(6999)), Vec::<String>::new());
    assert_eq!(answers(&b.tick(7000)), ["fail 2 ACQUIRE_TIMEOUT"]);
    // One granted at the start waited from its arrival.
    let mut b = parked_for_red();
    let out = b.at(2500).run(Input::Start(Saved::First));
    assert_eq!(granted_interlock(&out, 1).3, 1500);
    // Started when its time had run out: it timed out waiting, though RED is free.
    for start in [7000, 9000] {
        let mut b = Bench::unstarted(InterlockConfig::with_resources(LINES));
        b.at(2000).acquire(4, 2);
        let out = b.at(start).run(Input::Start(Saved::First));
        assert_eq!(
            answers(&out),
            ["fail 2 ACQUIRE_TIMEOUT"],
            "started at {start}"
        );
        let refusal = first_refusal(&out);
        assert_eq!(refusal.params()[2], ("seconds", Param::Text("5".into())));
        assert!(out.contains(&Output::NodeError {
            node: NodeId(4),
            code: Code::AcquireTimeout
        }));
        assert_eq!(b.engine.interlock().counts().queued, 0);
        assert_eq!(b.engine.next_deadline(), None);
    }
}

#[test]
fn a_parked_acquire_times_out_before_the_start_and_nothing_is_saved() {
    let mut b = parked_for_red();
    // Op 51 (node 4, 5 s) arrived at 2000: due at 7000 though the engine has not started.
    assert_eq!(b.engine.next_deadline(), Some(ms(7000)));
    assert_eq!(answers(&b.tick(6999)), Vec::<String>::new());
    let out = b.tick(7000);
    assert_eq!(answers(&out), ["fail 2 ACQUIRE_TIMEOUT"]);
    assert!(
        !out.iter().any(|o| matches!(o, Output::Commit { .. })),
        "an unstarted engine has no state to save"
    );
    let refusal = first_refusal(&out);
    assert_eq!(refusal.params()[0], ("operation", Param::Text("51".into())));
    assert_eq!(refusal.params()[2], ("seconds", Param::Text("5".into())));
    assert_eq!(b.engine.next_deadline(), None);
    // The rest still waits for the start.
    let out = b.at(8000).run(Input::Start(Saved::First));
    assert_eq!(answers(&out), ["send 1 on 0"]);
    // A removal before the start saves nothing either.
    let mut b = parked_for_red();
    let out = b.at(3000).run(Input::Life(Step::Retire));
    assert!(!out.iter().any(|o| matches!(o, Output::Commit { .. })));
}

#[test]
fn parked_inputs_move_to_a_new_engine_with_their_arrival() {
    let mut b = parked_for_red();
    let parked = b.engine.take_parked();
    // Unstarted: they park again, within its bound, their timeouts from their arrival.
    let mut next = Bench::unstarted(InterlockConfig::with_resources(LINES));
    next.engine.set_park_bound(2);
    next.engine.receive_parked(parked, ms(3000));
    let out = next.engine.take_outputs();
    assert!(matches!(answer_to(&out, 3), Err(r) if r.code == Code::QueueFull));
    assert_eq!(next.engine.next_deadline(), Some(ms(7000)));
    let out = next.at(4000).run(Input::Start(Saved::First));
    assert_eq!(answers(&out), ["send 1 on 0"]);
    assert_eq!(answers(&next.tick(7000)), ["fail 2 ACQUIRE_TIMEOUT"]);
    // Started: they are taken now, as of their arrival.
    let mut b = parked_for_red();
    let parked = b.engine.take_parked();
    let mut started = Bench::unstarted(InterlockConfig::with_resources(LINES));
    started.at(2500).run(Input::Start(Saved::First));
    started.engine.receive_parked(parked, ms(2500));
    let out = started.engine.take_outputs();
    assert_eq!(granted_interlock(&out, 1).3, 1500);
    assert!(answer_to(&out, 3).is_ok());
}

#[test]
fn parking_is_bounded_for_msgs_and_the_refusal_says_why() {
    let mut b = Bench::unstarted(InterlockConfig::with_resources(LINES));
    b.engine.set_park_bound(2);
    assert!(b.acquire(1, 1).is_empty());
    // Inputs without a msg are not counted (nor refused: nobody to tell).
    b.run(Input::StoreFailing(None));
    assert!(b.acquire(4, 2).is_empty());
    let out = b.acquire(3, 3);
    assert_eq!(answers(&out), ["fail 3 QUEUE_FULL"]);
    assert!(out.contains(&Output::NodeError {
        node: NodeId(3),
        code: Code::QueueFull
    }));
    let refusal = first_refusal(&out);
    assert_eq!(refusal.key(), Some("errors.parkedFull"));
    assert_eq!(
        refusal.params(),
        vec![
            ("kind", Param::Text("interlock".into())),
            ("max", Param::Text("2".into())),
        ]
    );
    let out = b.run(Input::Operator {
        msg: MsgId(4),
        action: OperatorAction::Clear { lines: None },
        who: WhoFields::default(),
    });
    assert!(matches!(answer_to(&out, 4), Err(r) if r.code == Code::QueueFull));
    let out = b.run(Input::Start(Saved::First));
    assert_eq!(answers(&out), ["send 1 on 0", "send 2 on 0"]);
    // Running, nothing parks: the bound does not apply (it queues for YEL).
    assert_eq!(answers(&b.acquire(2, 5)), Vec::<String>::new());
    assert_eq!(b.engine.counts().queued, 1);
}

#[test]
fn a_node_gone_for_good_withdraws_its_requests() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.acquire(1, 2);
    b.acquire(2, 3);
    // Restarted by a deploy: its msg waits for the next instance.
    b.run(Input::Life(Step::DeployBegin));
    b.run(Input::CloseNode {
        node: NodeId(1),
        removed: false,
    });
    b.run(Input::CloseNode {
        node: NodeId(2),
        removed: false,
    });
    b.run(Input::AddNode {
        node: NodeId(2),
        spec: NodeSpec::acquire(text("12"), text("22"), text("YEL"), ms(0)),
    });
    let out = b.run(Input::Life(Step::DeployEnd));
    assert_eq!(answers(&out), ["done 2"], "node 1 did not come back");
    assert_eq!(b.engine.counts().queued, 1);
    let out = b.run(Input::CloseNode {
        node: NodeId(2),
        removed: true,
    });
    assert_eq!(answers(&out), ["done 3"]);
}

/// Warnings after 10 s of waiting; op 18 holds YEL, op 10 waits for it from 1 s.
fn op_10_waiting() -> Bench {
    let mut config = InterlockConfig::with_resources(LINES);
    config.warn_queued_ms = Some(ms(10_000));
    let mut b = Bench::with(config);
    b.acquire(3, 1);
    b.at(1000).acquire(1, 2);
    b
}

#[test]
fn elapsed_time_warnings_and_their_alarms_are_deadlines() {
    let mut b = op_10_waiting();
    assert_eq!(b.engine.next_deadline(), Some(ms(11_000)));
    b.at(1500).acquire(2, 3);
    assert_eq!(
        b.engine.next_deadline(),
        Some(ms(11_000)),
        "op 12's warning falls on the beat after 11.5 s: 12 s"
    );
    let out = b.tick(11_000);
    assert!(logged(&out, Level::Warn, "events.waitedLong"));
    assert!(out
        .iter()
        .any(|o| matches!(o, Output::Alarm { change: c } if c.id == "waiting-long:10")));
    // The alarm's text counts the seconds: looked at again every second while it holds.
    assert_eq!(b.engine.next_deadline(), Some(ms(12_000)));
    b.at(11_500).run(Input::Cancel {
        node: NodeId(6),
        msg: MsgId(9),
        fields: Fields {
            follow: text("10"),
            ..Fields::default()
        }
        .into(),
    });
    let out = b.tick(12_000);
    assert!(
        out.iter()
            .any(|o| matches!(o, Output::Alarm { change: c } if c.id == "waiting-long:10")),
        "returned to normal"
    );
    assert!(
        logged(&out, Level::Warn, "events.waitedLong"),
        "op 12 warned at 12 s"
    );
}

#[test]
fn a_hand_over_beats_its_checks_from_then() {
    let mut b = op_10_waiting();
    let doc = b.engine.snapshot(ms(2500));
    let mut standby = Engine::new(b.engine.config().clone(), false).unwrap();
    standby.hand_over(&doc, ms(2500)).unwrap();
    b.engine.hand_over(&doc, ms(2500)).unwrap();
    for engine in [&mut b.engine, &mut standby] {
        engine.take_outputs();
        assert_eq!(
            engine.next_deadline(),
            Some(ms(11_500)),
            "op 10 waits long at 11 s: the beat after it counted from 2.5 s"
        );
        engine.tick(ms(11_500));
        assert!(logged(
            &engine.take_outputs(),
            Level::Warn,
            "events.waitedLong"
        ));
    }
}

#[test]
fn the_state_document_holds_the_requests_and_a_hand_over_keeps_them() {
    let mut b = Bench::new();
    b.acquire(3, 1);
    b.at(100).acquire(4, 2);
    let doc = b.engine.snapshot(ms(200));
    let text = serde_json::to_string(&doc).unwrap();
    let read: StateDoc = serde_json::from_str(&text).unwrap();
    assert_eq!(read, doc);
    assert_eq!(read.format, STATE_FORMAT);
    let requests = &read.engine.as_ref().unwrap().requests;
    assert_eq!(requests.len(), 1);
    assert_eq!(requests[0].deadline_ms, Some(ms(5100)));

    let mut standby = b.engine.clone();
    standby.hand_over(&read, ms(200)).unwrap();
    standby.take_outputs();
    // Both go on alike.
    for engine in [&mut b.engine, &mut standby] {
        engine.tick(ms(5100));
    }
    assert_eq!(b.engine.take_outputs(), standby.take_outputs());
}

#[test]
fn a_waiting_request_whose_lines_the_new_settings_lack_is_refused_at_the_hand_over() {
    let mut b = Bench::new();
    b.acquire(2, 1);
    b.at(10).run(Input::Acquire {
        node: NodeId(1),
        msg: MsgId(2),
        fields: Fields {
            resources: text("YEL, GRN"),
            ..Fields::default()
        }
        .into(),
    });
    b.run(Input::Life(Step::DrainBegin));
    let doc = b.engine.snapshot(ms(20));
    let lines: Vec<&str> = LINES.iter().copied().filter(|l| *l != "GRN").collect();
    let mut next = Engine::new(InterlockConfig::with_resources(lines), false).unwrap();
    next.hand_over(&doc, ms(20)).unwrap();
    let out = next.take_outputs();
    assert_eq!(answers(&out), ["fail 2 UNKNOWN_RESOURCE"]);
    assert_eq!(next.counts().queued, 0);
}

#[test]
fn during_a_drain_a_request_for_a_line_only_the_new_settings_have_waits_by_its_names_with_its_timeout(
) {
    let mut b = Bench::new();
    b.run(Input::Life(Step::DrainBegin));
    let teal = |msg: u32| Input::Acquire {
        node: NodeId(4),
        msg: MsgId(msg),
        fields: Fields {
            resources: text("TEAL"),
            ..Fields::default()
        }
        .into(),
    };
    assert_eq!(
        answers(&b.at(10).run(teal(1))),
        Vec::<String>::new(),
        "held back, not refused"
    );
    assert_eq!(b.engine.counts().queued, 1);
    // Its timeout runs while it waits.
    assert_eq!(answers(&b.tick(5010)), ["fail 1 ACQUIRE_TIMEOUT"]);
    b.at(6000).run(teal(2));
    let mut lines = LINES.to_vec();
    lines.push("TEAL");
    let mut next = Engine::new(InterlockConfig::with_resources(lines), false).unwrap();
    next.hand_over(&b.engine.snapshot(ms(6000)), ms(6000))
        .unwrap();
    next.handle(Input::Life(Step::DrainBegin), ms(6000));
    next.take_outputs();
    next.handle(Input::Life(Step::DrainEnd), ms(6100));
    assert_eq!(answers(&next.take_outputs()), ["send 2 on 0"]);
    // Under settings that still lack it, the drain's end refuses it.
    let out = b.at(6200).run(Input::Life(Step::DrainEnd));
    assert_eq!(answers(&out), ["fail 2 UNKNOWN_RESOURCE"]);
}

/// An engine on `lines` with a clear-all node (9), started from `saved` at `now`.
fn started(lines: &[&str], saved: Saved, now: u64) -> (Engine, Vec<Output>) {
    let mut engine = Engine::new(
        InterlockConfig::with_resources(lines.iter().copied()),
        false,
    )
    .unwrap();
    engine.handle(
        Input::AddNode {
            node: NodeId(9),
            spec: NodeSpec::of(
                NodeKind::Clear {
                    all_faulted: true,
                    refusals_wired: false,
                },
                Raw::Absent,
            ),
        },
        ms(0),
    );
    engine.handle(Input::Start(saved), ms(now));
    let out = engine.take_outputs();
    (engine, out)
}

fn sealed(text: &str, owner: &str) -> Saved {
    Saved::Sealed(Box::new(SealedDoc {
        text: text.to_owned(),
        source: "state.json".to_owned(),
        owner: owner.to_owned(),
        plant: None,
    }))
}

#[test]
fn a_sealed_document_restarts_by_the_one_rule_held_lines_faulted_added_lines_free() {
    let mut b = Bench::new();
    b.acquire(1, 1);
    b.at(100).acquire(2, 2);
    let text = b
        .engine
        .seal("il-1", None, BTreeMap::new(), Vec::new(), ms(200));
    // The interlock's own reader takes the engine's document.
    let config = InterlockConfig::with_resources(LINES);
    let binding = Binding {
        owner: "il-1",
        plant: None,
    };
    let opened = Interlock::open(config, binding, "state.json", &text, None, ms(300)).unwrap();
    assert!(matches!(opened.start, Start::Restored { .. }));

    let mut more = LINES.to_vec();
    more.push("ORG");
    let (engine, out) = started(&more, sealed(&text, "il-1"), 1000);
    // YEL was held: faulted by the restart; the waiting request is dropped; ORG was added since: free.
    let lock = engine.interlock();
    assert_eq!(
        lock.faulted_resources(),
        lock.resource_set(&["YEL"]).unwrap()
    );
    assert_eq!(engine.lost(), None);
    assert!(logged(&out, Level::Warn, "logs.lineAdded"));
    assert_eq!(
        counts(&out),
        Some(Counts {
            faulted: 1,
            ..Counts::default()
        })
    );
}

#[test]
fn another_interlocks_or_a_damaged_sealed_document_is_a_lost_state() {
    let b = Bench::new();
    let text = b
        .engine
        .seal("il-1", None, BTreeMap::new(), Vec::new(), ms(0));
    let damaged = text.replacen("YEL", "YEX", 1);
    for (text, owner) in [(text.as_str(), "il-2"), (damaged.as_str(), "il-1")] {
        let (engine, out) = started(&LINES, sealed(text, owner), 1000);
        assert_eq!(engine.interlock().faulted_resources().len(), LINES.len());
        assert!(engine
            .lost()
            .is_some_and(|why| why.starts_with("state.json: ")));
        assert!(logged(&out, Level::Error, "logs.stateUnknown"));
    }
}

#[test]
fn an_emergency_stops_note_is_the_caught_error_over_the_stated_reason_over_the_payload() {
    let cases = [
        (
            text("PS-4 tripped"),
            text("foam"),
            text("payload"),
            "PS-4 tripped",
        ),
        (Raw::Absent, text("foam"), text("payload"), "foam"),
        (Raw::Absent, Raw::Absent, text("payload"), "payload"),
    ];
    for (error_message, reason, payload, note) in cases {
        let mut b = Bench::new();
        let out = b.run(Input::Fault {
            node: NodeId(8),
            msg: MsgId(1),
            fields: Fields {
                error_message,
                payload,
                who: WhoFields {
                    reason,
                    ..WhoFields::default()
                },
                ..Fields::default()
            }
            .into(),
        });
        assert!(
            out.iter().any(|o| matches!(o,
                Output::Emit { msgs, .. } if msgs[0].note.as_deref() == Some(note))),
            "{note}"
        );
    }
}

#[test]
fn who_listens_before_the_start_hears_every_event_of_the_start() {
    let b = Bench::new();
    let text = b
        .engine
        .seal("il-1", None, BTreeMap::new(), Vec::new(), ms(0));
    let mut more = LINES.to_vec();
    more.push("ORG");
    let kinds = |listen: bool| {
        let mut engine =
            Engine::new(InterlockConfig::with_resources(more.iter().copied()), false).unwrap();
        engine.handle(Input::Listen(listen), ms(0));
        engine.handle(Input::Start(sealed(&text, "il-1")), ms(10));
        engine
            .take_outputs()
            .into_iter()
            .filter_map(|o| match o {
                Output::Event { event } => Some(event.kind),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    assert!(kinds(true).contains(&EventKind::ResourceAdded));
    assert!(
        !kinds(false).contains(&EventKind::ResourceAdded),
        "a normal event, and nobody listens"
    );
}

#[test]
fn a_one_shot_shelf_ends_when_its_condition_ends() {
    let mut config = InterlockConfig::with_resources(LINES);
    config.warn_queued_ms = Some(ms(1000));
    let mut b = Bench::with(config);
    b.acquire(3, 1);
    b.acquire(1, 2);
    b.tick(1000);
    let shelve = |one_shot| Input::Operator {
        msg: MsgId(7),
        action: OperatorAction::Alarm(AlarmAction::Shelve {
            id: "waiting-long:10".to_owned(),
            until_ms: ms(3_600_000),
            one_shot,
        }),
        who: WhoFields::default(),
    };
    let out = b.at(1500).run(shelve(true));
    assert!(out
        .iter()
        .any(|o| matches!(o, Output::Reply { answer: Ok(_), .. })));
    assert!(b
        .engine
        .alarms()
        .list()
        .any(|a| a.id == "waiting-long:10" && a.shelved.as_ref().is_some_and(|s| s.one_shot)));
}

#[test]
fn a_name_msgs_repeat_crosses_the_wire_once() {
    let mut b = Bench::new();
    let mut wire = wire::Wire::new();
    let named = |msg| Input::Acquire {
        node: NodeId(1),
        msg: MsgId(msg),
        fields: Fields {
            operation: text("boil"),
            resources: text("YEL, RED"),
            ..Fields::default()
        }
        .into(),
    };
    let out = b.run(named(1));
    wire.encode(&out);
    let announced = |wire: &wire::Wire| {
        wire.words()
            .iter()
            .filter(|w| **w == wire::tag::NAME)
            .count()
    };
    assert_eq!(announced(&wire), 3, "boil, YEL and RED");
    b.release(2, "boil");
    let out = b.run(named(3));
    assert_eq!(granted_interlock(&out, 3).0, "boil");
    wire.encode(&out);
    assert_eq!(
        announced(&wire),
        0,
        "the second msg's names are numbers only"
    );
}

/// What answered msg `k` in `out`.
fn answer_to(out: &[Output], k: u32) -> &Result<serde_json::Value, Refusal> {
    out.iter()
        .find_map(|o| match o {
            Output::Reply { msg, answer } if *msg == MsgId(k) => Some(answer),
            _ => None,
        })
        .expect("an answer")
}

#[test]
fn an_abort_saved_with_a_plant_stands_on_the_engine_until_a_person_resets_it() {
    let b = Bench::new();
    let mut aborted = AbortedOperations::default();
    let ana = Attribution::new(Some("ana"), Some("gasket"), false);
    aborted.ended("10", State::Aborted, &ana, ms(5));
    let beside = crate::interlock::Beside {
        aborted,
        ..Default::default()
    };
    let binding = Binding {
        owner: "il-1",
        plant: None,
    };
    let saved = b.engine.interlock().seal(binding, beside, ms(10));
    let (mut engine, _) = started(&LINES, sealed(&saved, "il-1"), 1000);
    let view = engine.view(ms(1000), &|_| Vec::new());
    assert_eq!(view.aborted.len(), 1);
    assert_eq!(
        (
            view.aborted[0].operation.as_str(),
            view.aborted[0].by.as_str()
        ),
        ("10", "ana")
    );
    // Carried through the engine's own document and a hand-over.
    let resealed = engine.seal("il-1", None, BTreeMap::new(), Vec::new(), ms(1001));
    let config = InterlockConfig::with_resources(LINES);
    let reopened =
        Interlock::open(config, binding, "state.json", &resealed, None, ms(1002)).unwrap();
    assert_eq!(reopened.aborted.state("10"), State::Aborted);
    assert_eq!(
        engine.snapshot(ms(1003)).aborted.state("10"),
        State::Aborted
    );

    let command = |k, target, command| Input::Operator {
        msg: MsgId(k),
        action: OperatorAction::Command { target, command },
        who: WhoFields {
            by: text("bo"),
            ..WhoFields::default()
        },
    };
    let ten = || CommandTarget::Operation("10".to_owned());
    let cases = [
        (1, ten(), Command::Hold, Code::CommandRefused),
        (
            2,
            CommandTarget::Routine("r".to_owned()),
            Command::Reset,
            Code::UnknownRun,
        ),
        (
            3,
            CommandTarget::Operation("12".to_owned()),
            Command::Reset,
            Code::UnknownRun,
        ),
    ];
    for (k, target, cmd, code) in cases {
        engine.handle(command(k, target, cmd), ms(1010));
        let out = engine.take_outputs();
        assert!(!out.iter().any(|o| matches!(o, Output::Commit { .. })));
        assert!(
            matches!(answer_to(&out, k), Err(r) if r.code == code),
            "{k}"
        );
    }
    engine.handle(command(4, ten(), Command::Reset), ms(1020));
    let out = engine.take_outputs();
    assert!(
        matches!(out.first(), Some(Output::Commit { .. })),
        "saved before answered"
    );
    assert!(out.iter().any(|o| matches!(o,
        Output::Journal(j) if j.action == Action::Reset && j.target == ["10"])));
    assert_eq!(
        answer_to(&out, 4).as_ref().unwrap(),
        &serde_json::json!({ "operation": "10", "command": "reset", "state": "idle", "by": "bo" })
    );
    assert!(engine.view(ms(1021), &|_| Vec::new()).aborted.is_empty());
    engine.handle(command(5, ten(), Command::Reset), ms(1030));
    let out = engine.take_outputs();
    assert!(matches!(answer_to(&out, 5), Err(r) if r.code == Code::UnknownRun));
}

#[test]
fn a_node_value_read_for_one_msg_takes_the_deployed_ones_place_for_that_msg_only() {
    let mut b = Bench::new();
    let read = |operation: &str, priority: Raw| -> MsgFields {
        Fields {
            configured: Some(Configured {
                operation: text(operation),
                priority,
                resources: text(" GRN "),
            }),
            ..Fields::default()
        }
        .into()
    };
    let out = b.run(Input::Acquire {
        node: NodeId(1),
        msg: MsgId(1),
        fields: read(" 11 ", text("7")),
    });
    assert!(
        out.iter().any(|o| matches!(o,
            Output::Send { msg: MsgId(1), set: Set::Interlock { operation, priority: 7, resources, .. }, .. }
            if &**operation == "11" && resources.len() == 1 && &*resources[0] == "GRN")),
        "{out:?}"
    );
    // The next msg with none reads the deployed values (op 10 on YEL, priority 20).
    let out = b.acquire(1, 2);
    assert!(
        out.iter().any(|o| matches!(o,
            Output::Send { msg: MsgId(2), set: Set::Interlock { operation, priority: 20, .. }, .. }
            if &**operation == "10")),
        "{out:?}"
    );
    // A msg's own value still comes first; a bad value read for the msg is refused as the node's.
    let out = b.run(Input::Acquire {
        node: NodeId(1),
        msg: MsgId(3),
        fields: read("13", text("urgent")),
    });
    assert_eq!(answers(&out), ["fail 3 INVALID_PRIORITY"]);
}

#[test]
fn release_cancel_fault_and_clear_nodes_read_their_value_for_one_msg_under_the_msgs_own() {
    let mut b = Bench::new();
    let read = |operation: &str, resources: &str| Fields {
        configured: Some(Configured {
            operation: text(operation),
            priority: Raw::Absent,
            resources: text(resources),
        }),
        ..Fields::default()
    };
    let faulted = |b: &Bench| -> Vec<String> {
        let interlock = b.engine.interlock();
        let set = interlock.faulted_resources();
        set.ids()
            .iter()
            .filter_map(|r| interlock.resource_name(*r).map(str::to_owned))
            .collect()
    };
    b.acquire(1, 1);
    assert_eq!(
        answers(&b.acquire(2, 2)),
        Vec::<String>::new(),
        "op 12 waits"
    );
    // A cancel node's operation read for this msg withdraws op 12.
    let out = b.run(Input::Cancel {
        node: NodeId(6),
        msg: MsgId(3),
        fields: read(" 12 ", "").into(),
    });
    assert_eq!(answers(&out), ["done 2", "send 3 on 0"]);
    // A release node's: the msg's own operation comes first (op 77 holds nothing; op 10 stays).
    let named = Fields {
        operation: text("77"),
        ..read("10", "")
    };
    b.run(Input::Release {
        node: NodeId(5),
        msg: MsgId(4),
        fields: named.into(),
    });
    assert_eq!(
        answers(&b.acquire(2, 5)),
        Vec::<String>::new(),
        "op 10 still holds YEL"
    );
    let out = b.run(Input::Release {
        node: NodeId(5),
        msg: MsgId(6),
        fields: read("10", "").into(),
    });
    assert!(
        answers(&out).contains(&"send 5 on 0".to_owned()),
        "op 12 granted: {out:?}"
    );
    // A fault node's operation.
    let out = b.run(Input::Fault {
        node: NodeId(7),
        msg: MsgId(7),
        fields: read("12", "").into(),
    });
    assert_eq!(answers(&out), ["emit 7 on 1 x1", "send 7 on 0"]);
    assert_eq!(faulted(&b), ["YEL"]);
    // An e-stop's lines in place of its deployed RED; the msg's own lines first.
    let out = b.run(Input::Fault {
        node: NodeId(8),
        msg: MsgId(8),
        fields: read("", "GRN, BLU").into(),
    });
    assert_eq!(answers(&out), ["emit 8 on 1 x2", "fail 8 FAULTED"]);
    let named = Fields {
        resources: text("PUR"),
        ..read("", "GRN")
    };
    b.run(Input::Fault {
        node: NodeId(8),
        msg: MsgId(9),
        fields: named.into(),
    });
    assert_eq!(faulted(&b), ["YEL", "GRN", "BLU", "PUR"]);
    // A clear node's lines; the msg's own lines first.
    let out = b.run(Input::Clear {
        node: NodeId(10),
        msg: MsgId(10),
        fields: read("", "GRN").into(),
        names_given: false,
    });
    assert!(
        answers(&out).contains(&"send 10 on 0".to_owned()),
        "{out:?}"
    );
    let named = Fields {
        resources: text("PUR"),
        ..read("", "BLU")
    };
    b.run(Input::Clear {
        node: NodeId(10),
        msg: MsgId(11),
        fields: named.into(),
        names_given: true,
    });
    assert_eq!(faulted(&b), ["YEL", "BLU"]);
    // The next msg with none reads the deployed value (the e-stop's RED).
    b.run(Input::Fault {
        node: NodeId(8),
        msg: MsgId(12),
        fields: MsgFields::default(),
    });
    assert_eq!(faulted(&b), ["YEL", "BLU", "RED"]);
}

#[test]
fn a_run_saved_held_comes_back_held_only_when_started_with_its_plant() {
    use crate::operation::{RunOwner, RunSnapshot};
    use crate::plant::fixtures::{yel_plant, yel_valve};
    let doc = yel_plant(
        serde_json::json!([yel_valve("V1", 1)]),
        serde_json::json!([{ "command": { "valves": { "V1": 100 } }, "timeoutMs": 2000 }]),
    );
    let plant = Plant::new(serde_json::from_value(doc).unwrap()).unwrap();
    let plan = plant.operation_plan("10").unwrap();
    // Operation 10 holds YEL, then its run is held by an operator and saved with the state.
    let mut engine = Engine::new(InterlockConfig::with_resources(["YEL"]), true).unwrap();
    engine.handle(Input::Start(Saved::First), ms(0));
    let acquire = NodeSpec::acquire(
        Raw::Text("10".into()),
        Raw::Number(1.0),
        Raw::Text("YEL".into()),
        ms(0),
    );
    engine.handle(
        Input::AddNode {
            node: NodeId(1),
            spec: acquire,
        },
        ms(0),
    );
    engine.handle(
        Input::Acquire {
            node: NodeId(1),
            msg: MsgId(1),
            fields: MsgFields::default(),
        },
        ms(10),
    );
    let held = RunSnapshot {
        operation: "10".into(),
        plan: plan.digest(),
        step: 0,
        used_ms: ms(5),
        started_ms: ms(10),
        granted_ms: ms(10),
        held_since_ms: ms(20),
        held_ms: Millis::ZERO,
        held: true,
        steps: Vec::new(),
        attempts: 1,
        owner: Some(RunOwner::Node {
            id: "op-node".into(),
        }),
    };
    let text = engine.seal(
        "il-1",
        Some("plant-1"),
        BTreeMap::new(),
        vec![held.clone()],
        ms(30),
    );
    let doc = || {
        Saved::Sealed(Box::new(SealedDoc {
            text: text.clone(),
            source: "state.json".into(),
            owner: "il-1".into(),
            plant: Some("plant-1".into()),
        }))
    };
    let fresh = || Engine::new(InterlockConfig::with_resources(["YEL"]), true).unwrap();

    let mut bound = fresh();
    bound.handle_bound(Input::Start(doc()), ms(100), &|_| Vec::new(), Some(&plant));
    assert_eq!(bound.take_restored_runs(), vec![held.clone()]);
    assert!(bound.take_restored_runs().is_empty(), "taken once");
    assert_eq!(bound.counts().holding, 1);
    assert_eq!(bound.counts().faulted, 0);
    // Sealed again with its run, it comes back held again.
    let again = bound.seal(
        "il-1",
        Some("plant-1"),
        BTreeMap::new(),
        vec![held],
        ms(110),
    );
    assert!(again.contains("op-node"));

    // Without its plant, the run cannot be supervised: its line comes back faulted.
    let mut alone = fresh();
    alone.handle(Input::Start(doc()), ms(100));
    assert!(alone.take_restored_runs().is_empty());
    assert_eq!(alone.counts().holding, 0);
    assert_eq!(alone.counts().faulted, 1);
}

#[test]
fn a_msg_that_only_follows_an_acquire_reads_as_those_fields_boxed() {
    // Each node that follows an acquire (release, cancel, fault), with the
    // usual name, one to trim, none, a number, text that is no name, and one nobody holds.
    let follows = [
        text("10"),
        text(" 12 "),
        text(""),
        Raw::Number(18.0),
        Raw::Names(vec!["10".into()]),
        text("nobody"),
        Raw::Absent,
    ];
    let run = |fields: &dyn Fn() -> MsgFields| {
        let mut b = Bench::new();
        b.acquire(1, 1);
        b.at(5).acquire(2, 2);
        b.at(6).acquire(3, 3);
        let mut out = Vec::new();
        for (k, node) in [6, 5, 7].into_iter().enumerate() {
            let input = |msg| match node {
                5 => Input::Release {
                    node: NodeId(5),
                    msg: MsgId(msg),
                    fields: fields(),
                },
                6 => Input::Cancel {
                    node: NodeId(6),
                    msg: MsgId(msg),
                    fields: fields(),
                },
                _ => Input::Fault {
                    node: NodeId(7),
                    msg: MsgId(msg),
                    fields: fields(),
                },
            };
            out.push(b.at(10 + k as u64).run(input(10 + k as u32)));
        }
        out
    };
    for follow in follows {
        let unboxed = run(&|| MsgFields::following(follow.clone()));
        let boxed = run(&|| {
            Fields {
                follow: follow.clone(),
                ..Fields::default()
            }
            .into()
        });
        assert_eq!(unboxed, boxed, "{follow:?}");
        assert!(!unboxed.iter().all(Vec::is_empty));
    }
}
