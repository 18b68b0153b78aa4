use serde::Serialize;
use sugarshack_core::code::Code;
use sugarshack_core::control::delay::DelayEstimator;
use sugarshack_core::control::error::time;
use sugarshack_core::control::pid::{PidInput, PidStep};
use sugarshack_core::control::pid_loop::{PidLoop as CoreLoop, PidLoopConfig};
use sugarshack_core::control::rcc::{self, Decision, IoState, RccConfig, RccController};
use sugarshack_core::control::smith::SmithPredictor;
use sugarshack_core::control::station::{
    Change, Sample, Saved, Station, StationConfig, PID_DEFAULTS,
};
use sugarshack_core::control::ControlError;
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, to_js, Bound};
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;

/// The TypeScript shapes of what this module's calls return and take
/// (`unchecked_return_type` / `unchecked_param_type` name them).
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** One PID step. */
export interface PidStep {
    p: number;
    i: number;
    d: number;
    output: number;
    mode: "auto" | "tracking" | "fallback";
    saturated: boolean;
}

/** One step of a `PidLoop`: the PID's, with what the Smith predictor saw. */
export interface PidLoopStep extends PidStep {
    seen: number | null;
    deadTimeSamples: number | null;
}

/** `PidLoop.stepDecided()`. */
export interface PidLoopScan {
    engaged: boolean;
    firstCycle: boolean;
    write: number | null;
    step: PidLoopStep;
}

/** `Rcc.scan()`. */
export interface RccScan {
    engaged: boolean;
    firstCycle: boolean;
    write: number | null;
    step: PidStep;
}

/** The Smith predictor's dead-time estimate. */
export interface DelayEstimate {
    deadTimeSamples: number;
    meanMs: number | null;
    stdMs: number | null;
}

/** The PID configuration in force. */
export interface PidConfig {
    kp: number;
    tiS: number;
    tdS: number;
    outMin: number;
    outMax: number;
    action: "direct" | "reverse";
    fallback: number | null;
    proportionalOn: "error" | "measurement";
}

/** The Computing step's decision (`Rcc.decide()`). */
export interface RccDecision {
    engaged: boolean;
    firstCycle: boolean;
    track: number | null;
}

/** The I/O side's state tuple: the last action and each controller's age (null: never acted). */
export interface IoState {
    lastAction: number;
    agesMs: (number | null)[];
}

/** What a `PidStation` step did. */
export interface StationReport {
    p: number;
    i: number;
    d: number;
    output: number;
    mode: "auto" | "tracking" | "fallback" | "manual";
    saturated: boolean;
    setpoint: number;
    measurement: number | null;
    seen: number | null;
    deadTimeSamples: number | null;
    dtS: number;
}

/** `PidStation.measure()`: `engaged` false behind an RCC decision in standby. */
export interface StationOutcome {
    engaged: boolean;
    pid: StationReport;
}

/** `PidStation.tick()`: a fallback step to send, or no I/O state came. */
export type StationStale = { kind: "fallback"; pid: StationReport } | { kind: "noIo" };

/** `PidStation.state()`. */
export interface StationState {
    setpoint: number;
    mode: "auto" | "manual";
    manual: number | null;
    lastOutput: number | null;
    integral: number;
}
/** A PID configuration as given (`tiS`, `tdS`, `action`, `fallback` and `proportionalOn` may be left out). */
export interface PidConfigInput {
    kp: number;
    tiS?: number;
    tdS?: number;
    outMin: number;
    outMax: number;
    action?: "direct" | "reverse";
    fallback?: number | null;
    proportionalOn?: "error" | "measurement";
}

/** A Smith predictor's configuration: its process model, sample time and dead-time mode. */
export interface SmithConfig {
    model: Record<string, unknown>;
    tsS: number;
    deadTime: Record<string, unknown>;
    maxSamples?: number;
}

/** `new PidLoop(config)`. */
export interface PidLoopConfig {
    pid: PidConfigInput;
    smith?: SmithConfig | null;
}

/** `new Rcc(config)`. */
export interface RccConfig {
    id: number;
    thresholdsMs: number[];
    tsMs: number;
    smoothHandover?: boolean;
    pollTimeoutMs?: number | null;
}

/** `new PidStation(config)`. */
export interface StationConfig {
    loop: PidLoopConfig;
    tsS: number;
    staleMs?: number | null;
    setpoint: number;
    mode?: "auto" | "manual";
    manual?: number | null;
}

