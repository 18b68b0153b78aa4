use serde::{Deserialize, Serialize};

use super::InterlockError;

use crate::time::Millis;

/// How queued requests are granted when resources become free.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Policy {
    /// The paper's Algorithm 2: walk the queue by priority and grant every
    /// request whose resources are all free. Keeps lines busy, but a wide
    /// request can wait forever behind a stream of narrow ones.
    #[default]
    Greedy,
    /// A request may not take a resource that a waiting request of higher
    /// priority (or equal priority, queued earlier) also needs. No starvation,
    /// at the cost of lines left idle while the waiter ahead is blocked.
    NoOvertaking,
}

/// One shared resource (a line of piping) and the group command that locks
/// its actuators out when it faults. The command is opaque to the interlock.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ResourceConfig {
    /// The line's name.
    pub name: String,
    /// What is sent to put the line in a safe state when it faults.
    #[serde(default)]
    pub lockout: serde_json::Value,
}

/// An interlock's lines and how it arbitrates them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct InterlockConfig {
    /// The lines, each with its lockout command.
    pub resources: Vec<ResourceConfig>,
    /// Strict priority order, or greedy (any request that fits goes).
    #[serde(default)]
    pub policy: Policy,
    /// Most requests that may wait at once; past it an acquire is refused.
    #[serde(default = "default_queue_bound")]
    pub queue_bound: usize,
    /// Warn once when a request has waited this long.
    #[serde(default)]
    pub warn_queued_ms: Option<Millis>,
    /// Warn once when an operation has held its resources this long.
    #[serde(default)]
    pub warn_held_ms: Option<Millis>,
    /// Keep an event log for `drain_events`; off spares the hot path.
    #[serde(default = "default_true")]
    pub record_events: bool,
}

/// The default bound on waiting requests.
pub const DEFAULT_QUEUE_BOUND: usize = 1024;

fn default_queue_bound() -> usize {
    DEFAULT_QUEUE_BOUND
}

fn default_true() -> bool {
    true
}

impl InterlockConfig {
    /// A configuration with these resources, no lockout commands and defaults elsewhere.
    pub fn with_resources<S: Into<String>>(names: impl IntoIterator<Item = S>) -> Self {
        InterlockConfig {
            resources: names
                .into_iter()
                .map(|name| ResourceConfig {
                    name: name.into(),
                    lockout: serde_json::Value::Null,
                })
                .collect(),
            policy: Policy::Greedy,
            queue_bound: DEFAULT_QUEUE_BOUND,
            warn_queued_ms: None,
            warn_held_ms: None,
            record_events: true,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), InterlockError> {
        let invalid = |reason: String| Err(InterlockError::InvalidConfig { reason });
        if self.resources.is_empty() {
            return invalid("no resources are configured; add at least one".into());
        }
        let mut seen = std::collections::HashSet::new();
        for (index, resource) in self.resources.iter().enumerate() {
            if resource.name.trim().is_empty() {
                return invalid(format!("resource #{} has an empty name", index + 1));
            }
            if !seen.insert(resource.name.as_str()) {
                return invalid(format!("resource '{}' is configured twice", resource.name));
            }
        }
        if self.resources.len() > u32::MAX as usize {
            return invalid("too many resources".into());
        }
        if self.queue_bound == 0 {
            return invalid("queue bound must be at least 1".into());
        }
        if self.warn_queued_ms == Some(Millis::ZERO) || self.warn_held_ms == Some(Millis::ZERO) {
            return invalid("warning thresholds must be positive (leave empty to disable)".into());
        }
        Ok(())
    }
}
