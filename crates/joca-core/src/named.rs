//! Enums whose values are named in files and on the command line: one list of names per enum
//! gives `ALL`, `NAMES`, `name`, `from_name` (its error lists the valid names), `Display`,
//! `FromStr` and serde (the same names; an unknown one is refused as serde's derive refuses it,
//! "unknown variant `x`, expected `a` or `b`"), so the names cannot drift apart.

/// Declares an enum with one name per value (see the module).
///
/// ```
/// joca_core::named_enum! {
///     /// A colour.
///     pub enum Colour("colour") {
///         /// Red.
///         Red = "red",
///         /// Dark blue.
///         DarkBlue = "dark-blue",
///     }
/// }
/// assert_eq!(Colour::DarkBlue.name(), "dark-blue");
/// assert_eq!("red".parse::<Colour>(), Ok(Colour::Red));
/// assert_eq!(Colour::from_name("green").unwrap_err(), "unknown colour \"green\"; valid: red, dark-blue");
/// assert_eq!(serde_json::to_string(&Colour::Red).unwrap(), "\"red\"");
/// let e = serde_json::from_str::<Colour>("\"green\"").unwrap_err().to_string();
/// assert!(e.starts_with("unknown variant `green`, expected `red` or `dark-blue`"));
/// ```
#[macro_export]
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $Name:ident ($what:literal) {
            $( $(#[$vmeta:meta])* $Variant:ident = $text:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $Name {
            $( $(#[$vmeta])* $Variant ),+
        }

        impl $Name {
            /// Every value, in declaration order.
            pub const ALL: &'static [$Name] = &[$( $Name::$Variant ),+];
            /// Every value's name, in the order of [`Self::ALL`].
            pub const NAMES: &'static [&'static str] = &[$( $text ),+];

            /// The name used in files and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $( $Name::$Variant => $text ),+
                }
            }

            /// Parses a name, listing the valid ones on failure.
            pub fn from_name(name: &str) -> ::std::result::Result<Self, String> {
                Self::ALL.iter().copied().find(|v| v.name() == name).ok_or_else(|| {
                    format!("unknown {} {name:?}; valid: {}", $what, Self::NAMES.join(", "))
                })
            }
        }

        impl ::std::fmt::Display for $Name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl ::std::str::FromStr for $Name {
            type Err = String;
            fn from_str(s: &str) -> ::std::result::Result<Self, String> {
                Self::from_name(s)
            }
        }

        impl ::serde::Serialize for $Name {
            fn serialize<S: ::serde::Serializer>(
                &self,
                serializer: S,
            ) -> ::std::result::Result<S::Ok, S::Error> {
                serializer.serialize_str(self.name())
            }
        }

        impl<'de> ::serde::Deserialize<'de> for $Name {
            fn deserialize<D: ::serde::Deserializer<'de>>(
                deserializer: D,
            ) -> ::std::result::Result<Self, D::Error> {
                let text = <String as ::serde::Deserialize>::deserialize(deserializer)?;
                Self::ALL.iter().copied().find(|v| v.name() == text).ok_or_else(|| {
                    <D::Error as ::serde::de::Error>::unknown_variant(&text, Self::NAMES)
                })
            }
        }
    };
}
