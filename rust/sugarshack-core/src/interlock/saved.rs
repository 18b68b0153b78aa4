//! An interlock's sealed state document (see [`crate::sealed`]) and the one
//! rule a restart follows with it: every configured line comes back as saved,
//! except a line the saved configuration shows was added since, which starts
//! free; anything else (another interlock's document, a damaged one, one of
//! an unknown version, a snapshot that does not say every line's state) is a
//! lost state, and every line starts faulted. The one exception to "held
//! lines come back faulted": a line held by an operation an operator held
//! (ISA-88) stays held by it, since that operation commands nothing and its
//! run comes back held on the same plan; if its plan changed, it is
//! interrupted like any other.

use std::collections::{BTreeMap, HashSet};

use serde::{Deserialize, Serialize};

use super::{
    Event, Hold, Interlock, InterlockConfig, InterlockError, OpState, Owner, Policy,
    RequestSnapshot, ResourceSet, ResourceState, RestoreOptions, Snapshot, SNAPSHOT_VERSION,
};
use crate::alarm::AlarmsSnapshot;
use crate::operation::{AbortedOperations, OperationRun, RunSnapshot};
use crate::plant::Plant;
use crate::routine::RoutineSnapshot;
use crate::sealed::{self, Kind};
use crate::time::Millis;

/// What an interlock's document keeps (its `state`): the interlock, the
/// routines running on it and its alarms, written as one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct SavedState {
    /// The interlock's snapshot (always version [`SNAPSHOT_VERSION`]).
    pub interlock: Snapshot,
    /// Each routine's state, by routine id.
    #[serde(default)]
    pub routines: BTreeMap<String, RoutineSnapshot>,
    /// The alarms, with their acknowledgements and shelves.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alarms: Option<AlarmsSnapshot>,
    /// Operation runs an operator held: they come back held.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub runs: Vec<RunSnapshot>,
    /// Operations aborted and not reset since.
    #[serde(default, skip_serializing_if = "AbortedOperations::is_empty")]
    pub aborted: AbortedOperations,
}

/// What an interlock's document keeps beside the interlock itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Beside {
    /// Each routine's state, by routine id.
    pub routines: BTreeMap<String, RoutineSnapshot>,
    /// The alarms.
    pub alarms: Option<AlarmsSnapshot>,
    /// Held operation runs.
    pub runs: Vec<RunSnapshot>,
    /// Aborted operations.
    pub aborted: AbortedOperations,
}

/// Which interlock a document belongs to, beyond its configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding<'a> {
    /// The interlock's node id.
    pub owner: &'a str,
    /// The plant node it takes its lines from, if bound to one.
    pub plant: Option<&'a str>,
}

/// The configuration that matters to a saved state, as digested in `savedFor`.
#[derive(Serialize)]
struct SavedFor<'a> {
    lines: Vec<&'a str>,
    policy: Policy,
    plant: Option<&'a str>,
}

/// The digest of `config` bound as `plant`: its lines, policy and plant binding.
pub fn saved_for(config: &InterlockConfig, plant: Option<&str>) -> String {
    sealed::digest(&SavedFor {
        lines: config.resources.iter().map(|r| r.name.as_str()).collect(),
        policy: config.policy,
        plant,
    })
}

/// How a start used what was saved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Start {
    /// Restored. `added`: lines configured after the save (free);
    /// `dropped`: lines saved but no longer configured.
    Restored {
        /// Lines the saved configuration did not have: they start free.
        added: Vec<String>,
        /// Lines no longer configured: their state is dropped.
        dropped: Vec<String>,
    },
    /// Not usable: every line starts faulted (cause unknown), for this reason.
    Lost {
        /// Why, in words a person acts on.
        reason: String,
    },
}

