//! A failed command in words a person acts on, and the code it fails with:
//! the core words it from the plant document, so the nodes never read
//! thresholds or switch on fault names themselves.

use super::FaultKind;
use crate::code::Code;
use crate::plant::{Actuator, ActuatorType, Signal};
use crate::time::Millis;

impl FaultKind {
    /// Every kind, for reading a name back.
    pub const ALL: [FaultKind; 6] = [
        FaultKind::NoMotion,
        FaultKind::NotReached,
        FaultKind::Uncommanded,
        FaultKind::Stale,
        FaultKind::DeviceOffline,
        FaultKind::LockedOut,
    ];

    /// Its name in effects and events (`"no-motion"`).
    pub const fn name(self) -> &'static str {
        match self {
            FaultKind::NoMotion => "no-motion",
            FaultKind::NotReached => "not-reached",
            FaultKind::Uncommanded => "uncommanded",
            FaultKind::Stale => "stale",
            FaultKind::DeviceOffline => "device-offline",
            FaultKind::LockedOut => "locked-out",
        }
    }

    /// The kind named `name`, if there is one.
    pub fn from_name(name: &str) -> Option<FaultKind> {
        FaultKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The code a group command fails with: a lockout taking the actuator
    /// over is not the actuator's failure.
    pub const fn code(self) -> Code {
        match self {
            FaultKind::LockedOut => Code::LockedOut,
            _ => Code::CommandFailed,
        }
    }
}

/// What has come from an actuator and its device since the plant started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heard {
    /// The actuator has reported a position.
    Feedback,
    /// Its device has (a status, another actuator), the actuator never.
    DeviceOnly,
    /// Nothing from its device at all.
    Nothing,
}

fn seconds(ms: Millis) -> String {
    crate::text::seconds(ms.as_f64())
}

