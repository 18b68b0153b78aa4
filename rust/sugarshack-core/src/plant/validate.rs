//! The checks of a plant document, one function per concern, in document
//! order: actuator types, devices, actuators, sensors, the MQTT contract,
//! resources, operations, routines. Each adds its errors and warnings to one
//! [`Report`]; [`check`] runs them all once.

use std::collections::{HashMap, HashSet};

use super::graph::RoutineGraph;
use super::group::{GroupCommand, GroupError, GroupKeys, Targeting};
use super::{
    DeviceKind, PlantError, PlantErrors, PlantModel, PlantWarning, Profile, Signal, Step, Trigger,
};
use crate::condition::Condition;
use crate::procedure::Command;
use crate::routine::RESET_TOPIC;
use crate::text::quote;
use crate::time::Millis;
use crate::topics::Contract;

/// The problems found so far.
#[derive(Debug, Default)]
pub(super) struct Report {
    pub(super) errors: Vec<PlantError>,
    pub(super) warnings: Vec<PlantWarning>,
}

impl Report {
    pub(super) fn error(&mut self, path: &str, message: impl Into<String>) {
        self.errors.push(PlantError {
            path: path.to_owned(),
            message: message.into(),
        });
    }

    fn warn(&mut self, path: &str, message: impl Into<String>) {
        self.warnings.push(PlantWarning {
            path: path.to_owned(),
            message: message.into(),
        });
    }
}

/// What the checks of a sound document leave behind for its [`super::Plant`].
#[derive(Debug)]
pub(super) struct Checked {
    pub(super) warnings: Vec<PlantWarning>,
    pub(super) targeting: Targeting,
    pub(super) contract: Contract,
    pub(super) routines: Vec<RoutineGraph>,
}

/// Every check, once: the warnings and what was built on the way, or every error.
pub(super) fn check(plant: &PlantModel) -> Result<Checked, PlantErrors> {
    let mut report = Report::default();
    actuator_types(plant, &mut report);
    let devices = devices(plant, &mut report);
    let mut ids = HashSet::new();
    actuators(plant, &devices, &mut ids, &mut report);
    sensors(plant, &devices, &mut ids, &mut report);
    let contract = Contract::new(plant).map_err(|problems| report.errors.extend(problems));
    let targeting = Targeting::new(plant);
    resources(plant, &targeting, &mut report);
    let operations = operations(plant, &targeting, &mut report);
    routines(plant, &operations, &mut report);
    super::simulation::check(plant, &mut report);
    let graphs: Option<Vec<RoutineGraph>> =
        plant.routines.iter().map(RoutineGraph::resolve).collect();
    match (contract, graphs) {
        (Ok(contract), Some(routines)) if report.errors.is_empty() => Ok(Checked {
            warnings: report.warnings,
            targeting,
            contract,
            routines,
        }),
        _ => Err(PlantErrors(report.errors)),
    }
}

/// A name that goes into MQTT topics as one component.
pub(super) fn topic_safe(name: &str) -> bool {
    !name.is_empty() && !name.contains(['/', '+', '#']) && !name.chars().any(char::is_whitespace)
}

/// Timings, ranges, and names that are topic components; a type called
/// as another's plural is a warning (its name in a group command means the other).
fn actuator_types(plant: &PlantModel, report: &mut Report) {
    let keys = GroupKeys::new(plant.actuator_types.keys());
    for (name, t) in &plant.actuator_types {
        let path = format!("actuatorTypes.{}", quote(name));
        if !topic_safe(name) {
            report.error(
                &path,
                "a type name is a topic component: no spaces, '/', '+' or '#'",
            );
        }
        if let Some(singular) = keys.kind(name).filter(|kind| kind != name) {
            report.warn(
                &path,
                format!(
                    "in a group command '{}' is the plural of type '{}': command these actuators under '{}'",
                    quote(name),
                    quote(singular),
                    quote(GroupKeys::plural(name))
                ),
            );
        }
        for (field, value) in [
            ("noMotionMs", t.no_motion_ms),
            ("completionMs", t.completion_ms),
            ("staleMs", t.stale_ms),
        ] {
            if value == Millis::ZERO {
                report.error(&path, format!("{field} must be positive"));
            }
        }
        if t.no_motion_ms > t.completion_ms {
            report.error(&path, "noMotionMs must not exceed completionMs");
        }
        if t.signal == Signal::Analog {
            let r = t.range(None);
            if !(r.min.is_finite() && r.max.is_finite() && r.min < r.max) {
                report.error(
                    &path,
                    format!(
                        "min ({}) must be below max ({})",
                        quote(r.min),
                        quote(r.max)
                    ),
                );
            }
            if !(r.tolerance >= 0.0 && r.tolerance < (r.max - r.min) / 2.0) {
                report.error(
                    &path,
                    format!(
                        "tolerance must be at least 0 and less than half the range, got {}",
                        quote(r.tolerance)
                    ),
                );
            }
        } else if t.min.is_some() || t.max.is_some() || t.tolerance.is_some() {
            report.error(&path, "a binary type has no min, max or tolerance");
        }
    }
}

