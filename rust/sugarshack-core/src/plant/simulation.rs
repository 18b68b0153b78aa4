//! The `simulation` section, read by the plant simulator only: tanks, the
//! transfers between them, and datapoint baselines. Checked here with the
//! rest of the document, so that the simulator and the plant check accept
//! and refuse the same documents (the simulator builds on what passed).

use std::collections::HashSet;

use serde::Deserialize;

use super::validate::{topic_safe, Report};
use super::{DeviceKind, PlantModel, Signal};
use crate::text::quote;

/// The plant simulator's tanks, the transfers between them, and the
/// baselines of the datapoints they do not drive.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
pub(super) struct Simulation {
    /// Tanks whose volume the transfers change.
    #[serde(default)]
    tanks: Vec<Tank>,
    /// Lines that move liquid between tanks (or in and out of the plant).
    #[serde(default)]
    transfers: Vec<Transfer>,
    /// Baselines and noise of datapoints no transfer drives.
    #[serde(default)]
    sensors: Vec<Baseline>,
    /// The cloud paper's flow loop, run as a Modbus/TCP I/O module (`--loop`).
    #[serde(default, rename = "loop")]
    flow_loop: Option<FlowLoop>,
}

/// A first-order flow process, y' = (K·u − y)/τ, behind a Modbus device's
/// output (the valve, u) and sensor (the flow, y), and the network delay
/// between that device and the palette.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct FlowLoop {
    /// The output (an id of a device's `modbus.outputs`) that drives the valve.
    output: String,
    /// The sensor that reads the flow, on the output's device.
    sensor: String,
    /// The process gain K: flow per unit of output.
    gain: f64,
    /// The process time constant τ, in s.
    tau_s: f64,
    /// The flow at the start; the output starts where it holds it (0 by default).
    #[serde(default)]
    initial: f64,
    /// The mean round trip the network adds to each request and its reply, in ms.
    #[serde(default)]
    delay_ms: f64,
    /// The uniform ± jitter around it, in ms.
    #[serde(default)]
    jitter_ms: f64,
    /// The flow reading's noise, ± in the flow's units.
    #[serde(default)]
    noise: f64,
}

/// Where a value is published: a plant sensor, or a station's datapoint.
#[derive(Default, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct Datapoint {
    /// A sensor's id: its station and datapoint.
    #[serde(default)]
    sensor: Option<String>,
    /// A sensor station's id (with `datapoint`).
    #[serde(default)]
    station: Option<String>,
    /// The datapoint's name on that station (with `station`).
    #[serde(default)]
    datapoint: Option<String>,
}

/// A tank: its volume in L, published on a sensor or a station's datapoint.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct Tank {
    /// Its id, which transfers name.
    id: String,
    /// How much it holds, in L.
    capacity_l: f64,
    /// What it holds at the start, in L (0 by default).
    #[serde(default)]
    initial_l: f64,
    /// The sensor its volume is published on.
    #[serde(default)]
    sensor: Option<String>,
    /// The sensor station its volume is published on (with `datapoint`).
    #[serde(default)]
    station: Option<String>,
    /// The datapoint its volume is published as (with `station`).
    #[serde(default)]
    datapoint: Option<String>,
    /// Where its fill level in % is published: a datapoint name on its
    /// station, or a sensor or station and datapoint of its own.
    #[serde(default)]
    level: Option<Level>,
}

/// A datapoint name on the tank's station, or a datapoint of its own.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(untagged)]
enum Level {
    /// A datapoint name on the tank's station.
    Name(String),
    /// A sensor, or a station and datapoint.
    At(Datapoint),
}

/// A line that moves liquid while its pump runs and its valves are open.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct Transfer {
    /// Its id, for the simulator's snapshots.
    #[serde(default)]
    id: Option<String>,
    /// The tank it draws from; none: from outside the plant.
    #[serde(default)]
    from: Option<String>,
    /// The tank it fills; none: out of the plant.
    #[serde(default)]
    to: Option<String>,
    /// The binary actuator that drives it; none: it flows by gravity.
    #[serde(default)]
    pump: Option<String>,
    /// The analog actuators it runs through; the least open one sets the rate.
    #[serde(default)]
    valves: Vec<String>,
    /// Its rate with every valve fully open, in L/min.
    rate_lpm: f64,
    /// The sensor that reports its current rate.
    #[serde(default)]
    flow_sensor: Option<String>,
    /// The datapoint that reports its current rate.
    #[serde(default)]
    flow: Option<Datapoint>,
}

