//! Conditions over sensor values: the waits of operations, the `when` of
//! routine transitions and the wait node's condition. The language is the part
//! of JSONata such conditions use, read and evaluated here so that the plant
//! check and the run can never disagree:
//!
//! | what | written |
//! |---|---|
//! | a sensor's value | its id: `` `LT-3` `` in backticks (needed when the id has a dash, a dot or a space), or plain: `LT3` |
//! | numbers, truth values | `12000`, `2.5`, `1e3`, `true`, `false` |
//! | arithmetic | `+ - * / %`, minus before a value, parentheses |
//! | comparisons | `= != < <= > >=` |
//! | joining | `and`, `or` |
//! | functions | `$not(c)`, `$abs(x)`, `$floor(x)`, `$ceil(x)`, `$min([x, y, ...])`, `$max([x, y, ...])` |
//!
//! Precedence, grouping and results are JSONata's (a test cross-checks them
//! against Node-RED's JSONata). A condition names only the sensors listed
//! with it, and must give true or false. Refused, with a hint: `LT-1` without
//! backticks (JSONata reads `LT` minus 1), a name that is no listed sensor,
//! text in quotes, comparing true or false with a number, and everything else
//! of JSONata (paths, strings, variables, other functions).
//!
//! ```
//! use sugarshack_core::condition::Condition;
//! let listed = ["LT-3".to_string(), "LT-2".to_string()];
//! let plant = ["LT-3", "LT-2", "FT-3"];
//! let c = Condition::compile("`LT-3` >= 6000 or `LT-2` <= 2000", &listed, &plant).unwrap();
//! assert_eq!(c.holds(&[7000.0, 5000.0]), Ok(true));
//! assert_eq!(c.holds(&[10.0, 5000.0]), Ok(false));
//!
//! let err = Condition::compile("LT-3 >= 6000", &listed, &plant).unwrap_err();
//! assert!(err.to_string().contains("in backticks, `LT-3`"), "{err}");
//! let err = Condition::compile("`LT3` >= 6000", &listed, &plant).unwrap_err();
//! assert!(err.to_string().contains("did you mean `LT-3`?"), "{err}");
//! ```

mod check;
mod eval;
mod lex;
mod parse;
mod verdict;
mod wait;

use std::fmt;
use std::ops::Range;

use crate::text::quote;

pub use verdict::Verdict;
pub use wait::{
    timeout_message, Checked, TimedOut, TooManyWaits, WaitId, Waits, MAX_WAITS, TIMEOUT_CODE,
};

/// The longest condition read.
pub const MAX_CHARS: usize = 2000;
/// The deepest nesting of a condition (parentheses, operators, calls).
pub const MAX_DEPTH: usize = 64;

/// How refusals of unsupported syntax end.
const SUPPORTED: &str = "a condition uses sensor ids (in backticks when they have a dash, as `LT-3`), numbers, true, false, ( ), + - * / %, = != < <= > >=, and, or, and the functions $not, $abs, $floor, $ceil, $min, $max";

/// Why a text is not a condition.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConditionError {
    /// Where in the text, in bytes.
    pub span: Range<usize>,
    /// What is wrong, in the words of the person who wrote it.
    pub message: String,
}

impl ConditionError {
    fn new(span: Range<usize>, message: impl Into<String>) -> Self {
        ConditionError {
            span,
            message: message.into(),
        }
    }
}

impl fmt::Display for ConditionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for ConditionError {}

/// A function a condition may call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Function {
    /// `$not(c)`: true when `c` is false.
    Not,
    /// `$abs(x)`.
    Abs,
    /// `$floor(x)`.
    Floor,
    /// `$ceil(x)`.
    Ceil,
    /// `$min([x, y, ...])`.
    Min,
    /// `$max([x, y, ...])`.
    Max,
}

impl Function {
    const ALL: [Function; 6] = [
        Function::Not,
        Function::Abs,
        Function::Floor,
        Function::Ceil,
        Function::Min,
        Function::Max,
    ];
    const LIST: &'static str = "$not, $abs, $floor, $ceil, $min and $max";

    fn named(name: &str) -> Option<Function> {
        Function::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Its name, without the `$`.
    pub fn name(self) -> &'static str {
        match self {
            Function::Not => "not",
            Function::Abs => "abs",
            Function::Floor => "floor",
            Function::Ceil => "ceil",
            Function::Min => "min",
            Function::Max => "max",
        }
    }

    fn takes_list(self) -> bool {
        matches!(self, Function::Min | Function::Max)
    }

    fn example(self) -> &'static str {
        match self {
            Function::Not => "$not(`LT-3` > 100)",
            Function::Abs => "$abs(`LT-3` - 500) < 20",
            Function::Floor => "$floor(`LT-3`)",
            Function::Ceil => "$ceil(`LT-3`)",
            Function::Min => "$min([`LT-2`, `LT-3`]) > 100",
            Function::Max => "$max([`LT-2`, `LT-3`]) > 100",
        }
    }
}

/// A condition read, its names resolved to the sensors listed with it and its
/// types checked: it gives true or false for any values of those sensors.
#[derive(Clone, Debug, PartialEq)]
pub struct Condition {
    text: String,
    listed: Vec<String>,
    expr: check::Expr,
    read: Vec<bool>,
}

/// Arithmetic met a value that is not a finite number (a division by zero, a
/// result too large): JSONata stops with an error there, and the condition
/// does not hold.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NoNumber {
    /// The part of the condition that gave no number.
    pub part: String,
}

impl fmt::Display for NoNumber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "'{}' gives no finite number with these values (a division by zero?)",
            self.part
        )
    }
}

impl Condition {
    /// Reads `text` as a condition over the sensors `listed` with it (each a
    /// sensor of the plant, whose ids are `plant`), or says what is wrong.
    pub fn compile(text: &str, listed: &[String], plant: &[&str]) -> Result<Self, ConditionError> {
        let tree = parse::parse(text)?;
        let mut checker = check::Checker {
            text,
            scope: check::Scope { listed, plant },
            read: vec![false; listed.len()],
        };
        let expr = checker.condition(&tree)?;
        Ok(Condition {
            text: text.to_owned(),
            listed: listed.to_vec(),
            read: checker.read,
            expr,
        })
    }

    /// The condition as written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The sensors listed with it, in the order [`Condition::holds`] takes their values.
    pub fn sensors(&self) -> &[String] {
        &self.listed
    }

    /// Listed sensors it does not read (their freshness still counts).
    pub fn unread(&self) -> impl Iterator<Item = &str> {
        self.listed
            .iter()
            .zip(&self.read)
            .filter(|(_, read)| !**read)
            .map(|(s, _)| s.as_str())
    }

    /// Whether it holds for `values`, one per listed sensor in order (fresh
    /// values: a stale sensor means it does not hold, before it is evaluated).
    pub fn holds(&self, values: &[f64]) -> Result<bool, NoNumber> {
        eval::boolean(&self.expr, values).map_err(|span| NoNumber {
            part: quote(self.text.get(span).unwrap_or_default()),
        })
    }
}

#[cfg(test)]
mod tests;
