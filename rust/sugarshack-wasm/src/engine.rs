use std::collections::BTreeMap;

use js_sys::{JsString, Reflect, JSON};
use sugarshack_core::code::Code;
use sugarshack_core::engine::wire::Wire;
use sugarshack_core::engine::{
    self as core, AlarmAction, Asks, CommandTarget, Configured, Fields, Input, MsgFields, MsgId,
    NodeId, NodeKind, NodeSpec, OperatorAction, Param, Raw, Resend, Saved, SealedDoc, SignedIn,
    StateDoc, Step, WhoFields,
};
use sugarshack_core::interlock::InterlockConfig;
use sugarshack_core::operation::RunSnapshot;
use sugarshack_core::procedure::{Command, State};
use sugarshack_core::routine::RoutineSnapshot;
use sugarshack_core::text::quote;
use sugarshack_core::time::Millis;
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

use crate::{from_js_bounded, js_error, time, to_js, Bound, Tracker};

/// The TypeScript shapes of what this module's calls return and take.
#[wasm_bindgen(typescript_custom_section)]
const TS_SHAPES: &str = r#"
/** `new Engine(config, options)`: how the outputs cross, and whether its lines are a plant's. */
export interface EngineOptions {
    plantBound?: boolean;
    /** Most msgs it keeps while it starts (Node-RED's nodeMessageBufferMaxLength; 0 or absent: no bound): one more is refused (QUEUE_FULL). */
    parkBound?: number;
    /** "typed" (words and a string table, the default) or "json" (one JSON text per batch). */
    wire?: "typed" | "json";
}

/** A node of an engine, as deployed. */
export type EngineNode =
    | { kind: "acquire"; timeoutMs: number; operation?: unknown; priority?: unknown; resources?: unknown }
    | { kind: "release"; operation?: unknown }
    | { kind: "cancel"; operation?: unknown }
    | { kind: "fault"; byResources: boolean; failMsg: boolean; operation?: unknown; resources?: unknown }
    | { kind: "clear"; allFaulted: boolean; refusalsWired: boolean; resources?: unknown };

/** What a msg carries that a fault or clear node reads (as read off the msg). */
export interface EngineFields {
    operation?: unknown;
    follow?: unknown;
    resources?: unknown;
    errorMessage?: unknown;
    payload?: unknown;
    /** msg._client.user as the msg carries it: its username, name, email or userId names who asks. */
    user?: unknown;
    by?: unknown;
    reason?: unknown;
    force?: boolean;
    /** The node's values as read for this msg (from context, env or JSONata), in place of its deployed ones. */
    configured?: { operation?: unknown; priority?: unknown; resources?: unknown };
}

/** A refusal as `readRequest` and `namesOf` answer it: its code, and its words (a catalog key with its values, or the core's own). */
export interface ReadRefusal {
    code: string;
    text: { kind: "catalog"; key: string; params: unknown[] } | { kind: "plain"; text: string };
}

/** `readRequest()`: what a msg asks for, read by the core's rules, or the refusal. */
export type RequestRead =
    | { ok: { operation?: string; priority?: number; resources?: string[]; who?: { by: string | null; reason: string | null; force: boolean } } }
    | { refused: ReadRefusal };

/** `nodeConfig()`: what a node's configuration means (its kind's values only), or the refusal. */
export type ConfigRead =
    | { ok: { id?: string; timeoutMs?: number; sensors?: string[] } }
    | { refused: ReadRefusal };

/** `namesOf()`: the names, trimmed, or the refusal. */
export type NamesRead = { ok: string[] } | { refused: ReadRefusal };

/** An operator's action: a clear, an emergency stop, an alarm action, or an ISA-88 command. */
export type OperatorRequest =
    | { kind: "clear"; lines?: unknown }
    | { kind: "eStop"; lines?: unknown }
    | { kind: "ack"; ids?: unknown }
    | { kind: "shelve"; id?: unknown; untilMs?: unknown; forMs?: unknown; oneShot?: boolean }
    | { kind: "unshelve"; id?: unknown }
    | { kind: "command"; command?: unknown; operation?: unknown; routine?: unknown };

/** A line's state, as the engine's view shows it. */
export type LineState =
    | { state: "free" }
    | { state: "held"; operation: string }
    | { state: "faulted"; cause: "operation" | "manual" | "interrupted" | "unknown"; operation?: string; note?: string; sinceMs: number };

/** A line in `Engine.view()`. */
export interface EngineLine {
    name: string;
    state: LineState;
    holder: { operation: string; priority: number; sinceMs: number; heldMs: number } | null;
    fault: { cause: string; operation: string | null; note: string | null; sinceMs: number } | null;
    waiting: string[];
    clearBlockers: WordedBlocker[];
}

/** Why a line in `Engine.view()` may not be cleared yet, with the core's words for it (`text`). */
export type WordedBlocker =
    | { kind: "lockoutPending"; actuator: string; sends: number; text: string }
    | { kind: "offLockout"; actuator: string; position: number; lockout: number; text: string }
    | { kind: "noFeedback"; actuator: string; text: string }
    | { kind: "stale"; actuator: string; text: string }
    | { kind: "deviceOffline"; device: string; text: string };

/** A waiting request in `Engine.view()`. */
export interface EngineWaiting {
    operation: string;
    priority: number;
    resources: string[];
    sinceMs: number;
    waitedMs: number;
}

/** `Engine.view()`: the interlock as a person reads it. */
export interface EngineView {
    atMs: number;
    stage: string;
    lines: EngineLine[];
    holds: RequestSnapshot[];
    queue: EngineWaiting[];
    lostState: string | null;
    alarms: Alarm[];
    alarmChanges: AlarmChange[];
    recentEvents: EventRecord[];
    /** The operations aborted and not reset: each refuses a start until a person resets it. */
    aborted: { operation: string; sinceMs: number; by: string; reason: string | null; commands: ["reset"] }[];
}
"#;

