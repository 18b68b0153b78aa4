use proptest::prelude::*;

use super::*;

fn group_key(key: &str) -> bool {
    matches!(key, "valve" | "valves" | "pump" | "pumps")
}

fn text(s: &str) -> Raw {
    Raw::Text(s.to_owned())
}

fn names(list: &[&str]) -> Raw {
    Raw::Names(list.iter().map(|s| (*s).to_owned()).collect())
}

fn key_of(refusal: &Refusal) -> (Code, Option<&'static str>) {
    (refusal.code, refusal.key())
}

#[test]
fn a_lockout_is_its_topic_or_its_flag() {
    assert_eq!(lockout_topic("YEL"), "lockout/YEL");
    assert!(is_lockout(Some("lockout/YEL"), &Raw::Absent));
    // Whatever the line is called, even a device's word.
    assert!(is_lockout(Some("lockout/state"), &Raw::Absent));
    assert!(is_lockout(Some("lockout/"), &Raw::Absent));
    assert!(is_lockout(None, &Raw::Bool(true)));
    assert!(is_lockout(Some("plant/command"), &Raw::Bool(true)));
    // Only `true` flags one: not the text "true", not 1.
    assert!(!is_lockout(None, &text("true")));
    assert!(!is_lockout(None, &Raw::Number(1.0)));
    assert!(!is_lockout(None, &Raw::Bool(false)));
    assert!(!is_lockout(Some("Lockout/YEL"), &Raw::Absent));
    assert!(!is_lockout(Some("plant/lockout/YEL"), &Raw::Absent));
}

#[test]
fn a_made_lockout_topic_reads_as_a_lockout_for_any_line() {
    for line in ["YEL", "", "a/b", "lockout/", "\u{0}", "名前"] {
        assert!(
            is_lockout(Some(&lockout_topic(line)), &Raw::Absent),
            "{line}"
        );
    }
}

