//! What a singular operation runs (the paper's §III-D): its steps as written,
//! then one group command returning every actuator it commanded to its idle
//! state (C3) before the release. [`OperationRun`] runs a plan.

mod aborted;
mod run;

use crate::time::Millis;
pub use aborted::{AbortRecord, AbortedOperations};
pub use run::{
    OperationRun, RunEffect, RunError, RunOwner, RunSnapshot, Stage, StepKind, StepRecord,
};

use serde::Serialize;

use crate::plant::{GroupCommand, HoldCommand, Plant, RestartRule, Step, StopRule};

/// An operation as it runs: its steps in order, the return to idle last,
/// and what an operator's hold, restart and stop do to it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct OperationPlan {
    /// Its id in the plant document.
    pub id: String,
    /// The request's priority (lower goes first).
    pub priority: i32,
    /// The lines' names.
    pub resources: Vec<String>,
    /// Its steps, in order.
    pub steps: Vec<PlanStep>,
    /// The hold command (its own, or the plant's default cut to its lines);
    /// none when a hold commands nothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hold: Option<HoldCommand>,
    /// What a stop does with the step in progress.
    pub stop: StopRule,
}

/// One step of a plan.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "camelCase")]
pub enum PlanStep {
    /// Send a group command and wait for it to complete.
    #[serde(rename_all = "camelCase")]
    Command {
        /// The group command.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
        /// How it goes on after a hold.
        restart: RestartRule,
    },
    /// Wait until a condition on sensors holds.
    #[serde(rename_all = "camelCase")]
    Wait {
        /// The condition (JSONata).
        condition: String,
        /// The sensors it reads.
        sensors: Vec<String>,
        /// How long it may take.
        timeout_ms: Millis,
        /// How it goes on after a hold.
        restart: RestartRule,
    },
    /// The C3 step the plan appends: every commanded actuator back to idle
    /// (those the hold command may set included). After a hold it sends its command again.
    #[serde(rename_all = "camelCase")]
    ReturnToIdle {
        /// Every commanded actuator to its idle state.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
    },
}

impl PlanStep {
    /// How long it may take.
    pub fn timeout_ms(&self) -> Millis {
        match self {
            Self::Command { timeout_ms, .. }
            | Self::Wait { timeout_ms, .. }
            | Self::ReturnToIdle { timeout_ms, .. } => *timeout_ms,
        }
    }

    /// How it goes on after a hold.
    pub fn restart(&self) -> RestartRule {
        match self {
            Self::Command { restart, .. } | Self::Wait { restart, .. } => *restart,
            Self::ReturnToIdle { .. } => RestartRule::Reissue,
        }
    }
}

impl OperationPlan {
    /// A digest of the plan: a run saved held comes back only on the plan it ran.
    pub fn digest(&self) -> String {
        crate::sealed::digest(self)
    }

    /// What a restart at step `index` sends before the step goes on: every
    /// actuator the hold command set, back where the run had it (as the last
    /// command step before `index` left it, else at its idle state), except
    /// those step `index` commands itself (rerun or reissued, it sends its
    /// command again; a wait commands nothing). None when there is nothing
    /// to put back.
    pub fn restore_before(&self, index: usize) -> Option<HoldCommand> {
        let hold = self.hold.as_ref()?;
        let idle = self.steps.iter().find_map(|s| match s {
            PlanStep::ReturnToIdle { command, .. } => Some(command),
            _ => None,
        });
        let step_commands = match self.steps.get(index) {
            Some(PlanStep::Command { command, .. } | PlanStep::ReturnToIdle { command, .. }) => {
                Some(command)
            }
            Some(PlanStep::Wait { .. }) | None => None,
        };
        let mut restore = GroupCommand::default();
        for (key, id, _) in hold.command.members() {
            if step_commands.is_some_and(|c| c.members().any(|(_, m, _)| m == id)) {
                continue;
            }
            let earlier = self.steps[..index.min(self.steps.len())]
                .iter()
                .rev()
                .find_map(|s| match s {
                    PlanStep::Command { command, .. } => {
                        command.members().find(|(_, m, _)| *m == id).map(|m| m.2)
                    }
                    _ => None,
                });
            let at = earlier
                .or_else(|| idle.and_then(|c| c.members().find(|(_, m, _)| *m == id).map(|m| m.2)));
            if let Some(setpoint) = at {
                restore.set(key, id, setpoint);
            }
        }
        (!restore.is_empty()).then_some(HoldCommand {
            command: restore,
            timeout_ms: hold.timeout_ms,
        })
    }
}

impl Plant {
    /// The hold command of operation `op`: its own, else the plant's default
    /// cut to its lines; none when empty.
    fn hold_of(&self, op: &crate::plant::Operation) -> Option<HoldCommand> {
        if let Some(own) = &op.hold {
            return (!own.command.is_empty()).then(|| own.clone());
        }
        let default = self.operation_defaults.as_ref()?.hold.as_ref()?;
        let mut command = GroupCommand::default();
        for (key, id, setpoint) in default.command.members() {
            let on_its_lines = self
                .actuator(id)
                .and_then(|i| self.actuators[i].resource.as_ref())
                .is_some_and(|r| op.resources.contains(r));
            if on_its_lines {
                command.set(key, id, setpoint);
            }
        }
        (!command.is_empty()).then_some(HoldCommand {
            command,
            timeout_ms: default.timeout_ms,
        })
    }

