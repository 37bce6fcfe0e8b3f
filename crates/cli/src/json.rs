//! The one way the CLI writes JSON. serde_json writes a NaN or an infinity as `null`,
//! silently; every JSON document or line the CLI writes goes through [`to_writer`] (or
//! [`to_string`]), which first walks the value and refuses a non-finite number with
//! an error naming where it is. Objects are built with [`obj!`] (an [`Obj`]), not
//! `serde_json::json!`, whose values are converted (and a NaN made `null`) before any
//! check could see them.

use std::fmt;
use std::io::Write;

use serde::ser::{self, Serialize, Serializer};

use crate::report::CliError;

/// A JSON object built field by field, its values checked as they are added: a
/// non-finite number in one is kept as an error that serialising the object returns.
#[derive(Debug, Default, Clone)]
pub struct Obj {
    fields: Vec<(String, Result<serde_json::Value, String>)>,
}

impl Obj {
    /// An empty object.
    pub fn new() -> Self {
        Obj::default()
    }

    /// Add `key: value` (a key given twice keeps both; do not).
    pub fn field<T: Serialize + ?Sized>(mut self, key: &str, value: &T) -> Self {
        self.set(key, value);
        self
    }

    /// The fields of a value that serialises as an object (a library's report), to add
    /// more to; a non-finite number in it is an error naming its place.
    pub fn of<T: Serialize + ?Sized>(v: &T) -> Result<Obj, CliError> {
        find_non_finite(v).map_err(|at| non_finite(&at))?;
        match serde_json::to_value(v) {
            Ok(serde_json::Value::Object(map)) => Ok(Obj {
                fields: map.into_iter().map(|(k, v)| (k, Ok(v))).collect(),
            }),
            Ok(_) => Err(CliError::usage(
                "error: internal: the report is not a JSON object\n".to_string(),
            )),
            Err(e) => Err(CliError::usage(format!("error: cannot write JSON: {e}\n"))),
        }
    }

    /// Add `key: value` in place.
    pub fn set<T: Serialize + ?Sized>(&mut self, key: &str, value: &T) {
        let v = match find_non_finite(value) {
            Err(at) => Err(join(key, &at)),
            Ok(()) => serde_json::to_value(value).map_err(|e| format!("{key}: {e}")),
        };
        self.fields.push((key.to_string(), v));
    }
}

impl Serialize for Obj {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.fields.len()))?;
        for (k, v) in &self.fields {
            match v {
                Ok(v) => m.serialize_entry(k, v)?,
                Err(at) => return Err(ser::Error::custom(NonFiniteAt(at.clone()))),
            }
        }
        m.end()
    }
}

/// `obj!{"key": value, …}`: an [`Obj`] (values by reference; nest with `obj!`).
macro_rules! obj {
    ($($k:literal : $v:expr),* $(,)?) => {
        $crate::json::Obj::new()$(.field($k, &$v))*
    };
}
pub(crate) use obj;

/// The marker of a non-finite number's place, carried through serde's errors.
struct NonFiniteAt(String);

impl fmt::Display for NonFiniteAt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{NON_FINITE}{}", self.0)
    }
}

const NON_FINITE: &str = "non-finite number at ";

fn join(key: &str, rest: &str) -> String {
    if rest.is_empty() {
        key.to_string()
    } else if rest.starts_with('[') {
        format!("{key}{rest}")
    } else {
        format!("{key}.{rest}")
    }
}

/// Write `v` as one line of JSON to `w`; a non-finite number anywhere in it is an
/// error and nothing of `v` is written.
pub fn to_writer<W: Write + ?Sized, T: Serialize + ?Sized>(
    w: &mut W,
    v: &T,
) -> Result<(), CliError> {
    let s = to_string(v)?;
    w.write_all(s.as_bytes()).map_err(|e| CliError::write(&e))
}

/// `v` as JSON text (no line break); a non-finite number anywhere in it is an error.
pub fn to_string<T: Serialize + ?Sized>(v: &T) -> Result<String, CliError> {
    find_non_finite(v).map_err(|at| non_finite(&at))?;
    serde_json::to_string(v)
        .map_err(|e| CliError::usage(format!("error: cannot write JSON: {e}\n")))
}

fn non_finite(at: &str) -> CliError {
    let at = if at.is_empty() { "the top" } else { at };
    CliError::failed(format!(
        "error: the result holds a non-finite number (NaN or infinity) at `{at}`; no JSON written\n  = help: the input's numbers are too large or degenerate for this computation; check them\n"
    ))
}

/// `Err(place)` for the first non-finite number in `v` (`a.b[2]`; empty at the top).
pub fn find_non_finite<T: Serialize + ?Sized>(v: &T) -> Result<(), String> {
    match v.serialize(Finder) {
        Ok(()) => Ok(()),
        Err(Found(at)) => Err(at),
    }
}

/// What [`Finder`] returns: the place of a non-finite number (or another error's text).
#[derive(Debug)]
struct Found(String);

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Found {}

impl ser::Error for Found {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        // An [`Obj`] reports its own non-finite field through serde's error.
        let m = msg.to_string();
        Found(m.strip_prefix(NON_FINITE).map_or(m.clone(), str::to_string))
    }
}

