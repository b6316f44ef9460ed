//! The scene file's tables that take a `type` (materials, lights, shapes), as written: each type
//! a struct of its own fields.
//!
//! Why not serde's internally tagged enums: they read a table into a buffer before choosing the
//! variant, and an error in a field then names neither the field nor its line (`radius = "big"`
//! gave "invalid type: string \"big\", expected f64" at the `[[shapes]]` header). Here the table
//! is read as it is, its `type` chooses the struct, and the struct's error names its field.

use serde::de::DeserializeOwned;
use serde::Deserialize;
use std::path::PathBuf;

/// A point or vector as written: `[x, y, z]`.
pub type Vec3 = [f64; 3];

/// Reads a [`Vec3`] that must hold three numbers exactly, for fields read straight from the
/// scene document (`#[serde(deserialize_with = "exactly_three")]`): serde reads an array's
/// first three numbers there and leaves the rest unread, so `eye = [1, 2, 3, 4]` was taken
/// as `[1, 2, 3]`. (The typed tables go through `toml::Value`, which counts them.)
pub fn exactly_three<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    struct Three;
    impl<'de> serde::de::Visitor<'de> for Three {
        type Value = Vec3;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an array of three numbers [x, y, z]")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec3, A::Error> {
            let mut v = [0.0; 3];
            for (k, x) in v.iter_mut().enumerate() {
                *x = seq
                    .next_element()?
                    .ok_or_else(|| serde::de::Error::invalid_length(k, &self))?;
            }
            let mut n = 3;
            while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                n += 1;
            }
            match n {
                3 => Ok(v),
                _ => Err(serde::de::Error::invalid_length(n, &self)),
            }
        }
    }
    d.deserialize_seq(Three)
}

/// [`exactly_three`] for an optional field (with `#[serde(default)]`).
pub fn maybe_three<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Vec3>, D::Error> {
    exactly_three(d).map(Some)
}

/// Takes the `type` of `table` out of it: one of `types`.
fn take_type(table: &mut toml::Table, types: &[&str]) -> Result<String, String> {
    let expected = || {
        let names: Vec<String> = types.iter().map(|t| format!("`{t}`")).collect();
        names.join(", ")
    };
    match table.remove("type") {
        None => Err("missing field `type`".into()),
        Some(toml::Value::String(t)) if types.contains(&t.as_str()) => Ok(t),
        Some(toml::Value::String(t)) => Err(format!(
            "unknown variant `{t}`, expected one of {}",
            expected()
        )),
        Some(v) => Err(format!(
            "type: invalid type: {}, expected a string, one of {}",
            v.type_str(),
            expected()
        )),
    }
}

/// The rest of a table as `T`; an error says which field (`radius: invalid type: ...`).
fn fields<T: DeserializeOwned>(kind: &str, table: toml::Table) -> Result<T, String> {
    toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| {
            let message = e.to_string().trim().to_string();
            // The value deserializer ends its message with "in `field`" (its path).
            match message.rsplit_once("\nin `") {
                Some((what, field)) => {
                    format!("{}: {what} (type \"{kind}\")", field.trim_end_matches('`'))
                }
                None => format!("{message} (type \"{kind}\")"),
            }
        })
}

/// A `[materials.NAME]` table.
#[derive(Deserialize)]
#[serde(try_from = "toml::Table")]
pub enum MaterialDesc {
    Diffuse(Diffuse),
    Mirror(Mirror),
    Glass(Glass),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Diffuse {
    pub albedo: Vec3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mirror {
    pub reflectance: Vec3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Glass {
    pub ior: f64,
}

impl TryFrom<toml::Table> for MaterialDesc {
    type Error = String;
    fn try_from(mut t: toml::Table) -> Result<Self, String> {
        let kind = take_type(&mut t, &["diffuse", "mirror", "glass"])?;
        Ok(match kind.as_str() {
            "diffuse" => MaterialDesc::Diffuse(fields(&kind, t)?),
            "mirror" => MaterialDesc::Mirror(fields(&kind, t)?),
            _ => MaterialDesc::Glass(fields(&kind, t)?),
        })
    }
}

/// A `[[lights]]` table.
#[derive(Deserialize)]
#[serde(try_from = "toml::Table")]
pub enum LightDesc {
    Point(PointLight),
    Spot(SpotLight),
    Quad(QuadLight),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Vec3,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLight {
    pub position: Vec3,
    pub direction: Vec3,
    pub intensity: Vec3,
    pub cone_angle: f64,
    pub falloff_start: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadLight {
    pub corner: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    pub radiance: Vec3,
}

impl TryFrom<toml::Table> for LightDesc {
    type Error = String;
    fn try_from(mut t: toml::Table) -> Result<Self, String> {
        let kind = take_type(&mut t, &["point", "spot", "quad"])?;
        Ok(match kind.as_str() {
            "point" => LightDesc::Point(fields(&kind, t)?),
            "spot" => LightDesc::Spot(fields(&kind, t)?),
            _ => LightDesc::Quad(fields(&kind, t)?),
        })
    }
}

/// A `[[shapes]]` table.
#[derive(Deserialize)]
#[serde(try_from = "toml::Table")]
pub enum ShapeDesc {
    Mesh(MeshShape),
    Quad(QuadShape),
    Sphere(SphereShape),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshShape {
    pub file: PathBuf,
    pub material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuadShape {
    pub corner: Vec3,
    pub edge_u: Vec3,
    pub edge_v: Vec3,
    pub material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereShape {
    pub center: Vec3,
    pub radius: f64,
    pub material: String,
    pub segments: Option<u32>,
}

impl TryFrom<toml::Table> for ShapeDesc {
    type Error = String;
    fn try_from(mut t: toml::Table) -> Result<Self, String> {
        let kind = take_type(&mut t, &["mesh", "quad", "sphere"])?;
        Ok(match kind.as_str() {
            "mesh" => ShapeDesc::Mesh(fields(&kind, t)?),
            "quad" => ShapeDesc::Quad(fields(&kind, t)?),
            _ => ShapeDesc::Sphere(fields(&kind, t)?),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(text: &str) -> Result<ShapeDesc, String> {
        let table: toml::Table = toml::from_str(text).unwrap();
        ShapeDesc::try_from(table)
    }

    #[test]
    fn a_fields_error_names_the_field_and_the_type() {
        let base = "center = [0.0, 1.0, 0.0]\nmaterial = \"white\"\n";
        let e = |extra: &str| {
            shape(&format!("type = \"sphere\"\n{base}{extra}"))
                .err()
                .unwrap()
        };
        assert_eq!(
            e("radius = \"big\""),
            "radius: invalid type: string \"big\", expected f64 (type \"sphere\")"
        );
        assert_eq!(
            e("radius = 1.0\nsegments = -4"),
            "segments: invalid value: integer `-4`, expected u32 (type \"sphere\")"
        );
        assert_eq!(
            e("radius = 1.0\nsegments = 4.5"),
            "segments: invalid type: floating point `4.5`, expected u32 (type \"sphere\")"
        );
        assert_eq!(e(""), "missing field `radius` (type \"sphere\")");
        assert!(
            e("radius = 1.0\ncolour = 1").starts_with("unknown field `colour`, expected one of")
        );
        assert_eq!(
            shape("type = \"cone\"").err().unwrap(),
            "unknown variant `cone`, expected one of `mesh`, `quad`, `sphere`"
        );
        assert_eq!(shape("radius = 1.0").err().unwrap(), "missing field `type`");
        assert!(shape(&format!(
            "type = \"sphere\"\n{base}radius = 2.0\nsegments = 8"
        ))
        .is_ok());
    }
}
