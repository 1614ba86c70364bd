//! The last line against non-finite numbers on the wire.
//!
//! Inputs are validated so that the model answers with finite numbers, but a NaN that slips
//! through anyway must not be sent: JSON would write it as `null` (a client reads "no height")
//! and protobuf as a NaN a client cannot tell from a real value. [`ensure_finite`] walks an
//! answer through its `Serialize` impl (so a field added to a response later is covered without
//! anyone remembering to add it here) and names the first NaN or infinity it meets. Every
//! transport calls it just before encoding — [`crate::api::wire::Reply`] for HTTP JSON and
//! protobuf, the WebSocket session's send queue for socket answers and tick frames — and sends
//! the error a [`NonFinite`] maps to (`ApiError::non_finite`, in `crate::error`) in place of
//! the answer.
//!
//! The walk allocates nothing for a finite answer: the path is only built on the way back out
//! from a bad number.

use std::fmt;

use serde::Serialize;
use serde::ser;

/// A non-finite number found in an answer.
#[derive(Debug, Clone, PartialEq)]
pub struct NonFinite {
    /// Where in the answer, as its JSON path: `bodies[0].heave`, `height[3]`; empty when the
    /// answer itself is the number.
    pub path: String,
    /// The number: NaN or ±infinity.
    pub value: f64,
}

impl fmt::Display for NonFinite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = if self.path.is_empty() {
            "the answer"
        } else {
            &self.path
        };
        write!(f, "{path} = {}", self.value)
    }
}

/// Checks that every number in `answer` is finite.
///
/// # Errors
/// The first non-finite number, in serialisation order, with its path. A value whose own
/// `Serialize` impl fails is not reported here: the encoder meets the same failure and answers
/// 500 itself.
pub fn ensure_finite<T: Serialize + ?Sized>(answer: &T) -> Result<(), NonFinite> {
    match answer.serialize(Walker) {
        Ok(()) | Err(Stop::Custom(_)) => Ok(()),
        Err(Stop::NonFinite { rev_path, value }) => {
            let mut path = String::new();
            for seg in rev_path.iter().rev() {
                match seg {
                    Seg::Field(name) => push_name(&mut path, name),
                    Seg::Key(name) => push_name(&mut path, name),
                    Seg::Index(i) => path.push_str(&format!("[{i}]")),
                }
            }
            Err(NonFinite { path, value })
        }
    }
}

fn push_name(path: &mut String, name: &str) {
    if !path.is_empty() {
        path.push('.');
    }
    path.push_str(name);
}

/// One step of a path, innermost first while the error travels out.
#[derive(Debug)]
enum Seg {
    Field(&'static str),
    Key(String),
    Index(usize),
}

/// Why the walk stopped.
#[derive(Debug)]
enum Stop {
    NonFinite { rev_path: Vec<Seg>, value: f64 },
    Custom(String),
}

impl Stop {
    fn at(mut self, seg: Seg) -> Stop {
        if let Stop::NonFinite { rev_path, .. } = &mut self {
            rev_path.push(seg);
        }
        self
    }

    fn in_variant(self, variant: Option<&'static str>) -> Stop {
        match variant {
            Some(v) => self.at(Seg::Field(v)),
            None => self,
        }
    }
}

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Stop::NonFinite { value, .. } => write!(f, "non-finite number {value}"),
            Stop::Custom(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Stop {}

impl ser::Error for Stop {
    fn custom<T: fmt::Display>(msg: T) -> Stop {
        Stop::Custom(msg.to_string())
    }
}

fn number(v: f64) -> Result<(), Stop> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Stop::NonFinite {
            rev_path: Vec::new(),
            value: v,
        })
    }
}

/// A serializer that produces nothing and fails on the first non-finite float.
struct Walker;

/// A sequence, tuple or tuple variant being walked.
struct Seq {
    next: usize,
    variant: Option<&'static str>,
}

impl Seq {
    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        let i = self.next;
        self.next += 1;
        value
            .serialize(Walker)
            .map_err(|e| e.at(Seg::Index(i)).in_variant(self.variant))
    }
}

/// A struct or struct variant being walked.
struct Fields {
    variant: Option<&'static str>,
}

impl Fields {
    fn field<T: Serialize + ?Sized>(&mut self, key: &'static str, value: &T) -> Result<(), Stop> {
        value
            .serialize(Walker)
            .map_err(|e| e.at(Seg::Field(key)).in_variant(self.variant))
    }
}

/// A map being walked: keys are checked too, and remembered (as JSON text) to name a bad value.
struct Map {
    key: Option<String>,
}

impl ser::Serializer for Walker {
    type Ok = ();
    type Error = Stop;
    type SerializeSeq = Seq;
    type SerializeTuple = Seq;
    type SerializeTupleStruct = Seq;
    type SerializeTupleVariant = Seq;
    type SerializeMap = Map;
    type SerializeStruct = Fields;
    type SerializeStructVariant = Fields;

