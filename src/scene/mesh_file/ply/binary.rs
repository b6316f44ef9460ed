//! Binary PLY data, little or big endian (`BE`), decoded from 1 MiB chunks of the file straight
//! into the final buffers. Vertices without lists are decoded record by record from the chunk
//! at fixed offsets; faces walk their properties, with a fast path for the common triangle.

use super::header::{Element, Header, Scalar};
use super::{Layout, Sink};
use crate::util::reserve;
use std::io::Read;

const CHUNK: usize = 1 << 20;

/// A window on the file: `buf[pos..end]` is read and not yet used.
struct Input<R> {
    reader: R,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    /// Bytes of the file not yet read into `buf`.
    unread: u64,
}

/// Data ran out: the caller names the element.
struct Truncated;

impl<R: Read> Input<R> {
    fn left(&self) -> u64 {
        (self.end - self.pos) as u64 + self.unread
    }

    /// Makes at least `n` bytes available in `buf[pos..end]`, or says the file is too short
    /// (without allocating for a length the file cannot hold).
    #[cold]
    fn refill(&mut self, n: usize) -> Result<(), Failure> {
        if (n as u64) > self.left() {
            return Err(Err(Truncated));
        }
        self.buf.copy_within(self.pos..self.end, 0);
        self.end -= self.pos;
        self.pos = 0;
        if self.buf.len() < n {
            self.buf.resize(n.max(CHUNK), 0);
        }
        while self.end < n {
            let want = ((self.buf.len() - self.end) as u64).min(self.unread) as usize;
            let got = self
                .reader
                .read(&mut self.buf[self.end..self.end + want])
                .map_err(|e| Ok(format!("cannot read: {e}")))?;
            if got == 0 {
                // Shorter than its size said (changed while reading).
                self.unread = 0;
                return Err(Err(Truncated));
            }
            self.end += got;
            self.unread -= got as u64;
        }
        Ok(())
    }

    /// The next `n` bytes.
    #[inline(always)]
    fn take(&mut self, n: usize) -> Result<&[u8], Failure> {
        if self.end - self.pos < n {
            self.refill(n)?;
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// Up to `max` whole records of `size` bytes (at least one, unless the file ends).
    #[inline]
    fn records(&mut self, size: usize, max: u64) -> Result<&[u8], Failure> {
        if self.end - self.pos < size {
            self.refill(size)?;
        }
        let k = (((self.end - self.pos) / size) as u64).min(max) as usize;
        let s = &self.buf[self.pos..self.pos + k * size];
        self.pos += k * size;
        Ok(s)
    }
}

#[inline(always)]
fn bytes<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0; N];
    a.copy_from_slice(&b[..N]);
    a
}

macro_rules! decode {
    ($t:ty, $b:expr, $be:expr) => {{
        let a = bytes::<{ std::mem::size_of::<$t>() }>($b);
        if $be {
            <$t>::from_be_bytes(a)
        } else {
            <$t>::from_le_bytes(a)
        }
    }};
}

/// A scalar of type `ty` at the start of `b`, as a float.
#[inline(always)]
fn float<const BE: bool>(ty: Scalar, b: &[u8]) -> f64 {
    match ty {
        Scalar::F32 => decode!(f32, b, BE) as f64,
        Scalar::F64 => decode!(f64, b, BE),
        _ => int::<BE>(ty, b) as f64,
    }
}

/// An integer of type `ty` at the start of `b` (floats are truncated; the header check keeps
/// them out of index lists).
#[inline(always)]
fn int<const BE: bool>(ty: Scalar, b: &[u8]) -> i64 {
    match ty {
        Scalar::I8 => b[0] as i8 as i64,
        Scalar::U8 => b[0] as i64,
        Scalar::I16 => decode!(i16, b, BE) as i64,
        Scalar::U16 => decode!(u16, b, BE) as i64,
        Scalar::I32 => decode!(i32, b, BE) as i64,
        Scalar::U32 => decode!(u32, b, BE) as i64,
        Scalar::F32 => decode!(f32, b, BE) as i64,
        Scalar::F64 => decode!(f64, b, BE) as i64,
    }
}

/// Reads the data of every element in `header` from `reader` (positioned after the header,
/// with `size` bytes of data) into `sink`.
pub(super) fn read<const BE: bool, R: Read>(
    reader: R,
    size: u64,
    header: &Header,
    layout: &Layout,
    sink: &mut Sink,
) -> Result<(), String> {
    let mut input = Input {
        reader,
        buf: vec![0; CHUNK],
        pos: 0,
        end: 0,
        unread: size,
    };
    for (e, element) in header.elements.iter().enumerate() {
        let mut done = 0u64;
        let result = if e == layout.vertex {
            vertices::<BE, R>(&mut input, element, layout, sink, &mut done)
        } else if e == layout.face {
            faces::<BE, R>(&mut input, element, layout, sink, &mut done)
        } else {
            skip::<BE, R>(&mut input, element, &mut done)
        };
        result.map_err(|e| match e {
            Ok(message) => message,
            Err(Truncated) => format!(
                "the file ends in {} {done} of {}: truncated, or the header's counts or types \
                 do not match the data",
                element.name, element.count
            ),
        })?;
    }
    if input.left() > 0 {
        return Err(format!(
            "{} bytes after the last element: the header's counts or types do not match the \
             file's size",
            input.left()
        ));
    }
    Ok(())
}

