//! Text from a log made safe for a terminal: control and escape bytes (C0, DEL, C1, and the
//! Unicode bidirectional overrides) are written as `\x1b`-style or `\u{202e}`-style escapes, so
//! a binary or hostile log cannot move the cursor, change colours or hide text in a message.
//!
//! ```
//! use polymap_io::printable::printable;
//! assert_eq!(printable("FLASER\x1b[2J"), "FLASER\\x1b[2J");
//! assert_eq!(printable("tab\there"), "tab\\there");
//! assert_eq!(printable("Küche 1.5 m"), "Küche 1.5 m");
//! ```

use std::borrow::Cow;
use std::fmt::Write as _;

/// `text` with every control character escaped (see the module docs); borrowed when there is
/// none.
pub fn printable(text: &str) -> Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c if (c as u32) < 0x80 && needs_escape(c) => {
                let _ = write!(out, "\\x{:02x}", c as u32);
            }
            c if needs_escape(c) => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

fn needs_escape(c: char) -> bool {
    c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_are_escaped_and_plain_text_is_borrowed() {
        assert!(matches!(printable("plain"), Cow::Borrowed(_)));
        assert_eq!(
            printable("\u{0}\u{7f}\u{9b}x\u{202e}"),
            "\\x00\\x7f\\u{9b}x\\u{202e}"
        );
    }
}