/// The devices by id: what each carries and the format it speaks.
struct Devices<'a> {
    kinds: HashMap<&'a str, DeviceKind>,
    profiles: HashMap<&'a str, Profile>,
}

/// Ids defined once and usable as topic prefixes.
fn devices<'a>(plant: &'a PlantModel, report: &mut Report) -> Devices<'a> {
    let mut devices = Devices {
        kinds: HashMap::new(),
        profiles: HashMap::new(),
    };
    for (i, d) in plant.devices.iter().enumerate() {
        let path = format!("devices[{i}] ({})", quote(&d.id));
        if d.prefix.is_none() && !topic_safe(&d.id) {
            report.error(
                &path,
                "a device id is its topic prefix: no spaces, '/', '+' or '#' (or give it a 'prefix')",
            );
        }
        devices.profiles.insert(d.id.as_str(), d.profile);
        if devices.kinds.insert(d.id.as_str(), d.kind).is_some() {
            report.error(&path, format!("device '{}' is defined twice", quote(&d.id)));
        }
    }
    devices
}

/// Ids (shared with the sensors), devices, outputs, types, and idle and
/// lockout states that suit the type's signal and range.
fn actuators<'a>(
    plant: &'a PlantModel,
    devices: &Devices,
    ids: &mut HashSet<&'a str>,
    report: &mut Report,
) {
    let mut slots = HashSet::new();
    for (i, a) in plant.actuators.iter().enumerate() {
        let path = format!("actuators[{i}] ({})", quote(&a.id));
        if a.id.trim().is_empty() {
            report.error(&path, "an actuator needs an id");
        }
        if !ids.insert(a.id.as_str()) {
            report.error(&path, format!("id '{}' is used twice", quote(&a.id)));
        }
        match devices.kinds.get(a.device.as_str()) {
            None => report.error(&path, format!("unknown device '{}'", quote(&a.device))),
            Some(DeviceKind::SensorStation) => report.error(
                &path,
                format!(
                    "device '{}' is a sensor station, not an actuator panel",
                    quote(&a.device)
                ),
            ),
            Some(DeviceKind::ActuatorPanel) => {}
        }
        if a.io == Some(0) {
            report.error(&path, "io numbers start at 1");
        }
        let sugarshack = devices.profiles.get(a.device.as_str()) == Some(&Profile::Sugarshack);
        if let Some(io) = a.io.filter(|_| sugarshack) {
            if !slots.insert((a.device.as_str(), a.kind.as_str(), io)) {
                report.error(
                    &path,
                    format!(
                        "{} {} io {} is already taken by another actuator",
                        quote(&a.device),
                        quote(&a.kind),
                        io
                    ),
                );
            }
        }
        let Some(t) = plant.actuator_types.get(&a.kind) else {
            let known: Vec<&str> = plant.actuator_types.keys().map(String::as_str).collect();
            report.error(
                &path,
                format!(
                    "unknown type '{}' (known: {})",
                    quote(&a.kind),
                    quote(known.join(", "))
                ),
            );
            continue;
        };
        if t.signal == Signal::Binary && a.tolerance.is_some() {
            report.error(&path, "a binary actuator has no tolerance");
        }
        let range = t.range(a.tolerance);
        if let Some(tol) = a.tolerance {
            if !(tol >= 0.0 && tol < (range.max - range.min) / 2.0) {
                report.error(
                    &path,
                    format!(
                        "tolerance must be at least 0 and less than half the range, got {}",
                        quote(tol)
                    ),
                );
            }
        }
        for (field, setpoint) in [("idle", a.idle), ("lockout", Some(a.lockout))] {
            if let Some(Err(why)) = setpoint.map(|s| s.position(t.signal, range)) {
                report.error(&path, format!("{field} {why}"));
            }
        }
    }
}

