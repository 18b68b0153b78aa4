//! Group commands: `{"valves": {"V12": 100, "V13": 0}, "pumps": {"P1": true}}`.
//! Each key names an actuator type, by its name or its plural; each member
//! is an actuator of that type and its setpoint.

use std::collections::HashMap;
use std::fmt;

use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::setpoint::wrong_setpoint;
use super::{PlantModel, Setpoint};
use crate::text::quote;

/// A group command as written, in its order. A key given twice keeps its
/// first place and its last members, as a JSON object does.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupCommand {
    groups: Vec<Group>,
}

/// The actuators a group command sets under one key.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// An actuator type's name or plural (`valve`, `valves`).
    pub key: String,
    /// Actuator ids and their setpoints, in order.
    pub members: Vec<(String, Setpoint)>,
}

impl GroupCommand {
    /// Its groups, in order.
    pub fn groups(&self) -> &[Group] {
        &self.groups
    }

    /// Every (key, actuator id, setpoint), in order.
    pub fn members(&self) -> impl Iterator<Item = (&str, &str, Setpoint)> {
        self.groups.iter().flat_map(|g| {
            g.members
                .iter()
                .map(move |(id, setpoint)| (g.key.as_str(), id.as_str(), *setpoint))
        })
    }

    /// Sets `id` under `key` to `setpoint`: in its place if already there, else last.
    pub fn set(&mut self, key: &str, id: &str, setpoint: Setpoint) {
        let group = match self.groups.iter().position(|g| g.key == key) {
            Some(i) => &mut self.groups[i],
            None => {
                self.groups.push(Group {
                    key: key.to_owned(),
                    members: Vec::new(),
                });
                self.groups.last_mut().expect("just pushed")
            }
        };
        match group.members.iter_mut().find(|(m, _)| m == id) {
            Some(member) => member.1 = setpoint,
            None => group.members.push((id.to_owned(), setpoint)),
        }
    }

    /// Whether it names no actuator.
    pub fn is_empty(&self) -> bool {
        self.groups.iter().all(|g| g.members.is_empty())
    }
}

impl Serialize for GroupCommand {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        struct Members<'a>(&'a [(String, Setpoint)]);

        impl Serialize for Members<'_> {
            fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let mut map = serializer.serialize_map(Some(self.0.len()))?;
                for (id, setpoint) in self.0 {
                    map.serialize_entry(id, setpoint)?;
                }
                map.end()
            }
        }

        let mut map = serializer.serialize_map(Some(self.groups.len()))?;
        for g in &self.groups {
            map.serialize_entry(&g.key, &Members(&g.members))?;
        }
        map.end()
    }
}

/// Reads one group's members.
struct Members(Vec<(String, Setpoint)>);

impl<'de> Deserialize<'de> for Members {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct MembersVisitor;

        impl<'de> Visitor<'de> for MembersVisitor {
            type Value = Members;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object of actuator ids and setpoints, such as {\"V12\": 100}")
            }

            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Members, A::Error> {
                let mut command = GroupCommand::default();
                while let Some((id, setpoint)) = map.next_entry::<String, Setpoint>()? {
                    command.set("", &id, setpoint);
                }
                Ok(Members(
                    command.groups.pop().map(|g| g.members).unwrap_or_default(),
                ))
            }
        }

        deserializer.deserialize_map(MembersVisitor)
    }
}

impl<'de> Deserialize<'de> for GroupCommand {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct GroupCommandVisitor;

        impl<'de> Visitor<'de> for GroupCommandVisitor {
            type Value = GroupCommand;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a group command such as {\"valves\": {\"V12\": 100}}")
            }

            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<GroupCommand, A::Error> {
                let mut command = GroupCommand::default();
                while let Some((key, members)) = map.next_entry::<String, Members>()? {
                    match command.groups.iter_mut().find(|g| g.key == key) {
                        Some(group) => group.members = members.0,
                        None => command.groups.push(Group {
                            key,
                            members: members.0,
                        }),
                    }
                }
                Ok(command)
            }
        }

        deserializer.deserialize_map(GroupCommandVisitor)
    }
}

/// What the visitors above accept: an object of objects of setpoints, any
/// keys (which types and actuators they name is the plant check's to say).
#[cfg(feature = "schema")]
impl schemars::JsonSchema for GroupCommand {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "GroupCommand".into()
    }

    fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let setpoint = generator.subschema_for::<Setpoint>();
        schemars::json_schema!({
            "description": "Actuators to set at once, grouped by type: `{\"valves\": {\"V101\": 100, \"V102\": 0}, \"pumps\": {\"P1\": true}}`. Each key is an actuator type, by its name or its plural (its name and an s: `valves` for type `valve`); under it, each actuator's id and its target: `true` or `false` for a binary type, a position from the type's `min` to its `max` for an analog one.",
            "type": "object",
            "additionalProperties": {
                "description": "The actuators of this type and their targets, such as `{\"V101\": 100}`.",
                "type": "object",
                "additionalProperties": setpoint
            }
        })
    }
}

