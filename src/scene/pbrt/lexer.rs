//! The tokens of a pbrt file: quoted strings, numbers, `[` and `]`, and bare
//! words (directives, `true`/`false`), each with the 1-based line and column
//! where it starts; `#` comments run to the end of the line.

use std::rc::Rc;

use super::super::SceneError;

/// Where a token starts: the file as shown in messages, 1-based line and column.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Loc {
    pub file: Rc<str>,
    pub line: usize,
    pub column: usize,
}

impl Loc {
    /// A refusal at this place: `file:line:column: message`.
    pub fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_string(),
            position: Some((self.line, self.column)),
            message: message.into(),
        }
    }

    /// `file:line` for notes.
    pub fn at(&self) -> String {
        format!("{}:{}", self.file, self.line)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Kind {
    /// A quoted string, without its quotes, escapes resolved.
    Str(String),
    /// A number as written, and its value.
    Num(f64),
    Open,
    Close,
    /// A bare word: a directive, or `true`/`false`.
    Word(String),
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Token {
    pub kind: Kind,
    pub loc: Loc,
}

impl Token {
    /// For messages: `"abc"`, `1.5`, `[`, `Shape`.
    pub fn describe(&self) -> String {
        match &self.kind {
            Kind::Str(s) => format!("the string \"{s}\""),
            Kind::Num(x) => format!("the number {x}"),
            Kind::Open => "`[`".to_string(),
            Kind::Close => "`]`".to_string(),
            Kind::Word(w) => format!("`{w}`"),
        }
    }
}

/// Splits `text` (the file `file`) into tokens, or refuses the first thing that
/// is none: an unterminated string, a malformed number.
pub(crate) fn tokenize(text: &str, file: &Rc<str>) -> Result<Vec<Token>, SceneError> {
    let mut tokens = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    let (mut i, mut line, mut column) = (0usize, 1usize, 1usize);
    let loc = |line, column| Loc { file: file.clone(), line, column };
    while i < chars.len() {
        let c = chars[i];
        let start = loc(line, column);
        let advance = |i: &mut usize, line: &mut usize, column: &mut usize| {
            if chars[*i] == '\n' {
                *line += 1;
                *column = 1;
            } else {
                *column += 1;
            }
            *i += 1;
        };
        if c.is_whitespace() {
            advance(&mut i, &mut line, &mut column);
        } else if c == '#' {
            while i < chars.len() && chars[i] != '\n' {
                advance(&mut i, &mut line, &mut column);
            }
        } else if c == '[' || c == ']' {
            tokens.push(Token { kind: if c == '[' { Kind::Open } else { Kind::Close }, loc: start });
            advance(&mut i, &mut line, &mut column);
        } else if c == '"' {
            advance(&mut i, &mut line, &mut column);
            let mut s = String::new();
            loop {
                match chars.get(i) {
                    None | Some('\n') => {
                        return Err(start.error("unterminated string: expected a closing `\"` on the same line"))
                    }
                    Some('"') => {
                        advance(&mut i, &mut line, &mut column);
                        break;
                    }
                    Some('\\') => {
                        advance(&mut i, &mut line, &mut column);
                        let escaped = match chars.get(i) {
                            Some('n') => '\n',
                            Some('t') => '\t',
                            Some(&other) if other != '\n' => other,
                            _ => {
                                return Err(start.error("unterminated string: expected a closing `\"` on the same line"))
                            }
                        };
                        s.push(escaped);
                        advance(&mut i, &mut line, &mut column);
                    }
                    Some(&other) => {
                        s.push(other);
                        advance(&mut i, &mut line, &mut column);
                    }
                }
            }
            tokens.push(Token { kind: Kind::Str(s), loc: start });
        } else {
            let mut word = String::new();
            while i < chars.len() && !chars[i].is_whitespace() && !matches!(chars[i], '"' | '[' | ']' | '#') {
                word.push(chars[i]);
                advance(&mut i, &mut line, &mut column);
            }
            let first = word.chars().next().unwrap_or(' ');
            let kind = if first.is_ascii_digit() || matches!(first, '-' | '+' | '.') {
                match word.parse::<f64>() {
                    Ok(x) if x.is_finite() && !word.to_ascii_lowercase().contains("inf") => Kind::Num(x),
                    _ => return Err(start.error(format!("expected a finite number, found `{word}`"))),
                }
            } else if first.is_ascii_alphabetic() || first == '_' {
                Kind::Word(word)
            } else {
                return Err(
                    start.error(format!("expected a directive, a quoted string, a number, `[` or `]`, found `{word}`"))
                );
            };
            tokens.push(Token { kind, loc: start });
        }
    }
    Ok(tokens)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_carry_line_and_column() {
        let file: Rc<str> = Rc::from("t.pbrt");
        let t = tokenize("Shape \"sphere\" # c\n  \"float radius\" [ -1.5e1 ]", &file).unwrap();
        let kinds: Vec<_> = t.iter().map(|t| (t.kind.clone(), t.loc.line, t.loc.column)).collect();
        assert_eq!(
            kinds,
            vec![
                (Kind::Word("Shape".into()), 1, 1),
                (Kind::Str("sphere".into()), 1, 7),
                (Kind::Str("float radius".into()), 2, 3),
                (Kind::Open, 2, 18),
                (Kind::Num(-15.0), 2, 20),
                (Kind::Close, 2, 27),
            ]
        );
        let e = tokenize("Shape\n \"abc", &file).unwrap_err();
        assert_eq!(e.to_string(), "t.pbrt:2:2: unterminated string: expected a closing `\"` on the same line");
        let e = tokenize("Scale 1 2x 3", &file).unwrap_err();
        assert_eq!(e.to_string(), "t.pbrt:1:9: expected a finite number, found `2x`");
    }
}
