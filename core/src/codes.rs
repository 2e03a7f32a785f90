//! Numbered codes from one table: a domain list written once.
//!
//! A fault an operator reads as `E-15`, a notice as `n-04`, a drive fault on the wire: each
//! is an enum whose variants carry a fixed number, and the code around it needs the list of
//! every variant, the number of each and the variant of a number. Written by hand these are
//! four parallel lists that compile even when one misses a variant. [`numbered!`] generates
//! all four from one row per variant — the enum, `ALL` (in table order), `number()` and
//! `from_number()` — so a variant cannot be missing from any of them, and a number used
//! twice does not compile (`from_number`'s match would have an unreachable arm, which the
//! workspace's lints refuse). Rows that carry words for the operator (a short name, what
//! the code means — also the variant's doc —, and how to recover) get `name()`,
//! `meaning()` and `recovery()` too.

/// One enum and its number table from rows `Variant = number` (optionally followed by
/// `{ "name", "meaning", "recovery" }`). See the module docs.
macro_rules! numbered {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $variant:ident = $number:literal { $short:literal, $meaning:literal, $recovery:literal } ),+ $(,)?
        }
    ) => {
        $crate::codes::numbered! {
            $(#[$meta])*
            $vis enum $name { $( #[doc = $meaning] $variant = $number ),+ }
        }

        impl $name {
            /// The code's short name (the fault table's second column in `docs/SPEC.md`).
            #[must_use]
            pub const fn name(self) -> &'static str {
                match self { $( Self::$variant => $short, )+ }
            }

            /// What the code means, in one line (also the variant's documentation).
            #[must_use]
            pub const fn meaning(self) -> &'static str {
                match self { $( Self::$variant => $meaning, )+ }
            }

            /// How the operator recovers from it.
            #[must_use]
            pub const fn recovery(self) -> &'static str {
                match self { $( Self::$variant => $recovery, )+ }
            }
        }
    };
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[doc = $doc:literal])* $variant:ident = $number:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis enum $name {
            $( $(#[doc = $doc])* $variant, )+
        }

        impl $name {
            /// Every variant, in the table's order.
            pub const ALL: [Self; 0 $( + ($number - $number + 1) )+] = [ $( Self::$variant ),+ ];

            /// The variant's number.
            #[must_use]
            pub const fn number(self) -> u8 {
                match self { $( Self::$variant => $number, )+ }
            }

            /// The variant numbered `number`, if any.
            #[must_use]
            pub const fn from_number(number: u8) -> Option<Self> {
                match number {
                    $( $number => Some(Self::$variant), )+
                    _ => None,
                }
            }
        }
    };
}

pub(crate) use numbered;
