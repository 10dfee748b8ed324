//! Text from a log or a path quoted for the terminal (control bytes escaped).

/// `text` with control and escape characters escaped (see `polymap_io::printable`).
pub fn quoted(text: &str) -> String {
    polymap_io::printable::printable(text).into_owned()
}