/// What went wrong with `actuator` (of type `kind`), in plain words: "valve
/// V12 did not move within 4 s of its command (after 1 retry)". `target` is
/// what the failed command asked for, when known. An actuator that never
/// reported a position did not fail to move: its device is not connected or
/// does not speak `profile`, the plant document's profile for it, and the
/// words say so (`heard`).
pub fn describe_fault(
    actuator: &Actuator,
    kind: &ActuatorType,
    fault: FaultKind,
    retries: u32,
    target: Option<f64>,
    (heard, profile): (Heard, &str),
) -> String {
    let who = format!("{} {}", actuator.kind, actuator.id);
    let retried = match retries {
        0 => String::new(),
        1 => " (after 1 retry)".to_owned(),
        n => format!(" (after {n} retries)"),
    };
    let unheard = matches!(
        fault,
        FaultKind::NoMotion | FaultKind::NotReached | FaultKind::Stale
    ) && heard != Heard::Feedback;
    if unheard {
        let device = &actuator.device;
        let when = match fault {
            FaultKind::Stale => format!("in the {} it is given", seconds(kind.stale_ms)),
            FaultKind::NoMotion => format!(
                "within {} of its command{retried}",
                seconds(kind.no_motion_ms)
            ),
            _ => format!(
                "within {} of its command{retried}",
                seconds(kind.completion_ms)
            ),
        };
        let why = if heard == Heard::Nothing {
            format!("nothing has come from its device {device} since the start: is {device} connected to this broker, speaking profile '{profile}' as the plant document says?")
        } else {
            format!(
                "its device {device} is online but nothing it sent reads as {}'s position: does {device} speak profile '{profile}', as the plant document says?",
                actuator.id
            )
        };
        return format!("{who} never reported a position {when}: {why}");
    }
    let binary = kind.signal == Signal::Binary;
    let wanted = match (target, binary) {
        (None, _) => "its target".to_owned(),
        (Some(t), true) => (if t == 1.0 { "on" } else { "off" }).to_owned(),
        (Some(t), false) => match &kind.unit {
            Some(unit) => format!("{t} {unit}"),
            None => t.to_string(),
        },
    };
    let text = match fault {
        FaultKind::NoMotion => format!(
            "{who} did not {} within {} of its command",
            if binary { "respond" } else { "move" },
            seconds(kind.no_motion_ms)
        ),
        FaultKind::NotReached => format!(
            "{who} did not {} {wanted} within {} of its command",
            if binary { "turn" } else { "reach" },
            seconds(kind.completion_ms)
        ),
        FaultKind::Stale => format!(
            "{who} sent no feedback for {} (device {})",
            seconds(kind.stale_ms),
            actuator.device
        ),
        FaultKind::DeviceOffline => format!(
            "{who} cannot complete its command: its device {} went offline",
            actuator.device
        ),
        FaultKind::LockedOut => {
            format!("{who} was taken over by a lockout command before it completed")
        }
        FaultKind::Uncommanded => format!("{who} moved without a command"),
    };
    format!("{text}{retried}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn valve() -> (Actuator, ActuatorType) {
        let actuator = serde_json::from_value(json!({
            "id": "V12", "type": "valve", "device": "ctrl-1", "lockout": 0
        }))
        .unwrap();
        let kind = serde_json::from_value(json!({
            "signal": "analog", "unit": "%", "noMotionMs": 300, "completionMs": 4000, "staleMs": 5000
        }))
        .unwrap();
        (actuator, kind)
    }

    #[test]
    fn faults_are_worded_from_the_plant_document() {
        let (v, t) = valve();
        assert_eq!(
            describe_fault(&v, &t, FaultKind::NoMotion, 1, Some(50.0), HEARD),
            "valve V12 did not move within 0.3 s of its command (after 1 retry)"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::NotReached, 2, Some(12.5), HEARD),
            "valve V12 did not reach 12.5 % within 4 s of its command (after 2 retries)"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::Stale, 0, None, HEARD),
            "valve V12 sent no feedback for 5 s (device ctrl-1)"
        );
        let pump = ActuatorType {
            signal: Signal::Binary,
            ..t
        };
        let p = Actuator {
            kind: "pump".into(),
            id: "P1".into(),
            ..v
        };
        assert_eq!(
            describe_fault(&p, &pump, FaultKind::NotReached, 0, Some(1.0), HEARD),
            "pump P1 did not turn on within 4 s of its command"
        );
        assert_eq!(
            describe_fault(&p, &pump, FaultKind::NoMotion, 0, None, HEARD),
            "pump P1 did not respond within 0.3 s of its command"
        );
    }

    const HEARD: (Heard, &str) = (Heard::Feedback, "sugarshack");

    #[test]
    fn a_fault_with_nothing_ever_heard_names_the_device_and_its_profile_not_the_valve() {
        let (v, t) = valve();
        assert_eq!(
            describe_fault(&v, &t, FaultKind::NoMotion, 1, Some(100.0), (Heard::DeviceOnly, "sugarshack")),
            "valve V12 never reported a position within 0.3 s of its command (after 1 retry): its device ctrl-1 is online but nothing it sent reads as V12's position: does ctrl-1 speak profile 'sugarshack', as the plant document says?"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::NotReached, 0, None, (Heard::Nothing, "esphome")),
            "valve V12 never reported a position within 4 s of its command: nothing has come from its device ctrl-1 since the start: is ctrl-1 connected to this broker, speaking profile 'esphome' as the plant document says?"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::Stale, 0, None, (Heard::Nothing, "esphome")),
            "valve V12 never reported a position in the 5 s it is given: nothing has come from its device ctrl-1 since the start: is ctrl-1 connected to this broker, speaking profile 'esphome' as the plant document says?"
        );
        // An offline device or a lockout says what it is, heard or not.
        assert_eq!(
            describe_fault(
                &v,
                &t,
                FaultKind::DeviceOffline,
                0,
                None,
                (Heard::Nothing, "esphome")
            ),
            "valve V12 cannot complete its command: its device ctrl-1 went offline"
        );
    }

    #[test]
    fn names_read_back_and_a_lockout_is_not_a_failed_command() {
        for kind in FaultKind::ALL {
            assert_eq!(FaultKind::from_name(kind.name()), Some(kind));
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.name());
        }
        assert_eq!(FaultKind::LockedOut.code(), Code::LockedOut);
        assert_eq!(FaultKind::NoMotion.code(), Code::CommandFailed);
        assert_eq!(FaultKind::from_name("nope"), None);
    }
}