/// The baseline and noise of a datapoint no transfer drives.
#[derive(Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(rename_all = "camelCase", deny_unknown_fields)]
struct Baseline {
    /// A sensor's id.
    #[serde(default)]
    sensor: Option<String>,
    /// A sensor station's id (with `datapoint`).
    #[serde(default)]
    station: Option<String>,
    /// The datapoint's name on that station (with `station`).
    #[serde(default)]
    datapoint: Option<String>,
    /// The value it reads without noise.
    #[serde(default)]
    base: Option<f64>,
    /// The span its noise is a share of.
    #[serde(default)]
    span: Option<f64>,
}

/// Tanks defined once with a capacity and a start within it; transfers
/// between known tanks through a binary actuator (the pump) and analog ones
/// (the valves) at a positive rate; every datapoint on a sensor station.
pub(super) fn check(plant: &PlantModel, report: &mut Report) {
    let Some(value) = &plant.simulation else {
        return;
    };
    let sim: Simulation = match crate::json::from_value(value) {
        Ok(sim) => sim,
        Err(err) => {
            let (path, message) = match err {
                crate::json::JsonError::Invalid {
                    path: Some(path),
                    message,
                    ..
                } => (format!("simulation.{path}"), message),
                other => ("simulation".to_owned(), other.to_string()),
            };
            report.error(&path, message);
            return;
        }
    };
    let sites = Sites { plant };
    let mut tanks = HashSet::new();
    for (i, t) in sim.tanks.iter().enumerate() {
        let path = format!("simulation.tanks[{i}] ({})", quote(&t.id));
        if !tanks.insert(t.id.as_str()) {
            report.error(&path, format!("tank '{}' is defined twice", quote(&t.id)));
        }
        if !(t.capacity_l.is_finite() && t.capacity_l > 0.0) {
            report.error(&path, "capacityL must be above 0");
        } else if !(t.initial_l >= 0.0 && t.initial_l <= t.capacity_l) {
            report.error(&path, "initialL must be within 0..capacityL");
        }
        let volume = Datapoint {
            sensor: t.sensor.clone(),
            station: t.station.clone(),
            datapoint: t.datapoint.clone(),
        };
        sites.datapoint(&volume, &path, report);
        match &t.level {
            Some(Level::Name(name)) => sites.datapoint(
                &Datapoint {
                    station: Some(t.station.clone().unwrap_or_default()),
                    datapoint: Some(name.clone()),
                    sensor: None,
                },
                &format!("{path}.level"),
                report,
            ),
            Some(Level::At(at)) => sites.datapoint(at, &format!("{path}.level"), report),
            None => {}
        }
    }
    for (i, x) in sim.transfers.iter().enumerate() {
        let path = match &x.id {
            Some(id) => format!("simulation.transfers[{i}] ({})", quote(id)),
            None => format!("simulation.transfers[{i}]"),
        };
        for tank in [&x.from, &x.to].into_iter().flatten() {
            if !tanks.contains(tank.as_str()) {
                report.error(&path, format!("unknown tank '{}'", quote(tank)));
            }
        }
        if let Some(pump) = &x.pump {
            sites.actuator(
                pump,
                Signal::Binary,
                "a pump (a binary actuator)",
                &path,
                report,
            );
        }
        for valve in &x.valves {
            sites.actuator(
                valve,
                Signal::Analog,
                "a valve (an analog actuator)",
                &path,
                report,
            );
        }
        if !(x.rate_lpm.is_finite() && x.rate_lpm > 0.0) {
            report.error(&path, "rateLpm must be above 0");
        }
        if let Some(sensor) = &x.flow_sensor {
            sites.sensor(sensor, &path, report);
        }
        if let Some(flow) = &x.flow {
            sites.datapoint(flow, &format!("{path}.flow"), report);
        }
    }
    if let Some(l) = &sim.flow_loop {
        flow_loop(plant, l, report);
    }
    for (i, s) in sim.sensors.iter().enumerate() {
        let path = format!("simulation.sensors[{i}]");
        if s.sensor.is_none() && s.station.is_none() {
            report.error(
                &path,
                "give 'sensor' (a sensor's id) or 'station' and 'datapoint'",
            );
        }
        let at = Datapoint {
            sensor: s.sensor.clone(),
            station: s.station.clone(),
            datapoint: s.datapoint.clone(),
        };
        sites.datapoint(&at, &path, report);
        for (field, value) in [("base", s.base), ("span", s.span)] {
            if value.is_some_and(|v| !v.is_finite()) {
                report.error(&path, format!("{field} must be a finite number"));
            }
        }
    }
}

