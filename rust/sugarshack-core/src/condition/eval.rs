//! A checked condition evaluated as JSONata evaluates it (`jsonata/src/jsonata.js`):
//! numbers are JS doubles; arithmetic (and minus) refuses an operand that is
//! not a finite number (JSONata's errors T2001, T2002, D1001, D1002), while
//! comparisons take any double as JS does; `and` and `or` stop at their left
//! side when it decides; `$min` and `$max` are JS's `Math.min` and `Math.max`.

use std::ops::Range;

use super::check::Expr;
use super::Function;

/// A value that arithmetic refused: the span of the operand that was not a finite number.
pub(super) type NotFinite = Range<usize>;

pub(super) fn boolean(expr: &Expr, values: &[f64]) -> Result<bool, NotFinite> {
    Ok(match expr {
        Expr::Bool(b) => *b,
        Expr::Compare(op, l, r) => {
            let (l, r) = (number(l, values)?, number(r, values)?);
            match *op {
                "<" => l < r,
                "<=" => l <= r,
                ">" => l > r,
                _ => l >= r,
            }
        }
        Expr::Equal {
            negated,
            numbers,
            left,
            right,
        } => {
            let equal = if *numbers {
                number(left, values)? == number(right, values)?
            } else {
                boolean(left, values)? == boolean(right, values)?
            };
            equal != *negated
        }
        Expr::And(l, r) => boolean(l, values)? && boolean(r, values)?,
        Expr::Or(l, r) => boolean(l, values)? || boolean(r, values)?,
        Expr::Call(Function::Not, args) => !boolean(&args[0], values)?,
        // The check types the others as numbers, never as true or false.
        _ => false,
    })
}

pub(super) fn number(expr: &Expr, values: &[f64]) -> Result<f64, NotFinite> {
    Ok(match expr {
        Expr::Number(n) => *n,
        Expr::Sensor(i) => values.get(*i).copied().unwrap_or(f64::NAN),
        Expr::Neg(operand, span) => -finite(number(operand, values)?, span)?,
        Expr::Arith(op, left, right) => {
            // Both sides first, then their check, in JSONata's order.
            let (l, r) = (number(&left.0, values)?, number(&right.0, values)?);
            let (l, r) = (finite(l, &left.1)?, finite(r, &right.1)?);
            match *op {
                "+" => l + r,
                "-" => l - r,
                "*" => l * r,
                "/" => l / r,
                _ => l % r,
            }
        }
        Expr::Call(function, args) => {
            let args = args
                .iter()
                .map(|a| number(a, values))
                .collect::<Result<Vec<_>, _>>()?;
            match function {
                Function::Abs => args[0].abs(),
                Function::Floor => args[0].floor(),
                Function::Ceil => args[0].ceil(),
                Function::Min => js_min_max(&args, true),
                Function::Max => js_min_max(&args, false),
                Function::Not => f64::NAN,
            }
        }
        // The check types these as true or false, never as a number.
        _ => f64::NAN,
    })
}

fn finite(value: f64, span: &Range<usize>) -> Result<f64, NotFinite> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(span.clone())
    }
}

/// JS's `Math.min` / `Math.max`: NaN if any is NaN; -0 below +0.
fn js_min_max(values: &[f64], min: bool) -> f64 {
    let mut best = if min {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    for &v in values {
        if v.is_nan() {
            return f64::NAN;
        }
        let better = if min {
            v < best || (v == 0.0 && best == 0.0 && v.is_sign_negative())
        } else {
            v > best || (v == 0.0 && best == 0.0 && v.is_sign_positive())
        };
        if better {
            best = v;
        }
    }
    best
}
