//! The engine's durable state: one document, written whole before any effect
//! of a change leaves, so a restart never sees a routine and its lines, or a
//! request and its timeout, disagree.
//!
//! Its shape is the interlock state file's: `{ format, version, savedAtMs,
//! interlock, routines, alarms }`, with the engine's own part under `engine`
//! (the requests waiting and their timeouts, the lost-state note). A file
//! written before the engine existed reads as one with no `engine` part.

use serde::{Deserialize, Serialize};

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{Due, Engine, MsgId, NodeId, Request, Stage};
use crate::alarm::Alarms;
use crate::interlock::{Beside, Binding, Interlock, InterlockError, RestoreOptions, Snapshot};
use crate::operation::{AbortedOperations, RunSnapshot};
use crate::routine::RoutineSnapshot;
use crate::time::Millis;

/// What the state file says it is.
pub const STATE_FORMAT: &str = "sugarshack-interlock-state";

/// The version this engine writes.
pub const STATE_VERSION: u32 = 1;

/// The whole durable state of an engine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct StateDoc {
    /// [`STATE_FORMAT`].
    #[serde(default = "format")]
    pub format: String,
    /// [`STATE_VERSION`].
    #[serde(default = "version")]
    pub version: u32,
    /// When it was written.
    #[serde(default)]
    pub saved_at_ms: Millis,
    /// The interlock.
    pub interlock: Snapshot,
    /// Each routine's state, by id.
    #[serde(default)]
    pub routines: serde_json::Map<String, serde_json::Value>,
    /// The alarms (read leniently: alarms that cannot be read start afresh).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alarms: Option<serde_json::Value>,
    /// Operations aborted and not reset.
    #[serde(default, skip_serializing_if = "AbortedOperations::is_empty")]
    pub aborted: AbortedOperations,
    /// What waits, and until when.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub engine: Option<EngineState>,
}

fn format() -> String {
    STATE_FORMAT.to_owned()
}

fn version() -> u32 {
    STATE_VERSION
}

/// The engine's part of the state: what a hand-over keeps.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct EngineState {
    /// Where it was in its life.
    pub stage: Option<Stage>,
    /// Why the state was unknown at start, while lines faulted for it stay faulted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lost: Option<String>,
    /// Requests waiting for their grant, queued ones in queue order, then
    /// those a drain held back.
    #[serde(default)]
    pub requests: Vec<RequestState>,
}

/// A waiting request, and the msg that waits for it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct RequestState {
    /// The msg's handle.
    pub msg: MsgId,
    /// Its node's handle.
    pub node: NodeId,
    /// The operation.
    pub operation: String,
    /// Its priority.
    pub priority: i32,
    /// The lines, as named.
    pub resources: Vec<String>,
    /// Since when it waits.
    pub since_ms: Millis,
    /// When its acquire timeout falls due.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deadline_ms: Option<Millis>,
    /// Held back by a drain.
    #[serde(default)]
    pub held_back: bool,
}

impl Engine {
    /// The whole state at `now`, as written to the state file.
    pub fn snapshot(&self, now: Millis) -> StateDoc {
        let mut requests: Vec<RequestState> = self
            .interlock_queue_msgs()
            .into_iter()
            .chain(self.held_back.iter().copied())
            .filter_map(|msg| {
                let r = self.requests.get(&msg)?;
                Some(RequestState {
                    msg,
                    node: r.node,
                    operation: r.name.to_string(),
                    priority: r.priority,
                    resources: r.names.iter().map(|n| n.to_string()).collect(),
                    since_ms: r.since,
                    deadline_ms: r.deadline,
                    held_back: r.held_back,
                })
            })
            .collect();
        requests.dedup_by_key(|r| r.msg);
        StateDoc {
            format: STATE_FORMAT.to_owned(),
            version: STATE_VERSION,
            saved_at_ms: now,
            interlock: self.interlock.snapshot(now),
            routines: self.saved_routines.clone(),
            alarms: serde_json::to_value(self.alarms.snapshot()).ok(),
            aborted: self.aborted.clone(),
            engine: Some(EngineState {
                stage: Some(self.stage),
                lost: self.lost.clone(),
                requests,
            }),
        }
    }

