//! Interlock benchmark, native side: the workloads of
//! `tests/bench/interlock-bench.js` (described there) run on the core
//! directly. Prints one JSON line per scale and event setting, which the JS
//! script merges into its table; `npm run bench` runs both.
//!
//! usage: cargo run --release -p sugarshack-core --example interlock_bench [-- PARAMS_JSON] [--no-events]
//!
//! PARAMS_JSON overrides the workload parameters, e.g. `{"large":{"samples":500}}`.

use std::collections::HashMap;
use std::hint::black_box;
use std::time::{Instant, SystemTime, UNIX_EPOCH};
use sugarshack_core::time::{ms, Millis};

use serde_json::{json, Value};
use sugarshack_core::interlock::{
    Acquisition, Grant, Interlock, InterlockConfig, OpId, ResourceSet,
};

const LINES: [&str; 5] = ["YEL", "GRN", "BLU", "PUR", "RED"];

/// Fig. 8: id, priority, lines.
const FIG8: [(u32, i32, &[&str]); 16] = [
    (10, 20, &["YEL"]),
    (11, 23, &["YEL"]),
    (12, 22, &["YEL"]),
    (20, 78, &["YEL"]),
    (15, 77, &["YEL"]),
    (18, 92, &["YEL", "RED"]),
    (19, 91, &["YEL"]),
    (21, 101, &["GRN"]),
    (23, 99, &["GRN", "RED"]),
    (24, 100, &["GRN", "RED"]),
    (33, 88, &["BLU", "RED"]),
    (41, 69, &["PUR", "RED"]),
    (42, 55, &["PUR", "RED"]),
    (48, 97, &["PUR", "RED"]),
    (49, 96, &["PUR", "RED"]),
    (51, 1, &["RED"]),
];

/// mulberry32, bit for bit the generator of the JS script.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        self.0 = self.0.wrapping_add(0x6d2b_79f5);
        let a = self.0;
        let mut t = (a ^ (a >> 15)).wrapping_mul(1 | a);
        t = t.wrapping_add((t ^ (t >> 7)).wrapping_mul(61 | t)) ^ t;
        t ^ (t >> 14)
    }

    /// Uniform in `[0, n)`.
    fn int(&mut self, n: usize) -> usize {
        ((self.next() as u64 * n as u64) >> 32) as usize
    }
}

const ACQ_GRANTED: u32 = 1 << 28;
const ACQ_QUEUED: u32 = 2 << 28;
const REL_GRANT: u32 = 3 << 28;
const REL_END: u32 = 4 << 28;

/// The order of grants, hashed as the JS script does, so the runs can be compared.
struct GrantLog {
    count: u64,
    hash: u32,
}

impl GrantLog {
    fn new() -> Self {
        GrantLog {
            count: 0,
            hash: 2_166_136_261,
        }
    }
    fn add(&mut self, v: u32) {
        self.count += 1;
        self.hash = (self.hash ^ v).wrapping_mul(16_777_619);
    }
    fn acquired(&mut self, op: usize, granted: bool) {
        self.add(if granted { ACQ_GRANTED } else { ACQ_QUEUED } | op as u32);
    }
    fn released(&mut self, op: usize, granted: impl IntoIterator<Item = usize>) {
        for g in granted {
            self.add(REL_GRANT | g as u32);
        }
        self.add(REL_END | op as u32);
    }
    fn json(&self) -> Value {
        json!({ "count": self.count, "hash": self.hash })
    }
}

fn summary(mut samples: Vec<f64>) -> Value {
    samples.sort_by(f64::total_cmp);
    let rank = |q: f64| samples[((q * samples.len() as f64).ceil() as usize).max(1) - 1];
    json!({ "median": rank(0.5), "p99": rank(0.99), "samples": samples.len() })
}

/// The bench plays the runtime: it reads the clock and hands the time in.
fn clock() -> Millis {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(Millis::ZERO, |d| ms(d.as_millis() as u64))
}