/// Ids (shared with the actuators), devices, datapoint names and periods.
fn sensors<'a>(
    plant: &'a PlantModel,
    devices: &Devices,
    ids: &mut HashSet<&'a str>,
    report: &mut Report,
) {
    for (i, s) in plant.sensors.iter().enumerate() {
        let path = format!("sensors[{i}] ({})", quote(&s.id));
        if !ids.insert(s.id.as_str()) {
            report.error(&path, format!("id '{}' is used twice", quote(&s.id)));
        }
        if !devices.kinds.contains_key(s.device.as_str()) {
            report.error(&path, format!("unknown device '{}'", quote(&s.device)));
        }
        if !topic_safe(&s.name) {
            report.error(
                &path,
                "a datapoint name is a topic component: no spaces, '/', '+' or '#'",
            );
        }
        if s.stale_ms == Some(Millis::ZERO) {
            report.error(&path, "staleMs must be positive");
        }
        if s.update_ms == Some(Millis::ZERO) {
            report.error(&path, "updateMs must be positive");
        }
        match (s.min, s.max) {
            (None, None) => {}
            (Some(min), Some(max)) if min.is_finite() && max.is_finite() && min < max => {}
            _ => report.error(&path, "min and max go together, finite, min below max"),
        }
    }
}

/// Actuators name known resources; each resource is defined once and has a
/// lockout (its own, whose actuators and setpoints must exist and suit them,
/// or its members').
fn resources(plant: &PlantModel, targeting: &Targeting, report: &mut Report) {
    let resources: HashSet<&str> = plant.resources.iter().map(|r| r.id.as_str()).collect();
    for (i, a) in plant.actuators.iter().enumerate() {
        if let Some(r) = a.resource.as_deref().filter(|r| !resources.contains(r)) {
            report.error(
                &format!("actuators[{i}] ({})", quote(&a.id)),
                format!("unknown resource '{}'", quote(r)),
            );
        }
    }
    let mut seen = HashSet::new();
    for (i, r) in plant.resources.iter().enumerate() {
        let path = format!("resources[{i}] ({})", quote(&r.id));
        if !seen.insert(r.id.as_str()) {
            report.error(
                &path,
                format!("resource '{}' is defined twice", quote(&r.id)),
            );
        }
        match &r.lockout {
            // What it names must exist and suit; a group naming nobody (even
            // under no known type) is allowed: the line has nothing to isolate.
            Some(lockout) => {
                let mut named = GroupCommand::default();
                for (key, id, setpoint) in lockout.members() {
                    named.set(key, id, setpoint);
                }
                match targeting.resolve(plant, &named) {
                    Ok(_) | Err(GroupError::Empty) => {}
                    Err(err) => report.error(&format!("{path}.lockout"), err.to_string()),
                }
            }
            None if plant.lockout_of(&r.id).is_none() => report.error(
                &path,
                "no lockout command: give it one, or actuators that belong to it",
            ),
            None => {}
        }
    }
}

