//! Publishes that cannot go out yet, and which of them may be lost.
//!
//! A host keeps a publish here while it cannot send it: during a deploy no
//! node serves its device yet ([`Outlet::Unsent`]), or a cluster leader waits
//! for its lease to be renewed ([`Outlet::Held`]). Each outlet keeps within a
//! bound (Node-RED's `nodeMessageBufferMaxLength`, else [`DEFAULT_BOUND`]).
//! Past it the newest publish is dropped, except a lockout: a lockout is a
//! standing order, so it takes the place of the oldest publish that is not one
//! (dropped instead), and is kept past the bound when only lockouts wait; one
//! that is already the last publish waiting on its topic is not kept twice, so
//! lockouts past the bound are at most one per distinct lockout msg of the
//! plant, and a lockout is always the last word on its topic when it was the
//! last handed. When the publishes go out after a drop, every commanded state
//! and standing lockout is published again ([`super::Tracker::send_kept`]), so
//! what was dropped still reaches its device, but for a dropped retained clear:
//! the broker then keeps the old retained lockout (the safe side).

use std::collections::VecDeque;

use super::DeviceId;

/// Publishes kept per outlet when the host gives no bound.
pub const DEFAULT_BOUND: usize = 10_000;

/// Why publishes wait.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outlet {
    /// A deploy in progress: no node serves their device yet.
    Unsent,
    /// A cluster leader waits for etcd to renew its lease.
    Held,
}

impl Outlet {
    /// `"unsent"` or `"held"`, as a host names them.
    pub fn named(name: &str) -> Option<Outlet> {
        match name {
            "unsent" => Some(Outlet::Unsent),
            "held" => Some(Outlet::Held),
            _ => None,
        }
    }
}

/// Why a publish cannot go out, as the host finds it; what then becomes of it is [`Blocked::outlet`]'s rule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blocked {
    /// A leader waits for its lease to be renewed: the publish waits ([`Outlet::Held`]).
    Suspended,
    /// Not the leader (a standby, or not or no longer in the cluster): the
    /// leader commands, so it is dropped unsaid.
    Standby,
    /// A deploy in progress, no node serving its device yet: it waits ([`Outlet::Unsent`]).
    Deploying,
    /// No node serves its device: dropped, and reported once per device.
    Unserved,
}

impl Blocked {
    /// As a host names it: a cluster role that may not act (`"suspended"`,
    /// `"standby"`, `"connecting"`, `"stopped"`), `"deploying"` or `"unserved"`.
    pub fn named(name: &str) -> Option<Blocked> {
        match name {
            "suspended" => Some(Blocked::Suspended),
            "standby" | "connecting" | "stopped" => Some(Blocked::Standby),
            "deploying" => Some(Blocked::Deploying),
            "unserved" => Some(Blocked::Unserved),
            _ => None,
        }
    }

    /// Where such a publish waits, if it does.
    pub fn outlet(self) -> Option<Outlet> {
        match self {
            Blocked::Suspended => Some(Outlet::Held),
            Blocked::Deploying => Some(Outlet::Unsent),
            Blocked::Standby | Blocked::Unserved => None,
        }
    }
}

/// What a host is to tell of a publish that did not go out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Told {
    /// Nothing.
    Nothing,
    /// Publishes past `bound` are dropped (the first drop since they last went out).
    Dropped {
        /// The bound in force.
        bound: usize,
    },
    /// No node serves its device (once per device until the serving nodes change).
    Unserved,
}

/// The bound in force for a host's `bound` (0: unset).
pub fn bound_in_force(bound: usize) -> usize {
    if bound == 0 {
        DEFAULT_BOUND
    } else {
        bound
    }
}

/// A publish that waits.
#[derive(Clone, Debug, PartialEq)]
pub struct Waiting {
    /// The device to send it to.
    pub device: DeviceId,
    /// The MQTT topic.
    pub topic: String,
    /// The MQTT payload.
    pub payload: String,
    /// Whether the broker keeps it.
    pub retain: bool,
    /// A lockout's msg: never the one dropped.
    pub lockout: bool,
}

