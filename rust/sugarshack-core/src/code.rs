//! Every code an error or a refusal carries, from the core, the wasm facade
//! or the nodes, in one table: its name (the `code` a Catch node sees), the
//! status text a node shows for it, and the stem of the message a person reads.
//! The nodes read this table through the facade; they never copy it.
//!
//! ```
//! use sugarshack_core::code::{Code, MAX_STATUS_CHARS};
//!
//! assert_eq!(Code::QueueFull.name(), "QUEUE_FULL");
//! assert_eq!(Code::from_name("QUEUE_FULL"), Some(Code::QueueFull));
//! assert!(Code::ALL.iter().all(|c| c.status().chars().count() <= MAX_STATUS_CHARS));
//! ```

use std::fmt;

use serde::Serialize;

macro_rules! codes {
    ($($(#[$doc:meta])* $variant:ident = $name:literal, $status:literal, $stem:literal;)*) => {
        /// A stable machine-readable error or status code.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Code {
            $($(#[$doc])* $variant,)*
        }

        impl Code {
            /// Every code, in the order of the table.
            pub const ALL: &'static [Code] = &[$(Code::$variant),*];

            /// The name Catch nodes and tests see, e.g. `"QUEUE_FULL"`.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Code::$variant => $name,)*
                }
            }

            /// A node's status text for it: at most [`MAX_STATUS_CHARS`] characters.
            pub const fn status(self) -> &'static str {
                match self {
                    $(Code::$variant => $status,)*
                }
            }

            /// What went wrong, in a few words a person reads ("the interlock queue is full").
            pub const fn stem(self) -> &'static str {
                match self {
                    $(Code::$variant => $stem,)*
                }
            }
        }
    };
}

/// Node-RED shows at most this many characters of a node's status without cutting it.
pub const MAX_STATUS_CHARS: usize = 19;

