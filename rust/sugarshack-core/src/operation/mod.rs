//! What a singular operation runs (the paper's §III-D): its steps as written,
//! then one group command returning every actuator it commanded to its idle
//! state (C3) before the release. [`OperationRun`] runs a plan.

mod run;

use crate::time::Millis;
pub use run::{OperationRun, Phase, RunEffect, RunError, Stage, StepKind, StepRecord};

use serde::Serialize;

use crate::plant::{GroupCommand, Plant, Step};

/// An operation as it runs: its steps in order, the return to idle last.
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
    },
    /// The C3 step the plan appends: every commanded actuator back to idle.
    #[serde(rename_all = "camelCase")]
    ReturnToIdle {
        /// Every commanded actuator to its idle state.
        command: GroupCommand,
        /// How long it may take.
        timeout_ms: Millis,
    },
}

impl Plant {
    /// The plan of operation `id`; None when there is no such operation.
    pub fn operation_plan(&self, id: &str) -> Option<OperationPlan> {
        let op = self.operations.iter().find(|o| o.id == id)?;
        let mut steps = Vec::with_capacity(op.steps.len() + 1);
        // Actuator ids in order of first command, grouped by type name (a
        // step may say "pump" and another "pumps").
        let mut idle = GroupCommand::default();
        let mut idle_timeout_ms = Millis::ZERO;
        for step in &op.steps {
            match step {
                Step::Command {
                    command,
                    timeout_ms,
                } => {
                    idle_timeout_ms = idle_timeout_ms.max(*timeout_ms);
                    for (_, name, _) in command.members() {
                        // Validated: every actuator commanded exists and has an idle state.
                        let Some(a) = self.actuator(name).map(|i| &self.actuators[i]) else {
                            continue;
                        };
                        if let Some(state) = a.idle {
                            idle.set(&a.kind, name, state);
                        }
                    }
                    steps.push(PlanStep::Command {
                        command: command.clone(),
                        timeout_ms: *timeout_ms,
                    });
                }
                Step::Wait {
                    wait,
                    sensors,
                    timeout_ms,
                } => steps.push(PlanStep::Wait {
                    condition: wait.clone(),
                    sensors: sensors.clone(),
                    timeout_ms: *timeout_ms,
                }),
            }
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
    fn a_plan_serializes_with_step_kinds() {
        let plan = plant().operation_plan("10").unwrap();
        let v = serde_json::to_value(&plan).unwrap();
        assert_eq!(v["steps"][2]["kind"], "wait");
        assert_eq!(v["steps"][2]["timeoutMs"], 60000);
        assert_eq!(v["steps"][4]["kind"], "returnToIdle");
    }
}
