//! Live sensor values with the time they were received. A value older than its
//! sensor's `staleMs` is stale, and a read over a stale (or never seen) value
//! fails: a condition must never pass on data the plant may no longer show.
//!
//! Samples are kept in arrival order (MQTT delivers a topic's messages in
//! order): ordering them by the device's timestamp would let one bad stamp,
//! or a device clock set back, hide every later sample. A sample stamped
//! further ahead of its reception than the plant's `clockSkewMs` is refused.

use std::collections::HashMap;
use std::fmt;

use crate::code::Code;
use crate::plant::PlantModel;
use crate::text::quote;
use crate::time::{ms, Millis};

/// For sensors whose document entry sets neither `staleMs` nor `updateMs`
/// on a sugarshack device: five missed 1 Hz samples (see [`PlantModel::sensor_stale_ms`]).
pub const DEFAULT_STALE_MS: Millis = ms(5000);

/// A sensor's handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SensorId(u32);

impl SensorId {
    /// Its position in the plant document's list.
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// The handle at `index` in the plant document's list.
    pub fn from_index(index: u32) -> Self {
        Self(index)
    }
}

/// A sensor's last value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The value read.
    pub value: f64,
    /// The device's own timestamp of the sample.
    pub sampled_ms: Millis,
    /// When it was received, in ms.
    pub received_ms: Millis,
}

/// Why a sensor value cannot be used.
#[derive(Clone, Debug, PartialEq)]
pub enum SensorError {
    /// The plant document has no such sensor.
    UnknownSensor {
        /// The name as given.
        name: String,
    },
    /// A value that is not a finite number.
    InvalidValue {
        /// The sensor's id.
        sensor: String,
        /// The value given.
        value: f64,
    },
    /// No value received yet.
    NoValue {
        /// The sensor's id.
        sensor: String,
    },
    /// Its device said it has no reading (ESPHome `nan`: a failed probe).
    Unavailable {
        /// The sensor's id.
        sensor: String,
    },
    /// The last value is too old.
    Stale {
        /// The sensor's id.
        sensor: String,
        /// Its age.
        age_ms: Millis,
        /// The allowed age.
        stale_ms: Millis,
    },
    /// The device's clock is ahead of ours by more than the plant allows.
    FutureTimestamp {
        /// The sensor's id.
        sensor: String,
        /// How far ahead of its reception it is stamped.
        ahead_ms: Millis,
        /// The allowed clock skew.
        skew_ms: Millis,
    },
}

impl SensorError {
    /// The code a Catch node sees.
    pub fn code(&self) -> Code {
        match self {
            Self::UnknownSensor { .. } => Code::UnknownSensor,
            Self::InvalidValue { .. } => Code::InvalidSensorValue,
            Self::NoValue { .. } => Code::SensorNoValue,
            Self::Unavailable { .. } => Code::SensorUnavailable,
            Self::Stale { .. } => Code::SensorStale,
            Self::FutureTimestamp { .. } => Code::FutureTimestamp,
        }
    }
}

impl fmt::Display for SensorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnknownSensor { name } => {
                write!(f, "unknown sensor '{}': it is not in the plant document", quote(name))
            }
            Self::InvalidValue { sensor, value } => {
                write!(f, "sample {} of sensor '{sensor}' is not a finite number", quote(value))
            }
            Self::NoValue { sensor } => write!(f, "sensor '{sensor}' has sent no value yet"),
            Self::Unavailable { sensor } => write!(
                f,
                "sensor '{sensor}' has no reading: its device reports none (nan); check the probe"
            ),
            Self::Stale {
                sensor,
                age_ms,
                stale_ms,
            } => write!(
                f,
                "sensor '{sensor}' is stale: its last value is {age_ms} ms old (limit {stale_ms} ms)"
            ),
            Self::FutureTimestamp {
                sensor,
                ahead_ms,
                skew_ms,
            } => write!(
                f,
                "sample of sensor '{sensor}' refused: its device's clock is {ahead_ms} ms ahead of ours \
                 (the plant allows {skew_ms} ms, clockSkewMs); set the device's clock right"
            ),
        }
    }
}

impl std::error::Error for SensorError {}

/// The last value of every sensor.
#[derive(Clone, Debug)]
pub struct SensorStore {
    clock_skew_ms: Millis,
    names: Vec<String>,
    stale_ms: Vec<Millis>,
    samples: Vec<Option<Sample>>,
    by_name: HashMap<String, SensorId>,
    /// (device, datapoint name) -> sensor, for `<device>/sensor/<name>/state` topics.
    by_topic: HashMap<(String, String), SensorId>,
}

