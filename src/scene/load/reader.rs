//! The TOML reader under the scene loader: byte offsets to line and column,
//! tables read key by key with the location of every value in its messages.

use super::*;

pub(super) type Value<'i> = Spanned<DeValue<'i>>;

pub(super) struct Source<'a> {
    pub(super) file: &'a str,
    pub(super) text: &'a str,
    /// Byte offset of the start of each line.
    pub(super) line_starts: Vec<usize>,
}

impl<'a> Source<'a> {
    pub(super) fn new(file: &'a str, text: &'a str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Self { file, text, line_starts }
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub(super) fn line_col(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = self.line_starts.partition_point(|&start| start <= offset) - 1;
        let column = self.text[self.line_starts[line]..offset].chars().count() + 1;
        (line + 1, column)
    }

    pub(super) fn error(&self, span: Option<Range<usize>>, message: String) -> SceneError {
        SceneError::Invalid { file: self.file.to_string(), position: span.map(|s| self.line_col(s.start)), message }
    }

    /// The source text of a span, on one line and shortened, for messages.
    pub(super) fn snippet(&self, span: Range<usize>) -> String {
        let raw = self.text.get(span).unwrap_or("").trim();
        let first = raw.lines().next().unwrap_or("");
        let mut out: String = first.chars().take(40).collect();
        if out.len() < raw.len() {
            out.push_str("...");
        }
        out
    }

    /// "string \"abc\"", "float 64.5", "an array of 2 values", ...
    pub(super) fn describe(&self, value: &Value<'_>) -> String {
        let text = self.snippet(value.span());
        match value.get_ref() {
            DeValue::String(_) => format!("string {text}"),
            DeValue::Integer(_) => format!("integer {text}"),
            DeValue::Float(_) => format!("float {text}"),
            DeValue::Boolean(b) => format!("boolean {b}"),
            DeValue::Datetime(d) => format!("datetime {d}"),
            DeValue::Array(a) => match a.len() {
                1 => "an array of 1 value".to_string(),
                n => format!("an array of {n} values"),
            },
            DeValue::Table(_) => "a table".to_string(),
        }
    }
}

/// The entries of a table in the order they appear in the text.
pub(super) fn entries_in_order<'a, 'i>(
    table: &'a DeTable<'i>,
) -> Vec<(&'a Spanned<std::borrow::Cow<'i, str>>, &'a Value<'i>)> {
    let mut entries: Vec<_> = table.iter().collect();
    entries.sort_by_key(|(key, _)| key.span().start);
    entries
}

// ---------------------------------------------------------------------------
// One table of the scene, with its label for messages ("[camera]",
// "[[material]] \"glass\"", "[[sphere]] #2").

pub(super) struct Table<'s, 'a, 'i> {
    pub(super) src: &'s Source<'a>,
    pub(super) label: String,
    pub(super) table: &'s DeTable<'i>,
    /// The header (or key) that opened the table, if it has one.
    pub(super) span: Option<Range<usize>>,
}