    /// The plan of operation `id`; None when there is no such operation.
    pub fn operation_plan(&self, id: &str) -> Option<OperationPlan> {
        let op = self.operations.iter().find(|o| o.id == id)?;
        let defaults = self.operation_defaults.clone().unwrap_or_default();
        let hold = self.hold_of(op);
        let mut steps = Vec::with_capacity(op.steps.len() + 1);
        // Actuator ids in order of first command, grouped by type name (a
        // step may say "pump" and another "pumps").
        let mut idle = GroupCommand::default();
        let mut idle_timeout_ms = Millis::ZERO;
        let mut to_idle = |command: &GroupCommand, timeout_ms: Millis| {
            idle_timeout_ms = idle_timeout_ms.max(timeout_ms);
            for (_, name, _) in command.members() {
                // Validated: every actuator commanded exists and has an idle state.
                let Some(a) = self.actuator(name).map(|i| &self.actuators[i]) else {
                    continue;
                };
                if let Some(state) = a.idle {
                    idle.set(&a.kind, name, state);
                }
            }
        };
        for step in &op.steps {
            match step {
                Step::Command {
                    command,
                    timeout_ms,
                    restart,
                } => {
                    to_idle(command, *timeout_ms);
                    steps.push(PlanStep::Command {
                        command: command.clone(),
                        timeout_ms: *timeout_ms,
                        restart: restart.or(defaults.restart).unwrap_or_default(),
                    });
                }
                Step::Wait {
                    wait,
                    sensors,
                    timeout_ms,
                    restart,
                } => steps.push(PlanStep::Wait {
                    condition: wait.clone(),
                    sensors: sensors.clone(),
                    timeout_ms: *timeout_ms,
                    restart: restart.or(defaults.restart).unwrap_or_default(),
                }),
            }
        }
        // What a hold may have moved goes back to idle too (C3).
        if let Some(hold) = &hold {
            to_idle(&hold.command, hold.timeout_ms);
        }
        if !idle.is_empty() {
            steps.push(PlanStep::ReturnToIdle {
                command: idle,
                timeout_ms: idle_timeout_ms,
            });
        }
        Some(OperationPlan {
            id: op.id.clone(),
            priority: op.priority,
            resources: op.resources.clone(),
            steps,
            hold,
            stop: op.stop.or(defaults.stop).unwrap_or_default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::fixtures::{yel_plant, yel_pump, yel_valve};
    use crate::time::ms;
    use serde_json::json;

    fn plant() -> Plant {
        let doc = yel_plant(
            json!([yel_valve("V1", 1), yel_valve("V2", 2), yel_pump("P1", 1)]),
            json!([
                { "command": { "valves": { "V2": 100, "V1": 100 } }, "timeoutMs": 20000 },
                { "command": { "pumps": { "P1": true } }, "timeoutMs": 5000 },
                { "wait": "`LT-3` > 100", "sensors": ["LT-3"], "timeoutMs": 60000 },
                { "command": { "pump": { "P1": false } }, "timeoutMs": 5000 }
            ]),
        );
        Plant::new(serde_json::from_value(doc).unwrap()).unwrap()
    }

    #[test]
    fn the_plan_ends_with_every_commanded_actuator_back_to_idle() {
        let plant = plant();
        let plan = plant.operation_plan("10").unwrap();
        assert_eq!(plan.steps.len(), 5);
        assert_eq!(
            plan.steps[4],
            PlanStep::ReturnToIdle {
                command: serde_json::from_value(
                    json!({ "valve": { "V2": 0, "V1": 0 }, "pump": { "P1": false } })
                )
                .unwrap(),
                timeout_ms: ms(20000),
            }
        );
        assert_eq!(plan.resources, vec!["YEL".to_string()]);
        assert!(plant.operation_plan("11").is_none());
    }

    #[test]
    fn a_restore_leaves_to_the_step_the_actuators_it_commands() {
        let mut plan = plant().operation_plan("10").unwrap();
        plan.hold = Some(HoldCommand {
            command: serde_json::from_value(
                json!({ "pumps": { "P1": false }, "valves": { "V1": 0 } }),
            )
            .unwrap(),
            timeout_ms: ms(4000),
        });
        let restore = |index| {
            plan.restore_before(index)
                .map(|r| serde_json::to_value(r.command).unwrap())
        };
        // The wait commands nothing: both back where the run had them.
        assert_eq!(
            restore(2),
            Some(json!({ "pumps": { "P1": true }, "valves": { "V1": 100 } }))
        );
        // "P1 off" and "P1 on" command P1 themselves; "V2, V1 open" commands V1.
        assert_eq!(restore(3), Some(json!({ "valves": { "V1": 100 } })));
        assert_eq!(restore(1), Some(json!({ "valves": { "V1": 100 } })));
        assert_eq!(restore(0), Some(json!({ "pumps": { "P1": false } })));
        // The return to idle commands every actuator a hold may set.
        assert_eq!(restore(4), None);
    }

    #[test]
    fn a_plan_serializes_with_step_kinds() {
        let plan = plant().operation_plan("10").unwrap();
        let v = serde_json::to_value(&plan).unwrap();
        assert_eq!(v["steps"][2]["kind"], "wait");
        assert_eq!(v["steps"][2]["timeoutMs"], 60000);
        assert_eq!(v["steps"][4]["kind"], "returnToIdle");
    }
}