    fn serialize_bool(self, _: bool) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i8(self, _: i8) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i16(self, _: i16) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i32(self, _: i32) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i64(self, _: i64) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_i128(self, _: i128) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u8(self, _: u8) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u16(self, _: u16) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u32(self, _: u32) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u64(self, _: u64) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_u128(self, _: u128) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_f32(self, v: f32) -> Result<(), Stop> {
        number(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), Stop> {
        number(v)
    }
    fn serialize_char(self, _: char) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_str(self, _: &str) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_none(self) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), Stop> {
        value.serialize(Walker)
    }
    fn serialize_unit(self) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_unit_variant(self, _: &'static str, _: u32, _: &'static str) -> Result<(), Stop> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), Stop> {
        value.serialize(Walker)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), Stop> {
        value
            .serialize(Walker)
            .map_err(|e| e.at(Seg::Field(variant)))
    }
    fn serialize_seq(self, _: Option<usize>) -> Result<Seq, Stop> {
        Ok(Seq {
            next: 0,
            variant: None,
        })
    }
    fn serialize_tuple(self, _: usize) -> Result<Seq, Stop> {
        self.serialize_seq(None)
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Seq, Stop> {
        self.serialize_seq(None)
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Seq, Stop> {
        Ok(Seq {
            next: 0,
            variant: Some(variant),
        })
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Map, Stop> {
        Ok(Map { key: None })
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Fields, Stop> {
        Ok(Fields { variant: None })
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        variant: &'static str,
        _: usize,
    ) -> Result<Fields, Stop> {
        Ok(Fields {
            variant: Some(variant),
        })
    }
}

impl ser::SerializeSeq for Seq {
    type Ok = ();
    type Error = Stop;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeTuple for Seq {
    type Ok = ();
    type Error = Stop;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for Seq {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeTupleVariant for Seq {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        self.element(value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeStruct for Fields {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Stop> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for Fields {
    type Ok = ();
    type Error = Stop;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), Stop> {
        self.field(key, value)
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

impl ser::SerializeMap for Map {
    type Ok = ();
    type Error = Stop;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), Stop> {
        key.serialize(Walker)?;
        // Maps are rare in answers; naming the key costs a small string per entry.
        let name = serde_json::to_string(key).unwrap_or_default();
        self.key = Some(name.trim_matches('"').to_owned());
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), Stop> {
        value
            .serialize(Walker)
            .map_err(|e| e.at(Seg::Key(self.key.take().unwrap_or_default())))
    }
    fn end(self) -> Result<(), Stop> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::types::{
        BodyOrientation, HeightResponse, OrientationResponse, SampleResponse,
    };

    fn orientation(heave: f64) -> OrientationResponse {
        let level = BodyOrientation {
            heave: 0.25,
            rotation: [0.0, 0.0, 0.0, 1.0],
            normal: [0.0, 1.0, 0.0],
            pitch: 0.0,
            roll: 0.0,
        };
        OrientationResponse {
            t: 1.5,
            bodies: vec![level, BodyOrientation { heave, ..level }],
        }
    }

    /// Regression: `POST …/orientation` with a body of length 1e300 answered 200 with
    /// `"heave": null` — the model's NaN went out as JSON null. The guard must stop any such
    /// answer, whatever made the NaN, and say where it was.
    #[test]
    fn issue_11_nan_heave_is_caught_with_its_path() {
        assert_eq!(ensure_finite(&orientation(0.5)), Ok(()));
        let e = ensure_finite(&orientation(f64::NAN)).unwrap_err();
        assert_eq!(e.path, "bodies[1].heave");
        assert!(e.value.is_nan());
        let api = crate::error::ApiError::from(ensure_finite(&orientation(f64::NAN)).unwrap_err());
        assert_eq!(
            (api.status().as_u16(), api.code.as_str()),
            (500, "non_finite_result")
        );
        assert!(api.message.contains("bodies[1].heave"), "{}", api.message);
    }

    #[test]
    fn every_response_shape_is_walked() {
        let h = HeightResponse {
            t: 0.0,
            height: f64::INFINITY,
        };
        assert_eq!(ensure_finite(&h).unwrap_err().path, "height");
        let mut s = SampleResponse {
            t: 2.0,
            height: Some(vec![0.0, 1.0]),
            normal: Some(vec![[0.0, 1.0, 0.0], [0.0, 1.0, f64::NEG_INFINITY]]),
            folded: Some(vec![false, true]),
            ..Default::default()
        };
        assert_eq!(ensure_finite(&s).unwrap_err().path, "normal[1][2]");
        s.normal = None;
        assert_eq!(ensure_finite(&s), Ok(()));
        s.t = f64::NAN;
        assert_eq!(ensure_finite(&s).unwrap_err().path, "t");
        // Bare numbers, f32, maps and enum variants.
        assert_eq!(ensure_finite(&f64::NAN).unwrap_err().path, "");
        assert_eq!(ensure_finite(&[1.0f32, f32::NAN]).unwrap_err().path, "[1]");
        let m: std::collections::BTreeMap<&str, f64> = [("a", 1.0), ("b", f64::NAN)].into();
        assert_eq!(ensure_finite(&m).unwrap_err().path, "b");
        #[derive(Serialize)]
        enum E {
            V { x: f64 },
        }
        assert_eq!(
            ensure_finite(&E::V { x: f64::NAN }).unwrap_err().path,
            "V.x"
        );
    }
}