type Failure = Result<String, Truncated>;

fn vertices<const BE: bool, R: Read>(
    input: &mut Input<R>,
    element: &Element,
    layout: &Layout,
    sink: &mut Sink,
    done: &mut u64,
) -> Result<(), Failure> {
    let props = &element.properties;
    let Some(stride) = element.fixed_size() else {
        // A list among the vertex properties (rare): walk each record.
        let mut values = vec![0.0; props.len()];
        while *done < element.count {
            for (p, value) in props.iter().zip(&mut values) {
                *value = read_property::<BE, R>(input, p.list, p.ty)?;
            }
            let p = layout.xyz.map(|k| values[k] as f32);
            let n = layout.normal.map(|n| n.map(|k| values[k] as f32));
            sink.vertex(*done, p, n).map_err(Ok)?;
            *done += 1;
        }
        return Ok(());
    };
    let offset = |k: usize| props[..k].iter().map(|p| p.ty.size()).sum::<usize>();
    let at = |k: usize| (offset(k), props[k].ty);
    let xyz = layout.xyz.map(at);
    let normal = layout.normal.map(|n| n.map(at));
    while *done < element.count {
        let chunk = input.records(stride, element.count - *done)?;
        for record in chunk.chunks_exact(stride) {
            let p = xyz.map(|(o, ty)| float::<BE>(ty, &record[o..]) as f32);
            let n = normal.map(|n| n.map(|(o, ty)| float::<BE>(ty, &record[o..]) as f32));
            sink.vertex(*done, p, n).map_err(Ok)?;
            *done += 1;
        }
    }
    Ok(())
}

/// Reads one property (a list's items are summed into nothing: only scalars are wanted here).
fn read_property<const BE: bool, R: Read>(
    input: &mut Input<R>,
    list: Option<Scalar>,
    ty: Scalar,
) -> Result<f64, Failure> {
    match list {
        None => Ok(float::<BE>(ty, input.take(ty.size())?)),
        Some(count) => {
            let n = int::<BE>(count, input.take(count.size())?).max(0) as usize;
            input.take(n.saturating_mul(ty.size()))?;
            Ok(0.0)
        }
    }
}

fn faces<const BE: bool, R: Read>(
    input: &mut Input<R>,
    element: &Element,
    layout: &Layout,
    sink: &mut Sink,
    done: &mut u64,
) -> Result<(), Failure> {
    let props = &element.properties;
    let list = &props[layout.indices];
    let (count_ty, index_ty) = (list.list.unwrap_or(Scalar::U8), list.ty);
    let index_size = index_ty.size();
    // The common file: nothing but the index list. A triangle is then one fixed-size record.
    let only_list = props.len() == 1;
    let triangle = count_ty.size() + 3 * index_size;
    while *done < element.count {
        let face = *done;
        if only_list && input.end - input.pos >= triangle {
            let b = &input.buf[input.pos..];
            if int::<BE>(count_ty, b) == 3 {
                let c = count_ty.size();
                let i = [0, 1, 2].map(|j| int::<BE>(index_ty, &b[c + j * index_size..]));
                input.pos += triangle;
                let t = [
                    sink.index(face, i[0]),
                    sink.index(face, i[1]),
                    sink.index(face, i[2]),
                ];
                let [a, b, c] = t.map(|r| r.map_err(Ok));
                sink.triangle([a?, b?, c?]);
                *done += 1;
                continue;
            }
        }
        for (k, p) in props.iter().enumerate() {
            if k != layout.indices {
                read_property::<BE, R>(input, p.list, p.ty)?;
                continue;
            }
            let n = int::<BE>(count_ty, input.take(count_ty.size())?);
            if n < 0 {
                return Err(Ok(format!("face {face} has {n} vertices")));
            }
            let bytes = (n as usize).saturating_mul(index_size);
            if bytes > CHUNK {
                // A face of many corners is held as read and as numbers: checked before it is
                // (ten million corners, 40 MB each way, aborted under a memory limit).
                if bytes as u64 > input.left() {
                    return Err(Err(Truncated));
                }
                let what = format!("face {face}'s {n} corners");
                reserve::check(bytes as u64 + 4 * n as u64, &what).map_err(Ok)?;
                sink.corners.clear();
                reserve::reserve_exact(&mut sink.corners, n as usize, &what).map_err(Ok)?;
            }
            let items = input.take(bytes)?;
            sink.corners.clear();
            for item in items.chunks_exact(index_size) {
                let index = int::<BE>(index_ty, item);
                // `sink.index` borrows the sink immutably: check, then push.
                let checked = sink.index(face, index).map_err(Ok)?;
                sink.corners.push(checked);
            }
        }
        sink.polygon(face).map_err(Ok)?;
        *done += 1;
    }
    Ok(())
}

fn skip<const BE: bool, R: Read>(
    input: &mut Input<R>,
    element: &Element,
    done: &mut u64,
) -> Result<(), Failure> {
    match element.fixed_size() {
        Some(0) => *done = element.count,
        Some(size) => {
            while *done < element.count {
                let chunk = input.records(size, element.count - *done)?;
                *done += (chunk.len() / size) as u64;
            }
        }
        None => {
            while *done < element.count {
                for p in &element.properties {
                    read_property::<BE, R>(input, p.list, p.ty)?;
                }
                *done += 1;
            }
        }
    }
    Ok(())
}
