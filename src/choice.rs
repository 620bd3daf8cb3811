//! Settings that are one of a few named values (`--sampler sobol`, `filter = "box"`): the
//! parsing and printing they share.

/// "a", "a or b", "a, b or c": the names a setting accepts, for its error message.
pub fn alternatives<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    let names: Vec<&str> = names.into_iter().collect();
    match names.split_last() {
        None => String::new(),
        Some((last, [])) => last.to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
    }
}

/// `FromStr` and `Display` for an enum of named values, given its `ALL` (every value, in the
/// order the error message lists them) and `name()` (the name on the command line and in
/// files): an unknown name fails with `unknown WHAT "x" (expected a, b or c)`.
macro_rules! named_choice {
    ($ty:ty, $what:literal) => {
        impl ::std::str::FromStr for $ty {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                <$ty>::ALL.into_iter().find(|v| v.name() == s).ok_or_else(|| {
                    let expected = $crate::choice::alternatives(<$ty>::ALL.iter().map(|v| v.name()));
                    format!("unknown {} {s:?} (expected {expected})", $what)
                })
            }
        }

        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}
pub(crate) use named_choice;

#[cfg(test)]
mod tests {
    use super::alternatives;

    #[test]
    fn alternatives_read_as_a_list() {
        assert_eq!(alternatives([]), "");
        assert_eq!(alternatives(["box"]), "box");
        assert_eq!(alternatives(["box", "gaussian"]), "box or gaussian");
        assert_eq!(alternatives(["clamp", "aces", "neutral"]), "clamp, aces or neutral");
    }
}
