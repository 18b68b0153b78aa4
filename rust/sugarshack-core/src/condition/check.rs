//! A parsed condition's names resolved to the sensors listed with it, and its
//! types checked: numbers where arithmetic and `< <= > >=` need them, true or
//! false where `and`, `or` and `$not` need them, the same type on both sides
//! of `=` and `!=`, and true or false in the end.

use std::ops::Range;

use super::parse::{Node, Syntax};
use super::{ConditionError, Function};
use crate::text::quote;

/// A checked condition: every name a listed sensor, every operand its type.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Expr {
    Number(f64),
    Bool(bool),
    /// The value of the listed sensor at this index.
    Sensor(usize),
    /// Minus a number; the span is the operand's.
    Neg(Box<Expr>, Range<usize>),
    /// Arithmetic on two numbers, with each operand's span.
    Arith(
        &'static str,
        Box<(Expr, Range<usize>)>,
        Box<(Expr, Range<usize>)>,
    ),
    /// `< <= > >=` on two numbers.
    Compare(&'static str, Box<Expr>, Box<Expr>),
    /// `=` (or `!=` when negated) on two values of one type.
    Equal {
        negated: bool,
        /// Both numbers (else both true or false).
        numbers: bool,
        left: Box<Expr>,
        right: Box<Expr>,
    },
    And(Box<Expr>, Box<Expr>),
    Or(Box<Expr>, Box<Expr>),
    Call(Function, Vec<Expr>),
}

/// What an expression gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Type {
    Number,
    Boolean,
}

impl Type {
    fn words(self) -> &'static str {
        match self {
            Type::Number => "a number",
            Type::Boolean => "true or false",
        }
    }
}

/// Where the names of a condition are looked up.
pub(super) struct Scope<'a> {
    /// The sensors listed with the condition, in order: the only ones it may read.
    pub(super) listed: &'a [String],
    /// Every sensor of the plant.
    pub(super) plant: &'a [&'a str],
}

pub(super) struct Checker<'a> {
    pub(super) text: &'a str,
    pub(super) scope: Scope<'a>,
    /// Listed sensors the condition reads.
    pub(super) read: Vec<bool>,
}