/// The loop's output and sensor on one Modbus device; a process that settles.
fn flow_loop(plant: &PlantModel, l: &FlowLoop, report: &mut Report) {
    let path = "simulation.loop";
    let device = plant.devices.iter().find(|d| {
        d.modbus
            .as_ref()
            .is_some_and(|m| m.outputs.iter().any(|o| o.id == l.output))
    });
    let Some(device) = device else {
        report.error(
            path,
            format!(
                "'{}' is not an output of the plant's modbus devices",
                quote(&l.output)
            ),
        );
        return;
    };
    if !plant
        .sensors
        .iter()
        .any(|s| s.id == l.sensor && s.device == device.id)
    {
        report.error(
            path,
            format!(
                "'{}' is not a sensor of '{}', the device of {}",
                quote(&l.sensor),
                quote(&device.id),
                quote(&l.output)
            ),
        );
    }
    for (field, value) in [("gain", l.gain), ("tauS", l.tau_s)] {
        if !(value.is_finite() && value > 0.0) {
            report.error(path, format!("{field} must be above 0"));
        }
    }
    for (field, value) in [
        ("initial", l.initial),
        ("delayMs", l.delay_ms),
        ("jitterMs", l.jitter_ms),
        ("noise", l.noise),
    ] {
        if !(value.is_finite() && (field == "initial" || value >= 0.0)) {
            report.error(path, format!("{field} must be a finite number, at least 0"));
        }
    }
}

/// Where the section's references point: the plant's sensors, stations and actuators.
struct Sites<'a> {
    plant: &'a PlantModel,
}