/// Which actuator type each group command key names: every type by its
/// name, and by its plural (its name and an `s`), which wins should another
/// type be called so (`valves` is the plural of `valve`).
#[derive(Clone, Debug, Default)]
pub struct GroupKeys {
    kinds: HashMap<String, String>,
}

impl GroupKeys {
    /// The keys of these actuator types.
    pub fn new<'a>(type_names: impl IntoIterator<Item = &'a String>) -> Self {
        let names: Vec<&String> = type_names.into_iter().collect();
        let mut kinds: HashMap<String, String> =
            names.iter().map(|n| ((*n).clone(), (*n).clone())).collect();
        for name in names {
            kinds.insert(format!("{name}s"), name.clone());
        }
        GroupKeys { kinds }
    }

    /// The type `key` names, if any.
    pub fn kind(&self, key: &str) -> Option<&str> {
        self.kinds.get(key).map(String::as_str)
    }

    /// The key a type's members are grouped under in the commands the plant
    /// writes (lockouts): its plural, as people write them.
    pub fn plural(kind: &str) -> String {
        format!("{kind}s")
    }
}

/// Why a group command cannot be carried out on this plant.
#[derive(Clone, Debug, PartialEq)]
pub enum GroupError {
    /// The command cannot be read.
    Invalid(String),
    /// An actuator the plant does not have.
    UnknownActuator(String),
    /// A target the actuator cannot take.
    InvalidTarget {
        /// The actuator's id.
        actuator: String,
        /// Why.
        reason: String,
    },
    /// The command names no actuator.
    Empty,
}

impl fmt::Display for GroupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Invalid(reason) => write!(f, "invalid group command: {reason}"),
            Self::UnknownActuator(name) => write!(f, "unknown actuator '{}'", quote(name)),
            Self::InvalidTarget { actuator, reason } => {
                write!(f, "target for '{}' {reason}", quote(actuator))
            }
            Self::Empty => write!(f, "the group command names no actuator"),
        }
    }
}

/// Finds the actuators a group command names: by its keys and the actuator ids.
#[derive(Clone, Debug, Default)]
pub(crate) struct Targeting {
    keys: GroupKeys,
    actuators: HashMap<String, usize>,
}

impl Targeting {
    /// The keys and actuator ids of `plant` (the last of an id given twice).
    pub fn new(plant: &PlantModel) -> Self {
        Targeting {
            keys: GroupKeys::new(plant.actuator_types.keys()),
            actuators: plant
                .actuators
                .iter()
                .enumerate()
                .map(|(i, a)| (a.id.clone(), i))
                .collect(),
        }
    }

    /// The type a key names.
    pub fn kind(&self, key: &str) -> Option<&str> {
        self.keys.kind(key)
    }

    /// The index of actuator `id` in the plant's list.
    pub fn actuator(&self, id: &str) -> Option<usize> {
        self.actuators.get(id).copied()
    }

    fn unknown_type(plant: &PlantModel, key: &str) -> GroupError {
        let known: Vec<&str> = plant.actuator_types.keys().map(String::as_str).collect();
        GroupError::Invalid(format!(
            "unknown actuator type '{}' (known: {})",
            quote(key),
            quote(known.join(", "))
        ))
    }

    /// (actuator index, position) of member `name` of a group of type `kind`,
    /// its setpoint read (or not: the JSON given) by the caller.
    fn target(
        &self,
        plant: &PlantModel,
        kind: &str,
        name: &str,
        setpoint: Result<Setpoint, &serde_json::Value>,
    ) -> Result<(usize, f64), GroupError> {
        // Quoted here: the name goes on into messages built elsewhere.
        let i = self
            .actuator(name)
            .ok_or_else(|| GroupError::UnknownActuator(quote(name)))?;
        let a = &plant.actuators[i];
        if a.kind != kind {
            return Err(GroupError::Invalid(format!(
                "'{}' is a {}, not a {kind}",
                quote(name),
                a.kind
            )));
        }
        let t = &plant.actuator_types[kind];
        let range = t.range(a.tolerance);
        setpoint
            .map_err(|given| wrong_setpoint(t.signal, range, given))
            .and_then(|s| s.position(t.signal, range))
            .map(|position| (i, position))
            .map_err(|reason| GroupError::InvalidTarget {
                actuator: name.to_owned(),
                reason,
            })
    }

    /// The (actuator index, position) a group command of the document sets.
    pub fn resolve(
        &self,
        plant: &PlantModel,
        command: &GroupCommand,
    ) -> Result<Vec<(usize, f64)>, GroupError> {
        let mut targets = Vec::new();
        for group in command.groups() {
            let kind = self
                .kind(&group.key)
                .ok_or_else(|| Self::unknown_type(plant, &group.key))?;
            for (name, setpoint) in &group.members {
                targets.push(self.target(plant, kind, name, Ok(*setpoint))?);
            }
        }
        if targets.is_empty() {
            return Err(GroupError::Empty);
        }
        Ok(targets)
    }