codes! {
    // ---- configuration and input read at the boundary
    /// A configuration that cannot run.
    InvalidConfig = "INVALID_CONFIG", "config error", "the configuration is invalid";
    /// A value handed in that cannot be used.
    InvalidInput = "INVALID_INPUT", "invalid input", "the input cannot be used";
    /// A time that is not a non-negative number of milliseconds.
    InvalidTime = "INVALID_TIME", "bad time", "the time is not a number of milliseconds";
    /// An input nested deeper than the facade reads.
    InputTooDeep = "INPUT_TOO_DEEP", "input too deep", "the input is nested too deep";
    /// An input over its size bound.
    InputTooLarge = "INPUT_TOO_LARGE", "input too large", "the input is too large";
    /// An input that refers to itself.
    InputCircular = "INPUT_CIRCULAR", "circular input", "the input refers to itself";
    /// A saved state that cannot be restored.
    InvalidSnapshot = "INVALID_SNAPSHOT", "state error", "the saved state cannot be restored";
    /// A failure inside sugarshack itself, not caused by the msg.
    Internal = "INTERNAL", "internal error", "sugarshack failed internally";

    // ---- the interlock
    /// A request that names no resource.
    EmptyResourceSet = "EMPTY_RESOURCE_SET", "no resources", "the request names no resource";
    /// A resource the interlock is not configured with.
    UnknownResource = "UNKNOWN_RESOURCE", "unknown resource", "the resource is not configured";
    /// A resource set handle the interlock never made.
    UnknownResourceSet = "UNKNOWN_RESOURCE_SET", "unknown resources", "the resource set is unknown";
    /// A fault of an operation that neither holds, waits, nor faulted lines (never seen, released, or refused at its acquire).
    UnknownOperation = "UNKNOWN_OPERATION", "unknown operation", "the operation is unknown";
    /// A msg without an operation id.
    MissingOperation = "MISSING_OPERATION", "no operation id", "the msg names no operation";
    /// An operation id that is not a usable name.
    InvalidOperation = "INVALID_OPERATION", "bad operation id", "the operation id is not usable";
    /// C1: the operation already holds its resources.
    AlreadyHolding = "ALREADY_HOLDING", "already holding", "the operation already holds its resources";
    /// C1: the operation already waits in the queue.
    AlreadyQueued = "ALREADY_QUEUED", "already queued", "the operation already waits in the queue";
    /// A release by an operation that holds nothing.
    NotHolding = "NOT_HOLDING", "holds nothing", "the operation holds nothing";
    /// A cancel of an operation that is not waiting.
    NotQueued = "NOT_QUEUED", "not queued", "the operation is not waiting";
    /// A clear of a line that is not faulted.
    NotFaulted = "NOT_FAULTED", "not faulted", "the line is not faulted";
    /// A clear the plant does not allow yet (the line is not isolated).
    ClearRefused = "CLEAR_REFUSED", "clear refused", "the plant does not show the line isolated";
    /// The interlock queue is at its bound.
    QueueFull = "QUEUE_FULL", "queue full", "the interlock queue is full";
    /// A priority that is not an integer in range.
    InvalidPriority = "INVALID_PRIORITY", "bad priority", "the priority is not usable";
    /// Resources given in a form that cannot be read.
    InvalidResources = "INVALID_RESOURCES", "bad resources", "the resources cannot be read";
    /// An acquire that waited longer than its timeout.
    AcquireTimeout = "ACQUIRE_TIMEOUT", "timed out", "the request waited too long";
    /// A node configured without an interlock.
    NoInterlock = "NO_INTERLOCK", "no interlock", "no interlock is configured";
    /// The interlock stopped (redeployed or closed) while the msg waited.
    InterlockStopped = "INTERLOCK_STOPPED", "stopped", "the interlock stopped";
    /// An operation or a fault node raised a fault.
    Faulted = "FAULTED", "faulted", "the operation faulted";

    // ---- the plant and its actuators
    /// A node configured without a plant.
    NoPlant = "NO_PLANT", "no plant", "no plant is configured";
    /// A plant document with problems.
    InvalidPlant = "INVALID_PLANT", "plant invalid", "the plant document is invalid";
    /// An actuator not in the plant document.
    UnknownActuator = "UNKNOWN_ACTUATOR", "unknown actuator", "the actuator is not in the plant";
    /// A device not in the plant document.
    UnknownDevice = "UNKNOWN_DEVICE", "unknown device", "the device is not in the plant";
    /// A group command that names no actuator.
    EmptyCommand = "EMPTY_COMMAND", "empty command", "the command names no actuator";
    /// A group command that cannot be read.
    InvalidGroup = "INVALID_GROUP", "bad command", "the group command is invalid";
    /// An actuator named twice in one group command.
    DuplicateActuator = "DUPLICATE_ACTUATOR", "duplicate actuator", "an actuator is named twice";
    /// A target an actuator cannot take.
    InvalidTarget = "INVALID_TARGET", "bad target", "the target is not valid";
    /// An output (`output/<id>`) the plant's Modbus devices do not have.
    UnknownOutput = "UNKNOWN_OUTPUT", "unknown output", "the output is not in the plant";
    /// An actuator still carrying out a command.
    StillMoving = "STILL_MOVING", "still moving", "the actuator is still moving";
    /// An actuator whose device is offline.
    DeviceOffline = "DEVICE_OFFLINE", "device offline", "the device is offline";
    /// A group command while the same caller's last one runs.
    CallerBusy = "CALLER_BUSY", "busy", "a command is already in progress";
    /// Feedback that is not a valid state.
    InvalidFeedback = "INVALID_FEEDBACK", "bad feedback", "the feedback is not a valid state";
    /// A command whose actuator failed to carry it out.
    CommandFailed = "COMMAND_FAILED", "command failed", "the command failed";
    /// A command that did not complete within its timeout.
    CommandTimeout = "COMMAND_TIMEOUT", "timed out", "the command did not complete in time";
    /// A command taken over by a lockout.
    LockedOut = "LOCKED_OUT", "locked out", "a lockout took the actuator over";
    /// C2: a command to an actuator outside the resources held.
    OutsideResources = "OUTSIDE_RESOURCES", "C2: outside lines", "the actuator is outside the lines held";
    /// A command to an actuator whose lockout is not confirmed yet.
    LockoutPending = "LOCKOUT_PENDING", "lockout pending", "the lockout is not confirmed yet";
    /// A sample stamped further ahead than the allowed clock skew.
    FutureTimestamp = "FUTURE_TIMESTAMP", "clock ahead", "the sample is stamped in the future";

    // ---- operations and conditions
    /// C1: the operation is already running.
    OperationRunning = "OPERATION_RUNNING", "already running", "the operation is already running";
    /// A run started twice.
    AlreadyStarted = "ALREADY_STARTED", "already started", "the run has already started";
    /// A step index or step outcome that does not fit the run.
    InvalidStep = "INVALID_STEP", "invalid step", "the step does not fit the run";
    /// A run aborted: by an operator's abort, or because its supervisor went away.
    Aborted = "ABORTED", "aborted", "the run was aborted";
    /// A command the state of an operation or routine does not allow (a restart of a running operation).
    CommandRefused = "COMMAND_REFUSED", "command refused", "the state does not allow the command";
    /// A start of an operation that was aborted and not reset since.
    OperationAborted = "OPERATION_ABORTED", "aborted: reset it", "the operation was aborted and waits for a reset";
    /// A run an operator stopped before it completed.
    OperationStopped = "OPERATION_STOPPED", "stopped", "an operator stopped the operation";
    /// An operator's command to an operation or routine that neither runs nor waits for a reset on the interlock.
    UnknownRun = "UNKNOWN_RUN", "not running", "nothing of that id runs here";
    /// A condition that did not hold within its timeout.
    ConditionTimeout = "CONDITION_TIMEOUT", "condition timeout", "the condition did not hold in time";
    /// A condition that cannot be compiled or evaluated.
    InvalidCondition = "INVALID_CONDITION", "bad condition", "the condition is invalid";

    // ---- sensors
    /// A sensor not in the plant document.
    UnknownSensor = "UNKNOWN_SENSOR", "unknown sensor", "the sensor is not in the plant";
    /// A sensor value that is not a finite number.
    InvalidSensorValue = "INVALID_SENSOR_VALUE", "bad sensor value", "the sensor value is not a number";
    /// A sensor that has sent no value yet.
    SensorNoValue = "SENSOR_NO_VALUE", "no sensor value", "the sensor has sent no value";
    /// A sensor its device reports unavailable.
    SensorUnavailable = "SENSOR_UNAVAILABLE", "sensor unavailable", "the sensor is unavailable";
    /// A sensor value older than allowed.
    SensorStale = "SENSOR_STALE", "sensor stale", "the sensor value is stale";

    // ---- routines
    /// A routine not in the plant document, or not running.
    UnknownRoutine = "UNKNOWN_ROUTINE", "unknown routine", "the routine is unknown";
    /// A routine run by another node already.
    RoutineTaken = "ROUTINE_TAKEN", "routine taken", "another node runs the routine";
    /// A routine whose operation is still running.
    RoutineBusy = "ROUTINE_BUSY", "busy", "the routine's operation is still running";
    /// A trigger with no transition from the current state.
    NoTransition = "NO_TRANSITION", "no transition", "no transition fits the trigger";
    /// A routine halted after a fault, waiting for a reset.
    RoutineHalted = "ROUTINE_HALTED", "halted", "the routine halted after a fault";
    /// A trigger of a held routine.
    RoutineHeld = "ROUTINE_HELD", "held", "the routine is held";
    /// An operation's return while none is pending.
    NotPending = "NOT_PENDING", "nothing pending", "no operation is pending";

    // ---- control loops
    /// A controller id outside those configured.
    UnknownController = "UNKNOWN_CONTROLLER", "unknown controller", "the controller is not configured";
    /// A measurement that is not a finite number.
    BadMeasurement = "BAD_MEASUREMENT", "bad measurement", "the measurement is not a number";

    // ---- alarms
    /// An alarm id that is not listed now.
    UnknownAlarm = "UNKNOWN_ALARM", "unknown alarm", "the alarm is not listed";
    /// A shelve without a valid end time.
    InvalidShelf = "INVALID_SHELF", "bad shelve time", "the shelve time cannot be used";
    /// More alarm conditions than the list keeps.
    TooManyAlarms = "TOO_MANY_ALARMS", "too many alarms", "there are more alarms than the list keeps";
}

