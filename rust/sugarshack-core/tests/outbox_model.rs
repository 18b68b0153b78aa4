//! Property tests of the outbox (publishes waiting to go out), against what
//! was handed to it: in any sequence of publishes, lockouts among them, and
//! sends, no lockout is lost, none handed last on its topic goes out
//! overridden there, the order is kept, the bound holds but for lockouts,
//! nothing is dropped below it, and a drop is told once per wait.

use proptest::prelude::*;
use sugarshack_core::actuator::outbox::{Kept, Outbox, Outlet, Waiting};
use sugarshack_core::actuator::DeviceId;

#[derive(Clone, Debug)]
enum Step {
    /// A publish numbered `n` (a lockout's, of one of four lines, when `lockout`).
    Wait {
        held: bool,
        n: u32,
        lockout: bool,
    },
    Send {
        held: bool,
    },
}

fn outlet(held: bool) -> Outlet {
    if held {
        Outlet::Held
    } else {
        Outlet::Unsent
    }
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        8 => (any::<bool>(), 0u32..1000, prop::bool::weighted(0.3)).prop_map(|(held, n, lockout)| Step::Wait { held, n, lockout }),
        1 => any::<bool>().prop_map(|held| Step::Send { held }),
    ]
}

fn publish(n: u32, lockout: bool) -> Waiting {
    // A line's lockout is the same msg each time it is sent; commands go to the
    // same topics as the lockouts (and to others), so a later one can override a lockout.
    let (topic, payload) = if lockout {
        (format!("line/{}", n % 4), "OFF".to_string())
    } else {
        (format!("line/{}", n % 8), n.to_string())
    };
    Waiting {
        device: DeviceId::from_index(0),
        topic,
        payload,
        retain: lockout,
        lockout,
    }
}

/// The last publish on `topic` in `publishes`.
fn last_on<'a>(publishes: &'a [Waiting], topic: &str) -> Option<&'a Waiting> {
    publishes.iter().rev().find(|p| p.topic == topic)
}

/// Checks what went out of one outlet against what was handed to it since it last went out.
fn check_sent(
    handed: &[Waiting],
    sent: &[Waiting],
    dropped: bool,
    told: usize,
    bound: usize,
) -> Result<(), TestCaseError> {
    // In arrival order: a subsequence of what was handed.
    let mut rest = handed.iter();
    for p in sent {
        prop_assert!(rest.any(|h| h == p), "{p:?} out of order or never handed");
    }
    for h in handed.iter().filter(|h| h.lockout) {
        prop_assert!(sent.contains(h), "lockout {h:?} lost");
        // The last word handed on its topic stays the last word sent there.
        if last_on(handed, &h.topic) == Some(h) {
            prop_assert_eq!(
                last_on(sent, &h.topic),
                Some(h),
                "lockout {:?} overridden",
                h
            );
        }
    }
    // Past the bound only lockouts wait, each line's once past it.
    prop_assert!(sent.len() <= bound + 4);
    if sent.len() > bound {
        prop_assert!(
            sent.iter().all(|p| p.lockout),
            "past the bound only lockouts"
        );
    }
    if handed.len() <= bound {
        prop_assert_eq!(sent, handed, "nothing dropped below the bound");
    }
    // Dropped: some publish that is no lockout was handed and did not go out.
    let kept_all =
        handed.iter().filter(|h| !h.lockout).count() == sent.iter().filter(|p| !p.lockout).count();
    prop_assert_eq!(dropped, !kept_all);
    prop_assert_eq!(told, usize::from(dropped), "a drop is told once per wait");
    Ok(())
}

proptest! {
    #[test]
    fn no_lockout_is_lost_and_the_bound_holds_but_for_lockouts(
        bound in 0usize..6,
        steps in prop::collection::vec(step(), 0..120),
    ) {
        let bound = if bound == 0 { 1 } else { bound };
        let mut outbox = Outbox::default();
        // Per outlet (unsent, held): what was handed and how many first drops were told since it last went out.
        let mut handed: [Vec<Waiting>; 2] = Default::default();
        let mut told = [0usize; 2];
        for step in steps.into_iter().chain([Step::Send { held: false }, Step::Send { held: true }]) {
            match step {
                Step::Wait { held, n, lockout } => {
                    let p = publish(n, lockout);
                    handed[usize::from(held)].push(p.clone());
                    if outbox.wait(outlet(held), p, bound) == (Kept::Dropped { first: true }) {
                        told[usize::from(held)] += 1;
                    }
                    prop_assert!(outbox.len(outlet(held)) <= bound + 4);
                }
                Step::Send { held } => {
                    let (sent, dropped) = outbox.take(outlet(held));
                    let i = usize::from(held);
                    check_sent(&handed[i], &sent, dropped, told[i], bound)?;
                    handed[i].clear();
                    told[i] = 0;
                    prop_assert_eq!(outbox.len(outlet(held)), 0);
                }
            }
        }
    }
}
