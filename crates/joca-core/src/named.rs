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

/// serde for a type written in files as the text its `Display` prints and `$parse` reads back
/// (`fn(&str) -> Result<Self, String>`; its error becomes serde's), such as `fog:300` or
/// `folder:DIR`.
///
/// ```
/// #[derive(Debug, PartialEq)]
/// struct Level(u8);
/// impl std::fmt::Display for Level {
///     fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
///         write!(f, "level:{}", self.0)
///     }
/// }
/// impl Level {
///     fn parse(text: &str) -> Result<Self, String> {
///         let n = text.strip_prefix("level:").and_then(|n| n.parse().ok());
///         n.map(Level).ok_or_else(|| format!("not a level: {text:?}"))
///     }
/// }
/// joca_core::serde_as_text!(Level, Level::parse);
/// assert_eq!(serde_json::to_string(&Level(3)).unwrap(), "\"level:3\"");
/// assert_eq!(serde_json::from_str::<Level>("\"level:3\"").unwrap(), Level(3));
/// assert!(serde_json::from_str::<Level>("\"high\"").unwrap_err().to_string().contains("not a level"));
/// ```
#[macro_export]
macro_rules! serde_as_text {
    ($Type:ty, $parse:path) => {
        impl ::serde::Serialize for $Type {
            fn serialize<S: ::serde::Serializer>(
                &self,
                serializer: S,
            ) -> ::std::result::Result<S::Ok, S::Error> {
                serializer.collect_str(self)
            }
        }

        impl<'de> ::serde::Deserialize<'de> for $Type {
            fn deserialize<D: ::serde::Deserializer<'de>>(
                deserializer: D,
            ) -> ::std::result::Result<Self, D::Error> {
                let text =
                    <::std::string::String as ::serde::Deserialize>::deserialize(deserializer)?;
                $parse(&text).map_err(<D::Error as ::serde::de::Error>::custom)
            }
        }
    };
}
