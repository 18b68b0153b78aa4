//! A condition's tokens into a tree, by JSONata's own precedences
//! (`or` 25, `and` 30, comparisons 40, `+ -` 50, `* / %` 60, unary minus 70),
//! every binary operator grouping to the left, as JSONata's parser does.
//! Whatever JSONata has beyond the documented subset is refused by name.

use std::ops::Range;

use super::lex::{self, unsupported, Tok, Token};
use super::{ConditionError, Function, MAX_CHARS, MAX_DEPTH};
use crate::text::quote;

/// A parsed condition, names not yet resolved.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Syntax {
    pub(super) node: Node,
    /// Byte offsets in the condition's text.
    pub(super) span: Range<usize>,
}

#[derive(Clone, Debug, PartialEq)]
pub(super) enum Node {
    Number(f64),
    Bool(bool),
    Name(String),
    Neg(Box<Syntax>),
    /// `+ - * / % = != < <= > >= and or`.
    Binary(&'static str, Box<Syntax>, Box<Syntax>),
    /// A function and its arguments (the list's items for `$min` and `$max`).
    Call(Function, Vec<Syntax>),
}

/// JSONata's binding power of an infix operator.
fn binding(op: &str) -> u8 {
    match op {
        "." => 75,
        "[" | "(" => 80,
        "{" => 70,
        "*" | "/" | "%" | "**" => 60,
        "+" | "-" | "&" => 50,
        "=" | "!=" | "<" | "<=" | ">" | ">=" | "in" | "^" | "~>" | "?:" | "??" => 40,
        "and" => 30,
        "or" => 25,
        "?" | ".." | "|" => 20,
        ":=" => 10,
        "@" | "#" | ";" | ":" => 80,
        _ => 0,
    }
}

const BINARY: [&str; 13] = [
    "+", "-", "*", "/", "%", "=", "!=", "<", "<=", ">", ">=", "and", "or",
];

/// What an operator JSONata has and a condition has not does there.
fn meaning(op: &str) -> &'static str {
    match op {
        "." => "'.' (a path into an object)",
        "[" => "'[' (a filter or a list)",
        "{" => "'{' (an object)",
        "&" => "'&' (joining text)",
        "in" => "'in' (membership of a list)",
        "?" | ":" => "'?' and ':' (a choice)",
        ".." => "'..' (a range)",
        ":=" => "':=' (an assignment)",
        "~>" => "'~>' (chaining functions)",
        "?:" | "??" => "'?:' and '??' (default values)",
        "^" => "'^' (sorting)",
        "|" => "'|' (a transform)",
        "@" | "#" => "'@' and '#' (bindings)",
        ";" => "';' (a block of expressions)",
        "**" => "'**' (all descendants)",
        "*" => "'*' (a wildcard)",
        "%" => "'%' (the parent)",
        "/" => "'/' (a regular expression)",
        "!" => "'!' (write not as $not(...))",
        "~" => "'~'",
        _ => "this operator",
    }
}

/// The tree of `text`, or why it is not a condition.
pub(super) fn parse(text: &str) -> Result<Syntax, ConditionError> {
    if text.chars().count() > MAX_CHARS {
        return Err(ConditionError::new(
            0..text.len(),
            format!("a condition is at most {MAX_CHARS} characters"),
        ));
    }
    let tokens = lex::tokens(text)?;
    if tokens.is_empty() {
        return Err(ConditionError::new(0..text.len(), "the condition is empty"));
    }
    let mut parser = Parser {
        text,
        tokens,
        at: 0,
        depth: 0,
    };
    let tree = parser.expression(0)?;
    if let Some(extra) = parser.tokens.get(parser.at) {
        return Err(parser.leftover(extra, &tree));
    }
    Ok(tree)
}