impl Checker<'_> {
    fn source(&self, span: &Range<usize>) -> String {
        quote(&self.text[span.clone()])
    }

    /// The condition as a whole: it must give true or false.
    pub(super) fn condition(&mut self, tree: &Syntax) -> Result<Expr, ConditionError> {
        let (expr, ty) = self.check(tree)?;
        if ty == Type::Number {
            return Err(ConditionError::new(
                tree.span.clone(),
                format!(
                    "the condition gives a number, not true or false: compare it, as in {} >= 50",
                    self.source(&tree.span)
                ),
            ));
        }
        Ok(expr)
    }

    fn check(&mut self, tree: &Syntax) -> Result<(Expr, Type), ConditionError> {
        Ok(match &tree.node {
            Node::Number(n) => (Expr::Number(*n), Type::Number),
            Node::Bool(b) => (Expr::Bool(*b), Type::Boolean),
            Node::Name(name) => (Expr::Sensor(self.sensor(name, &tree.span)?), Type::Number),
            Node::Neg(operand) => {
                let expr = self.number(operand, "'-' (minus)")?;
                (
                    Expr::Neg(Box::new(expr), operand.span.clone()),
                    Type::Number,
                )
            }
            Node::Binary(op, left, right) => self.binary(op, left, right)?,
            Node::Call(function, args) => {
                let what = format!("'${}'", function.name());
                let args = args
                    .iter()
                    .map(|a| {
                        if *function == Function::Not {
                            self.boolean(a, &what)
                        } else {
                            self.number(a, &what)
                        }
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                let ty = if *function == Function::Not {
                    Type::Boolean
                } else {
                    Type::Number
                };
                (Expr::Call(*function, args), ty)
            }
        })
    }

    fn binary(
        &mut self,
        op: &'static str,
        left: &Syntax,
        right: &Syntax,
    ) -> Result<(Expr, Type), ConditionError> {
        let what = format!("'{op}'");
        Ok(match op {
            "+" | "-" | "*" | "/" | "%" => {
                let l = self.number(left, &what)?;
                let r = self.number(right, &what)?;
                (
                    Expr::Arith(
                        op,
                        Box::new((l, left.span.clone())),
                        Box::new((r, right.span.clone())),
                    ),
                    Type::Number,
                )
            }
            "<" | "<=" | ">" | ">=" => {
                let l = self.number(left, &what)?;
                let r = self.number(right, &what)?;
                (Expr::Compare(op, Box::new(l), Box::new(r)), Type::Boolean)
            }
            "and" | "or" => {
                let l = self.boolean(left, &what)?;
                let r = self.boolean(right, &what)?;
                let expr = if op == "and" {
                    Expr::And(Box::new(l), Box::new(r))
                } else {
                    Expr::Or(Box::new(l), Box::new(r))
                };
                (expr, Type::Boolean)
            }
            _ => {
                // `=` and `!=`: JSONata compares any two values; one of each type is never equal.
                let (l, lt) = self.check(left)?;
                let (r, rt) = self.check(right)?;
                if lt != rt {
                    return Err(ConditionError::new(
                        left.span.start..right.span.end,
                        format!(
                            "{what} compares {} ('{}') with {} ('{}'), which are never equal",
                            lt.words(),
                            self.source(&left.span),
                            rt.words(),
                            self.source(&right.span)
                        ),
                    ));
                }
                (
                    Expr::Equal {
                        negated: op == "!=",
                        numbers: lt == Type::Number,
                        left: Box::new(l),
                        right: Box::new(r),
                    },
                    Type::Boolean,
                )
            }
        })
    }

    /// An operand of `what` that must give a number.
    fn number(&mut self, tree: &Syntax, what: &str) -> Result<Expr, ConditionError> {
        let (expr, ty) = self.check(tree)?;
        if ty == Type::Boolean {
            let hint = if matches!(what, "'<'" | "'<='" | "'>'" | "'>='") {
                ": to test two things, join them with and / or, as in `LT-2` > 10 and `LT-2` < 90"
            } else {
                ""
            };
            return Err(ConditionError::new(
                tree.span.clone(),
                format!(
                    "{what} needs a number, but '{}' gives true or false{hint}",
                    self.source(&tree.span)
                ),
            ));
        }
        Ok(expr)
    }

    /// An operand of `what` that must give true or false.
    fn boolean(&mut self, tree: &Syntax, what: &str) -> Result<Expr, ConditionError> {
        let (expr, ty) = self.check(tree)?;
        if ty == Type::Number {
            return Err(ConditionError::new(
                tree.span.clone(),
                format!(
                    "{what} needs true or false, but '{}' gives a number: compare it, as in {} > 0",
                    self.source(&tree.span),
                    self.source(&tree.span)
                ),
            ));
        }
        Ok(expr)
    }

    /// The index of the listed sensor `name`, or why it is not one.
    fn sensor(&mut self, name: &str, span: &Range<usize>) -> Result<usize, ConditionError> {
        if let Some(i) = self.scope.listed.iter().position(|s| s == name) {
            self.read[i] = true;
            return Ok(i);
        }
        let listed = if self.scope.listed.is_empty() {
            "no sensors are listed".to_owned()
        } else {
            format!(
                "the sensors listed are {}",
                quote(self.scope.listed.join(", "))
            )
        };
        let message = if self.scope.plant.contains(&name) {
            format!(
                "reads sensor '{}', which is not listed with the condition ({listed}): add it to the sensors, so that it is read fresh",
                quote(name)
            )
        } else {
            let close = self.close_to(name);
            format!(
                "'{}' is not a sensor of the plant; {listed}{}",
                quote(&self.text[span.clone()]),
                close.map_or(String::new(), |c| format!(
                    " (did you mean `{}`?)",
                    quote(c)
                ))
            )
        };
        Err(ConditionError::new(span.clone(), message))
    }

    /// A sensor (listed first, then the plant's) whose id differs from `name`
    /// only in case and punctuation: `LT1` for `LT-1`.
    fn close_to(&self, name: &str) -> Option<&str> {
        let plain = |s: &str| -> String {
            s.chars()
                .filter(|c| c.is_alphanumeric())
                .flat_map(char::to_lowercase)
                .collect()
        };
        let wanted = plain(name);
        self.scope
            .listed
            .iter()
            .map(String::as_str)
            .chain(self.scope.plant.iter().copied())
            .find(|s| plain(s) == wanted)
    }
}