/** `pidDefaults()`: what a pid node's blank settings become (stale after: `staleSamples` × Ts). */
export interface PidDefaults {
    alpha: number;
    h: number;
    maxSamples: number;
    staleSamples: number;
}

/** `PidStation.change()`: any part absent; applied whole or refused whole. */
export interface StationChange {
    setpoint?: number;
    mode?: "auto" | "manual";
    manual?: number | null;
    tunings?: { kp?: number; tiS?: number; tdS?: number };
    limits?: { min?: number; max?: number };
}

/** `PidStation.restore()`: what was saved of a station. */
export interface StationSaved {
    integral?: number | null;
    setpoint?: number | null;
    mode?: "auto" | "manual" | null;
    manual?: number | null;
}
"#;

fn control_error(err: ControlError) -> JsValue {
    js_error(err.code(), &err.to_string())
}

/// What a JS value is, for an error message.
fn kind(value: &JsValue) -> String {
    if value.is_null() {
        "null".into()
    } else if value.is_undefined() {
        "nothing (undefined)".into()
    } else if let Some(text) = value.as_string() {
        format!("the string {}", quote(format!("'{text}'")))
    } else {
        value.js_typeof().as_string().unwrap_or_default()
    }
}

/// A number argument: a JS number, never null, a string or a boolean coerced into one.
/// Whether it may be NaN or infinite is the core's to say.
fn number(value: &JsValue, what: &str) -> Result<f64, JsValue> {
    value.as_f64().ok_or_else(|| {
        js_error(
            Code::InvalidInput,
            &format!("{what} must be a number, got {}", kind(value)),
        )
    })
}

/// A time from JS: a number, finite and at least 0.
fn control_time(value: &JsValue) -> Result<Millis, JsValue> {
    time(number(value, "time (ms)")?, "time (ms)").map_err(control_error)
}

/// An optional number: undefined or null is absent; anything else must be a number.
fn optional_number(value: &JsValue, what: &str) -> Result<Option<f64>, JsValue> {
    if value.is_undefined() || value.is_null() {
        Ok(None)
    } else {
        number(value, what).map(Some)
    }
}