    /// Reads a group command given at run time as JSON into (actuator index, position).
    pub fn read(
        &self,
        plant: &PlantModel,
        payload: &serde_json::Value,
    ) -> Result<Vec<(usize, f64)>, GroupError> {
        let groups = payload.as_object().ok_or_else(|| {
            GroupError::Invalid(format!(
                "expected an object such as {{\"valves\": {{\"V12\": 100}}}}, got {}",
                quote(payload)
            ))
        })?;
        let mut targets = Vec::new();
        for (key, members) in groups {
            let kind = self
                .kind(key)
                .ok_or_else(|| Self::unknown_type(plant, key))?;
            let members = members.as_object().ok_or_else(|| {
                GroupError::Invalid(format!(
                    "'{}' must map actuator ids to targets, got {}",
                    quote(key),
                    quote(members)
                ))
            })?;
            for (name, value) in members {
                let setpoint = Setpoint::from_json(value).ok_or(value);
                targets.push(self.target(plant, kind, name, setpoint)?);
            }
        }
        if targets.is_empty() {
            return Err(GroupError::Empty);
        }
        Ok(targets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::fixtures::actuator_types;
    use serde_json::json;

    fn plant() -> PlantModel {
        serde_json::from_value(json!({
            "actuatorTypes": actuator_types(),
            "devices": [{ "id": "ctrl-1", "kind": "actuator-panel" }],
            "actuators": [
                { "id": "V1", "type": "valve", "device": "ctrl-1", "io": 1, "idle": 0, "lockout": 0 },
                { "id": "P1", "type": "pump", "device": "ctrl-1", "io": 1, "idle": false, "lockout": false }
            ]
        }))
        .unwrap()
    }

    #[test]
    fn a_key_is_a_type_or_its_plural() {
        let names = [
            "valve".to_string(),
            "valves".to_string(),
            "pump".to_string(),
        ];
        let keys = GroupKeys::new(&names);
        assert_eq!(keys.kind("valve"), Some("valve"));
        assert_eq!(keys.kind("pumps"), Some("pump"));
        assert_eq!(keys.kind("valves"), Some("valve"), "the plural wins");
        assert_eq!(keys.kind("valvess"), Some("valves"));
        assert_eq!(keys.kind("pumpss"), None);
        assert_eq!(keys.kind("blob"), None);
    }

    #[test]
    fn a_group_command_keeps_its_order_and_reads_back_as_written() {
        let written = json!({ "valves": { "V2": 100, "V1": 0 }, "pump": { "P1": true } });
        let command: GroupCommand = serde_json::from_value(written.clone()).unwrap();
        let members: Vec<_> = command.members().collect();
        assert_eq!(
            members,
            vec![
                ("valves", "V2", Setpoint::Analog(100.0)),
                ("valves", "V1", Setpoint::Analog(0.0)),
                ("pump", "P1", Setpoint::Binary(true)),
            ]
        );
        assert_eq!(serde_json::to_value(&command).unwrap(), written);
    }

    #[test]
    fn a_group_command_of_bad_setpoints_cannot_be_read() {
        for bad in [
            json!(5),
            json!({ "valves": 5 }),
            json!({ "valves": { "V1": "open" } }),
            json!({ "valves": { "V1": null } }),
        ] {
            assert!(
                serde_json::from_value::<GroupCommand>(bad.clone()).is_err(),
                "{bad}"
            );
        }
    }

    #[test]
    fn resolving_checks_type_id_and_setpoint() {
        let plant = plant();
        let targeting = Targeting::new(&plant);
        let resolve = |v| targeting.resolve(&plant, &serde_json::from_value(v).unwrap());
        assert_eq!(
            resolve(json!({ "valves": { "V1": 40 }, "pump": { "P1": true } })),
            Ok(vec![(0, 40.0), (1, 1.0)])
        );
        assert_eq!(
            resolve(json!({ "pumps": { "P1": 1 } }))
                .unwrap_err()
                .to_string(),
            "target for 'P1' must be true or false, got 1"
        );
        assert_eq!(
            resolve(json!({ "valves": { "P1": true } }))
                .unwrap_err()
                .to_string(),
            "invalid group command: 'P1' is a pump, not a valve"
        );
        assert_eq!(
            resolve(json!({ "motors": { "M1": true } }))
                .unwrap_err()
                .to_string(),
            "invalid group command: unknown actuator type 'motors' (known: pump, valve)"
        );
        assert_eq!(resolve(json!({ "valves": {} })), Err(GroupError::Empty));
    }

    #[test]
    fn a_command_read_at_run_time_gives_the_same_answers_with_the_json_it_was_given() {
        let plant = plant();
        let targeting = Targeting::new(&plant);
        let read = |v| targeting.read(&plant, &v);
        assert_eq!(read(json!({ "valve": { "V1": 40 } })), Ok(vec![(0, 40.0)]));
        assert_eq!(
            read(json!({ "valves": { "V1": "open" } }))
                .unwrap_err()
                .to_string(),
            "target for 'V1' must be a number within 0..100, got \"open\""
        );
        assert_eq!(
            read(json!({ "valves": { "V9": 1 } })),
            Err(GroupError::UnknownActuator("V9".into()))
        );
        assert_eq!(
            read(json!([1])).unwrap_err().to_string(),
            "invalid group command: expected an object such as {\"valves\": {\"V12\": 100}}, got [1]"
        );
    }
}