/// Ids, resources, steps (commands stay within the resources held, C2, and
/// command only actuators with an idle state to return to, C3; waits read
/// known sensors); equal priorities are a warning. The operations by id.
fn operations<'a>(
    plant: &'a PlantModel,
    targeting: &Targeting,
    report: &mut Report,
) -> HashSet<&'a str> {
    let resources: HashSet<&str> = plant.resources.iter().map(|r| r.id.as_str()).collect();
    let mut operations = HashSet::new();
    let mut priorities: HashMap<i32, &str> = HashMap::new();
    for (i, op) in plant.operations.iter().enumerate() {
        let path = format!("operations[{i}] ({})", quote(&op.id));
        if !operations.insert(op.id.as_str()) {
            report.error(
                &path,
                format!("operation '{}' is defined twice", quote(&op.id)),
            );
        }
        if let Some(other) = priorities.insert(op.priority, &op.id) {
            report.warn(
                &path,
                format!("priority {} is also operation '{}''s: equal priorities are granted first come, first served", op.priority, quote(other)),
            );
        }
        if op.resources.is_empty() {
            report.error(&path, "an operation acquires at least one resource");
        }
        for r in op
            .resources
            .iter()
            .filter(|r| !resources.contains(r.as_str()))
        {
            report.error(&path, format!("unknown resource '{}'", quote(r)));
        }
        if op.steps.is_empty() {
            report.error(&path, "an operation has at least one step");
        }
        if let Some(hold) = &op.hold {
            let path = format!("{path}.hold");
            hold_command(plant, targeting, hold, Some(&op.resources), &path, report);
        }
        for (j, step) in op.steps.iter().enumerate() {
            let path = format!("{path}.steps[{j}]");
            match step {
                Step::Command {
                    command,
                    timeout_ms,
                    ..
                } => {
                    if *timeout_ms == Millis::ZERO {
                        report.error(&path, "timeoutMs must be positive");
                    }
                    let targets = match targeting.resolve(plant, command) {
                        Ok(targets) => targets,
                        Err(err) => {
                            report.error(&path, err.to_string());
                            continue;
                        }
                    };
                    within_lines(plant, targets, &op.resources, &path, report);
                }
                Step::Wait {
                    wait,
                    sensors,
                    timeout_ms,
                    ..
                } => {
                    if *timeout_ms == Millis::ZERO {
                        report.error(&path, "timeoutMs must be positive");
                    }
                    unknown_sensors(plant, sensors, &path, report);
                    condition(plant, wait, sensors, &path, report);
                }
            }
        }
    }
    operation_defaults(plant, targeting, report);
    operations
}

/// An operation commands only actuators of its lines (C2) that have an idle
/// state to return to (C3).
fn within_lines(
    plant: &PlantModel,
    targets: Vec<(usize, f64)>,
    lines: &[String],
    path: &str,
    report: &mut Report,
) {
    for (a, _) in targets {
        let a = &plant.actuators[a];
        match a.resource.as_deref() {
            Some(r) if lines.iter().any(|o| o == r) => {}
            Some(r) => report.error(
                path,
                format!(
                    "C2: commands '{}' on resource '{}', outside the operation's resources ({})",
                    quote(&a.id),
                    quote(r),
                    quote(lines.join(", "))
                ),
            ),
            None => report.error(
                path,
                format!(
                    "C2: commands '{}', which belongs to no resource",
                    quote(&a.id)
                ),
            ),
        }
        idle_to_return_to(a, path, report);
    }
}

fn idle_to_return_to(a: &super::Actuator, path: &str, report: &mut Report) {
    if a.idle.is_none() {
        report.error(
            path,
            format!(
                "C3: commands '{}', which has no idle state to return to",
                quote(&a.id)
            ),
        );
    }
}

/// A hold command: a positive timeout, and actuators and targets that exist
/// and suit; with `lines`, only actuators of those lines (C2). Each needs an
/// idle state, since the return to idle puts back what a hold moved (C3).
/// An empty command holds without commanding anything.
fn hold_command(
    plant: &PlantModel,
    targeting: &Targeting,
    hold: &super::HoldCommand,
    lines: Option<&[String]>,
    path: &str,
    report: &mut Report,
) {
    if hold.timeout_ms == Millis::ZERO {
        report.error(path, "timeoutMs must be positive");
    }
    let targets = match targeting.resolve(plant, &hold.command) {
        Ok(targets) => targets,
        Err(GroupError::Empty) => return,
        Err(err) => return report.error(path, err.to_string()),
    };
    match lines {
        Some(lines) => within_lines(plant, targets, lines, path, report),
        None => {
            for (a, _) in targets {
                idle_to_return_to(&plant.actuators[a], path, report);
            }
        }
    }
}