/// Header slots: where the last batch is, and when the engine is next due.
const WORDS_PTR: usize = 0;
const WORDS_LEN: usize = 1;
const TEXT_PTR: usize = 2;
const TEXT_LEN: usize = 3;
const NEXT_DEADLINE: usize = 4;
const JSON_BATCH: usize = 5;

/// One interlock's engine, as JS sees it: one call per input; the call's
/// outputs are left in wasm memory where `headerPtr()` says (six numbers:
/// the words' address and count, the text's address and byte length, the
/// next deadline or -1, and 1 when the batch is one JSON text), so nothing
/// is asked after an input.
#[wasm_bindgen]
pub struct Engine {
    core: core::Engine,
    wire: Wire,
    json: Option<String>,
    header: Box<[f64; 6]>,
}

#[wasm_bindgen]
extern "C" {
    /// `Array.isArray`, which throws on a revoked proxy: caught, so no JS
    /// exception unwinds through an engine call (it would leave it borrowed).
    #[wasm_bindgen(catch, js_namespace = Array, js_name = isArray)]
    fn is_array(value: &JsValue) -> Result<bool, JsValue>;
}

/// The strings of an array of at most `max` of them, read without a getter or proxy trap escaping.
fn names_of(array: &JsValue, max: usize) -> Option<Vec<String>> {
    let length = Reflect::get(array, &"length".into()).ok()?.as_f64()?;
    if !(0.0..=max as f64).contains(&length) {
        return None;
    }
    (0..length as u32)
        .map(|i| Reflect::get_u32(array, i).ok()?.as_string())
        .collect()
}

/// A value read from JS: its shape, as the core's request rules read it.
pub(crate) fn raw(value: &JsValue) -> Raw {
    if value.is_undefined() || value.is_null() {
        return Raw::Absent;
    }
    if let Some(text) = value.dyn_ref::<JsString>() {
        // Text past what any rule reads crosses as its head and its length.
        let length = text.length() as usize;
        if length > core::MAX_TEXT {
            let head = text
                .slice(0, core::HEAD as u32)
                .as_string()
                .unwrap_or_default();
            return Raw::Long { head, length };
        }
        return Raw::Text(value.as_string().unwrap_or_default());
    }
    if let Some(n) = value.as_f64() {
        // A number that is not finite is no value a rule reads (quoted as JSON writes it).
        return if n.is_finite() {
            Raw::Number(n)
        } else {
            Raw::Other("null".to_owned())
        };
    }
    if let Some(b) = value.as_bool() {
        return Raw::Bool(b);
    }
    match is_array(value) {
        Ok(true) => {
            if let Some(names) = names_of(value, core::MAX_NAMES + 1) {
                return Raw::Names(names);
            }
        }
        Ok(false) => {}
        Err(_) => return Raw::Other("(unreadable)".to_owned()),
    }
    Raw::Other(quoted(value))
}

/// A short quote of any value: JSON where it can be written, `10n` for a BigInt.
pub(crate) fn quoted(value: &JsValue) -> String {
    if value.is_bigint() {
        let text = js_sys::BigInt::from(value.clone())
            .to_string(10)
            .ok()
            .and_then(|t| t.as_string())
            .unwrap_or_default();
        return quote(format!("{text}n"));
    }
    // Only what a quote shows crosses: a 1 MB object's JSON stays in JS.
    let json = JSON::stringify(value)
        .ok()
        .filter(|t| !t.is_undefined())
        .map(|t| t.slice(0, core::HEAD as u32));
    match json.and_then(|t| t.as_string()) {
        Some(text) => quote(text),
        None if is_array(value) == Ok(true) => "an array".to_owned(),
        None => value.js_typeof().as_string().unwrap_or_default(),
    }
}

thread_local! {
    /// Property names as JS strings, each made once: a fault or clear msg reads ten of them.
    static KEYS: std::cell::RefCell<Vec<(&'static str, JsValue)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The park bound of an engine's options: absent or a whole number of msgs
/// (0: none); more than a u32 is no bound memory could reach, kept as the most.
fn park_bound(value: &JsValue) -> Result<usize, JsValue> {
    if value.is_undefined() || value.is_null() {
        return Ok(0);
    }
    match value.as_f64() {
        Some(max) if max.is_finite() && max >= 0.0 && max.fract() == 0.0 => {
            Ok(max.min(f64::from(u32::MAX)) as usize)
        }
        _ => Err(js_error(
            Code::InvalidConfig,
            &format!(
                "parkBound must be a whole number of msgs, 0 or more, got {}",
                value
                    .as_f64()
                    .map_or_else(|| value.js_typeof().as_string().unwrap_or_default(), quote)
            ),
        )),
    }
}

/// A property of a plain object handed in by the host (read safely).
fn field(object: &JsValue, key: &'static str) -> JsValue {
    if !object.is_object() {
        return JsValue::UNDEFINED;
    }
    // Not borrowed while a getter runs: it may call into wasm again.
    let key = KEYS.with(|keys| {
        let mut keys = keys.borrow_mut();
        match keys.iter().find(|(name, _)| *name == key) {
            Some((_, js)) => js.clone(),
            None => {
                let js = JsValue::from_str(key);
                keys.push((key, js.clone()));
                js
            }
        }
    });
    Reflect::get(object, &key).unwrap_or(JsValue::UNDEFINED)
}

fn who_fields(object: &JsValue) -> WhoFields {
    let user = field(object, "user");
    WhoFields {
        user: SignedIn {
            username: raw(&field(&user, "username")),
            name: raw(&field(&user, "name")),
            email: raw(&field(&user, "email")),
            user_id: raw(&field(&user, "userId")),
        },
        by: raw(&field(object, "by")),
        reason: raw(&field(object, "reason")),
        force: field(object, "force").as_bool() == Some(true),
    }
}

fn msg_fields(object: &JsValue) -> MsgFields {
    fields_of(object).into()
}

/// A msg that names only its operation, as text.
fn operation_only(operation: String) -> MsgFields {
    Fields {
        operation: Raw::Text(operation),
        ..Fields::default()
    }
    .into()
}

fn fields_of(object: &JsValue) -> Fields {
    Fields {
        operation: raw(&field(object, "operation")),
        priority: raw(&field(object, "priority")),
        resources: raw(&field(object, "resources")),
        follow: raw(&field(object, "follow")),
        error_message: raw(&field(object, "errorMessage")),
        payload: raw(&field(object, "payload")),
        who: who_fields(object),
        configured: Some(field(object, "configured"))
            .filter(JsValue::is_object)
            .map(|c| configured_of(&c)),
    }
}

/// A node's operation, priority and resources, as JS read them.
fn configured_of(object: &JsValue) -> Configured {
    Configured {
        operation: raw(&field(object, "operation")),
        priority: raw(&field(object, "priority")),
        resources: raw(&field(object, "resources")),
    }
}

/// What a msg asks of a node run by no engine (an interlock bound to a
/// plant, an operation or routine node): `asks` says what the node reads
/// (`{ kind: "acquire" | "named" | "stop" | "who" }`, or `{ kind: "clear",
/// allFaulted, namesGiven }`), `fields` the msg's values, `configured` the
/// node's. Returns `{ ok: { operation?, priority?, resources?, who? } }` or
/// `{ refused: { code, text } }` (text as the engine's outputs carry it).
#[wasm_bindgen(js_name = readRequest, unchecked_return_type = "RequestRead")]
pub fn read_request(
    #[wasm_bindgen(
        unchecked_param_type = "{ kind: string; allFaulted?: boolean; namesGiven?: boolean }"
    )]
    asks: JsValue,
    #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
    #[wasm_bindgen(
        unchecked_param_type = "{ operation?: unknown; priority?: unknown; resources?: unknown }"
    )]
    configured: JsValue,
) -> Result<JsValue, JsValue> {
    let flag = |key| field(&asks, key).as_bool() == Some(true);
    let asks = match field(&asks, "kind").as_string().as_deref() {
        Some("acquire") => Asks::Acquire,
        Some("named") => Asks::Named,
        Some("stop") => Asks::Stop,
        Some("clear") => Asks::Clear {
            all_faulted: flag("allFaulted"),
            names_given: flag("namesGiven"),
        },
        Some("who") => Asks::Who,
        other => return Err(invalid(&format!("unknown request {other:?}"))),
    };
    answer(core::read_request(
        asks,
        &fields_of(&fields),
        &configured_of(&configured),
    ))
}