struct Parser<'a> {
    text: &'a str,
    tokens: Vec<Token>,
    at: usize,
    depth: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at)
    }

    fn peek_op(&self) -> Option<&'static str> {
        match self.peek() {
            Some(Token {
                tok: Tok::Op(op), ..
            }) => Some(op),
            _ => None,
        }
    }

    fn source(&self, span: &Range<usize>) -> &str {
        &self.text[span.clone()]
    }

    fn end(&self) -> usize {
        self.text.len()
    }

    fn missing(&self) -> ConditionError {
        let before = self.text.trim_end();
        ConditionError::new(
            self.end()..self.end(),
            format!(
                "the condition ends too early: something is missing after '{}'",
                quote(before)
            ),
        )
    }

    fn expression(&mut self, rbp: u8) -> Result<Syntax, ConditionError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            let at = self.peek().map_or(self.end(), |t| t.span.start);
            return Err(ConditionError::new(
                at..self.end(),
                format!("the condition nests deeper than {MAX_DEPTH} levels"),
            ));
        }
        let mut left = self.prefix()?;
        while let Some(op) = self.peek_op() {
            if binding(op) <= rbp {
                break;
            }
            left = self.infix(op, left)?;
        }
        self.depth -= 1;
        Ok(left)
    }

    fn prefix(&mut self) -> Result<Syntax, ConditionError> {
        let Some(token) = self.peek().cloned() else {
            return Err(self.missing());
        };
        self.at += 1;
        let leaf = |node| {
            Ok(Syntax {
                node,
                span: token.span.clone(),
            })
        };
        let said = self.source(&token.span).to_owned();
        let before = self.text[..token.span.start].trim_end();
        let after = if before.is_empty() {
            String::new()
        } else {
            format!(", after '{}'", quote(before))
        };
        match token.tok {
            Tok::Number(n) => leaf(Node::Number(n)),
            Tok::Bool(b) => leaf(Node::Bool(b)),
            Tok::Name(name) => leaf(Node::Name(name)),
            Tok::Null => Err(ConditionError::new(
                token.span,
                unsupported("null"),
            )),
            Tok::Text => {
                let inner = said.get(1..said.len().saturating_sub(1)).unwrap_or("");
                Err(ConditionError::new(
                    token.span,
                    format!(
                        "{} is text in quotes, not a sensor: name a sensor in backticks, `{}`",
                        quote(&said),
                        quote(inner)
                    ),
                ))
            }
            Tok::Variable(name) => self.call(&name, token.span),
            Tok::Op("(") => {
                let inner = self.expression(0)?;
                match self.peek_op() {
                    Some(")") => {
                        let close = self.tokens[self.at].span.end;
                        self.at += 1;
                        Ok(Syntax {
                            node: inner.node,
                            span: token.span.start..close,
                        })
                    }
                    Some(";") => Err(self.unsupported_here(";")),
                    _ => Err(self.expected("')' to close the '('")),
                }
            }
            Tok::Op("-") => {
                let operand = self.expression(70)?;
                Ok(Syntax {
                    span: token.span.start..operand.span.end,
                    node: Node::Neg(Box::new(operand)),
                })
            }
            Tok::Op("[") => Err(ConditionError::new(
                token.span,
                "a list [...] is only for the functions $min and $max, as in $max([`LT-2`, `LT-3`])",
            )),
            Tok::Op(op) if matches!(op, ")" | "]" | "," | "}") => Err(ConditionError::new(
                token.span,
                format!("'{op}' comes where a value is needed{after}"),
            )),
            Tok::Op(op) if BINARY.contains(&op) && op != "/" => Err(ConditionError::new(
                token.span,
                format!("'{op}' needs a value before it{after}"),
            )),
            Tok::Op(op) => Err(ConditionError::new(token.span, unsupported(meaning(op)))),
        }
    }

    fn infix(&mut self, op: &'static str, left: Syntax) -> Result<Syntax, ConditionError> {
        if op == "(" {
            return Err(ConditionError::new(
                left.span.start..self.tokens[self.at].span.end,
                format!(
                    "'{}(...)' calls something that is not a function; the functions are {}",
                    quote(self.source(&left.span)),
                    Function::LIST
                ),
            ));
        }
        if !BINARY.contains(&op) {
            return Err(self.unsupported_here(op));
        }
        self.at += 1;
        let right = self.expression(binding(op))?;
        Ok(Syntax {
            span: left.span.start..right.span.end,
            node: Node::Binary(op, Box::new(left), Box::new(right)),
        })
    }

    fn unsupported_here(&self, op: &str) -> ConditionError {
        let span = self
            .peek()
            .map_or(self.end()..self.end(), |t| t.span.clone());
        ConditionError::new(span, unsupported(meaning(op)))
    }

    fn expected(&self, what: &str) -> ConditionError {
        match self.peek() {
            None => ConditionError::new(
                self.end()..self.end(),
                format!("the condition ends where {what} is needed"),
            ),
            Some(t) => ConditionError::new(
                t.span.clone(),
                format!("expected {what}, found '{}'", quote(self.source(&t.span))),
            ),
        }
    }

    /// `$name(...)`: one of the supported functions with its arguments.
    fn call(&mut self, name: &str, span: Range<usize>) -> Result<Syntax, ConditionError> {
        let Some(function) = Function::named(name) else {
            let what = if name.is_empty() {
                "'$' (the input)".to_owned()
            } else if self.peek_op() == Some("(") {
                format!("the function ${}", quote(name))
            } else {
                format!("the variable ${}", quote(name))
            };
            return Err(ConditionError::new(span, unsupported(&what)));
        };
        if self.peek_op() != Some("(") {
            return Err(ConditionError::new(
                span,
                format!(
                    "${name} is a function: call it, as in {}",
                    function.example()
                ),
            ));
        }
        self.at += 1;
        let args = if function.takes_list() {
            if self.peek_op() != Some("[") {
                return Err(
                    self.expected(&format!("a list in brackets, as in {}", function.example()))
                );
            }
            self.at += 1;
            let items = self.list("]")?;
            if items.is_empty() {
                return Err(ConditionError::new(
                    span.start..self.tokens[self.at - 1].span.end,
                    format!("${name} needs at least one value in its list"),
                ));
            }
            items
        } else {
            self.list(")")?
        };
        if function.takes_list() {
            if self.peek_op() != Some(")") {
                return Err(self.expected(&format!("')' to close ${name}(")));
            }
            self.at += 1;
        }
        let end = self.tokens[self.at - 1].span.end;
        if !function.takes_list() && args.len() != 1 {
            return Err(ConditionError::new(
                span.start..end,
                format!(
                    "${name} takes one value, as in {}; it was given {}",
                    function.example(),
                    args.len()
                ),
            ));
        }
        Ok(Syntax {
            node: Node::Call(function, args),
            span: span.start..end,
        })
    }

    /// Expressions separated by `,` up to `close`, which is consumed.
    fn list(&mut self, close: &str) -> Result<Vec<Syntax>, ConditionError> {
        let mut items = Vec::new();
        if self.peek_op() == Some(close) {
            self.at += 1;
            return Ok(items);
        }
        loop {
            items.push(self.expression(0)?);
            match self.peek_op() {
                Some(",") => self.at += 1,
                Some(op) if op == close => {
                    self.at += 1;
                    return Ok(items);
                }
                _ => return Err(self.expected(&format!("',' or '{close}'"))),
            }
        }
    }

    /// Why a token after a complete condition does not belong there.
    fn leftover(&self, extra: &Token, tree: &Syntax) -> ConditionError {
        let before = quote(self.source(&tree.span));
        let said = quote(self.source(&extra.span));
        let message = match extra.tok {
            Tok::Op(")") => format!("')' after '{before}' has no '(' to close"),
            Tok::Op(op) if binding(op) == 0 => format!("unexpected '{said}' after '{before}'"),
            _ => format!(
                "'{said}' follows '{before}' without an operator between them (and, or, a comparison or arithmetic)"
            ),
        };
        ConditionError::new(extra.span.clone(), message)
    }
}