impl SensorStore {
    /// The sensors of a validated plant, all without a value.
    pub fn new(plant: &PlantModel) -> Self {
        let mut store = SensorStore {
            clock_skew_ms: plant.clock_skew_ms,
            names: Vec::with_capacity(plant.sensors.len()),
            stale_ms: Vec::with_capacity(plant.sensors.len()),
            samples: vec![None; plant.sensors.len()],
            by_name: HashMap::new(),
            by_topic: HashMap::new(),
        };
        for (i, s) in plant.sensors.iter().enumerate() {
            let id = SensorId(i as u32);
            store.names.push(s.id.clone());
            store.stale_ms.push(plant.sensor_stale_ms(s));
            store.by_name.insert(s.id.clone(), id);
            store
                .by_topic
                .insert((s.device.clone(), s.name.clone()), id);
        }
        store
    }

    /// The handle of the sensor `name`.
    pub fn sensor(&self, name: &str) -> Result<SensorId, SensorError> {
        self.by_name
            .get(name)
            .copied()
            .ok_or_else(|| SensorError::UnknownSensor { name: name.into() })
    }

    /// The id of the sensor with handle `id`.
    pub fn name(&self, id: SensorId) -> &str {
        &self.names[id.index()]
    }

    /// How many sensors.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether the plant has no sensor.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The sensor a device publishes as datapoint `name`, if the plant names one.
    pub fn slot(&self, device: &str, name: &str) -> Option<SensorId> {
        self.by_topic
            .get(&(device.to_owned(), name.to_owned()))
            .copied()
    }

    /// Keeps a sample received at `now` in place of the last one, whatever
    /// its device timestamp `sampled_ms`, unless that stamp is more than the
    /// plant's `clockSkewMs` ahead of `now`: then nothing is kept.
    pub fn record(
        &mut self,
        id: SensorId,
        value: f64,
        sampled_ms: Millis,
        now: Millis,
    ) -> Result<(), SensorError> {
        let slot = self
            .samples
            .get_mut(id.index())
            .ok_or_else(|| SensorError::UnknownSensor {
                name: format!("#{}", id.0),
            })?;
        if !value.is_finite() {
            return Err(SensorError::InvalidValue {
                sensor: self.names[id.index()].clone(),
                value,
            });
        }
        let ahead_ms = sampled_ms.saturating_sub(now);
        if ahead_ms > self.clock_skew_ms {
            return Err(SensorError::FutureTimestamp {
                sensor: self.names[id.index()].clone(),
                ahead_ms,
                skew_ms: self.clock_skew_ms,
            });
        }
        *slot = Some(Sample {
            value,
            sampled_ms,
            received_ms: now,
        });
        Ok(())
    }

    /// The device reports no reading for the sensor (`nan`): reads fail
    /// until its next value.
    pub fn record_unavailable(&mut self, id: SensorId, now: Millis) -> Result<(), SensorError> {
        let slot = self
            .samples
            .get_mut(id.index())
            .ok_or_else(|| SensorError::UnknownSensor {
                name: format!("#{}", id.0),
            })?;
        *slot = Some(Sample {
            value: f64::NAN,
            sampled_ms: now,
            received_ms: now,
        });
        Ok(())
    }

    /// How far ahead of its reception a device timestamp may be.
    pub fn clock_skew_ms(&self) -> Millis {
        self.clock_skew_ms
    }

    /// The last sample, fresh or not.
    pub fn sample(&self, id: SensorId) -> Option<Sample> {
        self.samples.get(id.index()).copied().flatten()
    }

    /// The value if it is fresh at `now` (received less than `staleMs` ago).
    pub fn fresh(&self, id: SensorId, now: Millis) -> Result<f64, SensorError> {
        let sensor = || self.names[id.index()].clone();
        let sample = self
            .sample(id)
            .ok_or_else(|| SensorError::NoValue { sensor: sensor() })?;
        if sample.value.is_nan() {
            return Err(SensorError::Unavailable { sensor: sensor() });
        }
        let age_ms = now.saturating_sub(sample.received_ms);
        let stale_ms = self.stale_ms[id.index()];
        if age_ms >= stale_ms {
            return Err(SensorError::Stale {
                sensor: sensor(),
                age_ms,
                stale_ms,
            });
        }
        Ok(sample.value)
    }