/// Names from a list or comma-separated text, trimmed; `from` says where
/// they came from when they are not names. `{ ok: string[] }` or `{ refused }`.
#[wasm_bindgen(js_name = namesOf, unchecked_return_type = "NamesRead")]
pub fn split_names(
    #[wasm_bindgen(unchecked_param_type = "unknown")] value: JsValue,
    from: &str,
) -> Result<JsValue, JsValue> {
    answer(core::names_of(&raw(&value), Param::Text(quote(from))))
}

/// Who an operator's action is attributed to (`by` as the action carried it),
/// as its event and journal line name them: "unknown" when nobody said.
#[wasm_bindgen(js_name = attributedBy)]
pub fn attributed_by(#[wasm_bindgen(unchecked_param_type = "unknown")] by: JsValue) -> String {
    let by = match raw(&by) {
        Raw::Text(text) | Raw::Long { head: text, .. } => Some(text),
        _ => None,
    };
    sugarshack_core::clearance::attributed_by(by.as_deref())
}

/// What the configuration of a node of `kind` ("operation", "routine",
/// "wait", "acquire", "groupCommand") means, read off its properties
/// (`operation`, `routine`, `timeout` in seconds, `sensors`) by the core:
/// `{ ok: { id?, timeoutMs?, sensors? } }` or `{ refused }`.
#[wasm_bindgen(js_name = nodeConfig, unchecked_return_type = "ConfigRead")]
pub fn node_config(
    kind: &str,
    #[wasm_bindgen(unchecked_param_type = "Record<string, unknown>")] props: JsValue,
) -> Result<JsValue, JsValue> {
    let of = core::ConfigOf::from_name(kind)
        .ok_or_else(|| invalid(&format!("unknown node kind '{}'", quote(kind))))?;
    let id = match of {
        core::ConfigOf::Routine => "routine",
        _ => "operation",
    };
    let fields = core::ConfigFields {
        id: config_raw(&field(&props, id)),
        timeout: config_raw(&field(&props, "timeout")),
        sensors: config_raw(&field(&props, "sensors")),
    };
    answer(core::node_config(of, &fields))
}

/// [`raw`], a number that is not finite quoted as JS writes it (a refusal names what was typed).
fn config_raw(value: &JsValue) -> Raw {
    match value.as_f64() {
        Some(n) if n.is_nan() => Raw::Other("NaN".to_owned()),
        Some(n) if n.is_infinite() => {
            Raw::Other(if n > 0.0 { "Infinity" } else { "-Infinity" }.to_owned())
        }
        _ => raw(value),
    }
}

/// A read's answer, as `readRequest` and `namesOf` return it: `{ ok }` or `{ refused }`.
fn answer<T: serde::Serialize>(read: Result<T, core::Refusal>) -> Result<JsValue, JsValue> {
    #[derive(serde::Serialize)]
    #[serde(rename_all = "camelCase")]
    enum Answer<T> {
        Ok(T),
        Refused(core::Refusal),
    }
    match read {
        Ok(value) => to_js(&Answer::Ok(value)),
        Err(refusal) => to_js(&Answer::<T>::Refused(refusal)),
    }
}

fn invalid(message: &str) -> JsValue {
    js_error(Code::InvalidInput, message)
}

