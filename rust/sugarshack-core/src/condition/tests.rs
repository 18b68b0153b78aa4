//! Each refusal with its words, evaluation by JSONata's rules, and two
//! properties: no text panics (each is read or refused with a reason inside
//! the text), and any condition of the language, written out, evaluates as a
//! simple reference evaluator says.

use proptest::prelude::*;

use super::*;

const PLANT: [&str; 5] = ["LT-1", "LT-2", "LT-3", "FT-3", "level"];

fn listed(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

fn compile(text: &str, names: &[&str]) -> Result<Condition, ConditionError> {
    Condition::compile(text, &listed(names), &PLANT)
}

fn refusal(text: &str, names: &[&str]) -> String {
    let err = compile(text, names).expect_err(text);
    assert!(
        text.get(err.span.clone()).is_some(),
        "{text}: span {:?}",
        err.span
    );
    err.message
}

fn holds(text: &str, names: &[&str], values: &[f64]) -> Result<bool, NoNumber> {
    compile(text, names)
        .unwrap_or_else(|e| panic!("{text}: {e}"))
        .holds(values)
}

#[test]
fn the_conditions_users_write_hold_as_jsonata_says() {
    let two = ["LT-3", "LT-2"];
    let cases: [(&str, [f64; 2], bool); 12] = [
        ("`LT-3` >= 6000 or `LT-2` <= 2000", [7000.0, 5000.0], true),
        ("`LT-3` >= 6000 or `LT-2` <= 2000", [10.0, 5000.0], false),
        ("`LT-3` < 6000 and `LT-2` >= 10000", [10.0, 10000.0], true),
        ("`LT-3` - `LT-2` > 0", [2.0, 1.0], true),
        ("(`LT-3` + `LT-2`) / 2 >= 1.5", [1.0, 2.0], true),
        ("`LT-3` + `LT-2` / 2 >= 1.5", [1.0, 1.0], true),
        ("-`LT-3` < -1", [2.0, 0.0], true),
        ("`LT-3` % 3 = 1", [7.0, 0.0], true),
        ("`LT-3` % 3 = -1", [-7.0, 0.0], true),
        (
            "$abs(`LT-3` - `LT-2`) < 5 and $not(`LT-3` = `LT-2`)",
            [3.0, 1.0],
            true,
        ),
        (
            "$max([`LT-3`, `LT-2`, 10]) = 10 and $min([`LT-3`, `LT-2`]) = 1",
            [1.0, 2.0],
            true,
        ),
        (
            "$floor(`LT-3`) = 2 and $ceil(`LT-2`) = 2 /* a comment */",
            [2.7, 1.2],
            true,
        ),
    ];
    for (text, values, expected) in cases {
        assert_eq!(
            holds(text, &two, &values),
            Ok(expected),
            "{text} with {values:?}"
        );
    }
    // `and` binds tighter than `or`; both join left to right; comparisons too.
    assert_eq!(holds("true or false and false", &[], &[]), Ok(true));
    assert_eq!(holds("(true or false) and false", &[], &[]), Ok(false));
    assert_eq!(holds("1 - 2 - 3 = -4", &[], &[]), Ok(true));
    assert_eq!(holds("8 / 4 / 2 = 1", &[], &[]), Ok(true));
    assert_eq!(holds("true = false = false", &[], &[]), Ok(true));
    assert_eq!(
        holds("level > 2", &["level"], &[3.0]),
        Ok(true),
        "a plain name"
    );
    assert_eq!(holds("true", &[], &[]), Ok(true));
}

#[test]
fn arithmetic_on_no_number_does_not_hold_and_says_where() {
    let c = compile("`LT-3` / `FT-3` * 60 > 5", &["LT-3", "FT-3"]).unwrap();
    assert_eq!(c.holds(&[10.0, 2.0]), Ok(true));
    let err = c.holds(&[10.0, 0.0]).unwrap_err();
    assert_eq!(err.part, "`LT-3` / `FT-3`");
    assert!(err.to_string().contains("division by zero"), "{err}");
    // A comparison takes what a division gave, as JSONata's does.
    assert_eq!(holds("`LT-3` / 0 > 5", &["LT-3"], &[1.0]), Ok(true));
    assert_eq!(holds("0 / 0 = 0 / 0", &[], &[]), Ok(false));
    assert_eq!(holds("0 / 0 != 0 / 0", &[], &[]), Ok(true));
    // `and` and `or` stop at a left side that decides.
    assert_eq!(holds("false and 1 / 0 + 1 > 0", &[], &[]), Ok(false));
    assert_eq!(holds("true or -(1 / 0) > 0", &[], &[]), Ok(true));
    assert!(holds("true and -(1 / 0) > 0", &[], &[]).is_err());
}

#[test]
fn an_unquoted_id_with_a_dash_is_refused_with_backticks_as_the_fix() {
    let m = refusal("LT-1 >= 50", &["LT-1"]);
    assert_eq!(
        m,
        "'LT-1' reads as LT minus 1: write a sensor id that has a dash in backticks, `LT-1` (to subtract, put spaces around the minus)"
    );
    assert!(refusal("`LT-2` > 1 and LT-1-B < 3", &["LT-1"])
        .starts_with("'LT-1-B' reads as LT minus 1-B"));
    // Spaced, it is a subtraction: then the name is what is wrong.
    assert!(refusal("LT - 1 >= 50", &["LT-1"]).starts_with("'LT' is not a sensor of the plant"));
}

#[test]
fn an_unknown_name_lists_the_sensors_and_the_likely_one() {
    assert_eq!(
        refusal("`LT1` >= 50", &["LT-3", "LT-2"]),
        "'`LT1`' is not a sensor of the plant; the sensors listed are LT-3, LT-2 (did you mean `LT-1`?)"
    );
    assert_eq!(
        refusal("tank > 1", &[]),
        "'tank' is not a sensor of the plant; no sensors are listed"
    );
    assert_eq!(
        refusal("`LT-2` > 1 and `LT-1` > 2", &["LT-2"]),
        "reads sensor 'LT-1', which is not listed with the condition (the sensors listed are LT-2): add it to the sensors, so that it is read fresh"
    );
}

#[test]
fn a_condition_must_give_true_or_false() {
    assert_eq!(
        refusal("`LT-3`", &["LT-3"]),
        "the condition gives a number, not true or false: compare it, as in `LT-3` >= 50"
    );
    assert!(refusal("`LT-3` + 1", &["LT-3"]).starts_with("the condition gives a number"));
    assert!(refusal("`LT-3` and true", &["LT-3"]).starts_with(
        "'and' needs true or false, but '`LT-3`' gives a number: compare it, as in `LT-3` > 0"
    ));
    assert!(refusal("1 < `LT-3` < 5", &["LT-3"]).starts_with(
        "'<' needs a number, but '1 < `LT-3`' gives true or false: to test two things, join them with and / or"
    ));
    assert!(refusal("`LT-3` > 1 = 1", &["LT-3"]).starts_with(
        "'=' compares true or false ('`LT-3` > 1') with a number ('1'), which are never equal"
    ));
    assert!(refusal("$not(`LT-3`)", &["LT-3"]).starts_with("'$not' needs true or false"));
    assert!(refusal("$abs(true) > 1", &[]).starts_with("'$abs' needs a number"));
    assert!(refusal("-true", &[]).starts_with("'-' (minus) needs a number"));
}

#[test]
fn jsonata_beyond_the_subset_is_refused_naming_what_is_supported() {
    for (text, start) in [
        (
            "`LT-3` & 'x'",
            "'&' (joining text) is not supported in a condition; a condition uses sensor ids",
        ),
        (
            "tank.level > 1",
            "'.' (a path into an object) is not supported",
        ),
        (
            "`LT-3` in [1, 2]",
            "'in' (membership of a list) is not supported",
        ),
        (
            "`LT-3` > 1 ? true : false",
            "'?' and ':' (a choice) is not supported",
        ),
        ("$x > 1", "the variable $x is not supported"),
        ("$sum([1]) > 1", "the function $sum is not supported"),
        ("$ > 1", "'$' (the input) is not supported"),
        ("null = null", "null is not supported"),
        ("{} = 1", "'{' (an object) is not supported"),
        (
            "(true; false)",
            "';' (a block of expressions) is not supported",
        ),
        ("/ab/ = 1", "'/' (a regular expression) is not supported"),
        ("!true", "'!' (write not as $not(...)) is not supported"),
    ] {
        let m = refusal(text, &["LT-3", "level"]);
        assert!(m.starts_with(start), "{text}: {m}");
        assert!(
            m.ends_with("$not, $abs, $floor, $ceil, $min, $max"),
            "{text}: {m}"
        );
    }
    assert_eq!(
        refusal("\"LT-3\" > 1", &["LT-3"]),
        "\"LT-3\" is text in quotes, not a sensor: name a sensor in backticks, `LT-3`"
    );
    assert!(refusal("$max(`LT-3`) > 1", &["LT-3"])
        .starts_with("expected a list in brackets, as in $max([`LT-2`, `LT-3`]) > 100"));
    assert!(refusal("$abs(1, 2) > 1", &[]).starts_with("$abs takes one value"));
    assert!(refusal("$min([]) > 1", &[]).starts_with("$min needs at least one value"));
    assert!(refusal("$abs > 1", &[]).starts_with("$abs is a function: call it"));
    assert!(refusal("LT(3) > 1", &[]).contains("calls something that is not a function"));
    assert!(
        refusal("[1] = 1", &[]).starts_with("a list [...] is only for the functions $min and $max")
    );
}

#[test]
fn syntax_errors_say_where() {
    assert_eq!(refusal("", &[]), "the condition is empty");
    assert_eq!(refusal("  /* nothing */ ", &[]), "the condition is empty");
    assert_eq!(
        refusal("`LT-3` >=", &["LT-3"]),
        "the condition ends too early: something is missing after '`LT-3` >='"
    );
    assert!(refusal("(`LT-3` > 1", &["LT-3"])
        .starts_with("the condition ends where ')' to close the '(' is needed"));
    assert_eq!(
        refusal("`LT-3` > 1)", &["LT-3"]),
        "')' after '`LT-3` > 1' has no '(' to close"
    );
    assert!(
        refusal("`LT-3` 50", &["LT-3"]).starts_with("'50' follows '`LT-3`' without an operator")
    );
    assert!(refusal("`LT-3 > 50", &["LT-3"]).starts_with("the name `LT-3 has no closing backtick"));
    assert!(refusal("> 50", &[]).starts_with("'>' needs a value before it"));
    assert!(refusal("1 > * 2", &[]).starts_with("'*' needs a value before it, after '1 >'"));
    assert!(refusal("1e400 > 1", &[]).starts_with("the number 1e400 is too large"));
    assert!(refusal("'x", &[]).starts_with("text in quotes is not closed"));
    assert!(refusal("/* open", &[]).starts_with("a comment '/*' is not closed"));
    let deep = format!("{}true{}", "(".repeat(100), ")".repeat(100));
    assert!(refusal(&deep, &[]).starts_with("the condition nests deeper than 64 levels"));
    let long = format!("true{}", " or true".repeat(300));
    assert!(refusal(&long, &[]).starts_with("a condition is at most 2000 characters"));
}

#[test]
fn listed_sensors_it_does_not_read_are_known() {
    let c = compile("`LT-3` > 1", &["LT-3", "LT-2"]).unwrap();
    assert_eq!(c.unread().collect::<Vec<_>>(), ["LT-2"]);
    assert_eq!(c.sensors(), ["LT-3", "LT-2"]);
    assert_eq!(c.text(), "`LT-3` > 1");
}

// ---- properties ------------------------------------------------------------------

/// A tree of the language, as the reference generates and evaluates it.
#[derive(Clone, Debug)]
enum Tree {
    Num(f64),
    Sensor(usize),
    Bool(bool),
    Neg(Box<Tree>),
    Arith(&'static str, Box<Tree>, Box<Tree>),
    Compare(&'static str, Box<Tree>, Box<Tree>),
    /// `=` or `!=` over two numbers, or over two truth values.
    Equal(&'static str, Box<Tree>, Box<Tree>),
    Logic(&'static str, Box<Tree>, Box<Tree>),
    Not(Box<Tree>),
    Unary(&'static str, Box<Tree>),
    MinMax(&'static str, Vec<Tree>),
}

const NAMES: [&str; 4] = ["LT-1", "level", "tank 2", "FT-3"];

fn number_tree() -> impl Strategy<Value = Tree> {
    let leaf = prop_oneof![
        prop_oneof![
            Just(0.0),
            Just(1.0),
            Just(2.5),
            Just(1e308),
            (0u32..1000u32).prop_map(f64::from)
        ]
        .prop_map(Tree::Num),
        (0..NAMES.len()).prop_map(Tree::Sensor),
    ];
    leaf.prop_recursive(4, 24, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|t| Tree::Neg(Box::new(t))),
            (
                prop_oneof![Just("+"), Just("-"), Just("*"), Just("/"), Just("%")],
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(op, l, r)| Tree::Arith(op, Box::new(l), Box::new(r))),
            (
                prop_oneof![Just("abs"), Just("floor"), Just("ceil")],
                inner.clone()
            )
                .prop_map(|(f, t)| Tree::Unary(f, Box::new(t))),
            (
                prop_oneof![Just("min"), Just("max")],
                prop::collection::vec(inner, 1..4)
            )
                .prop_map(|(f, items)| Tree::MinMax(f, items)),
        ]
    })
}

fn boolean_tree() -> impl Strategy<Value = Tree> {
    let compare = prop_oneof![
        (
            prop_oneof![Just("<"), Just("<="), Just(">"), Just(">=")],
            number_tree(),
            number_tree()
        )
            .prop_map(|(op, l, r)| Tree::Compare(op, Box::new(l), Box::new(r))),
        (
            prop_oneof![Just("="), Just("!=")],
            number_tree(),
            number_tree()
        )
            .prop_map(|(op, l, r)| Tree::Equal(op, Box::new(l), Box::new(r))),
        any::<bool>().prop_map(Tree::Bool),
    ];
    compare.prop_recursive(3, 16, 2, |inner| {
        prop_oneof![
            (
                prop_oneof![Just("and"), Just("or")],
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(op, l, r)| Tree::Logic(op, Box::new(l), Box::new(r))),
            (
                prop_oneof![Just("="), Just("!=")],
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(op, l, r)| Tree::Equal(op, Box::new(l), Box::new(r))),
            inner.prop_map(|t| Tree::Not(Box::new(t))),
        ]
    })
}

fn precedence(op: &str) -> u8 {
    match op {
        "or" => 25,
        "and" => 30,
        "+" | "-" => 50,
        "*" | "/" | "%" => 60,
        _ => 40,
    }
}

/// The tree as text, with the parentheses JSONata's precedences need (and
/// some it does not, when `extra`), each name plain where it may be.
fn write(tree: &Tree, extra: bool) -> String {
    let (text, _) = written(tree, extra);
    text
}

/// The text and the binding of its outermost operator (100 for an atom).
fn written(tree: &Tree, extra: bool) -> (String, u8) {
    let wrap = |t: &Tree, above: u8, right: bool| {
        let (s, p) = written(t, extra);
        if p < above || (right && p == above) || (extra && p < 100) {
            format!("({s})")
        } else {
            s
        }
    };
    match tree {
        Tree::Num(n) if *n >= 1e21 => (format!("{n:e}"), 100),
        Tree::Num(n) => (format!("{n}"), 100),
        Tree::Sensor(i) => {
            let name = NAMES[*i];
            let plain = name.chars().all(|c| c.is_alphanumeric());
            (
                if plain {
                    name.into()
                } else {
                    format!("`{name}`")
                },
                100,
            )
        }
        Tree::Bool(b) => (b.to_string(), 100),
        Tree::Neg(t) => (format!("-{}", wrap(t, 70, false)), 70),
        Tree::Arith(op, l, r)
        | Tree::Compare(op, l, r)
        | Tree::Equal(op, l, r)
        | Tree::Logic(op, l, r) => {
            let p = precedence(op);
            (
                format!("{} {op} {}", wrap(l, p, false), wrap(r, p, true)),
                p,
            )
        }
        Tree::Not(t) => (format!("$not({})", written(t, extra).0), 100),
        Tree::Unary(f, t) => (format!("${f}({})", written(t, extra).0), 100),
        Tree::MinMax(f, items) => {
            let items: Vec<String> = items.iter().map(|t| written(t, extra).0).collect();
            (format!("${f}([{}])", items.join(", ")), 100)
        }
    }
}

/// What a value is: a number, a truth value, or JSONata's error (arithmetic on no number).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    Number(f64),
    Truth(bool),
    Error,
}

/// The reference: JSONata's rules, read off its source, on the tree itself.
fn reference(tree: &Tree, values: &[f64]) -> Value {
    use Value::*;
    let num = |t: &Tree| match reference(t, values) {
        Number(n) => Ok(n),
        _ => Err(()),
    };
    let truth = |t: &Tree| match reference(t, values) {
        Truth(b) => Ok(b),
        _ => Err(()),
    };
    let out = (|| -> Result<Value, ()> {
        Ok(match tree {
            Tree::Num(n) => Number(*n),
            Tree::Sensor(i) => Number(values[*i]),
            Tree::Bool(b) => Truth(*b),
            Tree::Neg(t) => {
                let n = num(t)?;
                if !n.is_finite() {
                    return Err(());
                }
                Number(-n)
            }
            Tree::Arith(op, l, r) => {
                let (a, b) = (num(l)?, num(r)?);
                if !a.is_finite() || !b.is_finite() {
                    return Err(());
                }
                Number(match *op {
                    "+" => a + b,
                    "-" => a - b,
                    "*" => a * b,
                    "/" => a / b,
                    _ => a % b,
                })
            }
            Tree::Compare(op, l, r) => {
                let (a, b) = (num(l)?, num(r)?);
                Truth(match *op {
                    "<" => a < b,
                    "<=" => a <= b,
                    ">" => a > b,
                    _ => a >= b,
                })
            }
            Tree::Equal(op, l, r) => {
                let (a, b) = (reference(l, values), reference(r, values));
                if a == Error || b == Error {
                    return Err(());
                }
                Truth((a == b) == (*op == "="))
            }
            Tree::Logic("and", l, r) => Truth(truth(l)? && truth(r)?),
            Tree::Logic(_, l, r) => Truth(truth(l)? || truth(r)?),
            Tree::Not(t) => Truth(!truth(t)?),
            Tree::Unary(f, t) => {
                let n = num(t)?;
                Number(match *f {
                    "abs" => n.abs(),
                    "floor" => n.floor(),
                    _ => n.ceil(),
                })
            }
            Tree::MinMax(f, items) => {
                let items = items.iter().map(num).collect::<Result<Vec<_>, _>>()?;
                if items.iter().any(|n| n.is_nan()) {
                    Number(f64::NAN)
                } else {
                    let mut sorted = items.clone();
                    // -0 sorts below +0, as Math.min and Math.max order them.
                    sorted.sort_by(|a, b| a.total_cmp(b));
                    Number(if *f == "min" {
                        sorted[0]
                    } else {
                        sorted[sorted.len() - 1]
                    })
                }
            }
        })
    })();
    out.unwrap_or(Error)
}

fn sensor_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(1e308),
        Just(-1e308),
        (-100i32..100).prop_map(f64::from),
        -1e6f64..1e6,
    ]
}

fn token() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "`LT-1`", "level", "LT-1", "`LT1", "1", "0.5", "1e3", "-", "+", "*", "/", "%", "=", "!=",
        "<", "<=", ">", ">=", "and", "or", "(", ")", "[", "]", ",", "$not(", "$max([", "$abs(",
        "true", "false", "null", "\"x\"", "'", ".", "&", "?", ":", ";", "{", "}", "$", "/*", "*/",
        "in", "..", "~>", "`", "é", "\u{b}",
    ])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn any_text_is_read_or_refused_with_a_reason_inside_it(text in "\\PC{0,40}") {
        if let Err(err) = Condition::compile(&text, &listed(&["LT-1", "level"]), &PLANT) {
            prop_assert!(!err.message.is_empty());
            prop_assert!(text.get(err.span.clone()).is_some(), "span {:?} of {:?}", err.span, text);
        }
    }

    #[test]
    fn any_run_of_tokens_is_read_or_refused_with_a_reason_inside_it(
        tokens in prop::collection::vec((token(), prop::sample::select(vec!["", " "])), 0..24),
    ) {
        let text: String = tokens.iter().map(|(t, gap)| format!("{t}{gap}")).collect();
        match Condition::compile(&text, &listed(&["LT-1", "level"]), &PLANT) {
            Ok(c) => {
                // Read: it gives an answer for any values, never a panic.
                let _ = c.holds(&[1.0, 0.0]);
            }
            Err(err) => {
                prop_assert!(!err.message.is_empty());
                prop_assert!(text.get(err.span.clone()).is_some(), "span {:?} of {:?}", err.span, text);
            }
        }
    }

    #[test]
    fn conditions_evaluate_as_the_reference_says(
        tree in boolean_tree(),
        extra in any::<bool>(),
        values in prop::collection::vec(sensor_value(), NAMES.len()),
    ) {
        let text = write(&tree, extra);
        let plant: Vec<&str> = NAMES.to_vec();
        let c = Condition::compile(&text, &listed(&NAMES), &plant)
            .map_err(|e| TestCaseError::fail(format!("{text}: {e}")))?;
        let expected = reference(&tree, &values);
        let got = match c.holds(&values) {
            Ok(b) => Value::Truth(b),
            Err(_) => Value::Error,
        };
        prop_assert_eq!(got, expected, "{} with {:?}", text, values);
    }
}
