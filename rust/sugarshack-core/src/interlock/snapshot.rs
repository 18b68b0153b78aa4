use serde::{Deserialize, Serialize};

/// The whole interlock state by name, for persistence across restarts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct Snapshot {
    pub version: u32,
    pub taken_at_ms: u64,
    pub resources: Vec<ResourceSnapshot>,
    /// Waiting requests in grant order (priority, then arrival).
    pub queue: Vec<RequestSnapshot>,
    pub holds: Vec<RequestSnapshot>,
}

pub const SNAPSHOT_VERSION: u32 = 1;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct ResourceSnapshot {
    pub name: String,
    pub state: ResourceState,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", tag = "state")]
pub enum ResourceState {
    Free,
    Held { operation: String },
    Faulted(FaultSnapshot),
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct FaultSnapshot {
    pub cause: FaultCause,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operation: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
    pub since_ms: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaultCause {
    /// The operation holding the resource faulted.
    Operation,
    /// A person faulted the resource directly.
    Manual,
    /// The resource was held when the state was saved: its physical state is unknown.
    Interrupted,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub struct RequestSnapshot {
    pub operation: String,
    pub priority: i32,
    pub resources: Vec<String>,
    pub since_ms: u64,
    #[serde(default)]
    pub waited_ms: u64,
}