fn node_spec(spec: &JsValue) -> Result<NodeSpec, JsValue> {
    let flag = |key| field(spec, key).as_bool() == Some(true);
    let kind = match field(spec, "kind").as_string().as_deref() {
        Some("acquire") => NodeKind::Acquire {
            timeout_ms: Millis::new(field(spec, "timeoutMs").as_f64().unwrap_or(0.0))
                .unwrap_or(Millis::ZERO),
        },
        Some("release") => NodeKind::Release,
        Some("cancel") => NodeKind::Cancel,
        Some("fault") => NodeKind::Fault {
            by_resources: flag("byResources"),
            fail_msg: flag("failMsg"),
        },
        Some("clear") => NodeKind::Clear {
            all_faulted: flag("allFaulted"),
            refusals_wired: flag("refusalsWired"),
        },
        other => return Err(invalid(&format!("unknown node kind {other:?}"))),
    };
    Ok(NodeSpec {
        kind,
        operation: raw(&field(spec, "operation")),
        priority: raw(&field(spec, "priority")),
        resources: raw(&field(spec, "resources")),
    })
}

/// Lines named by an operator: a list of names, or none (every faulted line).
fn lines(value: &JsValue) -> Option<Vec<String>> {
    match raw(value) {
        Raw::Names(names)
            if names.len() <= core::MAX_NAMES
                && names.iter().all(|n| n.chars().count() <= core::MAX_NAME) =>
        {
            Some(names)
        }
        _ => None,
    }
}

fn operator_action(request: &JsValue, now: Millis) -> Result<OperatorAction, core::Refusal> {
    let kind = field(request, "kind").as_string().unwrap_or_default();
    Ok(match kind.as_str() {
        "clear" => OperatorAction::Clear {
            lines: lines(&field(request, "lines")),
        },
        "eStop" => OperatorAction::EStop {
            lines: lines(&field(request, "lines")).unwrap_or_default(),
        },
        "ack" => OperatorAction::Alarm(AlarmAction::Ack {
            ids: core::alarm_ids_of(&raw(&field(request, "ids")))?,
        }),
        "shelve" => OperatorAction::Alarm(AlarmAction::Shelve {
            id: core::alarm_id_of(&raw(&field(request, "id")))?,
            until_ms: core::shelf_end_of(
                &raw(&field(request, "untilMs")),
                &raw(&field(request, "forMs")),
                now,
            )?,
            one_shot: field(request, "oneShot").as_bool() == Some(true),
        }),
        "unshelve" => OperatorAction::Alarm(AlarmAction::Unshelve {
            id: core::alarm_id_of(&raw(&field(request, "id")))?,
        }),
        "command" => command_action(request)?,
        other => {
            return Err(core::Refusal::plain(
                Code::InvalidInput,
                format!("unknown operator action '{}'", quote(other)),
            ))
        }
    })
}

/// An ISA-88 command as main's interlock runtime reads it: an operator's
/// command, to a routine (`routine`) or else an operation (`operation`).
fn command_action(request: &JsValue) -> Result<OperatorAction, core::Refusal> {
    let name = field(request, "command").as_string().unwrap_or_default();
    let Some(command) = Command::from_name(&name).filter(|c| Command::OPERATOR.contains(c)) else {
        let commands: Vec<&str> = Command::OPERATOR.iter().map(|c| c.name()).collect();
        return Err(core::Refusal::catalog(
            Code::InvalidInput,
            "errors.notACommand",
            vec![
                ("command", Param::Text(quote(&name))),
                ("commands", Param::Text(commands.join(", "))),
            ],
        ));
    };
    let id = |key| {
        field(request, key)
            .as_string()
            .filter(|id| id.chars().count() <= core::MAX_NAME)
    };
    let target = match (id("routine"), id("operation")) {
        (Some(routine), _) => CommandTarget::Routine(routine),
        (None, Some(operation)) => CommandTarget::Operation(operation),
        (None, None) => {
            return Err(core::Refusal::catalog(
                Code::InvalidInput,
                "errors.commandTarget",
                Vec::new(),
            ))
        }
    };
    Ok(OperatorAction::Command { target, command })
}

fn no_blockers(_: &str) -> Vec<sugarshack_core::clearance::ClearBlocker> {
    Vec::new()
}

impl Engine {
    /// One input; its outputs are left where the header says.
    fn input(&mut self, input: Input, now: Millis, plant: Option<&Tracker>) {
        match plant {
            Some(tracker) => {
                let blockers = |line: &str| tracker.core.clear_blockers(line);
                self.core
                    .handle_bound(input, now, &blockers, Some(tracker.core.plant()));
            }
            None => self.core.handle_checked(input, now, &no_blockers),
        }
        self.flush();
    }

    /// Encodes the outputs so far and points the header at them.
    fn flush(&mut self) {
        let outputs = self.core.outputs();
        let header = &mut self.header;
        match &mut self.json {
            Some(json) => {
                *json = Wire::json(outputs);
                header[WORDS_PTR] = 0.0;
                header[WORDS_LEN] = 0.0;
                header[TEXT_PTR] = json.as_ptr() as usize as f64;
                header[TEXT_LEN] = json.len() as f64;
                header[JSON_BATCH] = 1.0;
            }
            None => {
                self.wire.encode(outputs);
                header[WORDS_PTR] = self.wire.words().as_ptr() as usize as f64;
                header[WORDS_LEN] = self.wire.words().len() as f64;
                header[TEXT_PTR] = self.wire.text().as_ptr() as usize as f64;
                header[TEXT_LEN] = self.wire.text().len() as f64;
                header[JSON_BATCH] = 0.0;
            }
        }
        self.core.clear_outputs();
        header[NEXT_DEADLINE] = self.core.next_deadline().map_or(-1.0, Millis::as_f64);
    }

    /// A msg into acquire node `node`, with what it carries.
    fn acquire_msg(&mut self, node: u32, msg: u32, fields: MsgFields, now_ms: f64) {
        let input = Input::Acquire {
            node: NodeId(node),
            msg: MsgId(msg),
            fields,
        };
        self.msg_input(msg, input, now_ms);
    }

    /// A msg into release node `node`: its own operation when it names one, else the acquire it follows (the core reads which).
    fn release_msg(&mut self, node: u32, msg: u32, operation: Raw, follow: Raw, now_ms: f64) {
        let fields = if operation.present() {
            Fields {
                operation,
                follow,
                ..Fields::default()
            }
            .into()
        } else {
            MsgFields::following(follow)
        };
        self.release_fields_msg(node, msg, fields, now_ms);
    }

