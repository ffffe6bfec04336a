//! Tokens of the scene format, and the number syntax shared with the OBJ reader.
//!
//! Tokens are whitespace-separated words; `{` and `}` are tokens of their own even when
//! glued to a word (`Group{`), and `#` starts a comment that runs to the end of the line.

use super::error::SceneError;
use super::model::Location;
use std::fs;
use std::path::Path;

/// A word of the scene file and the place where it starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Token<'a> {
    pub text: &'a str,
    pub location: Location,
}

/// Splits a scene text into [`Token`]s, one at a time (no token list is built, so a huge
/// file costs no memory beyond its text).
pub(crate) struct Lexer<'a> {
    rest: &'a str,
    line: u32,
    col: u32,
}

impl<'a> Lexer<'a> {
    pub fn new(text: &'a str) -> Self {
        Lexer { rest: text, line: 1, col: 1 }
    }

    /// Where the next token would start; at the end of the input, the end-of-file position
    /// (used to locate "unexpected end of file" errors).
    pub fn location(&self) -> Location {
        Location { line: self.line, col: self.col }
    }

    pub fn next_token(&mut self) -> Option<Token<'a>> {
        self.skip_blanks_and_comments();
        let location = self.location();
        let first = self.rest.chars().next()?;
        let len = if is_brace(first) {
            1
        } else {
            self.rest.find(|c: char| c.is_whitespace() || is_brace(c) || c == '#').unwrap_or(self.rest.len())
        };
        let (text, rest) = self.rest.split_at(len);
        self.rest = rest;
        self.col = self.col.saturating_add(char_count(text));
        Some(Token { text, location })
    }

    fn skip_blanks_and_comments(&mut self) {
        let mut in_comment = false;
        let mut consumed = 0;
        for c in self.rest.chars() {
            if c == '\n' {
                in_comment = false;
                self.line = self.line.saturating_add(1);
                self.col = 1;
            } else if in_comment || c == '#' || c.is_whitespace() {
                in_comment |= c == '#';
                self.col = self.col.saturating_add(1);
            } else {
                break;
            }
            consumed += c.len_utf8();
        }
        self.rest = &self.rest[consumed..];
    }
}

fn is_brace(c: char) -> bool {
    c == '{' || c == '}'
}

/// Columns count characters, not bytes.
pub(crate) fn char_count(text: &str) -> u32 {
    u32::try_from(text.chars().count()).unwrap_or(u32::MAX)
}

