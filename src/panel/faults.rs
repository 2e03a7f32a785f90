//! What each fault code and notice means and how the operator clears it, in words for the
//! terminal panel: the seven-segment display has room for `E-15` only, the terminal for a
//! sentence. The words are core's fault and notice tables' (`taut_core::machine::fault`),
//! the one place a code is defined.

use taut_core::machine::{FaultCode, Notice};

/// A fault's meaning and how to clear it: `(meaning, recovery)`, each short enough for the
/// panel's lines.
#[must_use]
pub const fn fault_text(code: FaultCode) -> (&'static str, &'static str) {
    (code.meaning(), code.recovery())
}

/// A notice's meaning and how it clears: `(meaning, recovery)`.
#[must_use]
pub const fn notice_text(notice: Notice) -> (&'static str, &'static str) {
    (notice.meaning(), notice.recovery())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::panel::FRAME_COLUMNS;

    /// The longest prefix a text gets in the frame (`| shows: E-15 `, `| next:  `).
    const PREFIX: usize = "| shows: E-15 ".len();

    #[test]
    fn every_code_has_words_that_fit_the_panel() {
        let fits = |text: &str| {
            !text.is_empty() && PREFIX + text.chars().count() <= usize::from(FRAME_COLUMNS)
        };
        let mut meanings: Vec<&str> = Vec::new();
        for code in FaultCode::ALL {
            let (meaning, recovery) = fault_text(code);
            assert!(fits(meaning) && fits(recovery), "{code:?}: {meaning} / {recovery}");
            assert!(!meanings.contains(&meaning), "{code:?} shares its meaning");
            meanings.push(meaning);
        }
        for notice in Notice::ALL {
            let (meaning, recovery) = notice_text(notice);
            assert!(fits(meaning) && fits(recovery), "{notice:?}");
        }
    }
}