#[test]
fn an_object_with_a_group_key_is_a_command_one_without_is_traffic() {
    assert!(command_like(r#"{"valves": {"V12": 100}}"#, group_key));
    assert!(command_like(
        r#"  {"ts": 1, "pump": {"P1": true}}"#,
        group_key
    ));
    assert!(!command_like(r#"{"ts": 1, "state": "ON"}"#, group_key));
    assert!(!command_like("{}", group_key));
    // Keys are matched whole, in their case.
    assert!(!command_like(r#"{"Valves": {}, "valves2": 1}"#, group_key));
}

#[test]
fn arrays_and_broken_json_are_commands_so_that_they_are_refused() {
    assert!(command_like("[1, 2]", group_key));
    assert!(command_like("\t\n [", group_key));
    assert!(command_like("{not json", group_key));
    assert!(command_like(r#"{"ts": 1} trailing"#, group_key));
    assert!(command_like(r#"{"ts": NaN}"#, group_key));
    assert!(command_like(r#"{"ts": Infinity}"#, group_key));
}

#[test]
fn other_text_is_someone_elses_traffic() {
    for payload in ["", "ON", "42", "null", "true", "\"{\"", "online", " x{"] {
        assert!(!command_like(payload, group_key), "{payload:?}");
    }
}

#[test]
fn white_space_is_what_js_trims() {
    assert!(command_like("\u{feff}{\"valves\": {}}", group_key));
    assert!(command_like("\u{a0}\u{2028}[", group_key));
}

#[test]
fn only_the_first_hundred_keys_are_looked_at() {
    let object = |before: usize| {
        let mut fields: Vec<String> = (0..before).map(|i| format!("\"k{i}\": {i}")).collect();
        fields.push("\"valves\": {\"V12\": 0}".to_owned());
        format!("{{{}}}", fields.join(","))
    };
    assert!(command_like(&object(0), group_key));
    assert!(command_like(&object(KEYS_LOOKED_AT - 1), group_key));
    assert!(!command_like(&object(KEYS_LOOKED_AT), group_key));
    assert!(!command_like(&object(100_000), group_key));
}

#[test]
fn hostile_text_is_read_without_harm() {
    // Deep nesting in a value is skipped, as deep as JSON.parse reads it, without recursion.
    for depth in [100, 100_000] {
        let deep = format!("{{\"ts\": {}{}}}", "[".repeat(depth), "]".repeat(depth));
        assert!(!command_like(&deep, group_key), "{depth}");
    }
    let unclosed = "{".repeat(1_000_000);
    assert!(command_like(&unclosed, group_key));
    // Keys a JS object treats specially are plain keys here.
    assert!(!command_like(
        r#"{"__proto__": {"valves": {}}, "constructor": 1}"#,
        group_key
    ));
    // Escaped keys are read as JS reads them.
    assert!(command_like(r#"{"valv\u0065s": {"V12": 0}}"#, group_key));
    // Numbers past f64 and BigInt-like digits are values, never refused here.
    assert!(!command_like(
        r#"{"n": 1e400, "big": 123456789012345678901234567890}"#,
        group_key
    ));
    // A huge object: every key is read, none is kept.
    let huge = format!("{{\"pad\": \"{}\", \"ts\": 1}}", "x".repeat(16 << 20));
    assert!(!command_like(&huge, group_key));
}

#[test]
fn group_text_is_bounded_as_js_counted_it() {
    assert!(check_group_text(0).is_ok());
    assert!(check_group_text(MAX_GROUP_TEXT).is_ok());
    let refused = check_group_text(MAX_GROUP_TEXT + 1).unwrap_err();
    assert_eq!(
        key_of(&refused),
        (Code::InputTooLarge, Some("errors.groupTooLarge"))
    );
    assert_eq!(
        refused.params(),
        vec![
            ("length", Param::Text("65537".into())),
            ("max", Param::Text("65536".into()))
        ]
    );
    assert!(check_group_text(usize::MAX).is_err());
}

#[test]
fn text_that_is_not_json_is_refused_with_the_parsers_words_cut_short() {
    let refused = not_json("Unexpected token o in JSON at position 1");
    assert_eq!(
        key_of(&refused),
        (Code::InvalidGroup, Some("errors.groupNotJson"))
    );
    assert_eq!(
        refused.params(),
        vec![(
            "message",
            Param::Text("Unexpected token o in JSON at position 1".into())
        )]
    );
    let long = not_json(&"é".repeat(10_000));
    let [(_, Param::Text(message))] = &long.params()[..] else {
        panic!("one message")
    };
    assert_eq!(message.chars().count(), MESSAGE_CHARS + 1);
}

#[test]
fn a_msg_of_no_acquire_node_holds_nothing_to_keep_within() {
    assert_eq!(held_lines(&Interlock::Unset), Ok(None));
}

#[test]
fn a_list_of_names_is_what_the_msg_holds() {
    assert_eq!(
        held_lines(&Interlock::Holds(names(&["YEL", "RED"]))),
        Ok(Some(vec!["YEL".to_owned(), "RED".to_owned()]))
    );
    assert_eq!(
        held_lines(&Interlock::Holds(names(&[]))),
        Ok(Some(Vec::new()))
    );
}

#[test]
fn anything_else_in_msg_interlock_is_refused_never_taken_as_no_restriction() {
    let refused = |interlock: Interlock| {
        let refusal = held_lines(&interlock).unwrap_err();
        assert_eq!(
            key_of(&refusal),
            (Code::InvalidResources, Some("errors.heldNotListed"))
        );
        match &refusal.params()[..] {
            [("got", Param::Text(got))] => got.clone(),
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(refused(Interlock::Holds(text("YEL"))), "\"YEL\"");
    assert_eq!(refused(Interlock::Holds(Raw::Absent)), "null");
    assert_eq!(refused(Interlock::Holds(Raw::Number(f64::NAN))), "null");
    assert_eq!(
        refused(Interlock::Holds(Raw::Number(f64::INFINITY))),
        "null"
    );
    assert_eq!(refused(Interlock::Holds(Raw::Other("{}".into()))), "{}");
    assert_eq!(refused(Interlock::Holds(Raw::Other("10n".into()))), "10n");
    assert_eq!(refused(Interlock::Other("\"x\"".into())), "\"x\"");
    assert_eq!(
        refused(Interlock::Other("{\"operation\":\"op\"}".into())),
        "{\"operation\":\"op\"}"
    );
    // More names than any plant has lines, or a name longer than a person gives.
    let many = vec!["R".to_owned(); MAX_NAMES + 1];
    refused(Interlock::Holds(Raw::Names(many)));
    let long = "R".repeat(MAX_NAME + 1);
    let quoted = refused(Interlock::Holds(Raw::Names(vec!["YEL".into(), long])));
    assert!(quoted.chars().count() <= 100, "{quoted}");
}

#[test]
fn names_are_as_long_as_js_counts_them() {
    // 200 characters outside the BMP are 400 UTF-16 units: too long.
    let astral = "😀".repeat(MAX_NAME / 2 + 1);
    assert!(held_lines(&Interlock::Holds(Raw::Names(vec![astral]))).is_err());
    let wide = "é".repeat(MAX_NAME);
    assert!(held_lines(&Interlock::Holds(Raw::Names(vec![wide]))).is_ok());
}

#[test]
fn a_lockout_keeps_within_nothing_whatever_its_msg_holds() {
    let read = read_group_msg(
        Some("lockout/YEL"),
        &Raw::Absent,
        &Interlock::Other("5".into()),
    )
    .unwrap();
    assert_eq!(
        read,
        GroupMsg {
            lockout: true,
            within: None
        }
    );
    let read = read_group_msg(
        Some("plant/command"),
        &Raw::Absent,
        &Interlock::Holds(names(&["YEL"])),
    )
    .unwrap();
    assert_eq!(
        read,
        GroupMsg {
            lockout: false,
            within: Some(vec!["YEL".into()])
        }
    );
    let refused = read_group_msg(
        Some("plant/command"),
        &Raw::Bool(false),
        &Interlock::Other("5".into()),
    );
    assert_eq!(refused.unwrap_err().code, Code::InvalidResources);
}

fn raw() -> impl Strategy<Value = Raw> {
    prop_oneof![
        Just(Raw::Absent),
        ".{0,20}".prop_map(Raw::Text),
        "lockout/.{0,10}".prop_map(Raw::Text),
        any::<f64>().prop_map(Raw::Number),
        any::<bool>().prop_map(Raw::Bool),
        prop::collection::vec(".{0,8}", 0..4).prop_map(Raw::Names),
        ".{0,20}".prop_map(Raw::Other),
    ]
}

proptest! {
    /// Any JSON object's text is read as JS reads it: a command exactly when
    /// one of its first hundred keys is a group key.
    #[test]
    fn an_objects_text_is_a_command_when_a_first_key_is_a_group_key(
        keys in prop::collection::vec(prop_oneof![Just("valves".to_owned()), Just("pump".to_owned()), "[a-z_]{0,6}"], 0..150),
    ) {
        let mut object = serde_json::Map::new();
        for (i, key) in keys.iter().enumerate() {
            object.insert(key.clone(), serde_json::json!(i));
        }
        let text = serde_json::to_string(&object).unwrap();
        // serde_json's map keeps keys sorted, as this text lists them.
        let expected = object.keys().take(KEYS_LOOKED_AT).any(|k| group_key(k));
        prop_assert_eq!(command_like(&text, group_key), expected);
    }

    /// No text makes the check panic; text that does not open as JSON is never a command.
    #[test]
    fn any_text_is_read_without_panic(payload in ".{0,64}") {
        let like = command_like(&payload, group_key);
        let start = payload.trim_start_matches(is_js_space).chars().next();
        if !matches!(start, Some('{' | '[')) {
            prop_assert!(!like);
        }
    }

    /// A msg is read without panic whatever it carries; a lockout never keeps within its lines.
    #[test]
    fn any_msg_reads_as_a_lockout_or_within_its_listed_lines(topic in prop::option::of("(lockout/)?.{0,10}"), flag in raw(), held in raw()) {
        let lockout = is_lockout(topic.as_deref(), &flag);
        match read_group_msg(topic.as_deref(), &flag, &Interlock::Holds(held.clone())) {
            Ok(read) => {
                prop_assert_eq!(read.lockout, lockout);
                if lockout {
                    prop_assert_eq!(read.within, None);
                } else {
                    prop_assert!(matches!(held, Raw::Names(_)));
                }
            }
            Err(refusal) => {
                prop_assert!(!lockout);
                prop_assert_eq!(refusal.code, Code::InvalidResources);
            }
        }
    }
}