/// A serializer that writes nothing and stops at the first non-finite number.
#[derive(Clone, Copy)]
struct Finder;

fn float(v: f64) -> Result<(), Found> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Found(String::new()))
    }
}

/// A compound value being walked: the place of the next element.
struct Walk {
    index: usize,
    key: Option<String>,
}

impl Walk {
    fn new() -> Self {
        Walk {
            index: 0,
            key: None,
        }
    }

    fn element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        let i = self.index;
        self.index += 1;
        v.serialize(Finder)
            .map_err(|Found(at)| Found(format!("[{i}]{}", dot(&at))))
    }

    fn named<T: Serialize + ?Sized>(&mut self, key: &str, v: &T) -> Result<(), Found> {
        v.serialize(Finder)
            .map_err(|Found(at)| Found(join(key, &at)))
    }
}

fn dot(at: &str) -> String {
    if at.is_empty() || at.starts_with('[') {
        at.to_string()
    } else {
        format!(".{at}")
    }
}

impl Serializer for Finder {
    type Ok = ();
    type Error = Found;
    type SerializeSeq = Walk;
    type SerializeTuple = Walk;
    type SerializeTupleStruct = Walk;
    type SerializeTupleVariant = Walk;
    type SerializeMap = Walk;
    type SerializeStruct = Walk;
    type SerializeStructVariant = Walk;

    fn serialize_bool(self, _: bool) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_i8(self, _: i8) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_i16(self, _: i16) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_i32(self, _: i32) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_i64(self, _: i64) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_u8(self, _: u8) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_u16(self, _: u16) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_u32(self, _: u32) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_u64(self, _: u64) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_f32(self, v: f32) -> Result<(), Found> {
        float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), Found> {
        float(v)
    }
    fn serialize_char(self, _: char) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_str(self, _: &str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_none(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<(), Found> {
        v.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), Found> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        v.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        Walk::new().named(variant, v)
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_tuple(self, _: usize) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Walk, Found> {
        Ok(Walk::new())
    }
}

impl ser::SerializeSeq for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        self.element(v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeTuple for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        self.element(v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        self.element(v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeTupleVariant for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        self.element(v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeMap for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, k: &T) -> Result<(), Found> {
        self.key = Some(match serde_json::to_value(k) {
            Ok(serde_json::Value::String(s)) => s,
            Ok(v) => v.to_string(),
            Err(_) => "?".to_string(),
        });
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), Found> {
        let key = self.key.take().unwrap_or_default();
        self.named(&key, v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeStruct for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        self.named(key, v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for Walk {
    type Ok = ();
    type Error = Found;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), Found> {
        self.named(key, v)
    }
    fn end(self) -> Result<(), Found> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Serialize)]
    struct Fit {
        rms: f64,
        centre: [f64; 3],
        runs: Vec<Option<f32>>,
    }

    #[test]
    fn a_non_finite_number_is_an_error_with_its_place_never_null() {
        let ok = Fit {
            rms: 0.5,
            centre: [1.0, 2.0, 3.0],
            runs: vec![None, Some(1.5)],
        };
        assert_eq!(
            to_string(&ok).expect("finite"),
            r#"{"rms":0.5,"centre":[1.0,2.0,3.0],"runs":[null,1.5]}"#
        );
        for (fit, at) in [
            (
                Fit {
                    rms: f64::NAN,
                    ..Fit {
                        rms: 0.0,
                        centre: [0.0; 3],
                        runs: vec![],
                    }
                },
                "rms",
            ),
            (
                Fit {
                    rms: 0.0,
                    centre: [0.0, f64::INFINITY, 0.0],
                    runs: vec![],
                },
                "centre[1]",
            ),
            (
                Fit {
                    rms: 0.0,
                    centre: [0.0; 3],
                    runs: vec![None, Some(f32::NEG_INFINITY)],
                },
                "runs[1]",
            ),
        ] {
            let e = to_string(&fit).expect_err("refused");
            assert!(e.message.contains(&format!("at `{at}`")), "{}", e.message);
            assert_eq!(e.code, 1);
            // serde_json alone would have written `null`.
            assert!(serde_json::to_string(&fit)
                .expect("serde_json")
                .contains("null"));
            let mut w = Vec::new();
            assert!(to_writer(&mut w, &fit).is_err());
            assert!(w.is_empty(), "nothing written");
        }
        // Built objects, nested: the place is kept through the layers.
        let inner = obj! {"position": [0.0, f64::NAN, 0.0]};
        let doc = obj! {"ok": true, "solutions": vec![obj! {"a": 1.0}, inner]};
        let e = to_string(&doc).expect_err("refused");
        assert!(
            e.message.contains("at `solutions[1].position[1]`"),
            "{}",
            e.message
        );
        let fine = obj! {"a": 1.0, "b": "text", "c": vec![1u32, 2]};
        assert_eq!(
            to_string(&fine).expect("fine"),
            r#"{"a":1.0,"b":"text","c":[1,2]}"#
        );
        let mut map = std::collections::BTreeMap::new();
        map.insert("x", f64::NAN);
        assert!(to_string(&map)
            .expect_err("refused")
            .message
            .contains("at `x`"));
        assert!(to_string(&f64::INFINITY)
            .expect_err("top")
            .message
            .contains("the top"));
    }
}