fn optional_decision(value: JsValue) -> Result<Option<Decision>, JsValue> {
    if value.is_undefined() || value.is_null() {
        return Ok(None);
    }
    from_js_bounded(value, Code::InvalidInput, "RCC decision", Bound::Control).map(Some)
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Estimate {
    dead_time_samples: usize,
    mean_ms: Option<f64>,
    std_ms: Option<f64>,
}

/// `{ deadTimeSamples, meanMs, stdMs }`, or undefined without a Smith predictor.
fn estimate(smith: Option<&SmithPredictor>) -> Result<JsValue, JsValue> {
    let Some(smith) = smith else {
        return Ok(JsValue::UNDEFINED);
    };
    let estimator = smith.estimator();
    to_js(&Estimate {
        dead_time_samples: smith.dead_time_samples(),
        mean_ms: estimator.and_then(|e| e.mean()).map(Millis::as_f64),
        std_ms: estimator.and_then(|e| e.std()).map(Millis::as_f64),
    })
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct StepView {
    #[serde(flatten)]
    step: PidStep,
    /// What the PID saw: the measurement, or the Smith predictor's estimate.
    seen: Option<f64>,
    dead_time_samples: Option<usize>,
}

/// A PID with an optional Smith predictor: `new PidLoop({ pid: {...}, smith: {...} })`.
/// Steps come back as `{ p, i, d, output, mode, saturated, seen, deadTimeSamples }`.
#[wasm_bindgen]
pub struct PidLoop {
    core: CoreLoop,
}

impl PidLoop {
    fn step_view(&self, step: PidStep) -> StepView {
        StepView {
            step,
            seen: self.core.seen(),
            dead_time_samples: self.core.smith().map(|s| s.dead_time_samples()),
        }
    }
}

/// A controller id or count from JS: a whole number >= 1 (wasm-bindgen would wrap -1 to 4294967295).
fn whole(value: f64) -> Option<usize> {
    (value.is_finite() && value >= 1.0 && value.fract() == 0.0 && value <= u32::MAX as f64)
        .then_some(value as usize)
}

#[wasm_bindgen]
impl PidLoop {
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "PidLoopConfig")] config: JsValue,
    ) -> Result<PidLoop, JsValue> {
        let config: PidLoopConfig = pid_config(config)?;
        CoreLoop::new(config)
            .map(|core| PidLoop { core })
            .map_err(control_error)
    }

    /// One step; `measurement` undefined, null or NaN outputs the fallback, `track`
    /// set makes the integrator follow an action someone else applied.
    #[wasm_bindgen(unchecked_return_type = "PidLoopStep")]
    pub fn step(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] setpoint: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] measurement: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] dt_s: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] track: JsValue,
    ) -> Result<JsValue, JsValue> {
        let input = PidInput {
            setpoint: number(&setpoint, "set point")?,
            measurement: optional_number(&measurement, "measurement")?,
            dt_s: number(&dt_s, "elapsed time (s)")?,
            track: optional_number(&track, "tracked action")?,
        };
        let step = self.core.step(input).map_err(control_error)?;
        to_js(&self.step_view(step))
    }

    /// One step as an RCC decision (from `Rcc.decide`) says: `{ engaged, firstCycle, write, step }`.
    #[wasm_bindgen(js_name = stepDecided, unchecked_return_type = "PidLoopScan")]
    pub fn step_decided(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "RccDecision")] decision: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] setpoint: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] measurement: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] dt_s: JsValue,
    ) -> Result<JsValue, JsValue> {
        let decision: Decision =
            from_js_bounded(decision, Code::InvalidInput, "RCC decision", Bound::Control)?;
        let setpoint = number(&setpoint, "set point")?;
        let measurement = optional_number(&measurement, "measurement")?;
        let dt_s = number(&dt_s, "elapsed time (s)")?;
        let scan = rcc::act(&decision, &mut self.core, setpoint, measurement, dt_s)
            .map_err(control_error)?;
        #[derive(Serialize)]
        #[serde(rename_all = "camelCase")]
        struct ScanView {
            engaged: bool,
            first_cycle: bool,
            write: Option<f64>,
            step: StepView,
        }
        to_js(&ScanView {
            engaged: scan.engaged,
            first_cycle: scan.first_cycle,
            write: scan.write,
            step: self.step_view(scan.step),
        })
    }

    #[wasm_bindgen(js_name = setTunings)]
    pub fn set_tunings(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] kp: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] ti_s: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] td_s: JsValue,
    ) -> Result<(), JsValue> {
        let (kp, ti_s, td_s) = (
            number(&kp, "kp")?,
            number(&ti_s, "ti (s)")?,
            number(&td_s, "td (s)")?,
        );
        self.core
            .pid_mut()
            .set_tunings(kp, ti_s, td_s)
            .map_err(control_error)
    }

    #[wasm_bindgen(js_name = setLimits)]
    pub fn set_limits(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] out_min: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] out_max: JsValue,
    ) -> Result<(), JsValue> {
        let (out_min, out_max) = (
            number(&out_min, "output min")?,
            number(&out_max, "output max")?,
        );
        self.core
            .pid_mut()
            .set_limits(out_min, out_max)
            .map_err(control_error)
    }

    pub fn integral(&self) -> f64 {
        self.core.pid().integral()
    }

    #[wasm_bindgen(js_name = setIntegral)]
    pub fn set_integral(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] integral: JsValue,
    ) -> Result<(), JsValue> {
        let integral = number(&integral, "integral")?;
        self.core
            .pid_mut()
            .set_integral(integral)
            .map_err(control_error)
    }

    #[wasm_bindgen(js_name = lastOutput)]
    pub fn last_output(&self) -> Option<f64> {
        self.core.pid().last_output()
    }

    /// Forget the previous measurement: no derivative kick across a gap.
    pub fn restart(&mut self) {
        self.core.pid_mut().restart();
    }

    /// A measured round trip (ms) for the adaptive Smith predictor.
    #[wasm_bindgen(js_name = observeRoundTrip)]
    pub fn observe_round_trip(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] round_trip_ms: JsValue,
    ) -> Result<(), JsValue> {
        let round_trip = round_trip_of(&round_trip_ms)?;
        self.core
            .observe_round_trip(round_trip)
            .map_err(control_error)
    }

    /// `{ deadTimeSamples, meanMs, stdMs }`, or undefined without a Smith predictor.
    #[wasm_bindgen(js_name = delayEstimate, unchecked_return_type = "DelayEstimate | undefined")]
    pub fn delay_estimate(&self) -> Result<JsValue, JsValue> {
        estimate(self.core.smith())
    }

    /// The configuration in force (tunings and limits as last set).
    #[wasm_bindgen(unchecked_return_type = "PidConfig")]
    pub fn config(&self) -> Result<JsValue, JsValue> {
        to_js(self.core.pid().config())
    }
}

