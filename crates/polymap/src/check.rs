//! Range checks of configuration values. Each stage's params struct validates itself with a
//! [`Checks`] chain; the first value out of range is an [`InvalidParam`] naming the key, the
//! value and the rule it breaks. [`crate::config::Config::validate`] prefixes the section.

use std::fmt::Display;

/// A configuration value out of its range.
///
/// ```
/// use polymap::check::Checks;
/// let e = Checks::new().within("bins", 0usize, 1, 3600).done().unwrap_err();
/// assert_eq!(e.key, "bins");
/// assert_eq!(e.to_string(), "bins = 0 is out of range: must be within [1, 3600]");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key} = {value} is out of range: {rule}")]
pub struct InvalidParam {
    /// The key: `name` from the stage, `section.name` from [`crate::config::Config::validate`].
    pub key: String,
    /// The value given, as text.
    pub value: String,
    /// The rule it breaks, e.g. `must be within [1, 3600]`.
    pub rule: String,
}

impl InvalidParam {
    /// The same error with the key prefixed by its section (`section.key`).
    pub fn in_section(mut self, section: &str) -> Self {
        self.key = format!("{section}.{}", self.key);
        self
    }
}

/// A chain of checks that keeps the first failure.
#[derive(Debug, Clone, Default)]
#[must_use = "call `done` to get the outcome"]
pub struct Checks {
    first: Option<InvalidParam>,
}

impl Checks {
    /// No checks yet.
    pub fn new() -> Self {
        Checks::default()
    }

    /// `ok` must hold for `key`, whose value is `value`; `rule` says what was required.
    pub fn rule(mut self, key: &str, ok: bool, value: impl Display, rule: impl Display) -> Self {
        if self.first.is_none() && !ok {
            self.first = Some(InvalidParam {
                key: key.to_string(),
                value: value.to_string(),
                rule: rule.to_string(),
            });
        }
        self
    }

    /// `lo ≤ value ≤ hi` (NaN fails; an infinite bound admits infinity).
    pub fn within<T: PartialOrd + Display + Copy>(self, key: &str, value: T, lo: T, hi: T) -> Self {
        let ok = lo <= value && value <= hi;
        self.rule(key, ok, value, format_args!("must be within [{lo}, {hi}]"))
    }

    /// `lo < value ≤ hi` (NaN fails).
    pub fn above<T: PartialOrd + Display + Copy>(self, key: &str, value: T, lo: T, hi: T) -> Self {
        let ok = lo < value && value <= hi;
        self.rule(key, ok, value, format_args!("must be within ({lo}, {hi}]"))
    }

    /// A share: `0 ≤ value ≤ 1`.
    pub fn share(self, key: &str, value: f64) -> Self {
        self.within(key, value, 0.0, 1.0)
    }

    /// The first failure, if any.
    pub fn done(self) -> Result<(), InvalidParam> {
        match self.first {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_failure_is_kept() {
        let e = Checks::new()
            .within("a", 1.0, 0.0, 2.0)
            .above("b", 0.0, 0.0, 1.0)
            .share("c", 2.0)
            .done()
            .unwrap_err();
        assert_eq!(e.key, "b");
        assert_eq!(e.rule, "must be within (0, 1]");
    }

    #[test]
    fn nan_fails_and_infinity_needs_an_infinite_bound() {
        assert!(
            Checks::new()
                .within("a", f64::NAN, 0.0, 1.0)
                .done()
                .is_err()
        );
        assert!(
            Checks::new()
                .within("a", f64::INFINITY, 0.0, 1e9)
                .done()
                .is_err()
        );
        let open = Checks::new().within("a", f64::INFINITY, 0.0, f64::INFINITY);
        assert!(open.done().is_ok());
    }

    #[test]
    fn the_section_prefixes_the_key() {
        let e = Checks::new().share("x", -1.0).done().unwrap_err();
        assert_eq!(e.in_section("merge").key, "merge.x");
    }
}
