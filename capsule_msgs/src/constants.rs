//! The named constants of an interface, each written once: the associated `const`s, the
//! `CONSTANTS` table that lists them by name as the interface file spells them, and the
//! lookup of a value's name.

/// `impl Type` with one `const` per `NAME: value` row (doc comments kept), the table
/// `CONSTANTS: &[(&str, T)]` of them all in order, and `constant_name(value)`.
#[macro_export]
macro_rules! constants {
    ($ty:ty: $t:ty { $($(#[$doc:meta])* $name:ident: $value:expr,)* }) => {
        impl $ty {
            $($(#[$doc])* pub const $name: $t = $value;)*
            /// Every constant of the interface file, by name, in the file's order.
            pub const CONSTANTS: &'static [(&'static str, $t)] = &[$((stringify!($name), Self::$name)),*];

            /// The name of the constant of value `value`, or `None` for an unknown value.
            pub fn constant_name(value: $t) -> Option<&'static str> {
                Self::CONSTANTS
                    .iter()
                    .find(|(_, v)| *v == value)
                    .map(|(n, _)| *n)
            }
        }
    };
}
