//! A cursor over the whitespace-separated fields of one line, with typed, checked accessors.

use std::str::SplitAsciiWhitespace;

use polymap::geometry::Pose2;
use polymap::scan::Stamp;

use super::error::{LineProblem, shorten};

/// The fields of one message, after its type name, read left to right.
pub(crate) struct Fields<'a> {
    tokens: SplitAsciiWhitespace<'a>,
    message: &'static str,
}

impl<'a> Fields<'a> {
    /// Fields of `rest` (the line after the message name) for a message of type `message`.
    pub(crate) fn new(rest: &'a str, message: &'static str) -> Self {
        Fields {
            tokens: rest.split_ascii_whitespace(),
            message,
        }
    }

    /// The next token, or an error naming `field` if the line has ended.
    pub(crate) fn token(&mut self, field: &'static str) -> Result<&'a str, LineProblem> {
        self.tokens.next().ok_or(LineProblem::MissingField {
            message: self.message,
            field,
        })
    }

    /// The next field as a float; `nan`, `inf` and `-inf` are accepted.
    pub(crate) fn float(&mut self, field: &'static str) -> Result<f64, LineProblem> {
        let token = self.token(field)?;
        fast_float2::parse::<f64, _>(token).map_err(|_| self.bad(field, token))
    }

    /// The next field as a finite float.
    pub(crate) fn finite(&mut self, field: &'static str) -> Result<f64, LineProblem> {
        let token = self.token(field)?;
        match fast_float2::parse::<f64, _>(token) {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.bad(field, token)),
        }
    }

    /// The next field as a non-negative integer count, at most `cap`.
    pub(crate) fn count(&mut self, field: &'static str, cap: usize) -> Result<usize, LineProblem> {
        let token = self.token(field)?;
        let value: u64 = token.parse().map_err(|_| self.bad(field, token))?;
        match usize::try_from(value) {
            Ok(n) if n <= cap => Ok(n),
            _ => Err(LineProblem::CountTooLarge {
                message: self.message,
                field,
                value,
                cap,
            }),
        }
    }

    /// The next field as an integer (e.g. a laser type or a mode flag).
    pub(crate) fn integer(&mut self, field: &'static str) -> Result<i64, LineProblem> {
        let token = self.token(field)?;
        token.parse().map_err(|_| self.bad(field, token))
    }

    /// The next three fields as a pose `x y theta` (metres, metres, radians), all finite.
    pub(crate) fn pose(&mut self, field: &'static str) -> Result<Pose2, LineProblem> {
        let x_m = self.finite(field)?;
        let y_m = self.finite(field)?;
        let theta_rad = self.finite(field)?;
        Ok(Pose2::new(x_m, y_m, theta_rad))
    }

    /// Reads `ipc_timestamp ipc_hostname logger_timestamp`; the stamp keeps its literal text.
    pub(crate) fn trailer(&mut self) -> Result<Stamp, LineProblem> {
        let token = self.token("ipc_timestamp")?;
        let seconds = match fast_float2::parse::<f64, _>(token) {
            Ok(v) if v.is_finite() => v,
            _ => return Err(self.bad("ipc_timestamp", token)),
        };
        self.token("ipc_hostname")?;
        self.finite("logger_timestamp")?;
        Ok(Stamp {
            seconds,
            text: token.to_owned(),
        })
    }

    /// Appends the next `n` fields (already known to be present) to `out` as floats.
    pub(crate) fn floats_into(
        &mut self,
        n: usize,
        field: &'static str,
        out: &mut Vec<f64>,
    ) -> Result<(), LineProblem> {
        for _ in 0..n {
            out.push(self.float(field)?);
        }
        Ok(())
    }

    fn bad(&self, field: &'static str, token: &str) -> LineProblem {
        LineProblem::BadNumber {
            message: self.message,
            field,
            token: shorten(token),
        }
    }
}

/// Number of whitespace-separated tokens in `line`.
pub(crate) fn token_count(line: &str) -> usize {
    line.split_ascii_whitespace().count()
}