struct CaseParams {
    seed: u32,
    instances: usize,
    pair_batch: usize,
    warmup: usize,
    samples: usize,
}

struct LargeParams {
    seed: u32,
    resources: usize,
    waiting: usize,
    max_set: usize,
    pool: usize,
    priorities: usize,
    queue_bound: usize,
    warmup: usize,
    samples: usize,
}

fn param(v: &Value, scale: &str, key: &str, default: u64) -> u64 {
    v.get(scale)
        .and_then(|s| s.get(key))
        .and_then(Value::as_u64)
        .unwrap_or(default)
}

type FigOps = Vec<(OpId, i32, ResourceSet)>;

fn fig8_ops(lock: &mut Interlock) -> FigOps {
    FIG8.iter()
        .map(|(id, priority, lines)| {
            (
                lock.operation(&format!("op{id}")),
                *priority,
                lock.resource_set(lines).expect("Fig. 8 lines"),
            )
        })
        .collect()
}

fn case_config(events: bool) -> InterlockConfig {
    let mut config = InterlockConfig::with_resources(LINES);
    config.record_events = events;
    config
}

fn run_case(p: &CaseParams, events: bool) -> Value {
    let mut rng = Rng(p.seed);
    let mut log = GrantLog::new();

    let mut idle = Interlock::new(case_config(events)).expect("config");
    let idle_ops = fig8_ops(&mut idle);
    let mut pair = Vec::with_capacity(p.samples);
    let (mut refused, mut stray) = (0usize, 0usize);
    for s in 0..p.warmup + p.samples {
        let now = clock();
        let t0 = Instant::now();
        for k in 0..p.pair_batch {
            let (op, priority, set) = &idle_ops[k % 16];
            if idle.acquire(*op, *priority, set, now).expect("acquire") != Acquisition::Granted {
                refused += 1;
            }
            stray += black_box(idle.release(*op, now).expect("release")).len();
        }
        let elapsed = t0.elapsed();
        if s >= p.warmup {
            pair.push(elapsed.as_nanos() as f64 / p.pair_batch as f64);
        }
        idle.drain_events();
    }
    assert!(
        refused == 0 && stray == 0,
        "case pair: {refused} queued, {stray} stray grants on an idle interlock"
    );

    let n = p.instances;
    let mut locks = Vec::with_capacity(n);
    let mut ops = Vec::with_capacity(n);
    let mut holders: Vec<Vec<usize>> = Vec::with_capacity(n);
    let now = clock();
    for _ in 0..n {
        let mut lock = Interlock::new(case_config(events)).expect("config");
        let o = fig8_ops(&mut lock);
        let mut h = Vec::new();
        for (k, (op, priority, set)) in o.iter().enumerate() {
            let granted =
                lock.acquire(*op, *priority, set, now).expect("acquire") == Acquisition::Granted;
            log.acquired(k, granted);
            if granted {
                h.push(k);
            }
        }
        locks.push(lock);
        ops.push(o);
        holders.push(h);
    }
    let mut release = Vec::with_capacity(p.samples);
    let mut victim_index = vec![0usize; n];
    let mut victim = vec![0usize; n];
    let mut results: Vec<Vec<Grant>> = (0..n).map(|_| Vec::new()).collect();
    for s in 0..p.warmup + p.samples {
        for i in 0..n {
            victim_index[i] = rng.int(holders[i].len());
            victim[i] = holders[i][victim_index[i]];
        }
        let now = clock();
        let t0 = Instant::now();
        for i in 0..n {
            results[i] = locks[i].release(ops[i][victim[i]].0, now).expect("release");
        }
        let elapsed = t0.elapsed();
        if s >= p.warmup {
            release.push(elapsed.as_nanos() as f64 / n as f64);
        }
        for i in 0..n {
            holders[i].swap_remove(victim_index[i]);
            let grants = std::mem::take(&mut results[i]);
            log.released(victim[i], grants.iter().map(|g| g.operation.index()));
            holders[i].extend(grants.iter().map(|g| g.operation.index()));
            let (op, priority, set) = &ops[i][victim[i]];
            let granted = locks[i].acquire(*op, *priority, set, now).expect("acquire")
                == Acquisition::Granted;
            log.acquired(victim[i], granted);
            if granted {
                holders[i].push(victim[i]);
            }
            locks[i].drain_events();
        }
    }
    json!({
        "scale": "case", "impl": "native", "events": events,
        "pair": summary(pair), "release": summary(release), "log": log.json(),
    })
}

