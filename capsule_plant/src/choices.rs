//! The choices a message lists (friction laws, integration methods).

/// `a, b or c`: a list of names for messages.
pub(crate) fn one_of<const N: usize>(names: [&str; N]) -> String {
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => names.join(""),
    }
}