/// An interlock opened from a document, with the states saved beside it.
#[derive(Debug)]
pub struct Opened {
    /// The interlock: restored, or every line faulted.
    pub interlock: Interlock,
    /// How it started.
    pub start: Start,
    /// The routines' states saved with it (none when lost).
    pub routines: BTreeMap<String, RoutineSnapshot>,
    /// The alarms saved with it (none when lost).
    pub alarms: Option<AlarmsSnapshot>,
    /// The held runs that came back held, their lines kept (each restores on its plan).
    pub runs: Vec<RunSnapshot>,
    /// Why each other held run did not come back held (its lines came back faulted).
    pub runs_interrupted: Vec<String>,
    /// The operations aborted and not reset (kept even when lost: an abort
    /// stands until a person resets it).
    pub aborted: AbortedOperations,
}

impl Opened {
    fn lost(config: InterlockConfig, reason: String, now: Millis) -> Result<Self, InterlockError> {
        let note = format!("state unknown after restart: {reason}");
        Ok(Opened {
            interlock: Interlock::unknown_state(config, &note, now)?,
            start: Start::Lost { reason },
            routines: BTreeMap::new(),
            alarms: None,
            runs: Vec::new(),
            runs_interrupted: Vec::new(),
            aborted: AbortedOperations::default(),
        })
    }
}

/// The saved held runs that come back held: each on a plan `plant` still has
/// and with a hold on lines all still configured. Their holds are taken out
/// of `snapshot` (their lines listed free), to be kept after the restore;
/// the others' stay, and come back faulted "interrupted". With each run kept,
/// its hold; and why each other did not come back.
fn held_runs(
    snapshot: &mut Snapshot,
    runs: Vec<RunSnapshot>,
    lines: &[String],
    plant: Option<&Plant>,
) -> (Vec<(RunSnapshot, RequestSnapshot)>, Vec<String>) {
    let mut kept = Vec::new();
    let mut interrupted = Vec::new();
    for run in runs {
        let hold = snapshot
            .holds
            .iter()
            .position(|h| h.operation == run.operation);
        let fits = match (plant, hold) {
            (_, None) => Err(format!(
                "operation '{}' was saved held, but it held no lines",
                run.operation
            )),
            (None, _) => Err(format!(
                "operation '{}' was saved held, but the interlock has no plant now",
                run.operation
            )),
            (Some(plant), Some(i))
                if snapshot.holds[i]
                    .resources
                    .iter()
                    .all(|l| lines.contains(l)) =>
            {
                match plant.operation_plan(&run.operation) {
                    None => Err(format!(
                        "operation '{}' was saved held, but the plant document has it no more",
                        run.operation
                    )),
                    Some(plan) => OperationRun::restore(plan, &run)
                        .map(|_| i)
                        .map_err(|err| err.to_string()),
                }
            }
            (Some(_), Some(_)) => Err(format!(
                "operation '{}' was saved held on a line no longer configured",
                run.operation
            )),
        };
        match fits {
            Ok(i) => {
                let hold = snapshot.holds.remove(i);
                for line in &mut snapshot.resources {
                    if hold.resources.contains(&line.name) {
                        line.state = ResourceState::Free;
                    }
                }
                kept.push((run, hold));
            }
            Err(why) => interrupted.push(why),
        }
    }
    (kept, interrupted)
}

/// The lines of `names` not in `others`, in their order.
fn missing_from<'a>(names: &'a [String], others: &[String]) -> Vec<&'a str> {
    let others: HashSet<&str> = others.iter().map(String::as_str).collect();
    names
        .iter()
        .map(String::as_str)
        .filter(|name| !others.contains(name))
        .collect()
}

impl Interlock {
    /// Its state document: this interlock's snapshot at `now` with what is
    /// kept beside it, sealed as `binding`'s and for its configuration.
    pub fn seal(&self, binding: Binding<'_>, beside: Beside, now: Millis) -> String {
        let state = SavedState {
            interlock: self.snapshot(now),
            routines: beside.routines,
            alarms: beside.alarms,
            runs: beside.runs,
            aborted: beside.aborted,
        };
        let saved_for = saved_for(&self.config, binding.plant);
        // Plain data with string keys always serializes.
        sealed::seal(Kind::Interlock, binding.owner, &saved_for, now, &state).unwrap_or_default()
    }