/// The large-scale workload's driver state; the steps mirror `runLarge` in the JS script.
struct Large<'a> {
    p: &'a LargeParams,
    rng: Rng,
    log: GrantLog,
    lock: Interlock,
    /// Resource indices and the resolved set, drawn up front.
    pool: Vec<(Vec<usize>, ResourceSet)>,
    owner: Vec<Option<usize>>,
    priority: Vec<i32>,
    op_set: Vec<usize>,
    /// Each operation's handle, and back: past the names an interlock keeps,
    /// slots of idle operations are reused, so handles are not positions.
    ids: Vec<OpId>,
    of_id: HashMap<OpId, usize>,
    holders: Vec<usize>,
    queued: usize,
}

impl Large<'_> {
    fn take(&mut self, op: usize) {
        self.holders.push(op);
        for &r in &self.pool[self.op_set[op]].0 {
            self.owner[r] = Some(op);
        }
    }

    fn acquire(&mut self, op: usize, now: Millis) {
        let set = &self.pool[self.op_set[op]].1;
        let outcome = self.lock.acquire(self.ids[op], self.priority[op], set, now);
        let granted = outcome.expect("acquire") == Acquisition::Granted;
        self.log.acquired(op, granted);
        if granted {
            self.take(op);
        } else {
            self.queued += 1;
        }
    }

    fn register(&mut self, priority: i32) -> usize {
        let op = self.priority.len();
        let id = self.lock.operation(&format!("op{op}"));
        self.ids.push(id);
        self.of_id.insert(id, op);
        self.priority.push(priority);
        self.op_set.push(usize::MAX);
        op
    }

    fn new_op(&mut self, now: Millis) {
        let priority = 1 + self.rng.int(self.p.priorities) as i32;
        let op = self.register(priority);
        self.op_set[op] = self.rng.int(self.p.pool);
        self.acquire(op, now);
    }
}