/// What became of a publish handed to [`Outbox::wait`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kept {
    /// It waits (or the same lockout already waits, last on its topic).
    Kept,
    /// It, or an older one that is no lockout, was dropped.
    Dropped {
        /// The first drop since the outlet last went out (the host warns once).
        first: bool,
    },
}

#[derive(Clone, Debug, Default)]
struct Queue {
    publishes: VecDeque<Waiting>,
    dropped: u32,
}

/// The publishes waiting at each outlet.
#[derive(Clone, Debug, Default)]
pub struct Outbox {
    unsent: Queue,
    held: Queue,
}

impl Outbox {
    fn queue(&mut self, outlet: Outlet) -> &mut Queue {
        match outlet {
            Outlet::Unsent => &mut self.unsent,
            Outlet::Held => &mut self.held,
        }
    }

    /// Keeps `publish` at `outlet`, within `bound` (0: [`DEFAULT_BOUND`]; see the module).
    pub fn wait(&mut self, outlet: Outlet, publish: Waiting, bound: usize) -> Kept {
        let bound = bound_in_force(bound);
        let queue = self.queue(outlet);
        if queue.publishes.len() < bound {
            queue.publishes.push_back(publish);
            return Kept::Kept;
        }
        if publish.lockout {
            // Already the last word on its topic; one that a later publish overrides is sent again.
            let last = queue
                .publishes
                .iter()
                .rev()
                .find(|p| p.device == publish.device && p.topic == publish.topic);
            if last == Some(&publish) {
                return Kept::Kept;
            }
            let evicted = queue.publishes.iter().position(|p| !p.lockout);
            queue.publishes.push_back(publish);
            let Some(index) = evicted else {
                return Kept::Kept;
            };
            queue.publishes.remove(index);
        }
        queue.dropped = queue.dropped.saturating_add(1);
        Kept::Dropped {
            first: queue.dropped == 1,
        }
    }

    /// Everything waiting at `outlet`, oldest first, taken, and whether any was
    /// dropped since it last went out.
    pub fn take(&mut self, outlet: Outlet) -> (Vec<Waiting>, bool) {
        let queue = std::mem::take(self.queue(outlet));
        (queue.publishes.into(), queue.dropped > 0)
    }