    /// Takes over the state `doc` of an engine (a hand-over inside a running
    /// process, to new settings after a deploy's drain, or a standby taking over):
    /// holds, waiting requests, their msgs and timeouts go on where they
    /// were. A waiting request whose msg the document does not know is
    /// released once granted (nobody waits for it).
    pub fn hand_over(&mut self, doc: &StateDoc, now: Millis) -> Result<(), InterlockError> {
        let options = RestoreOptions {
            keep_queue: true,
            keep_holds: true,
        };
        let (interlock, grants) =
            Interlock::restore(super::recording(&self.config), &doc.interlock, options, now)?;
        self.interlock = interlock;
        self.update_recording();
        // Its checks beat from the hand-over, as from a start: a standby and the engine it replaces agree.
        self.beat = now;
        self.requests.clear();
        self.by_op.clear();
        self.held_back.clear();
        self.deadlines = super::Deadlines::default();
        for node in self.nodes.values_mut() {
            node.op = None;
            node.set = None;
        }
        if let Some(alarms) = doc
            .alarms
            .clone()
            .and_then(|a| serde_json::from_value(a).ok())
            .and_then(|a| Alarms::restore(a).ok())
        {
            self.alarms = alarms;
        }
        self.saved_routines = doc.routines.clone();
        self.aborted = doc.aborted.clone();
        let state = doc.engine.clone().unwrap_or_default();
        self.lost = state.lost;
        for saved in state.requests {
            let op = self.interlock.operation(&saved.operation);
            let set = match self.interlock.resource_set(&saved.resources) {
                Ok(set) => set,
                Err(err) => {
                    // Its lines left with the new settings: refused, as at a drain's end (never lost unanswered).
                    self.refuse(saved.node, saved.msg, err.into());
                    continue;
                }
            };
            let request = Request {
                node: saved.node,
                op,
                name: Arc::from(saved.operation.as_str()),
                priority: saved.priority,
                set,
                names: saved
                    .resources
                    .iter()
                    .map(|n| Arc::from(n.as_str()))
                    .collect(),
                since: saved.since_ms,
                deadline: saved.deadline_ms,
                held_back: saved.held_back,
            };
            if request.held_back {
                self.held_back.push_back(saved.msg);
            } else if self.interlock.is_queued(op) {
                self.by_op.insert(op, saved.msg);
            } else {
                continue;
            }
            if let Some(at) = request.deadline {
                self.deadlines
                    .set(at, Due::AcquireTimeout { msg: saved.msg });
            }
            self.requests.insert(saved.msg, request);
        }
        let mut effects = Vec::new();
        self.answer(grants, now, &mut effects);
        self.commit(false, effects);
        self.schedule_alarms(now);
        self.shown = self.counts();
        self.out.push(super::Output::Counts(self.shown));
        if self.stage.gate() == super::Gate::Park {
            self.stage = self.stage.after(super::Step::Started);
            self.update_recording();
            self.replay_parked(now, &|_| Vec::new());
        }
        Ok(())
    }

    /// Its sealed state document at `now` for the interlock node `owner`
    /// bound to `plant`, with the `running` routines' states over those read
    /// at start (the same document the interlock's [`Interlock::seal`]
    /// writes: what a restart or a new leader opens through
    /// [`super::Saved::Sealed`]). Waiting requests are not in it: a restart
    /// drops them.
    pub fn seal(
        &self,
        owner: &str,
        plant: Option<&str>,
        running: BTreeMap<String, RoutineSnapshot>,
        runs: Vec<RunSnapshot>,
        now: Millis,
    ) -> String {
        // Those read at start were a routine's state when opened (the document's types say so).
        let mut routines: BTreeMap<String, RoutineSnapshot> = self
            .saved_routines
            .iter()
            .filter_map(|(id, v)| Some((id.clone(), serde_json::from_value(v.clone()).ok()?)))
            .collect();
        routines.extend(running);
        // The runs held now (the host supervises them) come back held; the aborted ones stand.
        let beside = Beside {
            routines,
            alarms: Some(self.alarms.snapshot()),
            runs,
            aborted: self.aborted.clone(),
        };
        self.interlock.seal(Binding { owner, plant }, beside, now)
    }

    /// The state file's text at `now`.
    pub fn state_text(&self, now: Millis) -> String {
        serde_json::to_string(&self.snapshot(now)).expect("plain data")
    }
}