fn run_large(p: &LargeParams, events: bool) -> Value {
    let names: Vec<String> = (0..p.resources).map(|r| format!("r{r}")).collect();
    let mut config = InterlockConfig::with_resources(names.iter().cloned());
    config.queue_bound = p.queue_bound;
    config.record_events = events;
    let mut rng = Rng(p.seed);
    let lock = Interlock::new(config).expect("config");

    let mut pool = Vec::with_capacity(p.pool);
    for _ in 0..p.pool {
        let size = 1 + rng.int(p.max_set);
        let mut ids = Vec::with_capacity(size);
        while ids.len() < size {
            let r = rng.int(p.resources);
            if !ids.contains(&r) {
                ids.push(r);
            }
        }
        let set = lock
            .resource_set(&ids.iter().map(|&r| names[r].as_str()).collect::<Vec<_>>())
            .expect("set");
        pool.push((ids, set));
    }
    let singles: Vec<ResourceSet> = names
        .iter()
        .map(|n| lock.resource_set(&[n]).expect("set"))
        .collect();

    let mut st = Large {
        p,
        rng,
        log: GrantLog::new(),
        lock,
        pool,
        owner: vec![None; p.resources],
        priority: Vec::new(),
        op_set: Vec::new(),
        ids: Vec::new(),
        of_id: HashMap::new(),
        holders: Vec::new(),
        queued: 0,
    };
    let now = clock();
    st.register(0);
    while st.queued < p.waiting {
        st.new_op(now);
    }

    let mut release = Vec::with_capacity(p.samples);
    let mut pair = Vec::with_capacity(p.samples);
    let mut free = Vec::with_capacity(p.resources);
    for s in 0..p.warmup + p.samples {
        let index = st.rng.int(st.holders.len());
        let victim = st.holders[index];
        let now = clock();
        let t0 = Instant::now();
        let grants = st.lock.release(st.ids[victim], now).expect("release");
        let elapsed = t0.elapsed();
        if s >= p.warmup {
            release.push(elapsed.as_nanos() as f64);
        }
        st.holders.swap_remove(index);
        for i in 0..st.pool[st.op_set[victim]].0.len() {
            let r = st.pool[st.op_set[victim]].0[i];
            st.owner[r] = None;
        }
        st.log
            .released(victim, grants.iter().map(|g| st.of_id[&g.operation]));
        for g in &grants {
            st.take(st.of_id[&g.operation]);
        }
        st.queued -= grants.len();
        st.op_set[victim] = st.rng.int(p.pool);
        st.acquire(victim, now);
        while st.queued < p.waiting {
            st.new_op(now);
        }
        st.lock.drain_events();

        free.clear();
        free.extend((0..p.resources).filter(|&r| st.owner[r].is_none()));
        if free.is_empty() {
            continue;
        }
        let set = &singles[free[st.rng.int(free.len())]];
        // Idle between steps, the probe may have been forgotten: named anew, as a node would.
        let probe = st.lock.operation("op0");
        let t0 = Instant::now();
        let granted = st.lock.acquire(probe, 0, set, now).expect("probe acquire");
        let stray = black_box(st.lock.release(probe, now).expect("probe release")).len();
        let elapsed = t0.elapsed();
        assert!(
            granted == Acquisition::Granted && stray == 0,
            "large pair: probe refused a free resource or its release granted"
        );
        if s >= p.warmup {
            pair.push(elapsed.as_nanos() as f64);
        }
        st.lock.drain_events();
    }
    json!({
        "scale": "large", "impl": "native", "events": events,
        "pair": summary(pair), "release": summary(release), "log": st.log.json(),
    })
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let params = args
        .iter()
        .find(|a| a.starts_with('{'))
        .map(|a| serde_json::from_str::<Value>(a).expect("PARAMS_JSON is not valid JSON"))
        .unwrap_or(Value::Null);
    let no_events = args.iter().any(|a| a == "--no-events");
    let v = &params;
    let case = CaseParams {
        seed: param(v, "case", "seed", 0x5eed_0c5e) as u32,
        instances: param(v, "case", "instances", 128) as usize,
        pair_batch: param(v, "case", "pairBatch", 128) as usize,
        warmup: param(v, "case", "warmup", 500) as usize,
        samples: param(v, "case", "samples", 3000) as usize,
    };
    let large = LargeParams {
        seed: param(v, "large", "seed", 0x5eed_1a26) as u32,
        resources: param(v, "large", "resources", 1024) as usize,
        waiting: param(v, "large", "waiting", 10_000) as usize,
        max_set: param(v, "large", "maxSet", 8) as usize,
        pool: param(v, "large", "pool", 16_384) as usize,
        priorities: param(v, "large", "priorities", 100) as usize,
        queue_bound: param(v, "large", "queueBound", 20_000) as usize,
        warmup: param(v, "large", "warmup", 300) as usize,
        samples: param(v, "large", "samples", 3000) as usize,
    };
    let settings: &[bool] = if no_events { &[false] } else { &[false, true] };
    for &events in settings {
        println!("{}", run_case(&case, events));
    }
    for &events in settings {
        println!("{}", run_large(&large, events));
    }
}
