//! The keys a file section accepts, read from the serde struct that reads it, so that the file
//! reference (`docs/reference.md`) is checked against the code rather than kept by hand: a test
//! fails when a key the code accepts is missing from the reference.

use serde::de::{self, Deserialize, Deserializer, Visitor};
use std::cell::Cell;

/// The keys of the struct `T` reads (its fields as named in files, aliases included where serde
/// lists them). Empty for a type that is not read as a struct.
pub fn of<'de, T: Deserialize<'de>>() -> Vec<&'static str> {
    let seen = Cell::new(&[][..]);
    let _ = T::deserialize(Probe(&seen));
    seen.get().to_vec()
}

/// A deserializer that records the field names serde asks a struct for, and reads nothing.
struct Probe<'a>(&'a Cell<&'static [&'static str]>);

impl<'de> Deserializer<'de> for Probe<'_> {
    type Error = de::value::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
        Err(de::Error::custom("keys are only listed"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _: &'static str,
        fields: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, Self::Error> {
        self.0.set(fields);
        Err(de::Error::custom("keys are only listed"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    #[allow(dead_code)]
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Sample {
        radius: f64,
        #[serde(rename = "type")]
        kind: String,
        #[serde(alias = "center")]
        centre: Option<[f64; 3]>,
    }

    #[test]
    fn the_keys_of_a_struct_are_its_fields_as_files_name_them() {
        let keys = super::of::<Sample>();
        for k in ["radius", "type", "centre"] {
            assert!(keys.contains(&k), "{keys:?}");
        }
        assert!(!keys.contains(&"kind"));
        // serde lists aliases too, so an alias the code accepts must be in the reference.
        assert!(keys.contains(&"center"), "{keys:?}");
    }
}