impl Sites<'_> {
    fn sensor(&self, id: &str, path: &str, report: &mut Report) {
        if !self.plant.sensors.iter().any(|s| s.id == id) {
            report.error(path, format!("unknown sensor '{}'", quote(id)));
        }
    }

    fn datapoint(&self, at: &Datapoint, path: &str, report: &mut Report) {
        if let Some(sensor) = &at.sensor {
            self.sensor(sensor, path, report);
            return;
        }
        let (Some(station), Some(name)) = (&at.station, &at.datapoint) else {
            if at.station.is_some() || at.datapoint.is_some() {
                report.error(path, "give both 'station' and 'datapoint'");
            }
            return;
        };
        let kind = self
            .plant
            .devices
            .iter()
            .find(|d| &d.id == station)
            .map(|d| d.kind);
        if kind != Some(DeviceKind::SensorStation) {
            report.error(
                path,
                format!("'{}' is not a sensor station of the plant", quote(station)),
            );
        }
        if !topic_safe(name) {
            report.error(
                path,
                format!(
                    "datapoint '{}' is a topic component: no spaces, '/', '+' or '#'",
                    quote(name)
                ),
            );
        }
    }

    fn actuator(&self, id: &str, signal: Signal, what: &str, path: &str, report: &mut Report) {
        let found = self.plant.actuators.iter().find(|a| a.id == id);
        let is = found
            .and_then(|a| self.plant.actuator_types.get(&a.kind))
            .map(|t| t.signal);
        if is != Some(signal) {
            report.error(
                path,
                format!("'{}' is not {what} of the plant's actuators", quote(id)),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use serde_json::{json, Value};

    use super::*;
    use crate::plant::fixtures::{yel_plant, yel_pump, yel_valve};

    fn errors(simulation: Value) -> Vec<String> {
        let mut doc = yel_plant(
            json!([yel_valve("V1", 1), yel_pump("P1", 1)]),
            json!([{ "command": { "valves": { "V1": 100 } }, "timeoutMs": 1000 }]),
        );
        doc["simulation"] = simulation;
        let plant: PlantModel = serde_json::from_value(doc).unwrap();
        let mut report = Report::default();
        check(&plant, &mut report);
        report.errors.iter().map(ToString::to_string).collect()
    }

    #[test]
    fn a_sound_section_passes() {
        let sound = json!({
            "tanks": [
                { "id": "T1", "station": "station-3", "datapoint": "volume", "level": "level", "capacityL": 100, "initialL": 10 },
                { "id": "T2", "sensor": "LT-3", "capacityL": 50 }
            ],
            "transfers": [{ "id": "x", "from": "T1", "to": "T2", "pump": "P1", "valves": ["V1"], "rateLpm": 5, "flowSensor": "LT-3" }],
            "sensors": [{ "sensor": "LT-3", "base": 4 }, { "station": "station-3", "datapoint": "brix", "span": 70 }]
        });
        assert_eq!(errors(sound), Vec::<String>::new());
    }

    #[test]
    fn each_problem_names_its_entry() {
        assert_eq!(
            errors(json!({
                "tanks": [{ "id": "T1", "capacityL": 10, "initialL": 11 }, { "id": "T1", "capacityL": 0 }],
                "transfers": [{ "id": "x", "from": "T-nope", "pump": "V1", "valves": ["P1"], "rateLpm": 0 }],
                "sensors": [{ "base": 1 }, { "station": "ctrl-1", "datapoint": "a b" }]
            })),
            vec![
                "simulation.tanks[0] (T1): initialL must be within 0..capacityL",
                "simulation.tanks[1] (T1): tank 'T1' is defined twice",
                "simulation.tanks[1] (T1): capacityL must be above 0",
                "simulation.transfers[0] (x): unknown tank 'T-nope'",
                "simulation.transfers[0] (x): 'V1' is not a pump (a binary actuator) of the plant's actuators",
                "simulation.transfers[0] (x): 'P1' is not a valve (an analog actuator) of the plant's actuators",
                "simulation.transfers[0] (x): rateLpm must be above 0",
                "simulation.sensors[0]: give 'sensor' (a sensor's id) or 'station' and 'datapoint'",
                "simulation.sensors[1]: 'ctrl-1' is not a sensor station of the plant",
                "simulation.sensors[1]: datapoint 'a b' is a topic component: no spaces, '/', '+' or '#'",
            ]
        );
    }

    #[test]
    fn a_flow_loop_runs_behind_a_modbus_device_s_output_and_sensor() {
        let pct = json!({ "raw": [4000, 20000], "value": [0, 100] });
        let doc = json!({
            "actuatorTypes": {},
            "devices": [{ "id": "io", "kind": "sensor-station", "profile": "modbus", "modbus": {
                "host": "127.0.0.1", "unit": 1, "outputs": [{ "id": "FCV", "kind": "holding", "address": 0, "scale": pct }] } },
                { "id": "other", "kind": "sensor-station" }],
            "sensors": [{ "id": "FT", "device": "io", "name": "flow", "modbus": { "kind": "input", "address": 0 } },
                        { "id": "TT", "device": "other", "name": "temperature" }]
        });
        let check_loop = |l: Value| {
            let mut doc = doc.clone();
            doc["simulation"] = json!({ "loop": l });
            let plant: PlantModel = serde_json::from_value(doc).unwrap();
            let mut report = Report::default();
            check(&plant, &mut report);
            report
                .errors
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
        };
        let sound = json!({ "output": "FCV", "sensor": "FT", "gain": 0.02, "tauS": 2, "delayMs": 400, "jitterMs": 250 });
        assert_eq!(check_loop(sound), Vec::<String>::new());
        assert_eq!(
            check_loop(
                json!({ "output": "FCV", "sensor": "TT", "gain": 0, "tauS": 2, "noise": -1 })
            ),
            vec![
                "simulation.loop: 'TT' is not a sensor of 'io', the device of FCV",
                "simulation.loop: gain must be above 0",
                "simulation.loop: noise must be a finite number, at least 0",
            ]
        );
        assert_eq!(
            check_loop(json!({ "output": "nope", "sensor": "FT", "gain": 1, "tauS": 1 })),
            vec!["simulation.loop: 'nope' is not an output of the plant's modbus devices"]
        );
    }

    #[test]
    fn a_section_that_cannot_be_read_says_where() {
        assert_eq!(
            errors(json!({ "tanks": [{ "id": "T1", "capacityL": "big" }] })),
            vec!["simulation.tanks[0]: capacityL must be a number, like 2.5; got 'big'"]
        );
        assert_eq!(
            errors(json!("tanks")),
            vec!["simulation: it must be an object in braces, {...}; got 'tanks'"]
        );
        assert!(
            errors(json!({ "tank": [] }))[0].starts_with("simulation.tank: unknown field `tank`")
        );
    }
}