/// Reads a text file for parsing. Only regular files are read, so a path such as
/// `/dev/zero` or a FIFO cannot hang the reader; bytes that are not UTF-8 become U+FFFD
/// (they can then only show up inside an "unknown word" error, never cause a panic).
pub(crate) fn read_source(path: &Path) -> Result<String, SceneError> {
    let cannot_read = |e: std::io::Error| SceneError::in_file(path, format!("cannot read file: {e}"));
    let metadata = fs::metadata(path).map_err(cannot_read)?;
    if !metadata.is_file() {
        return Err(SceneError::in_file(path, "cannot read file: not a regular file"));
    }
    let bytes = fs::read(path).map_err(cannot_read)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Parses a decimal number as C's `%f` reads it (`5`, `-.16`, `+2.`, `1e-3`), requiring the
/// whole word to be the number. `None` for anything else, including `nan`, `inf`, hex and
/// values that overflow to infinity (`1e999`).
pub(crate) fn parse_decimal(text: &str) -> Option<f64> {
    if !is_c_decimal(text.as_bytes()) {
        return None;
    }
    // The syntax check leaves only forms Rust's parser accepts as well.
    text.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// `[+-] digits [. digits] [(e|E) [+-] digits]`, with at least one mantissa digit.
fn is_c_decimal(bytes: &[u8]) -> bool {
    let mut i = skip_sign(bytes, 0);
    let int_end = skip_digits(bytes, i);
    let mut mantissa_digits = int_end - i;
    i = int_end;
    if bytes.get(i) == Some(&b'.') {
        let frac_end = skip_digits(bytes, i + 1);
        mantissa_digits += frac_end - (i + 1);
        i = frac_end;
    }
    if mantissa_digits == 0 {
        return false;
    }
    if matches!(bytes.get(i), Some(b'e' | b'E')) {
        let exp_start = skip_sign(bytes, i + 1);
        let exp_end = skip_digits(bytes, exp_start);
        if exp_end == exp_start {
            return false;
        }
        i = exp_end;
    }
    i == bytes.len()
}

fn skip_sign(bytes: &[u8], i: usize) -> usize {
    match bytes.get(i) {
        Some(b'+' | b'-') => i + 1,
        _ => i,
    }
}

fn skip_digits(bytes: &[u8], mut i: usize) -> usize {
    while bytes.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    i
}

/// Parses a non-negative decimal integer (`3`, `+3`), the form of counts and indices.
/// `None` for signs other than `+`, fractions, exponents and values beyond `u64`.
pub(crate) fn parse_count(text: &str) -> Option<u64> {
    let digits = text.strip_prefix('+').unwrap_or(text);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// A word as quoted in messages: control characters escaped, long words shortened, so an
/// error about a megabyte of garbage stays one readable line.
pub(crate) fn describe(text: &str) -> String {
    const MAX_CHARS: usize = 40;
    let mut shown: String = text.chars().take(MAX_CHARS).flat_map(char::escape_debug).collect();
    if text.chars().nth(MAX_CHARS).is_some() {
        shown.push('…');
    }
    format!("`{shown}`")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tokens(text: &str) -> Vec<(&str, u32, u32)> {
        let mut lexer = Lexer::new(text);
        std::iter::from_fn(|| lexer.next_token()).map(|t| (t.text, t.location.line, t.location.col)).collect()
    }

    #[test]
    fn splits_words_and_braces_with_locations() {
        assert_eq!(
            tokens("Group{ numObjects 1\n\tSphere {}}"),
            vec![
                ("Group", 1, 1),
                ("{", 1, 6),
                ("numObjects", 1, 8),
                ("1", 1, 19),
                ("Sphere", 2, 2),
                ("{", 2, 9),
                ("}", 2, 10),
                ("}", 2, 11)
            ]
        );
    }

    #[test]
    fn comments_crlf_and_unicode_columns() {
        assert_eq!(tokens("# title\r\nä b#c d\r\n  e # f\n"), vec![("ä", 2, 1), ("b", 2, 3), ("e", 3, 3)]);
    }

    #[test]
    fn end_of_file_location() {
        let mut lexer = Lexer::new("a\n  ");
        assert!(lexer.next_token().is_some());
        assert!(lexer.next_token().is_none());
        assert_eq!(lexer.location(), Location { line: 2, col: 3 });
    }

    #[test]
    fn c_style_decimals() {
        for (text, value) in
            [("5", 5.0), ("-.16", -0.16), ("+2.", 2.0), ("1e-3", 1e-3), ("2.5E+2", 250.0), ("-0", -0.0)]
        {
            assert_eq!(parse_decimal(text), Some(value), "{text}");
        }
        for text in [
            "", ".", "-", "e5", "1e", "1e+", "nan", "inf", "-inf", "NaN", "infinity", "0x10", "1e999", "1.2.3", "1,5",
            "5a", "--1", " 1",
        ] {
            assert_eq!(parse_decimal(text), None, "{text}");
        }
    }

    #[test]
    fn counts() {
        assert_eq!(parse_count("3"), Some(3));
        assert_eq!(parse_count("+3"), Some(3));
        for text in ["3.5", "-1", "", "+", "1e3", "99999999999999999999999"] {
            assert_eq!(parse_count(text), None, "{text}");
        }
    }

    #[test]
    fn describe_escapes_and_shortens() {
        assert_eq!(describe("a\u{7}b"), "`a\\u{7}b`");
        assert_eq!(describe(&"x".repeat(100)), format!("`{}…`", "x".repeat(40)));
    }
}