impl Code {
    /// The code named `name`, if there is one.
    pub fn from_name(name: &str) -> Option<Code> {
        Code::ALL.iter().copied().find(|c| c.name() == name)
    }
}

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Code {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

/// Tests and callers compare a code with its name.
impl PartialEq<&str> for Code {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// One row of the table as the nodes read it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct CodeEntry {
    /// The code's name.
    pub code: &'static str,
    /// Its status text.
    pub status: &'static str,
    /// Its message stem.
    pub stem: &'static str,
}

/// The whole table, in order.
pub fn table() -> Vec<CodeEntry> {
    Code::ALL
        .iter()
        .map(|c| CodeEntry {
            code: c.name(),
            status: c.status(),
            stem: c.stem(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn every_status_text_fits_a_node_status() {
        for code in Code::ALL {
            let chars = code.status().chars().count();
            assert!(
                (1..=MAX_STATUS_CHARS).contains(&chars),
                "{code}: '{}' is {chars} characters",
                code.status()
            );
        }
    }

    #[test]
    fn names_are_unique_screaming_snake_case_and_read_back() {
        let mut seen = HashSet::new();
        for &code in Code::ALL {
            assert!(seen.insert(code.name()), "{code} twice");
            assert!(
                code.name()
                    .chars()
                    .all(|c| c.is_ascii_uppercase() || c == '_'),
                "{code}"
            );
            assert_eq!(Code::from_name(code.name()), Some(code));
            assert!(
                !code.stem().is_empty() && !code.stem().ends_with('.'),
                "{code}"
            );
        }
        assert_eq!(Code::from_name("NOPE"), None);
    }

    #[test]
    fn the_table_serializes_as_the_nodes_read_it() {
        let row = serde_json::to_value(&table()[0]).unwrap();
        assert_eq!(
            row,
            serde_json::json!({ "code": "INVALID_CONFIG", "status": "config error", "stem": "the configuration is invalid" })
        );
        assert_eq!(serde_json::to_value(Code::QueueFull).unwrap(), "QUEUE_FULL");
    }
}
