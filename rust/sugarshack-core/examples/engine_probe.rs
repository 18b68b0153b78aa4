//! Instructions per acquire+release through the engine, for `perf stat`:
//! `engine_probe engine|wire|follow|interlock` (follow: the release follows
//! msg.interlock.operation, as a release node with no operation of its own).
use sugarshack_core::engine::wire::Wire;
use sugarshack_core::engine::*;
use sugarshack_core::interlock::InterlockConfig;
use sugarshack_core::time::ms;

fn main() {
    let what = std::env::args().nth(1).unwrap_or_default();
    let n: u32 = std::env::args()
        .nth(2)
        .and_then(|n| n.parse().ok())
        .unwrap_or(1_000_000);
    let mut e = Engine::new(InterlockConfig::with_resources(["YEL", "GRN"]), false).unwrap();
    e.handle(
        Input::AddNode {
            node: NodeId(1),
            spec: NodeSpec::acquire(
                Raw::Text("load truck".into()),
                Raw::Number(20.0),
                Raw::Text("YEL".into()),
                ms(0),
            ),
        },
        ms(0),
    );
    e.handle(
        Input::AddNode {
            node: NodeId(2),
            spec: NodeSpec::of(NodeKind::Release, Raw::Text("load truck".into())),
        },
        ms(0),
    );
    e.handle(
        Input::AddNode {
            node: NodeId(3),
            spec: NodeSpec::of(NodeKind::Release, Raw::Absent),
        },
        ms(0),
    );
    e.handle(Input::Start(Saved::First), ms(0));
    e.take_outputs();
    let mut wire = Wire::new();
    let mut il =
        sugarshack_core::interlock::Interlock::new(InterlockConfig::with_resources(["YEL", "GRN"]))
            .unwrap();
    let op = il.operation("a");
    let set = il.resource_set(&["YEL"]).unwrap();
    for i in 0..n {
        match what.as_str() {
            "interlock" => {
                il.acquire(op, 1, &set, ms(1)).unwrap();
                il.release(op, ms(1)).unwrap();
            }
            "none" => {}
            _ => {
                e.handle(
                    Input::Acquire {
                        node: NodeId(1),
                        msg: MsgId(2 * i),
                        fields: MsgFields::default(),
                    },
                    ms(1),
                );
                if what != "engine" {
                    wire.encode(e.outputs());
                }
                e.clear_outputs();
                let release = if what == "follow" {
                    Input::Release {
                        node: NodeId(3),
                        msg: MsgId(2 * i + 1),
                        fields: MsgFields::following(Raw::Text("load truck".into())),
                    }
                } else {
                    Input::Release {
                        node: NodeId(2),
                        msg: MsgId(2 * i + 1),
                        fields: MsgFields::default(),
                    }
                };
                e.handle(release, ms(1));
                if what != "engine" {
                    wire.encode(e.outputs());
                }
                e.clear_outputs();
            }
        }
    }
}