    fn release_fields_msg(&mut self, node: u32, msg: u32, fields: MsgFields, now_ms: f64) {
        let input = Input::Release {
            node: NodeId(node),
            msg: MsgId(msg),
            fields,
        };
        self.msg_input(msg, input, now_ms);
    }

    /// A msg's input at a time from JS; a bad time refuses the msg (the hot calls never throw).
    fn msg_input(&mut self, msg: u32, input: Input, now_ms: f64) {
        match Millis::whole(now_ms) {
            Some(now) => self.input(input, now, None),
            None => {
                let refusal = core::Refusal::plain(
                    Code::InvalidTime,
                    format!(
                        "time must be a non-negative number of milliseconds, got {}",
                        quote(now_ms)
                    ),
                );
                self.core.refuse_msg(MsgId(msg), refusal);
                self.flush();
            }
        }
    }

    fn refused(&mut self, msg: u32, refusal: core::Refusal) {
        // An operator's request refused before it reached the engine: answered as the engine answers.
        self.core.refuse_reply(MsgId(msg), refusal);
        self.flush();
    }
}

#[wasm_bindgen]
impl Engine {
    /// `config`: the interlock's configuration; `options`: `{ plantBound, wire }`.
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "InterlockConfig")] config: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EngineOptions")] options: JsValue,
    ) -> Result<Engine, JsValue> {
        let config: InterlockConfig = from_js_bounded(
            config,
            Code::InvalidConfig,
            "invalid interlock configuration",
            Bound::InterlockConfig,
        )?;
        let plant_bound = field(&options, "plantBound").as_bool() == Some(true);
        let json = field(&options, "wire").as_string().as_deref() == Some("json");
        let park_bound = park_bound(&field(&options, "parkBound"))?;
        let mut core = core::Engine::new(config, plant_bound)
            .map_err(|err| js_error(err.code(), &err.to_string()))?;
        core.set_park_bound(park_bound);
        Ok(Engine {
            core,
            wire: Wire::new(),
            json: json.then(String::new),
            header: Box::new([0.0, 0.0, 0.0, 0.0, -1.0, 0.0]),
        })
    }

    /// Where the header of each call's outputs is, in wasm memory (fixed for the engine's life).
    #[wasm_bindgen(js_name = headerPtr)]
    pub fn header_ptr(&self) -> u32 {
        self.header.as_ptr() as usize as u32
    }

    /// The saved state was read: `doc` the state document (null: none, never ran here),
    /// `lost` why it is lost (it ran here before).
    pub fn start(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "unknown")] doc: JsValue,
        lost: Option<String>,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.start_with(doc, lost, now_ms, None)
    }

    /// `start` for an interlock bound to `plant` (a clear waiting for the start is checked against it).
    #[wasm_bindgen(js_name = startAgainst)]
    pub fn start_against(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "unknown")] doc: JsValue,
        lost: Option<String>,
        now_ms: f64,
        plant: &Tracker,
    ) -> Result<(), JsValue> {
        self.start_with(doc, lost, now_ms, Some(plant))
    }

    /// The saved state was read: `text` its sealed document from `source`,
    /// opened as the interlock `owner` bound to `plant` by the one restart
    /// rule (a line added since starts free; another interlock's, a damaged
    /// or an unknown version's document starts every line faulted).
    #[wasm_bindgen(js_name = startSealed)]
    pub fn start_sealed(
        &mut self,
        owner: String,
        plant: Option<String>,
        source: String,
        text: String,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.start_sealed_with(owner, plant, source, text, now_ms, None)
    }

    /// `startSealed` for an interlock bound to the plant `tracker` (a clear waiting for the start is checked against it).
    #[wasm_bindgen(js_name = startSealedAgainst)]
    pub fn start_sealed_against(
        &mut self,
        owner: String,
        plant: Option<String>,
        source: String,
        text: String,
        now_ms: f64,
        tracker: &Tracker,
    ) -> Result<(), JsValue> {
        self.start_sealed_with(owner, plant, source, text, now_ms, Some(tracker))
    }
}

impl Engine {
    fn start_sealed_with(
        &mut self,
        owner: String,
        plant: Option<String>,
        source: String,
        text: String,
        now_ms: f64,
        tracker: Option<&Tracker>,
    ) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        if text.len() > Bound::InterlockSnapshot.max_bytes() {
            return Err(js_error(
                Code::InputTooLarge,
                &format!("{source}: {} bytes, more than a state can be", text.len()),
            ));
        }
        let doc = SealedDoc {
            text,
            source,
            owner,
            plant,
        };
        self.input(Input::Start(Saved::Sealed(Box::new(doc))), now, tracker);
        Ok(())
    }

    fn start_with(
        &mut self,
        doc: JsValue,
        lost: Option<String>,
        now_ms: f64,
        plant: Option<&Tracker>,
    ) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        let saved = match lost {
            Some(why) => Saved::Lost(why),
            None if doc.is_null() || doc.is_undefined() => Saved::First,
            None => match from_js_bounded::<StateDoc>(
                doc,
                Code::InvalidSnapshot,
                "cannot restore interlock state",
                Bound::InterlockSnapshot,
            ) {
                Ok(doc) => Saved::Doc(Box::new(doc)),
                Err(err) => Saved::Lost(
                    Reflect::get(&err, &"message".into())
                        .ok()
                        .and_then(|m| m.as_string())
                        .unwrap_or_default(),
                ),
            },
        };
        self.input(Input::Start(saved), now, plant);
        Ok(())
    }

    fn clear_with(
        &mut self,
        (node, msg): (u32, u32),
        fields: JsValue,
        names_given: bool,
        now_ms: f64,
        plant: Option<&Tracker>,
    ) -> Result<(), JsValue> {
        let input = Input::Clear {
            node: NodeId(node),
            msg: MsgId(msg),
            fields: msg_fields(&fields),
            names_given,
        };
        self.input(input, time(now_ms)?, plant);
        Ok(())
    }

    fn operator_with(
        &mut self,
        msg: u32,
        (action, who): (JsValue, JsValue),
        now_ms: f64,
        plant: Option<&Tracker>,
    ) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        match operator_action(&action, now) {
            Ok(action) => {
                let input = Input::Operator {
                    msg: MsgId(msg),
                    action,
                    who: who_fields(&who),
                };
                self.input(input, now, plant);
            }
            Err(refusal) => self.refused(msg, refusal),
        }
        Ok(())
    }

    fn view_with(&self, now_ms: f64, plant: Option<&Tracker>) -> Result<JsValue, JsValue> {
        let now = time(now_ms)?;
        match plant {
            Some(tracker) => {
                let blockers = |line: &str| tracker.core.clear_blockers(line);
                to_js(&self.core.view(now, &blockers))
            }
            None => to_js(&self.core.view(now, &no_blockers)),
        }
    }
}