/// A measured round trip from JS, checked as the delay estimator takes it.
fn round_trip_of(value: &JsValue) -> Result<Millis, JsValue> {
    let round_trip_ms = number(value, "round trip (ms)")?;
    DelayEstimator::round_trip(round_trip_ms).map_err(control_error)
}

/// One controller of an RCC group: `new Rcc({ id, thresholdsMs, tsMs, smoothHandover })`.
#[wasm_bindgen]
pub struct Rcc {
    core: RccController,
}

#[wasm_bindgen]
impl Rcc {
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "RccConfig")] config: JsValue,
    ) -> Result<Rcc, JsValue> {
        let config: RccConfig = from_js_bounded(
            config,
            Code::InvalidConfig,
            "RCC configuration",
            Bound::Control,
        )?;
        RccController::new(config)
            .map(|core| Rcc { core })
            .map_err(control_error)
    }

    /// The Computing step for a polled state `{ lastAction, agesMs }`: `{ engaged, firstCycle, track }`.
    /// With `nowMs` the polling timeout counts from it.
    #[wasm_bindgen(unchecked_return_type = "RccDecision")]
    pub fn decide(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "IoState")] state: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] now_ms: JsValue,
    ) -> Result<JsValue, JsValue> {
        let state: IoState =
            from_js_bounded(state, Code::InvalidInput, "I/O state", Bound::Control)?;
        let decision = match optional_number(&now_ms, "time (ms)")? {
            Some(now_ms) => {
                let now = time(now_ms, "time (ms)").map_err(control_error)?;
                self.core.decide_at(&state, now)
            }
            None => self.core.decide(&state),
        };
        to_js(&decision.map_err(control_error)?)
    }

    /// Counts the polling timeout from `nowMs` (at deploy, before any state).
    #[wasm_bindgen(js_name = watchFrom)]
    pub fn watch_from(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
    ) -> Result<(), JsValue> {
        let now = control_time(&now_ms)?;
        self.core.watch_from(now).map_err(control_error)
    }

    /// True once when no state came within the polling timeout.
    pub fn tick(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
    ) -> Result<bool, JsValue> {
        let now = control_time(&now_ms)?;
        self.core.tick(now).map_err(control_error)
    }

    /// When `tick` next has something to do (ms), or undefined.
    #[wasm_bindgen(js_name = nextTickMs)]
    pub fn next_tick_ms(&self) -> Option<f64> {
        self.core.next_tick().map(Millis::as_f64)
    }

    /// Decide and step `pid` in one call: `{ engaged, firstCycle, write, step }`.
    #[wasm_bindgen(unchecked_return_type = "RccScan")]
    pub fn scan(
        &mut self,
        pid: &mut PidLoop,
        #[wasm_bindgen(unchecked_param_type = "IoState")] state: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] setpoint: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] measurement: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] dt_s: JsValue,
    ) -> Result<JsValue, JsValue> {
        let state: IoState =
            from_js_bounded(state, Code::InvalidInput, "I/O state", Bound::Control)?;
        let setpoint = number(&setpoint, "set point")?;
        let measurement = optional_number(&measurement, "measurement")?;
        let dt_s = number(&dt_s, "elapsed time (s)")?;
        let scan = self
            .core
            .scan(&mut pid.core, &state, setpoint, measurement, dt_s)
            .map_err(control_error)?;
        to_js(&scan)
    }

    /// No I/O state came within the polling timeout (Fig. 7 line 11).
    #[wasm_bindgen(js_name = pollTimedOut)]
    pub fn poll_timed_out(&mut self) {
        self.core.poll_timed_out();
    }

    #[wasm_bindgen(getter, js_name = firstCycle)]
    pub fn first_cycle(&self) -> bool {
        self.core.first_cycle()
    }
}

/// The I/O side's state tuple (a, u_1..u_n), aged by the caller's clock.
#[wasm_bindgen]
pub struct IoModule {
    core: rcc::IoModule,
}