    /// How many publishes wait at `outlet`.
    pub fn len(&self, outlet: Outlet) -> usize {
        match outlet {
            Outlet::Unsent => self.unsent.publishes.len(),
            Outlet::Held => self.held.publishes.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn publish(n: u32, lockout: bool) -> Waiting {
        Waiting {
            device: DeviceId::from_index(0),
            topic: format!("t/{n}"),
            payload: n.to_string(),
            retain: lockout,
            lockout,
        }
    }

    fn topics(outbox: &mut Outbox, outlet: Outlet) -> (Vec<String>, bool) {
        let (publishes, dropped) = outbox.take(outlet);
        (publishes.into_iter().map(|p| p.topic).collect(), dropped)
    }

    #[test]
    fn keeps_within_the_bound_and_drops_the_newest_warning_once() {
        let mut outbox = Outbox::default();
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(1, false), 2),
            Kept::Kept
        );
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(2, false), 2),
            Kept::Kept
        );
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(3, false), 2),
            Kept::Dropped { first: true }
        );
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(4, false), 2),
            Kept::Dropped { first: false }
        );
        assert_eq!(
            topics(&mut outbox, Outlet::Unsent),
            (vec!["t/1".into(), "t/2".into()], true)
        );
        // Gone out: the next drop is warned about again.
        outbox.wait(Outlet::Unsent, publish(5, false), 1);
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(6, false), 1),
            Kept::Dropped { first: true }
        );
    }

    #[test]
    fn a_lockout_past_the_bound_takes_the_place_of_the_oldest_publish_that_is_none() {
        let mut outbox = Outbox::default();
        outbox.wait(Outlet::Held, publish(1, true), 2);
        outbox.wait(Outlet::Held, publish(2, false), 2);
        assert_eq!(
            outbox.wait(Outlet::Held, publish(3, true), 2),
            Kept::Dropped { first: true }
        );
        assert_eq!(
            topics(&mut outbox, Outlet::Held),
            (vec!["t/1".into(), "t/3".into()], true)
        );
    }

    #[test]
    fn a_lockout_a_later_publish_overrides_is_kept_again_past_the_bound() {
        let on = |payload: &str, retain: bool| Waiting {
            device: DeviceId::from_index(0),
            topic: "p/1".into(),
            payload: payload.into(),
            retain,
            lockout: false,
        };
        let lockout = Waiting {
            lockout: true,
            ..on("OFF", true)
        };
        let mut outbox = Outbox::default();
        // Locked out, cleared, commanded on: the queue full; then locked out again.
        outbox.wait(Outlet::Held, lockout.clone(), 3);
        outbox.wait(Outlet::Held, on("", true), 3);
        outbox.wait(Outlet::Held, on("ON", false), 3);
        assert_eq!(
            outbox.wait(Outlet::Held, lockout.clone(), 3),
            Kept::Dropped { first: true }
        );
        let (sent, dropped) = outbox.take(Outlet::Held);
        assert!(dropped);
        assert_eq!(
            sent.last(),
            Some(&lockout),
            "the lockout is the last word: {sent:?}"
        );
    }

    #[test]
    fn lockouts_are_kept_past_the_bound_once_each() {
        let mut outbox = Outbox::default();
        outbox.wait(Outlet::Held, publish(1, true), 1);
        assert_eq!(outbox.wait(Outlet::Held, publish(2, true), 1), Kept::Kept);
        assert_eq!(outbox.wait(Outlet::Held, publish(1, true), 1), Kept::Kept);
        assert_eq!(
            outbox.len(Outlet::Held),
            2,
            "the same lockout is not kept twice"
        );
        assert_eq!(
            topics(&mut outbox, Outlet::Held),
            (vec!["t/1".into(), "t/2".into()], false)
        );
    }

    #[test]
    fn the_outlets_wait_apart_and_an_unset_bound_is_the_default() {
        let mut outbox = Outbox::default();
        for n in 0..DEFAULT_BOUND as u32 {
            assert_eq!(
                outbox.wait(Outlet::Unsent, publish(n, false), 0),
                Kept::Kept
            );
        }
        assert_eq!(
            outbox.wait(Outlet::Unsent, publish(0, false), 0),
            Kept::Dropped { first: true }
        );
        assert_eq!(outbox.wait(Outlet::Held, publish(0, false), 0), Kept::Kept);
        assert_eq!(outbox.len(Outlet::Held), 1);
        assert!(!outbox.take(Outlet::Held).1, "nothing dropped there");
        assert_eq!(Outlet::named("held"), Some(Outlet::Held));
        assert_eq!(Outlet::named("unsent"), Some(Outlet::Unsent));
        assert_eq!(Outlet::named("other"), None);
    }

    #[test]
    fn a_suspended_leader_and_a_deploy_wait_a_standby_and_an_unserved_device_do_not() {
        for (name, outlet) in [
            ("suspended", Some(Outlet::Held)),
            ("deploying", Some(Outlet::Unsent)),
            ("standby", None),
            ("connecting", None),
            ("stopped", None),
            ("unserved", None),
        ] {
            assert_eq!(
                Blocked::named(name).and_then(Blocked::outlet),
                outlet,
                "{name}"
            );
        }
        assert_eq!(
            Blocked::named("active"),
            None,
            "an active leader is not blocked"
        );
        assert_eq!(bound_in_force(0), DEFAULT_BOUND);
        assert_eq!(bound_in_force(3), 3);
    }
}
