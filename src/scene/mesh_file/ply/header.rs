//! The PLY header: format, elements and their properties, read line by line. `comment` and
//! `obj_info` lines are skipped; any element or property is accepted (extra ones are skipped
//! when the data is read), but not the same element twice, nor the same property twice in one.

use std::io::{BufRead, Read};

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scalar {
    /// `char` / `int8`.
    I8,
    /// `uchar` / `uint8`.
    U8,
    /// `short` / `int16`.
    I16,
    /// `ushort` / `uint16`.
    U16,
    /// `int` / `int32`.
    I32,
    /// `uint` / `uint32`.
    U32,
    /// `float` / `float32`.
    F32,
    /// `double` / `float64`.
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// The name PLY headers use.
    pub fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    /// Bytes in a binary file.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Whether it is an integer type.
    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// One property of an element.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Property {
    /// Its name.
    pub name: String,
    /// `Some(count type)` for a list.
    pub list: Option<Scalar>,
    /// The value type (of the items, for a list).
    pub ty: Scalar,
}

/// An element: a name, a count and the properties of each.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Element {
    /// Its name (`vertex`, `face`, ...).
    pub name: String,
    /// How many the file holds, as the header says.
    pub count: u64,
    /// Its properties in file order.
    pub properties: Vec<Property>,
}

impl Element {
    /// The index of the property called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }

    /// Bytes of one record in a binary file when it has no list (`None` otherwise).
    pub fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| p.list.is_none().then_some(p.ty.size()))
            .sum()
    }

    /// The fewest bytes one record can take in a binary file (a list may be empty).
    pub fn min_binary_size(&self) -> u64 {
        self.properties
            .iter()
            .map(|p| p.list.unwrap_or(p.ty).size() as u64)
            .sum()
    }
}

/// How the data after the header is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Text.
    Ascii,
    /// Binary, little endian.
    BinaryLittleEndian,
    /// Binary, big endian.
    BinaryBigEndian,
}

/// A parsed header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// The data format.
    pub format: Format,
    /// The elements in file order.
    pub elements: Vec<Element>,
    /// The header's length in bytes (where the data starts).
    pub length: u64,
    /// The header's length in lines.
    pub lines: u64,
}

/// A header longer than this is not a header (a binary file misnamed, say).
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Reads the header from `reader`, leaving it at the first byte of data.
pub fn read(reader: &mut impl BufRead) -> Result<Header, String> {
    let mut line = Vec::new();
    let mut length = 0u64;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut number = 0;
    loop {
        number += 1;
        line.clear();
        let n = reader
            .by_ref()
            .take(MAX_HEADER_BYTES + 1 - length)
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("cannot read: {e}"))?;
        length += n as u64;
        let at = |e: String| format!("cannot parse PLY: header line {number}: {e}");
        if length > MAX_HEADER_BYTES {
            return Err(at(format!(
                "the header is over {} MiB without an end_header line (a header that long is \
                 not read)",
                MAX_HEADER_BYTES >> 20
            )));
        }
        if n == 0 {
            return Err(at("the header has no end_header line".into()));
        }
        let bytes = if number == 1 {
            line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&line)
        } else {
            &line
        };
        let text = std::str::from_utf8(bytes).map_err(|_| at("not text".into()))?;
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        if number == 1 {
            if words != ["ply"] {
                return Err(at("not a PLY file (the first line is not 'ply')".into()));
            }
            continue;
        }
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, version] => {
                if !version.starts_with('1') {
                    return Err(at(format!("unsupported PLY version {version}")));
                }
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLittleEndian,
                    "binary_big_endian" => Format::BinaryBigEndian,
                    _ => return Err(at(format!("unknown format '{f}'"))),
                });
            }
            // Twice the same element or property: which one the geometry is would be a guess.
            ["element", name, _] if elements.iter().any(|e| e.name == *name) => {
                return Err(at(format!("a second element '{name}'")));
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| at(format!("'{count}' is not an element count")))?,
                properties: Vec::new(),
            }),
            ["property", rest @ ..] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| at("a property before any element".into()))?;
                let scalar = |t: &str| {
                    Scalar::parse(t).ok_or_else(|| at(format!("unknown property type '{t}'")))
                };
                let property = match rest {
                    ["list", count, item, name] => {
                        let count = scalar(count)?;
                        if !count.is_integer() {
                            return Err(at(format!(
                                "the count of list '{name}' must be an integer type"
                            )));
                        }
                        Property {
                            name: name.to_string(),
                            list: Some(count),
                            ty: scalar(item)?,
                        }
                    }
                    [ty, name] => Property {
                        name: name.to_string(),
                        list: None,
                        ty: scalar(ty)?,
                    },
                    _ => return Err(at(format!("malformed property line '{}'", text.trim()))),
                };
                if element.find(&property.name).is_some() {
                    return Err(at(format!(
                        "a second property '{}' in element '{}'",
                        property.name, element.name
                    )));
                }
                element.properties.push(property);
            }
            ["end_header"] => {
                let format = format.ok_or_else(|| at("no format line before end_header".into()))?;
                return Ok(Header {
                    format,
                    elements,
                    length,
                    lines: number,
                });
            }
            _ => return Err(at(format!("unexpected line '{}'", text.trim()))),
        }
    }
}
