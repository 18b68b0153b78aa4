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

fn seconds(ms: Millis) -> String {
    crate::text::seconds(ms.as_f64())
}

/// What went wrong with `actuator` (of type `kind`), in plain words: "valve
/// V12 did not move within 4 s of its command (after 1 retry)". `target` is
/// what the failed command asked for, when known.
pub fn describe_fault(
    actuator: &Actuator,
    kind: &ActuatorType,
    fault: FaultKind,
    retries: u32,
    target: Option<f64>,
) -> String {
    let who = format!("{} {}", actuator.kind, actuator.id);
    let binary = kind.signal == Signal::Binary;
    let wanted = match (target, binary) {
        (None, _) => "its target".to_owned(),
        (Some(t), true) => (if t == 1.0 { "on" } else { "off" }).to_owned(),
        (Some(t), false) => match &kind.unit {
            Some(unit) => format!("{t} {unit}"),
            None => t.to_string(),
        },
    };
    let mut text = match fault {
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
    if retries > 0 {
        text.push_str(&format!(
            " (after {retries} {})",
            if retries == 1 { "retry" } else { "retries" }
        ));
    }
    text
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
            describe_fault(&v, &t, FaultKind::NoMotion, 1, Some(50.0)),
            "valve V12 did not move within 0.3 s of its command (after 1 retry)"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::NotReached, 2, Some(12.5)),
            "valve V12 did not reach 12.5 % within 4 s of its command (after 2 retries)"
        );
        assert_eq!(
            describe_fault(&v, &t, FaultKind::Stale, 0, None),
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
            describe_fault(&p, &pump, FaultKind::NotReached, 0, Some(1.0)),
            "pump P1 did not turn on within 4 s of its command"
        );
        assert_eq!(
            describe_fault(&p, &pump, FaultKind::NoMotion, 0, None),
            "pump P1 did not respond within 0.3 s of its command"
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
