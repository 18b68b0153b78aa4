//! The interlock's abnormal conditions, as alarm conditions: a faulted line,
//! and waits or holds past the configured warning times.

use super::snapshot::{FaultCause, ResourceState};
use super::Interlock;
use crate::alarm::{AlarmKind, Condition};
use crate::time::Millis;

impl Interlock {
    /// The conditions that hold at `now`, for [`crate::alarm::Alarms::observe`]:
    /// every faulted line, every request waiting at least `warn_queued_ms`
    /// and every hold of at least `warn_held_ms` (each since it crossed that time).
    pub fn alarm_conditions(&self, now: Millis) -> Vec<Condition> {
        let snapshot = self.snapshot(now);
        let mut conditions = Vec::new();
        for line in &snapshot.resources {
            if let ResourceState::Faulted(fault) = &line.state {
                let op = fault
                    .operation
                    .as_ref()
                    .map(|op| format!(" (op {op})"))
                    .unwrap_or_default();
                let note = fault
                    .note
                    .as_ref()
                    .map(|n| format!(": {n}"))
                    .unwrap_or_default();
                conditions.push(Condition {
                    kind: AlarmKind::LineFaulted,
                    subject: line.name.clone(),
                    text: format!(
                        "{} faulted, {}{op}{note}",
                        line.name,
                        cause_name(fault.cause)
                    ),
                    since_ms: Some(fault.since_ms),
                });
            }
        }
        let long =
            |requests: &[super::snapshot::RequestSnapshot], warn_ms: Option<Millis>, kind, verb| {
                let Some(warn_ms) = warn_ms else {
                    return Vec::new();
                };
                requests
                    .iter()
                    .filter(|r| now.saturating_sub(r.since_ms) >= warn_ms)
                    .map(|r| Condition {
                        kind,
                        subject: r.operation.clone(),
                        text: format!(
                            "op {} {verb} {} for {} s",
                            r.operation,
                            r.resources.join("+"),
                            now.saturating_sub(r.since_ms).as_secs_f64().round()
                        ),
                        since_ms: Some(r.since_ms.saturating_add(warn_ms)),
                    })
                    .collect::<Vec<_>>()
            };
        conditions.extend(long(
            &snapshot.queue,
            self.config.warn_queued_ms,
            AlarmKind::WaitingLong,
            "waiting for",
        ));
        conditions.extend(long(
            &snapshot.holds,
            self.config.warn_held_ms,
            AlarmKind::HeldLong,
            "holding",
        ));
        conditions
    }
}

fn cause_name(cause: FaultCause) -> &'static str {
    match cause {
        FaultCause::Operation => "operation",
        FaultCause::Manual => "manual",
        FaultCause::Interrupted => "interrupted",
        FaultCause::Unknown => "unknown",
    }
}

#[cfg(test)]
mod tests {
    use crate::alarm::AlarmKind;
    use crate::interlock::{Interlock, InterlockConfig};
    use crate::time::ms;

    #[test]
    fn a_faulted_line_a_long_wait_and_a_long_hold_are_conditions() {
        let mut config = InterlockConfig::with_resources(["YEL", "RED"]);
        config.warn_queued_ms = Some(ms(10_000));
        config.warn_held_ms = Some(ms(60_000));
        let mut il = Interlock::new(config).unwrap();
        let yel = il.resource_set(&["YEL"]).unwrap();
        let (a, b) = (il.operation("10"), il.operation("12"));
        il.acquire(a, 1, &yel, ms(0)).unwrap();
        il.acquire(b, 1, &yel, ms(1_000)).unwrap();
        assert!(
            il.alarm_conditions(ms(10_999)).is_empty(),
            "op 12 has waited 9.999 s"
        );

        let at = il.alarm_conditions(ms(61_000));
        let kinds: Vec<_> = at
            .iter()
            .map(|c| (c.kind, c.subject.as_str(), c.since_ms))
            .collect();
        assert_eq!(
            kinds,
            [
                (AlarmKind::WaitingLong, "12", Some(ms(11_000))),
                (AlarmKind::HeldLong, "10", Some(ms(60_000)))
            ]
        );
        assert_eq!(at[0].text, "op 12 waiting for YEL for 60 s");
        assert_eq!(at[1].text, "op 10 holding YEL for 61 s");

        let red = il.resource_set(&["RED"]).unwrap();
        il.fault_resources(&red, Some("leak"), ms(62_000)).unwrap();
        let faulted = &il.alarm_conditions(ms(62_000))[0];
        assert_eq!(
            (faulted.kind, faulted.subject.as_str()),
            (AlarmKind::LineFaulted, "RED")
        );
        assert_eq!(faulted.text, "RED faulted, manual: leak");
        assert_eq!(faulted.since_ms, Some(ms(62_000)));
    }
}