#[wasm_bindgen]
impl IoModule {
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "number")] controllers: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] initial_action: JsValue,
    ) -> Result<IoModule, JsValue> {
        let controllers = number(&controllers, "controllers")?;
        let initial_action = number(&initial_action, "initial action")?;
        let controllers = whole(controllers).ok_or_else(|| {
            js_error(
                Code::InvalidConfig,
                &format!(
                    "controllers must be a whole number >= 1, got {}",
                    quote(controllers)
                ),
            )
        })?;
        rcc::IoModule::new(controllers, initial_action)
            .map(|core| IoModule { core })
            .map_err(control_error)
    }

    /// Conditional Acting's write from controller `id` (1-based).
    pub fn write(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] id: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] action: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
    ) -> Result<(), JsValue> {
        let controllers = self.core.controllers();
        let id = number(&id, "controller id")?;
        let (action, now_ms) = (number(&action, "action")?, number(&now_ms, "time (ms)")?);
        let id = whole(id).ok_or_else(|| {
            js_error(Code::UnknownController, &format!("controller id {} is not one of the {controllers} configured (ids run from 1 to {controllers})", quote(id)))
        })?;
        let now = time(now_ms, "time (ms)").map_err(control_error)?;
        self.core.write(id, action, now).map_err(control_error)
    }

    /// `{ lastAction, agesMs }`; an age is null for a controller that never acted.
    #[wasm_bindgen(unchecked_return_type = "IoState")]
    pub fn state(
        &self,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
    ) -> Result<JsValue, JsValue> {
        to_js(&self.core.state(control_time(&now_ms)?))
    }

    #[wasm_bindgen(getter, js_name = lastAction)]
    pub fn last_action(&self) -> f64 {
        self.core.last_action()
    }
}

/// Refuses engagement thresholds that break D_i > D_j >= Ts for i > j.
#[wasm_bindgen(js_name = validateThresholds)]
pub fn validate_thresholds(
    thresholds_ms: Vec<f64>,
    #[wasm_bindgen(unchecked_param_type = "number")] ts_ms: JsValue,
) -> Result<(), JsValue> {
    let ts_ms = number(&ts_ms, "sampling period Ts (ms)")?;
    rcc::thresholds_from_ms(&thresholds_ms, ts_ms)
        .map(drop)
        .map_err(control_error)
}

/// A PID loop's or station's configuration, bounded as every control input is.
fn pid_config<T: serde::de::DeserializeOwned>(config: JsValue) -> Result<T, JsValue> {
    from_js_bounded(
        config,
        Code::InvalidConfig,
        "PID configuration",
        Bound::Control,
    )
}

/// What a pid node's blank settings become, from the core: for the editor and help.
#[wasm_bindgen(js_name = pidDefaults, unchecked_return_type = "PidDefaults")]
pub fn pid_defaults() -> Result<JsValue, JsValue> {
    to_js(&PID_DEFAULTS)
}

/// The state document of pid node `owner`: `saved` sealed for `config` at `nowMs`.
#[wasm_bindgen(js_name = sealPidState)]
pub fn seal_pid_state(
    owner: &str,
    #[wasm_bindgen(unchecked_param_type = "StationConfig")] config: JsValue,
    #[wasm_bindgen(unchecked_param_type = "StationSaved")] saved: JsValue,
    #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
) -> Result<String, JsValue> {
    let config: StationConfig = pid_config(config)?;
    let saved: Saved =
        from_js_bounded(saved, Code::InvalidInput, "saved PID state", Bound::Control)?;
    Ok(saved.seal(owner, &config, control_time(&now_ms)?))
}

/// The state pid node `owner` sealed in `text` (read from `source`); refused
/// with `INVALID_SNAPSHOT` and the reason when it is not usable.
#[wasm_bindgen(js_name = openPidState, unchecked_return_type = "StationSaved")]
pub fn open_pid_state(source: &str, text: &str, owner: &str) -> Result<JsValue, JsValue> {
    if text.len() > Bound::Control.max_bytes() {
        return Err(js_error(
            Code::InputTooLarge,
            &format!(
                "{source}: {} bytes, more than a PID state can be",
                text.len()
            ),
        ));
    }
    let saved = Saved::open(text, owner)
        .map_err(|refusal| js_error(Code::InvalidSnapshot, &format!("{source}: {refusal}")))?;
    to_js(&saved)
}

/// A PID loop with its set point, auto/manual mode, manual output and stale
/// watch: `new PidStation({ loop: { pid, smith }, tsS, staleMs, setpoint, mode, manual })`.
/// Steps come back as `{ engaged, pid: { p, i, d, output, mode, saturated, setpoint,
/// measurement, seen, deadTimeSamples, dtS } }`.
#[wasm_bindgen]
pub struct PidStation {
    core: Station,
}