    /// A restart from the document `text` (read from `source`, named in a
    /// refusal): restored as a restart restores (held lines faulted
    /// "interrupted", waiting requests dropped), with a line added to the
    /// configuration since the save starting free (one `resource-added`
    /// event each); or, when `text` is not this interlock's usable state,
    /// every line faulted with the reason. A run saved held whose plan
    /// `plant` still has keeps its lines. Refused only for a configuration
    /// that cannot run.
    pub fn open(
        config: InterlockConfig,
        binding: Binding<'_>,
        source: &str,
        text: &str,
        plant: Option<&Plant>,
        now: Millis,
    ) -> Result<Opened, InterlockError> {
        let lost = |config, why: String| Opened::lost(config, format!("{source}: {why}"), now);
        let document = match sealed::open::<SavedState>(text, Kind::Interlock, binding.owner) {
            Ok(document) => document,
            Err(refusal) => return lost(config, refusal.to_string()),
        };
        let SavedState {
            interlock: mut snapshot,
            routines,
            alarms,
            runs,
            aborted,
        } = document.state;
        if snapshot.version != SNAPSHOT_VERSION {
            return lost(
                config,
                format!(
                    "its interlock snapshot is version {}; a state file holds version {SNAPSHOT_VERSION} only",
                    snapshot.version
                ),
            );
        }
        let lines: Vec<String> = config.resources.iter().map(|r| r.name.clone()).collect();
        if document.saved_for == saved_for(&config, binding.plant) && snapshot.configured != lines {
            return lost(
                config,
                format!(
                    "it was saved for this very configuration, yet it lists the lines {} where the configuration has {}",
                    snapshot.configured.join(", "),
                    lines.join(", ")
                ),
            );
        }
        let added = missing_from(&lines, &snapshot.configured);
        let added: Vec<String> = added.into_iter().map(str::to_owned).collect();
        let dropped: Vec<String> = missing_from(&snapshot.configured, &lines)
            .into_iter()
            .map(str::to_owned)
            .collect();
        let (kept, runs_interrupted) = held_runs(&mut snapshot, runs, &lines, plant);
        match Interlock::restore(config.clone(), &snapshot, RestoreOptions::default(), now) {
            Ok((mut interlock, _)) => {
                let runs = kept
                    .into_iter()
                    .map(|(run, hold)| {
                        interlock.keep_hold(&hold);
                        run
                    })
                    .collect();
                Ok(Opened {
                    interlock,
                    start: Start::Restored { added, dropped },
                    routines,
                    alarms,
                    runs,
                    runs_interrupted,
                    aborted,
                })
            }
            Err(InterlockError::InvalidSnapshot { reason }) => {
                let mut opened = lost(config, reason)?;
                opened.aborted = aborted;
                Ok(opened)
            }
            Err(other) => Err(other),
        }
    }

    /// A hold taken out of a snapshot for a run that comes back held: its lines held by it again.
    fn keep_hold(&mut self, hold: &RequestSnapshot) {
        let op = self.operation(&hold.operation);
        // Checked by `held_runs`: every line is configured and was free after the restore.
        let Ok(lines) = self.resource_set(&hold.resources) else {
            return;
        };
        for &r in lines.ids() {
            self.occupy(r, Owner::Held(op));
        }
        self.holding += 1;
        self.operations[op.index()].state = OpState::Holding(Hold {
            priority: hold.priority,
            resources: lines,
            since_ms: hold.since_ms,
            waited_ms: hold.waited_ms,
            warned: false,
        });
    }

