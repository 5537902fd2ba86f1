//! Files: rotorid's TOML model files ([`model_file`]), rotors saved by ROSS
//! ([`ross`]), the measurement CSV ([`measurement`]) and the writing of every
//! output file ([`output`]).

pub mod measurement;
pub mod model_file;
pub mod output;
pub mod ross;

/// Longest excerpt of a user's field quoted in a message (characters).
pub const QUOTE_CHARS: usize = 40;

/// `s` for a message: whole if at most [`QUOTE_CHARS`] characters, else its
/// first [`QUOTE_CHARS`] characters and `…` (so a huge field is not echoed
/// whole).
pub fn clip(s: &str) -> String {
    match s.char_indices().nth(QUOTE_CHARS) {
        None => s.to_string(),
        Some((i, _)) => format!("{}…", &s[..i]),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn clip_cuts_long_fields() {
        assert_eq!(super::clip("1.5e3"), "1.5e3");
        let long = "9".repeat(5_000_000);
        let c = super::clip(&long);
        assert_eq!(c.chars().count(), super::QUOTE_CHARS + 1);
        assert!(c.ends_with('…'));
        assert_eq!(super::clip(&"é".repeat(41)).chars().count(), 41);
    }
}