impl<'s, 'i> Table<'s, '_, 'i> {
    pub(super) fn error_at(&self, span: Range<usize>, message: impl Display) -> SceneError {
        self.src.error(Some(span), format!("{}: {message}", self.label))
    }

    pub(super) fn error_here(&self, message: impl Display) -> SceneError {
        self.src.error(self.span.clone(), format!("{}: {message}", self.label))
    }

    /// Refuses the first key (in text order) that is not in `allowed`.
    pub(super) fn check_keys(&self, allowed: &[&str], context: &str) -> Result<(), SceneError> {
        for (key, _) in entries_in_order(self.table) {
            if !allowed.contains(&key.get_ref().as_ref()) {
                return Err(self.error_at(
                    key.span(),
                    format!("unknown key `{}`{context}; expected one of {}", key.get_ref(), allowed.join(", ")),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn get(&self, key: &str) -> Option<&'s Value<'i>> {
        self.table.get(key)
    }

    pub(super) fn required(&self, key: &str, hint: &str) -> Result<&'s Value<'i>, SceneError> {
        self.get(key).ok_or_else(|| self.error_here(format!("missing key `{key}` ({hint})")))
    }

    /// A finite number (integer or float) that fits a finite `f32`;
    /// `what` names the value ("key `radius`", "key `albedo` component 2").
    pub(super) fn number_at(&self, value: &Value<'_>, what: &str, expected: &str) -> Result<f64, SceneError> {
        let text = self.src.snippet(value.span());
        let x = match value.get_ref() {
            DeValue::Integer(i) => match i64::from_str_radix(i.as_str(), i.radix()) {
                Ok(i) => i as f64,
                Err(_) => {
                    return Err(self.error_at(
                        value.span(),
                        format!("{what} must be {expected}, found {text}, which is out of range"),
                    ))
                }
            },
            DeValue::Float(f) => {
                let s = f.as_str();
                let lower = s.to_ascii_lowercase();
                let parsed = if lower.contains("nan") || lower.contains("inf") { None } else { s.parse::<f64>().ok() };
                match parsed {
                    Some(x) if x.is_finite() => x,
                    _ => {
                        return Err(self.error_at(
                            value.span(),
                            format!("{what} must be a finite number ({expected}), found {text}"),
                        ))
                    }
                }
            }
            _ => {
                return Err(self
                    .error_at(value.span(), format!("{what} must be {expected}, found {}", self.src.describe(value))))
            }
        };
        if !(x as f32).is_finite() {
            return Err(self.error_at(
                value.span(),
                format!("{what} must be {expected} and fit a 32-bit float (magnitude below 3.4e38), found {text}"),
            ));
        }
        Ok(x)
    }

    /// A number checked against a range; `expected` describes the range.
    pub(super) fn ranged(
        &self,
        key: &str,
        value: &Value<'_>,
        ok: impl Fn(f64) -> bool,
        expected: &str,
    ) -> Result<f32, SceneError> {
        let x = self.number_at(value, &format!("key `{key}`"), expected)?;
        if !ok(x) {
            return Err(self.error_at(
                value.span(),
                format!("key `{key}` must be {expected}, found {}", self.src.snippet(value.span())),
            ));
        }
        Ok(x as f32)
    }

    /// An array of exactly three finite numbers, each passing `ok` (described by
    /// `expected_component`, e.g. "in [0, 1]").
    pub(super) fn vec3(
        &self,
        key: &str,
        value: &Value<'_>,
        ok: impl Fn(f64) -> bool,
        expected_component: &str,
    ) -> Result<[f64; 3], SceneError> {
        let shape = "an array of 3 numbers [x, y, z]";
        let array = match value.get_ref() {
            DeValue::Array(a) if a.len() == 3 => a,
            _ => {
                return Err(self.error_at(
                    value.span(),
                    format!("key `{key}` must be {shape}, found {}", self.src.describe(value)),
                ))
            }
        };
        let mut out = [0.0; 3];
        for (i, element) in array.iter().enumerate() {
            let what = format!("key `{key}` component {}", i + 1);
            let expected = if expected_component.is_empty() {
                "a number".to_string()
            } else {
                format!("a number {expected_component}")
            };
            let x = self.number_at(element, &what, &expected)?;
            if !ok(x) {
                return Err(self.error_at(
                    element.span(),
                    format!(
                        "key `{key}` must have every component {expected_component}, found {} (component {})",
                        self.src.snippet(element.span()),
                        i + 1
                    ),
                ));
            }
            out[i] = x;
        }
        Ok(out)
    }

    /// A vector of components within +-[`MAX_MAGNITUDE`].
    pub(super) fn point(&self, key: &str, value: &Value<'_>) -> Result<[f64; 3], SceneError> {
        self.vec3(key, value, |x| x.abs() <= MAX_MAGNITUDE, "within +-1e12")
    }

    /// An integer in `min..=max`; floats are refused.
    pub(super) fn integer(
        &self,
        key: &str,
        value: &Value<'_>,
        min: i64,
        max: i64,
        meaning: &str,
    ) -> Result<u32, SceneError> {
        self.integer_at(value, &format!("key `{key}`"), min, max, meaning)
    }

    /// [`Table::integer`] for any value; `what` names it ("key `resolution` component 2").
    pub(super) fn integer_at(
        &self,
        value: &Value<'_>,
        what: &str,
        min: i64,
        max: i64,
        meaning: &str,
    ) -> Result<u32, SceneError> {
        let expected = if max == i64::from(u32::MAX) {
            format!("an integer >= {min} ({meaning})")
        } else {
            format!("an integer from {min} to {max} ({meaning})")
        };
        let text = self.src.snippet(value.span());
        let n = match value.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix()).ok(),
            _ => {
                return Err(self
                    .error_at(value.span(), format!("{what} must be {expected}, found {}", self.src.describe(value))))
            }
        };
        match n {
            Some(n) if (min..=max).contains(&n) => Ok(n as u32),
            _ => Err(self.error_at(value.span(), format!("{what} must be {expected}, found {text}"))),
        }
    }

    pub(super) fn string(&self, key: &str, value: &'s Value<'i>, expected: &str) -> Result<&'s str, SceneError> {
        match value.get_ref() {
            DeValue::String(s) => Ok(s.as_ref()),
            _ => Err(self
                .error_at(value.span(), format!("key `{key}` must be {expected}, found {}", self.src.describe(value)))),
        }
    }

    pub(super) fn boolean(&self, key: &str, value: &Value<'_>) -> Result<bool, SceneError> {
        match value.get_ref() {
            DeValue::Boolean(b) => Ok(*b),
            _ => Err(self.error_at(
                value.span(),
                format!("key `{key}` must be true or false, found {}", self.src.describe(value)),
            )),
        }
    }
}

pub(super) fn to_vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(super) fn length(a: [f64; 3]) -> f64 {
    // Scaled so that neither huge nor tiny components overflow or underflow.
    let m = a[0].abs().max(a[1].abs()).max(a[2].abs());
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    let s = [a[0] / m, a[1] / m, a[2] / m];
    m * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
}

/// Sine of the angle between two non-zero vectors.
pub(super) fn sine_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (la, lb) = (length(a), length(b));
    let ua = [a[0] / la, a[1] / la, a[2] / la];
    let ub = [b[0] / lb, b[1] / lb, b[2] / lb];
    length(cross(ua, ub))
}

pub(super) fn format_vec(v: [f64; 3]) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}
