use serde::Serialize;
use sugarshack_core::control::pid::PidStep;
use sugarshack_core::control::pid_loop::{PidLoop as CoreLoop, PidLoopConfig};
use sugarshack_core::control::rcc::{self, Decision, IoState, RccConfig, RccController};
use sugarshack_core::control::ControlError;
use wasm_bindgen::prelude::*;

use crate::{from_js_bounded, js_error, to_js, Bound};
use sugarshack_core::text::quote;

fn control_error(err: ControlError) -> JsValue {
    js_error(err.code(), &err.to_string())
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
    pub fn new(config: JsValue) -> Result<PidLoop, JsValue> {
        let config: PidLoopConfig = from_js_bounded(
            config,
            "INVALID_CONFIG",
            "PID configuration",
            Bound::Control,
        )?;
        CoreLoop::new(config)
            .map(|core| PidLoop { core })
            .map_err(control_error)
    }

    /// One step; `measurement` undefined or NaN outputs the fallback, `track`
    /// set makes the integrator follow an action someone else applied.
    pub fn step(
        &mut self,
        setpoint: f64,
        measurement: Option<f64>,
        dt_s: f64,
        track: Option<f64>,
    ) -> Result<JsValue, JsValue> {
        let input = sugarshack_core::control::pid::PidInput {
            setpoint,
            measurement,
            dt_s,
            track,
        };
        let step = self.core.step(input).map_err(control_error)?;
        to_js(&self.step_view(step))
    }

    /// One step as an RCC decision (from `Rcc.decide`) says: `{ engaged, firstCycle, write, step }`.
    #[wasm_bindgen(js_name = stepDecided)]
    pub fn step_decided(
        &mut self,
        decision: JsValue,
        setpoint: f64,
        measurement: Option<f64>,
        dt_s: f64,
    ) -> Result<JsValue, JsValue> {
        let decision: Decision =
            from_js_bounded(decision, "INVALID_INPUT", "RCC decision", Bound::Control)?;
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
    pub fn set_tunings(&mut self, kp: f64, ti_s: f64, td_s: f64) -> Result<(), JsValue> {
        self.core
            .pid_mut()
            .set_tunings(kp, ti_s, td_s)
            .map_err(control_error)
    }

    #[wasm_bindgen(js_name = setLimits)]
    pub fn set_limits(&mut self, out_min: f64, out_max: f64) -> Result<(), JsValue> {
        self.core
            .pid_mut()
            .set_limits(out_min, out_max)
            .map_err(control_error)
    }

    pub fn integral(&self) -> f64 {
        self.core.pid().integral()
    }

    #[wasm_bindgen(js_name = setIntegral)]
    pub fn set_integral(&mut self, integral: f64) -> Result<(), JsValue> {
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
    pub fn observe_round_trip(&mut self, round_trip_ms: f64) -> Result<(), JsValue> {
        self.core
            .observe_round_trip(round_trip_ms)
            .map_err(control_error)
    }

    /// `{ deadTimeSamples, meanMs, stdMs }`, or undefined without a Smith predictor.
    #[wasm_bindgen(js_name = delayEstimate)]
    pub fn delay_estimate(&self) -> Result<JsValue, JsValue> {
        #[derive(Serialize)]
        #[serde(rename_all = "camelCase")]
        struct Estimate {
            dead_time_samples: usize,
            mean_ms: Option<f64>,
            std_ms: Option<f64>,
        }
        let Some(smith) = self.core.smith() else {
            return Ok(JsValue::UNDEFINED);
        };
        let estimator = smith.estimator();
        to_js(&Estimate {
            dead_time_samples: smith.dead_time_samples(),
            mean_ms: estimator.and_then(|e| e.mean_ms()),
            std_ms: estimator.and_then(|e| e.std_ms()),
        })
    }

    /// The configuration in force (tunings and limits as last set).
    pub fn config(&self) -> Result<JsValue, JsValue> {
        to_js(self.core.pid().config())
    }
}

/// One controller of an RCC group: `new Rcc({ id, thresholdsMs, tsMs, smoothHandover })`.
#[wasm_bindgen]
pub struct Rcc {
    core: RccController,
}

#[wasm_bindgen]
impl Rcc {
    #[wasm_bindgen(constructor)]
    pub fn new(config: JsValue) -> Result<Rcc, JsValue> {
        let config: RccConfig = from_js_bounded(
            config,
            "INVALID_CONFIG",
            "RCC configuration",
            Bound::Control,
        )?;
        RccController::new(config)
            .map(|core| Rcc { core })
            .map_err(control_error)
    }

    /// The Computing step for a polled state `{ lastAction, agesMs }`: `{ engaged, firstCycle, track }`.
    pub fn decide(&mut self, state: JsValue) -> Result<JsValue, JsValue> {
        let state: IoState = from_js_bounded(state, "INVALID_INPUT", "I/O state", Bound::Control)?;
        let decision = self.core.decide(&state).map_err(control_error)?;
        to_js(&decision)
    }

    /// Decide and step `pid` in one call: `{ engaged, firstCycle, write, step }`.
    pub fn scan(
        &mut self,
        pid: &mut PidLoop,
        state: JsValue,
        setpoint: f64,
        measurement: Option<f64>,
        dt_s: f64,
    ) -> Result<JsValue, JsValue> {
        let state: IoState = from_js_bounded(state, "INVALID_INPUT", "I/O state", Bound::Control)?;
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
    pub fn new(controllers: f64, initial_action: f64) -> Result<IoModule, JsValue> {
        let controllers = whole(controllers).ok_or_else(|| {
            js_error(
                "INVALID_CONFIG",
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
    pub fn write(&mut self, id: f64, action: f64, now_ms: f64) -> Result<(), JsValue> {
        let controllers = self.core.controllers();
        let id = whole(id).ok_or_else(|| {
            js_error("UNKNOWN_CONTROLLER", &format!("controller id {} is not one of the {controllers} configured (ids run from 1 to {controllers})", quote(id)))
        })?;
        self.core.write(id, action, now_ms).map_err(control_error)
    }

    /// `{ lastAction, agesMs }`; an age is null for a controller that never acted.
    pub fn state(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        to_js(&self.core.state(now_ms))
    }

    #[wasm_bindgen(getter, js_name = lastAction)]
    pub fn last_action(&self) -> f64 {
        self.core.last_action()
    }
}

/// Refuses engagement thresholds that break D_i > D_j >= Ts for i > j.
#[wasm_bindgen(js_name = validateThresholds)]
pub fn validate_thresholds(thresholds_ms: Vec<f64>, ts_ms: f64) -> Result<(), JsValue> {
    rcc::validate_thresholds(&thresholds_ms, ts_ms).map_err(control_error)
}