#[wasm_bindgen]
impl PidStation {
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "StationConfig")] config: JsValue,
    ) -> Result<PidStation, JsValue> {
        let config: StationConfig = pid_config(config)?;
        Station::new(config)
            .map(|core| PidStation { core })
            .map_err(control_error)
    }

    /// A sample: `measurement` undefined, null or NaN is a bad one (the fallback
    /// is stepped); `sampleMs` when it was measured, `nowMs` when it arrived;
    /// `track` an action someone else applied; `decision` an rcc node's.
    #[wasm_bindgen(unchecked_return_type = "StationOutcome")]
    pub fn measure(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] measurement: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] sample_ms: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
        #[wasm_bindgen(unchecked_param_type = "number | null | undefined")] track: JsValue,
        #[wasm_bindgen(unchecked_param_type = "RccDecision | null | undefined")] decision: JsValue,
    ) -> Result<JsValue, JsValue> {
        let measurement = optional_number(&measurement, "measurement")?;
        let (sample_ms, now_ms) = (
            number(&sample_ms, "sample time (ms)")?,
            number(&now_ms, "time (ms)")?,
        );
        let (track, decision) = (
            optional_number(&track, "tracked action")?,
            optional_decision(decision)?,
        );
        // Checked in the order the station checked them.
        let now = time(now_ms, "time (ms)").map_err(control_error)?;
        let sampled = time(sample_ms, "sample time (ms)").map_err(control_error)?;
        let sample = Sample {
            measurement,
            sampled,
            now,
            track,
            decision,
        };
        to_js(&self.core.measure(sample).map_err(control_error)?)
    }

    /// `{ kind: "fallback", pid }` to send, `{ kind: "noIo" }`, or undefined when nothing is due.
    #[wasm_bindgen(unchecked_return_type = "StationStale | undefined")]
    pub fn tick(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] now_ms: JsValue,
    ) -> Result<JsValue, JsValue> {
        let now = control_time(&now_ms)?;
        match self.core.tick(now).map_err(control_error)? {
            Some(stale) => to_js(&stale),
            None => Ok(JsValue::UNDEFINED),
        }
    }

    /// When `tick` next has something to do (ms), or undefined.
    #[wasm_bindgen(js_name = nextTickMs)]
    pub fn next_tick_ms(&self) -> Option<f64> {
        self.core.next_tick().map(Millis::as_f64)
    }

    /// `{ setpoint, mode, manual, tunings: { kp, tiS, tdS }, limits: { min, max } }`, any part
    /// absent; applied whole or refused whole.
    pub fn change(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "StationChange")] change: JsValue,
    ) -> Result<(), JsValue> {
        let change: Change =
            from_js_bounded(change, Code::InvalidInput, "loop change", Bound::Control)?;
        self.core.change(change).map_err(control_error)
    }

    /// `{ integral, setpoint, mode, manual }` as saved; refused whole if any is unusable.
    pub fn restore(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "StationSaved")] saved: JsValue,
    ) -> Result<(), JsValue> {
        let saved: Saved =
            from_js_bounded(saved, Code::InvalidInput, "saved PID state", Bound::Control)?;
        self.core.restore(saved).map_err(control_error)
    }

    /// `{ setpoint, mode, manual, lastOutput, integral }`.
    #[wasm_bindgen(unchecked_return_type = "StationState")]
    pub fn state(&self) -> Result<JsValue, JsValue> {
        to_js(&self.core.state())
    }

    #[wasm_bindgen(js_name = observeRoundTrip)]
    pub fn observe_round_trip(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "number")] round_trip_ms: JsValue,
    ) -> Result<(), JsValue> {
        let round_trip = round_trip_of(&round_trip_ms)?;
        self.core
            .observe_round_trip(round_trip)
            .map_err(control_error)
    }

    #[wasm_bindgen(js_name = delayEstimate, unchecked_return_type = "DelayEstimate | undefined")]
    pub fn delay_estimate(&self) -> Result<JsValue, JsValue> {
        estimate(self.core.pid_loop().smith())
    }

    /// The PID configuration in force (tunings and limits as last set).
    #[wasm_bindgen(unchecked_return_type = "PidConfig")]
    pub fn config(&self) -> Result<JsValue, JsValue> {
        to_js(self.core.pid_loop().pid().config())
    }
}
