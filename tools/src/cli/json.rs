//! A one-line JSON object, formatted by hand (the tool has no dependencies beyond the library).

use std::fmt::Write;

/// Fields in insertion order, values already rendered as JSON.
#[derive(Debug, Default)]
pub struct JsonLine {
    fields: Vec<(&'static str, String)>,
}

impl JsonLine {
    pub fn int(mut self, key: &'static str, value: usize) -> Self {
        self.fields.push((key, value.to_string()));
        self
    }

    /// A number with 3 decimals; `null` if it is not finite (JSON has no NaN or infinity).
    pub fn num(mut self, key: &'static str, value: f64) -> Self {
        let rendered = if value.is_finite() {
            format!("{value:.3}")
        } else {
            "null".to_string()
        };
        self.fields.push((key, rendered));
        self
    }

    /// An array of numbers with 3 decimals (`null` for those that are not finite).
    pub fn nums(mut self, key: &'static str, values: &[f64]) -> Self {
        let rendered: Vec<String> = values
            .iter()
            .map(|v| {
                if v.is_finite() {
                    format!("{v:.3}")
                } else {
                    "null".to_string()
                }
            })
            .collect();
        self.fields.push((key, format!("[{}]", rendered.join(","))));
        self
    }

    pub fn str(mut self, key: &'static str, value: &str) -> Self {
        self.fields.push((key, quote(value)));
        self
    }

    pub fn render(&self) -> String {
        let fields: Vec<String> = self
            .fields
            .iter()
            .map(|(k, v)| format!("{}:{v}", quote(k)))
            .collect();
        format!("{{{}}}", fields.join(","))
    }
}

/// `text` as a JSON string literal.
fn quote(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if u32::from(c) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_a_flat_object() {
        let line = JsonLine::default()
            .int("rays", 3)
            .num("ms", 1.5)
            .num("rate", f64::INFINITY)
            .str("name", "a\"b\\c\n");
        assert_eq!(
            line.render(),
            r#"{"rays":3,"ms":1.500,"rate":null,"name":"a\"b\\c\u000a"}"#
        );
    }
}