/// The plant's defaults for operator commands: a hold command cut to each
/// operation's lines, so it only has to name actuators that exist and can
/// return to idle.
fn operation_defaults(plant: &PlantModel, targeting: &Targeting, report: &mut Report) {
    if let Some(hold) = plant
        .operation_defaults
        .as_ref()
        .and_then(|d| d.hold.as_ref())
    {
        hold_command(
            plant,
            targeting,
            hold,
            None,
            "operationDefaults.hold",
            report,
        );
    }
}

fn unknown_sensors(plant: &PlantModel, names: &[String], path: &str, report: &mut Report) {
    for name in names {
        if !plant.sensors.iter().any(|s| &s.id == name) {
            report.error(path, format!("unknown sensor '{}'", quote(name)));
        }
    }
}

/// A condition reads only sensors listed with it and gives true or false
/// (see [`Condition`]); a listed sensor it does not read is a warning.
fn condition(plant: &PlantModel, text: &str, sensors: &[String], path: &str, report: &mut Report) {
    let ids: Vec<&str> = plant.sensors.iter().map(|s| s.id.as_str()).collect();
    match Condition::compile(text, sensors, &ids) {
        Ok(c) => {
            for unread in c.unread() {
                report.warn(
                    path,
                    format!(
                        "lists sensor '{}', which the condition does not read: the condition holds only while it is fresh too",
                        quote(unread)
                    ),
                );
            }
        }
        Err(err) => report.error(path, format!("condition '{}': {err}", quote(text))),
    }
}

/// Ids, states, transitions between known states running known operations,
/// each operation in one routine only (C1), triggers that can fire.
fn routines(plant: &PlantModel, operations: &HashSet<&str>, report: &mut Report) {
    let mut owner: HashMap<&str, &str> = HashMap::new();
    let mut routine_ids = HashSet::new();
    for (i, routine) in plant.routines.iter().enumerate() {
        let path = format!("routines[{i}] ({})", quote(&routine.id));
        if !routine_ids.insert(routine.id.as_str()) {
            report.error(
                &path,
                format!("routine '{}' is defined twice", quote(&routine.id)),
            );
        }
        let states: HashSet<&str> = routine.states.iter().map(String::as_str).collect();
        if states.len() != routine.states.len() {
            report.error(&path, "a state is listed twice");
        }
        for (field, state) in [
            ("initial", Some(&routine.initial)),
            ("errorState", routine.error_state.as_ref()),
        ] {
            if let Some(state) = state.filter(|s| !states.contains(s.as_str())) {
                report.error(
                    &path,
                    format!("{field} '{}' is not one of its states", quote(state)),
                );
            }
        }
        let mut mine = HashSet::new();
        for (j, t) in routine.transitions.iter().enumerate() {
            let path = format!("{path}.transitions[{j}]");
            for state in [&t.from, &t.to]
                .into_iter()
                .filter(|s| !states.contains(s.as_str()))
            {
                report.error(&path, format!("unknown state '{}'", quote(state)));
            }
            if !operations.contains(t.operation.as_str()) {
                report.error(
                    &path,
                    format!("unknown operation '{}'", quote(&t.operation)),
                );
            } else if mine.insert(t.operation.as_str()) {
                if let Some(other) = owner.insert(t.operation.as_str(), routine.id.as_str()) {
                    report.error(
                        &path,
                        format!("C1: operation '{}' already belongs to routine '{}'; an operation belongs to one routine", quote(&t.operation), quote(other)),
                    );
                }
            }
            match &t.trigger {
                Trigger::Msg { msg } if msg == RESET_TOPIC => report.error(
                    &path,
                    format!("the msg topic '{RESET_TOPIC}' is reserved: it sends the routine back to its initial state, so this transition could never fire; give it another topic"),
                ),
                Trigger::Msg { msg } if Command::OPERATOR.iter().any(|c| c.name() == msg) => report.error(
                    &path,
                    format!("the msg topic '{msg}' is reserved: it is an operator's {msg} command to the routine, so this transition could never fire; give it another topic"),
                ),
                Trigger::Msg { .. } => {}
                Trigger::When {
                    when,
                    sensors,
                    every_ms,
                } => {
                    if *every_ms == Millis::ZERO {
                        report.error(&path, "everyMs must be positive");
                    }
                    unknown_sensors(plant, sensors, &path, report);
                    condition(plant, when, sensors, &path, report);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
