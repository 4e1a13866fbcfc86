//! Validated scalar and vector values of scene files. Each checks itself while
//! it is parsed, so a bad number is reported at its own line and column, and
//! writes itself back as it was read (the scene writer).

use glam::Vec3;
use serde::de::{self, Deserialize, Deserializer};

/// A finite number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Finite(pub f32);

/// A finite number `> 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Positive(pub f32);

/// Three finite numbers `(x, y, z)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3(pub Vec3);

/// A colour `(r, g, b)`, each in `[0, 1]`, in linear RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Color(pub Vec3);

pub use crate::field::MAX_MAGNITUDE;

fn check_finite<E: de::Error>(v: f32) -> Result<f32, E> {
    if v.is_finite() && v.abs() <= MAX_MAGNITUDE {
        Ok(v)
    } else {
        Err(E::custom(format!("expected a finite number of magnitude at most {MAX_MAGNITUDE:e}, got {v:e}")))
    }
}

/// Deserializes three finite numbers (see [`V3`]) as a vector.
pub fn finite_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    V3::deserialize(d).map(|v| v.0)
}

/// Deserializes a finite number (see [`Finite`]).
pub fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    Finite::deserialize(d).map(|v| v.0)
}

/// Deserializes a finite number `> 0` (see [`Positive`]).
pub fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    Positive::deserialize(d).map(|v| v.0)
}

/// Deserializes a finite number `≥ 1` (see [`AtLeastOne`]).
pub fn at_least_one<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    AtLeastOne::deserialize(d).map(|v| v.0)
}

/// Deserializes a finite number `≥ 0` (a tolerance).
pub fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    let v = check_finite(f32::deserialize(d)?)?;
    if v >= 0.0 { Ok(v) } else { Err(de::Error::custom(format!("expected a number of at least 0, got {v}"))) }
}

/// Deserializes a percentage in `[0, 100]`.
pub fn percentage<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if (0.0..=100.0).contains(&v) {
        Ok(v)
    } else {
        Err(de::Error::custom(format!("expected a percentage between 0 and 100, got {v}")))
    }
}

/// Deserializes three finite, non-zero scale factors (see [`Scale`]).
pub fn scale_factors<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    Scale::deserialize(d).map(|v| v.0)
}

impl<'de> Deserialize<'de> for Finite {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        check_finite(f32::deserialize(d)?).map(Finite)
    }
}

impl<'de> Deserialize<'de> for Positive {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = check_finite(f32::deserialize(d)?)?;
        if v > 0.0 { Ok(Positive(v)) } else { Err(de::Error::custom(format!("expected a positive number, got {v}"))) }
    }
}

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (x, y, z) = <(f32, f32, f32)>::deserialize(d)?;
        for v in [x, y, z] {
            check_finite::<D::Error>(v)?;
        }
        Ok(V3(Vec3::new(x, y, z)))
    }
}

impl<'de> Deserialize<'de> for Color {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let V3(c) = V3::deserialize(d)?;
        if c.min_element() < 0.0 || c.max_element() > 1.0 {
            return Err(de::Error::custom(format!("colour components must lie in [0, 1], got {c}")));
        }
        Ok(Color(c))
    }
}

/// A finite number `≥ 1` (a Ricci blend's exponent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtLeastOne(pub f32);

impl<'de> Deserialize<'de> for AtLeastOne {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = check_finite(f32::deserialize(d)?)?;
        if v >= 1.0 {
            Ok(AtLeastOne(v))
        } else {
            Err(de::Error::custom(format!("expected a number of at least 1, got {v}")))
        }
    }
}

/// Three finite numbers, not all zero (a direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction(pub Vec3);

impl<'de> Deserialize<'de> for Direction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let V3(v) = V3::deserialize(d)?;
        if v.try_normalize().is_none() {
            return Err(de::Error::custom(format!("expected a direction, got {v}, which has no length")));
        }
        Ok(Direction(v))
    }
}

/// A non-empty name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Name(pub String);

impl<'de> Deserialize<'de> for Name {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        if name.is_empty() {
            return Err(de::Error::custom("expected a name, got the empty string"));
        }
        Ok(Name(name))
    }
}

/// Three finite, non-zero scale factors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale(pub Vec3);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let V3(s) = V3::deserialize(d)?;
        if s.abs().min_element() <= f32::EPSILON {
            return Err(de::Error::custom(format!("scale factors must be non-zero, got {s}")));
        }
        Ok(Scale(s))
    }
}

/// Writes a wrapped number as the bare number it was read from.
macro_rules! serialize_as_number {
    ($($t:ty),*) => {$(
        impl serde::Serialize for $t {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                self.0.serialize(s)
            }
        }
    )*};
}

/// Writes a wrapped vector as the tuple `(x, y, z)` it was read from.
macro_rules! serialize_as_triple {
    ($($t:ty),*) => {$(
        impl serde::Serialize for $t {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                (self.0.x, self.0.y, self.0.z).serialize(s)
            }
        }
    )*};
}

serialize_as_number!(Finite, Positive, AtLeastOne, Name);
serialize_as_triple!(V3, Color, Direction, Scale);