#[wasm_bindgen]
impl Engine {
    /// A step of its life: "deploy-begin", "deploy-end", "drain-begin", "drain-end", "shutdown", "retire".
    pub fn life(&mut self, step: &str, now_ms: f64) -> Result<(), JsValue> {
        let step = match step {
            "deploy-begin" => Step::DeployBegin,
            "deploy-end" => Step::DeployEnd,
            "drain-begin" => Step::DrainBegin,
            "drain-end" => Step::DrainEnd,
            "shutdown" => Step::Shutdown,
            "retire" => Step::Retire,
            other => return Err(invalid(&format!("unknown step '{}'", quote(other)))),
        };
        self.input(Input::Life(step), time(now_ms)?, None);
        Ok(())
    }

    /// Takes over the state of another engine (its `stateText`): holds,
    /// waiting msgs and their timeouts go on, under this engine's settings.
    #[wasm_bindgen(js_name = handOver)]
    pub fn hand_over(&mut self, doc: &str, now_ms: f64) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        let doc: StateDoc = from_js_bounded(
            JsValue::from_str(doc),
            Code::InvalidSnapshot,
            "cannot take the interlock state over",
            Bound::InterlockSnapshot,
        )?;
        self.core
            .hand_over(&doc, now)
            .map_err(|err| js_error(err.code(), &err.to_string()))?;
        self.flush();
        Ok(())
    }

    /// A node of a deploy (`node`: the host's handle for it).
    #[wasm_bindgen(js_name = addNode)]
    pub fn add_node(
        &mut self,
        node: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineNode")] spec: JsValue,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        let spec = node_spec(&spec)?;
        self.input(
            Input::AddNode {
                node: NodeId(node),
                spec,
            },
            time(now_ms)?,
            None,
        );
        Ok(())
    }

    /// A node closes: removed from the flows, or restarted by a deploy.
    #[wasm_bindgen(js_name = closeNode)]
    pub fn close_node(&mut self, node: u32, removed: bool, now_ms: f64) -> Result<(), JsValue> {
        self.input(
            Input::CloseNode {
                node: NodeId(node),
                removed,
            },
            time(now_ms)?,
            None,
        );
        Ok(())
    }

    /// A msg into an acquire node that names nothing itself (the node's
    /// configuration applies). Never throws: a bad time refuses the msg.
    pub fn acquire(&mut self, node: u32, msg: u32, now_ms: f64) {
        self.acquire_msg(node, msg, MsgFields::default(), now_ms);
    }

    /// A msg into an acquire node, with what it names (msg.operation, msg.priority, msg.resources).
    #[wasm_bindgen(js_name = acquireNamed)]
    pub fn acquire_named(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "unknown")] operation: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] priority: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] resources: JsValue,
        now_ms: f64,
    ) {
        let fields = Fields {
            operation: raw(&operation),
            priority: raw(&priority),
            resources: raw(&resources),
            ..Fields::default()
        }
        .into();
        self.acquire_msg(node, msg, fields, now_ms);
    }

    /// A msg into an acquire node whose values are read per msg (from
    /// context, env or JSONata): `fields.configured` holds them.
    #[wasm_bindgen(js_name = acquireFields)]
    pub fn acquire_fields(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        now_ms: f64,
    ) {
        self.acquire_msg(node, msg, msg_fields(&fields), now_ms);
    }

    /// `acquireNamed` for a msg that names only its operation, as text: one string crosses, nothing else.
    #[wasm_bindgen(js_name = acquireOperation)]
    pub fn acquire_operation(&mut self, node: u32, msg: u32, operation: String, now_ms: f64) {
        let fields = operation_only(operation);
        self.acquire_msg(node, msg, fields, now_ms);
    }

    /// `release` for a msg whose operation and followed operation are each text
    /// or absent: they cross as strings, and nothing is asked of JS.
    #[wasm_bindgen(js_name = releaseTexts)]
    pub fn release_texts(
        &mut self,
        node: u32,
        msg: u32,
        operation: Option<String>,
        follow: Option<String>,
        now_ms: f64,
    ) {
        let text = |t: Option<String>| t.map_or(Raw::Absent, Raw::Text);
        self.release_msg(node, msg, text(operation), text(follow), now_ms);
    }

    /// A msg into a release node: msg.operation, and msg.interlock.operation (the acquire it follows).
    pub fn release(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "unknown")] operation: JsValue,
        #[wasm_bindgen(unchecked_param_type = "unknown")] follow: JsValue,
        now_ms: f64,
    ) {
        self.release_msg(node, msg, raw(&operation), raw(&follow), now_ms);
    }

    /// A msg into a release node whose operation is read per msg (from
    /// context, env or JSONata): `fields` holds msg.operation, follow and `configured`.
    #[wasm_bindgen(js_name = releaseFields)]
    pub fn release_fields(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        now_ms: f64,
    ) {
        self.release_fields_msg(node, msg, msg_fields(&fields), now_ms);
    }

    /// A msg into a cancel node (`fields`: operation, follow, and who asks).
    pub fn cancel(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.input(
            Input::Cancel {
                node: NodeId(node),
                msg: MsgId(msg),
                fields: msg_fields(&fields),
            },
            time(now_ms)?,
            None,
        );
        Ok(())
    }

    /// A msg into a fault node.
    pub fn fault(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.input(
            Input::Fault {
                node: NodeId(node),
                msg: MsgId(msg),
                fields: msg_fields(&fields),
            },
            time(now_ms)?,
            None,
        );
        Ok(())
    }

    /// A msg into a clear node; `namesGiven`: msg.resources is set.
    pub fn clear(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        names_given: bool,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.clear_with((node, msg), fields, names_given, now_ms, None)
    }

    /// `clear` for an interlock bound to `plant`: refused (CLEAR_REFUSED) until
    /// the plant shows each line isolated, unless forced.
    #[wasm_bindgen(js_name = clearAgainst)]
    pub fn clear_against(
        &mut self,
        node: u32,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] fields: JsValue,
        names_given: bool,
        now_ms: f64,
        plant: &Tracker,
    ) -> Result<(), JsValue> {
        self.clear_with((node, msg), fields, names_given, now_ms, Some(plant))
    }

    /// A person's action from the editor or a dashboard; the answer goes to `msg`.
    pub fn operator(
        &mut self,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "OperatorRequest")] action: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] who: JsValue,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        self.operator_with(msg, (action, who), now_ms, None)
    }

    /// `operator` for an interlock bound to `plant` (a clear is checked against it).
    #[wasm_bindgen(js_name = operatorAgainst)]
    pub fn operator_against(
        &mut self,
        msg: u32,
        #[wasm_bindgen(unchecked_param_type = "OperatorRequest")] action: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EngineFields")] who: JsValue,
        now_ms: f64,
        plant: &Tracker,
    ) -> Result<(), JsValue> {
        self.operator_with(msg, (action, who), now_ms, Some(plant))
    }

    /// Faulted lines send their lockouts again: "atStart", "plantChanged" or "afterRebuild".
    #[wasm_bindgen(js_name = resendLockouts)]
    pub fn resend_lockouts(&mut self, why: &str, now_ms: f64) -> Result<(), JsValue> {
        let why = match why {
            "atStart" => Resend::AtStart,
            "plantChanged" => Resend::PlantChanged,
            "afterRebuild" => Resend::AfterRebuild,
            other => return Err(invalid(&format!("unknown reason '{}'", quote(other)))),
        };
        self.input(Input::ResendLockouts(why), time(now_ms)?, None);
        Ok(())
    }

    /// Whether events nodes or the journal listen to its events.
    pub fn listen(&mut self, on: bool, now_ms: f64) -> Result<(), JsValue> {
        self.input(Input::Listen(on), time(now_ms)?, None);
        Ok(())
    }

    /// Writing the state fails (`store`: where it writes), or works again (null).
    #[wasm_bindgen(js_name = storeFailing)]
    pub fn store_failing(&mut self, store: Option<String>, now_ms: f64) -> Result<(), JsValue> {
        self.input(Input::StoreFailing(store), time(now_ms)?, None);
        Ok(())
    }

    /// The plant's abnormal conditions (devices, buses) as they hold now.
    #[wasm_bindgen(js_name = plantConditions)]
    pub fn plant_conditions(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "AlarmConditionInput[]")] conditions: JsValue,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        let conditions = from_js_bounded(
            conditions,
            Code::InvalidInput,
            "invalid alarm conditions",
            Bound::Alarms,
        )?;
        self.input(Input::PlantConditions(conditions), time(now_ms)?, None);
        Ok(())
    }

    /// Frees it unstarted (its start failed, or it stood down): the handles
    /// of the msgs it kept for the start, taken out, for the host to complete.
    #[wasm_bindgen(js_name = takeParked)]
    pub fn take_parked(&mut self) -> Vec<u32> {
        self.core
            .take_parked()
            .iter()
            .filter_map(|(input, _)| input.msg())
            .map(|msg| msg.0)
            .collect()
    }

    /// Moves the msgs it kept for the start to `next` (made for new settings
    /// before this one started), each as of its arrival: parked there within
    /// its bound, or taken if it runs; `next`'s outputs are left in its header.
    #[wasm_bindgen(js_name = handParkedTo)]
    pub fn hand_parked_to(&mut self, next: &mut Engine, now_ms: f64) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        next.core.receive_parked(self.core.take_parked(), now);
        next.flush();
        Ok(())
    }

    /// The deadlines due at `now`.
    pub fn tick(&mut self, now_ms: f64) -> Result<(), JsValue> {
        self.input(Input::Tick, time(now_ms)?, None);
        Ok(())
    }

    /// The state file's text at `now`, with the routines' states (`routines`, by id).
    #[wasm_bindgen(js_name = stateText)]
    pub fn state_text(
        &self,
        now_ms: f64,
        #[wasm_bindgen(unchecked_param_type = "Record<string, unknown>")] routines: JsValue,
    ) -> Result<String, JsValue> {
        let mut doc = self.core.snapshot(time(now_ms)?);
        if routines.is_object() {
            let routines: serde_json::Map<String, serde_json::Value> = from_js_bounded(
                routines,
                Code::InvalidSnapshot,
                "invalid routine states",
                Bound::InterlockSnapshot,
            )?;
            doc.routines.extend(routines);
        }
        serde_json::to_string(&doc).map_err(|e| js_error(Code::Internal, &e.to_string()))
    }

    /// Its sealed state document at `nowMs`, with the running routines'
    /// states (`routines`, by id) over those read at start, its alarms and
    /// the `runs` held now (they come back held), as the interlock `owner`
    /// bound to `plant`.
    pub fn seal(
        &self,
        owner: &str,
        plant: Option<String>,
        #[wasm_bindgen(unchecked_param_type = "Record<string, RoutineSnapshot>")] routines: JsValue,
        now_ms: f64,
        #[wasm_bindgen(unchecked_param_type = "RunSnapshot[] | undefined")] runs: JsValue,
    ) -> Result<String, JsValue> {
        let now = time(now_ms)?;
        let routines: BTreeMap<String, RoutineSnapshot> = from_js_bounded(
            routines,
            Code::InvalidSnapshot,
            "invalid routine snapshots",
            Bound::InterlockSnapshot,
        )?;
        let runs: Vec<RunSnapshot> = if runs.is_undefined() || runs.is_null() {
            Vec::new()
        } else {
            from_js_bounded(
                runs,
                Code::InvalidSnapshot,
                "invalid held runs",
                Bound::InterlockSnapshot,
            )?
        };
        Ok(self.core.seal(owner, plant.as_deref(), routines, runs, now))
    }

    /// The runs that came back held at start (once), for their owners to supervise again.
    #[wasm_bindgen(js_name = takeRestoredRuns, unchecked_return_type = "RunSnapshot[]")]
    pub fn take_restored_runs(&mut self) -> Result<JsValue, JsValue> {
        to_js(&self.core.take_restored_runs())
    }

    /// Refused (OPERATION_ABORTED) while `operation` stands aborted and not reset.
    #[wasm_bindgen(js_name = abortedCheckStart)]
    pub fn aborted_check_start(&self, operation: &str) -> Result<(), JsValue> {
        self.core
            .aborted()
            .check_start(operation)
            .map_err(|err| js_error(err.code(), &err.to_string()))
    }

    /// Whether `operation` stands aborted: its run state ("aborted", or "idle").
    #[wasm_bindgen(js_name = abortedState, unchecked_return_type = "RunState")]
    pub fn aborted_state(&self, operation: &str) -> String {
        self.core.aborted().state(operation).name().into()
    }

    /// A run of `operation` ended aborted by `by` (saved with the state): it refuses starts until reset.
    #[wasm_bindgen(js_name = operationAborted)]
    pub fn operation_aborted(
        &mut self,
        operation: &str,
        by: Option<String>,
        reason: Option<String>,
        now_ms: f64,
    ) -> Result<(), JsValue> {
        let now = time(now_ms)?;
        let who = crate::operation::attribution(by, reason);
        self.core
            .aborted_mut()
            .ended(operation, State::Aborted, &who, now);
        Ok(())
    }

    /// A command to an operation saved aborted (a person's reset); the state it entered.
    #[wasm_bindgen(js_name = abortedCommand, unchecked_return_type = "RunState")]
    pub fn aborted_command(&mut self, operation: &str, command: &str) -> Result<String, JsValue> {
        let command = crate::operation::command_of(command)?;
        self.core
            .aborted_mut()
            .command(operation, command)
            .map(|state| state.name().into())
            .map_err(|err| js_error(err.code(), &err.to_string()))
    }

    /// A routine's reset resets the operations it dispatched that stand aborted; their ids.
    #[wasm_bindgen(js_name = abortedResetRoutine)]
    pub fn aborted_reset_routine(&mut self, routine: &crate::routine::Routine) -> Vec<String> {
        self.core
            .aborted_mut()
            .reset_routine(&routine.machine().operations())
    }

    /// The interlock as a person reads it.
    #[wasm_bindgen(unchecked_return_type = "EngineView")]
    pub fn view(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        self.view_with(now_ms, None)
    }

    /// `view` of an interlock bound to `plant`: why each faulted line may not be cleared yet.
    #[wasm_bindgen(js_name = viewAgainst, unchecked_return_type = "EngineView")]
    pub fn view_against(&self, now_ms: f64, plant: &Tracker) -> Result<JsValue, JsValue> {
        self.view_with(now_ms, Some(plant))
    }

    /// The routines' states as read at start, by id.
    #[wasm_bindgen(js_name = savedRoutines, unchecked_return_type = "Record<string, unknown>")]
    pub fn saved_routines(&self) -> Result<JsValue, JsValue> {
        to_js(self.core.saved_routines())
    }

    /// Where it is in its life.
    pub fn stage(&self) -> String {
        self.core.stage().name().to_owned()
    }

    /// Lines faulted, by name (for an operator's "clear all" and the lockouts sent again).
    #[wasm_bindgen(js_name = faultedResources)]
    pub fn faulted_resources(&self) -> Vec<String> {
        let faulted = self.core.interlock().faulted_resources();
        faulted
            .ids()
            .iter()
            .filter_map(|r| self.core.interlock().resource_name(*r))
            .map(str::to_owned)
            .collect()
    }

    /// `{ holding, queued, faulted }`.
    #[wasm_bindgen(unchecked_return_type = "InterlockCounts")]
    pub fn counts(&self) -> Result<JsValue, JsValue> {
        let c = self.core.interlock().counts();
        to_js(
            &serde_json::json!({ "holding": c.holding, "queued": c.queued, "faulted": c.faulted }),
        )
    }

    /// The interlock's snapshot (its part of the state file).
    #[wasm_bindgen(unchecked_return_type = "InterlockSnapshot")]
    pub fn snapshot(&self, now_ms: f64) -> Result<JsValue, JsValue> {
        to_js(&self.core.interlock().snapshot(time(now_ms)?))
    }

    /// Why the state was unknown at start, while lines faulted for it stay faulted.
    pub fn lost(&self) -> Option<String> {
        self.core.lost().map(str::to_owned)
    }

    /// Changes whenever the interlock forgot idle operation names (a flow naming a new operation per msg).
    #[wasm_bindgen(js_name = handleEpoch)]
    pub fn handle_epoch(&self) -> f64 {
        self.core.interlock().forgettings() as f64
    }

    /// The interlock's handle of an operation it knows (its slot in the low 32 bits).
    #[wasm_bindgen(js_name = findOperation)]
    pub fn find_operation(&self, name: &str) -> Result<f64, JsValue> {
        self.core
            .interlock()
            .find_operation(name)
            .map(|op| op.to_bits() as f64)
            .map_err(|err| js_error(err.code(), &err.to_string()))
    }

    /// The alarm ids listed now.
    #[wasm_bindgen(js_name = alarmIds)]
    pub fn alarm_ids(&self) -> Vec<String> {
        self.core.alarms().list().map(|a| a.id.clone()).collect()
    }
}