    /// Records that each line of `added` was configured after the state was saved and starts free.
    pub(super) fn record_added(&mut self, added: &[super::ResourceId], now: Millis) {
        for &line in added {
            self.record(Event::ResourceAdded {
                at_ms: now,
                resources: ResourceSet(vec![line].into()),
                note: "line added after the state was saved: starts free".to_owned(),
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interlock::{EventKind, ResourceState};
    use crate::time::ms;
    use proptest::prelude::*;

    const IL: Binding = Binding {
        owner: "il",
        plant: None,
    };
    const FILE: &str = "interlock-il.json";

    fn config(lines: &[&str]) -> InterlockConfig {
        InterlockConfig::with_resources(lines.iter().copied())
    }

    /// 'op10' holds YEL, PUR is e-stopped with a note, the rest free.
    fn running(lines: &[&str]) -> Interlock {
        let mut lock = Interlock::new(config(lines)).unwrap();
        let op = lock.operation("op10");
        let yel = lock.resource_set(&["YEL"]).unwrap();
        lock.acquire(op, 20, &yel, ms(1)).unwrap();
        let pur = lock.resource_set(&["PUR"]).unwrap();
        lock.fault_resources(&pur, Some("washball leak"), ms(2))
            .unwrap();
        lock.drain_events();
        lock
    }

    fn states(lock: &Interlock) -> Vec<(String, String)> {
        lock.snapshot(ms(0))
            .resources
            .into_iter()
            .map(|r| {
                let state = match r.state {
                    ResourceState::Free => "free".to_owned(),
                    ResourceState::Held { .. } => "held".to_owned(),
                    ResourceState::Faulted(f) => format!("faulted:{:?}", f.cause),
                };
                (r.name, state)
            })
            .collect()
    }

    fn all_unknown(lines: &[&str]) -> Vec<(String, String)> {
        lines
            .iter()
            .map(|l| (l.to_string(), "faulted:Unknown".to_owned()))
            .collect()
    }

    const LINES: [&str; 5] = ["YEL", "GRN", "BLU", "PUR", "RED"];

    fn sealed() -> String {
        running(&LINES).seal(IL, Beside::default(), ms(3))
    }

    fn lost_reason(opened: &Opened) -> &str {
        match &opened.start {
            Start::Lost { reason } => reason,
            other => panic!("restored, not lost: {other:?}"),
        }
    }

    /// Opens `text` under the five lines; it must be lost, every line faulted "unknown".
    fn assert_lost(text: &str, why: &str) {
        let opened = Interlock::open(config(&LINES), IL, FILE, text, None, ms(9)).unwrap();
        let reason = lost_reason(&opened);
        assert!(
            reason.starts_with(FILE) && reason.contains(why),
            "{reason:?} should say {why:?}"
        );
        assert_eq!(states(&opened.interlock), all_unknown(&LINES));
    }

    #[test]
    fn a_restart_restores_what_was_sealed() {
        let opened = Interlock::open(config(&LINES), IL, FILE, &sealed(), None, ms(9)).unwrap();
        assert_eq!(
            opened.start,
            Start::Restored {
                added: vec![],
                dropped: vec![]
            }
        );
        let restored = states(&opened.interlock);
        assert_eq!(restored[0], ("YEL".into(), "faulted:Interrupted".into()));
        assert_eq!(restored[3], ("PUR".into(), "faulted:Manual".into()));
        assert_eq!(restored[1].1, "free");
    }

    #[test]
    fn another_interlocks_damaged_or_unknown_document_is_lost() {
        let other = running(&LINES).seal(
            Binding {
                owner: "il-2",
                plant: None,
            },
            Beside::default(),
            ms(3),
        );
        assert_lost(&other, "the state of node 'il-2'");
        assert_lost(
            &sealed().replace("washball leak", "washball leek"),
            "does not match its checksum",
        );
        assert_lost(
            &sealed().replace("\"version\":2,\"owner\"", "\"version\":99,\"owner\""),
            "document version 99",
        );
    }

    /// `snapshot` sealed as the interlock's own, as no writer of this build would.
    fn resealed(snapshot: Snapshot, saved_for: &str) -> String {
        let state = SavedState {
            interlock: snapshot,
            routines: BTreeMap::new(),
            alarms: None,
            runs: Vec::new(),
            aborted: AbortedOperations::default(),
        };
        sealed::seal(Kind::Interlock, "il", saved_for, ms(3), &state).unwrap()
    }

    #[test]
    fn a_version_1_snapshot_is_never_read_from_a_document() {
        let mut snapshot = running(&LINES).snapshot(ms(3));
        snapshot.version = 1;
        snapshot.configured.clear();
        assert_lost(
            &resealed(snapshot.clone(), &saved_for(&config(&LINES), None)),
            "snapshot is version 1",
        );
        // Carried over from a context store, it must give every line's state.
        snapshot.resources.clear();
        snapshot.holds.clear();
        let refused =
            Interlock::restore(config(&LINES), &snapshot, RestoreOptions::default(), ms(9));
        assert!(refused.unwrap_err().to_string().contains(
            "line 'YEL' is configured but this version 1 snapshot does not say its state"
        ),);
    }

    #[test]
    fn a_line_missing_from_a_document_saved_for_this_configuration_is_lost() {
        let mut snapshot = running(&LINES).snapshot(ms(3));
        snapshot.configured.retain(|l| l != "RED");
        snapshot.resources.retain(|r| r.name != "RED");
        assert_lost(
            &resealed(snapshot, &saved_for(&config(&LINES), None)),
            "saved for this very configuration, yet it lists the lines YEL, GRN, BLU, PUR where the configuration has YEL, GRN, BLU, PUR, RED",
        );
    }

    #[test]
    fn a_line_added_to_the_configuration_after_the_save_starts_free_with_an_event_each() {
        let text = running(&["YEL", "PUR", "RED"]).seal(IL, Beside::default(), ms(3));
        let lines = ["BLU", "YEL", "PUR", "RED", "GRN"];
        let mut opened = Interlock::open(config(&lines), IL, FILE, &text, None, ms(9)).unwrap();
        assert_eq!(
            opened.start,
            Start::Restored {
                added: vec!["BLU".into(), "GRN".into()],
                dropped: vec![]
            }
        );
        let lock = &mut opened.interlock;
        assert_eq!(
            states(lock),
            [
                ("BLU", "free"),
                ("YEL", "faulted:Interrupted"),
                ("PUR", "faulted:Manual"),
                ("RED", "free"),
                ("GRN", "free")
            ]
            .map(|(l, s)| (l.to_owned(), s.to_owned()))
        );
        let added: Vec<Vec<String>> = lock
            .drain_events()
            .iter()
            .filter(|e| e.kind() == EventKind::ResourceAdded)
            .map(|e| lock.describe(e).resources)
            .collect();
        assert_eq!(added, [vec!["BLU".to_owned()], vec!["GRN".to_owned()]]);
        // A plant binding is part of what it was saved for.
        assert_ne!(
            saved_for(&config(&LINES), Some("plant-1")),
            saved_for(&config(&LINES), None)
        );
    }

    fn lines_of(opened: &Opened) -> Vec<(String, String)> {
        states(&opened.interlock)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        /// Whatever one byte of a document becomes, it opens as it was or is lost:
        /// never a line freed that was held or faulted.
        #[test]
        fn a_byte_changed_anywhere_is_caught(at in 0usize..10_000, byte in any::<u8>()) {
            let text = sealed();
            let mut bytes = text.clone().into_bytes();
            let at = at % bytes.len();
            prop_assume!(bytes[at] != byte);
            bytes[at] = byte;
            let Ok(changed) = String::from_utf8(bytes) else { return Ok(()) };
            let opened = Interlock::open(config(&LINES), IL, FILE, &changed, None, ms(9)).unwrap();
            let intact = Interlock::open(config(&LINES), IL, FILE, &text, None, ms(9)).unwrap();
            match opened.start {
                Start::Lost { .. } => prop_assert_eq!(lines_of(&opened), all_unknown(&LINES)),
                Start::Restored { .. } => prop_assert_eq!(lines_of(&opened), lines_of(&intact)),
            }
        }
    }
}