    /// Every value of `ids` if all are fresh, else the first that is not.
    pub fn read(&self, ids: &[SensorId], now: Millis) -> Result<Vec<f64>, SensorError> {
        ids.iter().map(|&id| self.fresh(id, now)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::DEFAULT_CLOCK_SKEW_MS;
    use serde_json::json;

    fn plant() -> PlantModel {
        serde_json::from_value(json!({
            "actuatorTypes": {},
            "devices": [{ "id": "station-2", "kind": "sensor-station" }],
            "sensors": [
                { "id": "LT-2", "device": "station-2", "name": "volume", "staleMs": 3000 },
                { "id": "FT-2", "device": "station-2", "name": "flow" }
            ]
        }))
        .unwrap()
    }

    /// A store of the plant's sensors and its level sensor LT-2.
    fn level_store() -> (SensorStore, SensorId) {
        let s = SensorStore::new(&plant());
        let lt = s.sensor("LT-2").unwrap();
        (s, lt)
    }

    #[test]
    fn a_value_is_fresh_until_its_limit_and_stale_from_it() {
        let (mut s, lt) = level_store();
        assert_eq!(
            s.fresh(lt, ms(0)),
            Err(SensorError::NoValue {
                sensor: "LT-2".into()
            })
        );
        s.record(lt, 120.0, ms(900), ms(1000)).unwrap();
        assert_eq!(s.fresh(lt, ms(3999)), Ok(120.0));
        let err = s.fresh(lt, ms(4000)).unwrap_err();
        assert_eq!(err.code(), "SENSOR_STALE");
        assert_eq!(
            err.to_string(),
            "sensor 'LT-2' is stale: its last value is 3000 ms old (limit 3000 ms)"
        );
    }

    #[test]
    fn a_sensor_without_a_limit_uses_the_default() {
        let mut s = SensorStore::new(&plant());
        let ft = s.sensor("FT-2").unwrap();
        s.record(ft, 0.0, ms(0), ms(0)).unwrap();
        assert!(s.fresh(ft, DEFAULT_STALE_MS.saturating_sub(ms(1))).is_ok());
        assert!(s.fresh(ft, DEFAULT_STALE_MS).is_err());
    }

    #[test]
    fn a_read_fails_on_the_first_stale_sensor() {
        let mut s = SensorStore::new(&plant());
        let (lt, ft) = (s.sensor("LT-2").unwrap(), s.sensor("FT-2").unwrap());
        s.record(lt, 1.0, ms(0), ms(0)).unwrap();
        s.record(ft, 2.0, ms(0), ms(2500)).unwrap();
        assert_eq!(s.read(&[lt, ft], ms(2999)), Ok(vec![1.0, 2.0]));
        assert!(
            matches!(s.read(&[ft, lt], ms(3000)), Err(SensorError::Stale { sensor, .. }) if sensor == "LT-2")
        );
    }

    #[test]
    fn non_finite_samples_are_not_kept() {
        let (mut s, lt) = level_store();
        s.record(lt, 5.0, ms(2000), ms(2000)).unwrap();
        assert_eq!(
            s.record(lt, f64::NAN, ms(3000), ms(3000))
                .unwrap_err()
                .code(),
            "INVALID_SENSOR_VALUE"
        );
        assert_eq!(s.sample(lt).unwrap().received_ms, ms(2000));
    }

    #[test]
    fn the_last_sample_received_wins_whatever_its_timestamp() {
        let (mut s, lt) = level_store();
        s.record(lt, 5.0, ms(2000), ms(2000)).unwrap();
        s.record(lt, 4.0, ms(1000), ms(2100)).unwrap();
        assert_eq!(s.sample(lt).unwrap().value, 4.0);
        assert_eq!(s.sample(lt).unwrap().sampled_ms, ms(1000));
        assert_eq!(
            s.fresh(lt, ms(2100 + 2999)),
            Ok(4.0),
            "fresh from its reception"
        );
    }

    #[test]
    fn a_sample_stamped_in_the_future_is_refused_and_the_next_real_one_kept() {
        let (mut s, lt) = level_store();
        s.record(lt, 5.0, ms(10_000), ms(10_000)).unwrap();
        let err = s
            .record(lt, 99.0, ms(9_000_000_000_000_000), ms(11_000))
            .unwrap_err();
        assert_eq!(
            err,
            SensorError::FutureTimestamp {
                sensor: "LT-2".into(),
                ahead_ms: ms(9_000_000_000_000_000 - 11_000),
                skew_ms: DEFAULT_CLOCK_SKEW_MS,
            }
        );
        assert_eq!(err.code(), "FUTURE_TIMESTAMP");
        let message = err.to_string();
        assert!(
            message.contains("clock is 8999999999989000 ms ahead"),
            "{message}"
        );
        assert!(message.contains("allows 5000 ms"), "{message}");
        assert_eq!(s.sample(lt).unwrap().value, 5.0, "nothing of it kept");
        assert_eq!(s.sample(lt).unwrap().received_ms, ms(10_000));
        s.record(lt, 6.0, ms(12_000), ms(12_000)).unwrap();
        assert_eq!(s.fresh(lt, ms(12_500)), Ok(6.0));
    }

    #[test]
    fn a_sample_exactly_at_the_allowed_skew_is_kept() {
        let (mut s, lt) = level_store();
        s.record(
            lt,
            1.0,
            ms(1000).saturating_add(DEFAULT_CLOCK_SKEW_MS),
            ms(1000),
        )
        .unwrap();
        assert_eq!(s.fresh(lt, ms(1000)), Ok(1.0));
        assert_eq!(
            s.record(
                lt,
                2.0,
                ms(2001).saturating_add(DEFAULT_CLOCK_SKEW_MS),
                ms(2000)
            )
            .unwrap_err()
            .code(),
            "FUTURE_TIMESTAMP"
        );
        assert_eq!(s.fresh(lt, ms(2000)), Ok(1.0));
    }

    #[test]
    fn the_skew_comes_from_the_plant() {
        let mut doc = serde_json::to_value(plant()).unwrap();
        doc["clockSkewMs"] = json!(0);
        let mut s = SensorStore::new(&serde_json::from_value(doc).unwrap());
        assert_eq!(s.clock_skew_ms(), ms(0));
        let ft = s.sensor("FT-2").unwrap();
        s.record(ft, 1.0, ms(500), ms(500)).unwrap();
        assert!(s.record(ft, 1.0, ms(502), ms(501)).is_err());
    }

    #[test]
    fn a_device_clock_set_back_an_hour_is_still_heard() {
        let mut s = SensorStore::new(&plant());
        let ft = s.sensor("FT-2").unwrap();
        let hour = 3_600_000;
        s.record(ft, 1.0, ms(2 * hour), ms(2 * hour)).unwrap();
        for k in 1..=5 {
            let now = 2 * hour + k * 1000;
            s.record(ft, k as f64, ms(now - hour), ms(now)).unwrap();
            assert_eq!(s.fresh(ft, ms(now)), Ok(k as f64));
        }
    }

    #[test]
    fn topics_and_names_find_sensors() {
        let s = SensorStore::new(&plant());
        assert_eq!(s.slot("station-2", "flow"), Some(s.sensor("FT-2").unwrap()));
        assert_eq!(s.slot("station-2", "brix"), None);
        assert_eq!(s.sensor("XX").unwrap_err().code(), "UNKNOWN_SENSOR");
    }

    #[test]
    fn a_sensor_its_device_reports_without_a_reading_fails_until_its_next_value() {
        let mut store = SensorStore::new(&plant());
        let lt = store.sensor("LT-2").unwrap();
        store.record(lt, 10.0, ms(0), ms(0)).unwrap();
        store.record_unavailable(lt, ms(100)).unwrap();
        let err = store.fresh(lt, ms(200)).unwrap_err();
        assert_eq!(err.code(), "SENSOR_UNAVAILABLE");
        assert!(err.to_string().contains("nan"), "{err}");
        store.record(lt, 12.0, ms(300), ms(300)).unwrap();
        assert_eq!(store.fresh(lt, ms(400)), Ok(12.0));
    }

    #[test]
    fn stale_limits_follow_the_update_interval_and_the_profile() {
        let plant: PlantModel = serde_json::from_value(json!({
            "actuatorTypes": {},
            "devices": [
                { "id": "station-2", "kind": "sensor-station", "profile": "esphome" },
                { "id": "station-3", "kind": "sensor-station" }
            ],
            "sensors": [
                { "id": "A", "device": "station-2", "name": "a", "updateMs": 10000 },
                { "id": "B", "device": "station-2", "name": "b" },
                { "id": "C", "device": "station-3", "name": "c" },
                { "id": "D", "device": "station-3", "name": "d", "updateMs": 2000, "staleMs": 3000 }
            ]
        }))
        .unwrap();
        let limits: Vec<Millis> = plant
            .sensors
            .iter()
            .map(|s| plant.sensor_stale_ms(s))
            .collect();
        // Five missed updates; ESPHome's default update_interval is 60 s; staleMs wins.
        assert_eq!(
            limits,
            vec![ms(50_000), ms(300_000), DEFAULT_STALE_MS, ms(3000)]
        );
        let mut store = SensorStore::new(&plant);
        let a = store.sensor("A").unwrap();
        store.record(a, 1.0, ms(0), ms(0)).unwrap();
        assert_eq!(store.fresh(a, ms(49_999)), Ok(1.0));
        assert_eq!(
            store.fresh(a, ms(50_000)).unwrap_err().code(),
            "SENSOR_STALE"
        );
    }
}
