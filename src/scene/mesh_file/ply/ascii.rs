//! ASCII PLY data: whitespace-separated values read line by line, each element beginning a
//! line (its values may wrap onto the next). Errors name the element and the line.

use super::super::shown;
use super::header::{Header, Scalar};
use super::{Layout, Sink};
use crate::util::reserve;
use std::io::BufRead;

/// Values of the file, one at a time, with the line they are on.
struct Tokens<R> {
    reader: R,
    line: Vec<u8>,
    pos: usize,
    /// Line number of `line` in the file.
    number: u64,
}

impl<R: BufRead> Tokens<R> {
    /// The next value and its line, or `None` at the end of the file.
    fn next(&mut self) -> Result<Option<(&[u8], u64)>, String> {
        loop {
            let rest = &self.line[self.pos..];
            if let Some(start) = rest.iter().position(|b| !b.is_ascii_whitespace()) {
                let len = rest[start..]
                    .iter()
                    .position(|b| b.is_ascii_whitespace())
                    .unwrap_or(rest.len() - start);
                let token = self.pos + start..self.pos + start + len;
                self.pos = token.end;
                return Ok(Some((&self.line[token], self.number)));
            }
            self.line.clear();
            self.pos = 0;
            let n = self
                .reader
                .read_until(b'\n', &mut self.line)
                .map_err(|e| format!("cannot read: {e}"))?;
            if n == 0 {
                return Ok(None);
            }
            self.number += 1;
        }
    }
}

/// Reads the data of every element in `header` into `sink`. `reader` is just past the header.
pub(super) fn read(
    reader: impl BufRead,
    header: &Header,
    layout: &Layout,
    sink: &mut Sink,
) -> Result<(), String> {
    let mut tokens = Tokens {
        reader,
        line: Vec::new(),
        pos: 0,
        number: header.lines,
    };
    let mut values = Vec::new();
    // The line the last element ended on, and which element that was.
    let mut ended: Option<(u64, usize, u64)> = None;
    for (e, element) in header.elements.iter().enumerate() {
        // An element without properties holds no values: nothing to read, however many it
        // claims (reading "nothing" 10^12 times took 80 minutes).
        if element.properties.is_empty() {
            continue;
        }
        for i in 0..element.count {
            let at = |line: u64, what: String| format!("line {line}: {} {i}: {what}", element.name);
            let ends = || {
                format!(
                    "the file ends in {} {i} of {}: truncated, or the header's counts do not \
                     match the data",
                    element.name, element.count
                )
            };
            values.clear();
            sink.corners.clear();
            let mut line = tokens.number;
            for (k, p) in element.properties.iter().enumerate() {
                let Some(count) = p.list else {
                    let (token, l) = tokens.next()?.ok_or_else(ends)?;
                    if k == 0 {
                        begins_a_line(l, ended, header, &element.name, i)?;
                    }
                    line = l;
                    let value = number(token)
                        .ok_or_else(|| at(l, format!("'{}' is not a number", shown(token))))?;
                    values.push(value);
                    continue;
                };
                let (token, l) = tokens.next()?.ok_or_else(ends)?;
                if k == 0 {
                    begins_a_line(l, ended, header, &element.name, i)?;
                }
                line = l;
                // A negative length was read as an empty list.
                let n = integer(token, count)
                    .filter(|n| *n >= 0)
                    .ok_or_else(|| at(l, format!("'{}' is not a list length", shown(token))))?;
                values.push(0.0);
                let indices = e == layout.face && k == layout.indices;
                for _ in 0..n {
                    let (token, l) = tokens.next()?.ok_or_else(ends)?;
                    line = l;
                    if !indices {
                        number(token)
                            .ok_or_else(|| at(l, format!("'{}' is not a number", shown(token))))?;
                        continue;
                    }
                    let index = integer(token, p.ty).ok_or_else(|| {
                        at(l, format!("'{}' is not a vertex index", shown(token)))
                    })?;
                    // The sink's messages name the element themselves.
                    let index = sink.index(i, index).map_err(|e| format!("line {l}: {e}"))?;
                    reserve::make_room(&mut sink.corners, 1, "corners of the face read")
                        .map_err(|e| at(l, e))?;
                    sink.corners.push(index);
                }
            }
            if e == layout.vertex {
                let p = layout.xyz.map(|k| values[k] as f32);
                let n = layout.normal.map(|n| n.map(|k| values[k] as f32));
                sink.vertex(i, p, n)
                    .map_err(|e| format!("line {line}: {e}"))?;
            } else if e == layout.face {
                sink.polygon(i).map_err(|e| format!("line {line}: {e}"))?;
            }
            ended = Some((line, e, i));
        }
    }
    if let Some((token, line)) = tokens.next()? {
        return Err(format!(
            "line {line}: '{}' after the last element: the header's counts do not match the data",
            shown(token)
        ));
    }
    Ok(())
}

/// Each element begins a line (its values may wrap onto the next): an element that begins on
/// the line where the one before ended is a row of another length than the header says, and
/// reading on would shift every value after it into the wrong property.
fn begins_a_line(
    line: u64,
    ended: Option<(u64, usize, u64)>,
    header: &Header,
    name: &str,
    i: u64,
) -> Result<(), String> {
    match ended {
        Some((l, e, j)) if l == line => {
            let before = &header.elements[e].name;
            Err(format!(
                "line {line}: {name} {i} begins on the line where {before} {j} ended: each \
                 element must begin a line (a row of another length than the header says would \
                 shift every value after it)"
            ))
        }
        _ => Ok(()),
    }
}

fn number(token: &[u8]) -> Option<f64> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// An integer value of type `ty` (a float type accepts a whole number written as one).
fn integer(token: &[u8], ty: Scalar) -> Option<i64> {
    let text = std::str::from_utf8(token).ok()?;
    if ty.is_integer() {
        text.parse().ok()
    } else {
        let x: f64 = text.parse().ok()?;
        (x.fract() == 0.0 && x.abs() < 1e15).then_some(x as i64)
    }
}
