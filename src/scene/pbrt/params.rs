//! A directive's parameter list (`"float radius" [ 1 ]`): parsed from tokens,
//! read by type, and each read marked, so that the ones nothing read can be
//! named in a note.

use std::cell::Cell;

use super::lexer::{Kind, Loc, Token};
use crate::scene::SceneError;

const TYPES: &[&str] = &[
    "integer",
    "float",
    "point2",
    "vector2",
    "point3",
    "vector3",
    "normal3",
    "normal",
    "point",
    "vector",
    "spectrum",
    "rgb",
    "color",
    "blackbody",
    "bool",
    "string",
    "texture",
];

#[derive(Clone, Debug)]
pub(crate) enum Value {
    Num(f64),
    Str(String),
    Bool(bool),
}

#[derive(Clone, Debug)]
pub(crate) struct Param {
    pub ty: String,
    pub name: String,
    pub values: Vec<(Value, Loc)>,
    /// Where the `"type name"` string is.
    pub loc: Loc,
    used: Cell<bool>,
}

impl Param {
    /// `"float radius"` for messages.
    pub fn label(&self) -> String {
        format!("\"{} {}\"", self.ty, self.name)
    }

    fn error(&self, expected: &str) -> SceneError {
        let (found, loc) = match self.values.first() {
            None => ("no value".to_string(), &self.loc),
            Some((Value::Num(x), l)) => (format!("the number {x}"), l),
            Some((Value::Str(s), l)) => (format!("the string \"{s}\""), l),
            Some((Value::Bool(b), l)) => (format!("{b}"), l),
        };
        loc.error(format!("parameter {} must be {expected}, found {found}", self.label()))
    }

    /// Every value as a number.
    pub fn numbers(&self) -> Result<Vec<f64>, SceneError> {
        self.values
            .iter()
            .map(|(v, l)| match v {
                Value::Num(x) => Ok(*x),
                _ => Err(l.error(format!("parameter {} must hold numbers only", self.label()))),
            })
            .collect()
    }

    /// Exactly `n` numbers.
    pub fn numbers_n(&self, n: usize) -> Result<Vec<f64>, SceneError> {
        let v = self.numbers()?;
        if v.len() != n {
            let s = if n == 1 { "" } else { "s" };
            return Err(self.loc.error(format!(
                "parameter {} must have {n} number{s}, found {}",
                self.label(),
                v.len()
            )));
        }
        Ok(v)
    }

    /// The one string value.
    pub fn string(&self) -> Result<String, SceneError> {
        match self.values.as_slice() {
            [(Value::Str(s), _)] => Ok(s.clone()),
            _ => Err(self.error("one quoted string")),
        }
    }

    /// Every value as a string.
    pub fn strings(&self) -> Result<Vec<String>, SceneError> {
        self.values
            .iter()
            .map(|(v, l)| match v {
                Value::Str(s) => Ok(s.clone()),
                _ => Err(l.error(format!("parameter {} must hold quoted strings only", self.label()))),
            })
            .collect()
    }
}

#[derive(Clone, Debug, Default)]
pub(crate) struct Params {
    pub list: Vec<Param>,
}

impl Params {
    /// The parameter `name` of one of `types`, marked as read.
    pub fn get(&self, name: &str, types: &[&str]) -> Option<&Param> {
        let p = self.list.iter().rev().find(|p| p.name == name && types.contains(&p.ty.as_str()))?;
        p.used.set(true);
        Some(p)
    }

    /// Marks `name` read whatever its type (a parameter a mapping consumes by
    /// approximating it as a whole, named in its own note).
    pub fn touch(&self, name: &str) -> Option<&Param> {
        let p = self.list.iter().rev().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        self.get(name, &["float"]).map(|p| Ok(p.numbers_n(1)?[0])).transpose()
    }

    pub fn float_or(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    pub fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        self.get(name, &["integer"])
            .map(|p| {
                let x = p.numbers_n(1)?[0];
                if x.fract() != 0.0 || x.abs() > 1e15 {
                    return Err(p.error("an integer"));
                }
                Ok(x as i64)
            })
            .transpose()
    }

    pub fn string(&self, name: &str) -> Result<Option<String>, SceneError> {
        self.get(name, &["string"]).map(Param::string).transpose()
    }

    pub fn bool(&self, name: &str) -> Result<Option<bool>, SceneError> {
        self.get(name, &["bool"])
            .map(|p| match p.values.as_slice() {
                [(Value::Bool(b), _)] => Ok(*b),
                [(Value::Str(s), _)] if s == "true" || s == "false" => Ok(s == "true"),
                _ => Err(p.error("true or false")),
            })
            .transpose()
    }

    /// The parameters nothing read.
    pub fn unused(&self) -> impl Iterator<Item = &Param> {
        self.list.iter().filter(|p| !p.used.get())
    }
}

/// Reads a parameter list from `tokens[*i..]`, stopping at the first bare word
/// that is not `true`/`false` (the next directive) or the end.
pub(crate) fn parse(tokens: &[Token], i: &mut usize) -> Result<Params, SceneError> {
    let mut list = Vec::new();
    while let Some(t) = tokens.get(*i) {
        let decl = match &t.kind {
            Kind::Str(s) => s.clone(),
            Kind::Word(_) => break,
            _ => {
                return Err(t.loc.error(format!(
                    "expected a parameter (\"type name\" then its value) or the next directive, found {}",
                    t.describe()
                )))
            }
        };
        let words: Vec<&str> = decl.split_whitespace().collect();
        let [ty, name] = words.as_slice() else {
            return Err(t.loc.error(format!(
                "expected a parameter declaration \"type name\" (e.g. \"float radius\"), found \"{decl}\""
            )));
        };
        if !TYPES.contains(ty) {
            return Err(t
                .loc
                .error(format!("unknown parameter type `{ty}` in \"{decl}\"; expected one of {}", TYPES.join(", "))));
        }
        *i += 1;
        let value = |t: &Token| -> Result<(Value, Loc), SceneError> {
            let v = match &t.kind {
                Kind::Num(x) => Value::Num(*x),
                Kind::Str(s) => Value::Str(s.clone()),
                Kind::Word(w) if w == "true" || w == "false" => Value::Bool(w == "true"),
                _ => {
                    return Err(t.loc.error(format!(
                    "expected a value for parameter \"{decl}\" (a number, a quoted string, true or false), found {}",
                    t.describe()
                )))
                }
            };
            Ok((v, t.loc.clone()))
        };
        let mut values = Vec::new();
        match tokens.get(*i) {
            None => {
                return Err(t
                    .loc
                    .error(format!("expected a value after parameter \"{decl}\", found the end of the file")))
            }
            Some(open) if open.kind == Kind::Open => {
                *i += 1;
                loop {
                    match tokens.get(*i) {
                        None => {
                            return Err(open.loc.error(format!(
                                "expected `]` to close the values of parameter \"{decl}\", found the end of the file"
                            )))
                        }
                        Some(c) if c.kind == Kind::Close => {
                            *i += 1;
                            break;
                        }
                        Some(v) => {
                            values.push(value(v)?);
                            *i += 1;
                        }
                    }
                }
            }
            Some(v) => {
                values.push(value(v)?);
                *i += 1;
            }
        }
        list.push(Param {
            ty: ty.to_string(),
            name: name.to_string(),
            values,
            loc: t.loc.clone(),
            used: Cell::new(false),
        });
    }
    Ok(Params { list })
}
